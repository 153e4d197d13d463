#pragma once
// Outputs are written to a temporary file in the target's directory, flushed and renamed over the
// target: a reader sees the old file or the new one, never half of one, and a failure leaves the
// old file untouched (brief: "never overwrite good data with bad").
#include <string>

namespace pof::io {

/// Throws IoError (74) naming the path on any failure; the temporary file is removed.
void write_file_atomic(const std::string& path, const std::string& content);

}  // namespace pof::io
