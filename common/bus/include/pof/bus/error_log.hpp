#pragma once
// Rate-limited reporting of errors that may repeat at line rate (a bus flooded with undecodable
// messages must not flood the journal too): per key (a channel), the first error is emitted in
// full; later ones are counted and summarised at most once per period with the latest text.
//
// Pure: the caller passes the time and receives lines through `emit` (the daemons hand them to
// spdlog). Keys are bounded (max_keys); errors of further keys share the key "(other)".
// Thread safety: none; one thread.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>

namespace pof::bus {

class ErrorLog {
 public:
  using Emit = std::function<void(const std::string&)>;

  explicit ErrorLog(Emit emit, int64_t period_us = 10'000'000, std::size_t max_keys = 64);

  /// One error under `key`, `what` being its full description. Never throws.
  void note(std::string_view key, std::string_view what, int64_t now_us) noexcept;
  /// Emits the summaries that are due. Call regularly (e.g. once a second). Never throws.
  void tick(int64_t now_us) noexcept;

  /// Errors noted under `key` since the start (0 for an unknown key).
  [[nodiscard]] uint64_t count(std::string_view key) const;

 private:
  struct Entry {
    uint64_t total = 0;
    uint64_t pending = 0;      // noted since the last line emitted for this key
    int64_t last_emit_us = 0;  // when that line was emitted
    std::string latest;
  };
  void emit(const std::string& line) noexcept;

  Emit emit_;
  int64_t period_us_;
  std::size_t max_keys_;
  std::map<std::string, Entry, std::less<>> keys_;
};

}  // namespace pof::bus
