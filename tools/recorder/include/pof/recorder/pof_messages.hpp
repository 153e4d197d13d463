#pragma once
// The `seq` of pofkit's own LCM messages, read from raw bytes: every POF stream carries it
// (lcmtypes/*.lcm), and the type comes from the fingerprint (pof/bus/fingerprint.hpp). Used by
// `pof record --check` (per-channel sequence gaps) and `pof spy`.
#include <cstddef>
#include <cstdint>
#include <optional>

namespace pof::recorder {

/// The `seq` field of one of our messages, read at its fixed offset (cheap: no allocation);
/// nullopt when not ours or too short.
std::optional<int64_t> pof_seq(const void* data, std::size_t size);
/// The same through the generated decode() (slow; the reference for pof_seq in tests).
std::optional<int64_t> pof_seq_decoded(const void* data, std::size_t size);

/// Sequence bookkeeping for one stream: gaps are counted in missing messages; a restart of the
/// publisher (seq going back to 0 or backwards) is counted separately, not as a gap.
struct SeqTracker {
  bool have = false;
  int64_t first = 0;
  int64_t last = 0;
  uint64_t gaps = 0;        // number of jumps
  uint64_t missing = 0;     // messages missing in those jumps
  uint64_t restarts = 0;    // seq went backwards
  void update(int64_t seq) {
    if (!have) {
      have = true;
      first = last = seq;
      return;
    }
    if (seq == last + 1) {
    } else if (seq > last + 1) {
      ++gaps;
      missing += static_cast<uint64_t>(seq - last - 1);
    } else {
      ++restarts;
    }
    last = seq;
  }
};

}  // namespace pof::recorder
