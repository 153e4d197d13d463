#pragma once
// Channel selection with exactly liblcm's semantics: lcm_subscribe() compiles "^" + regex + "$" with
// GLib's GRegex (PCRE syntax), so `pof record -c`, `pof spy -c` and `lcm-logger -c` accept the same
// patterns and select the same channels. (std::regex differs in syntax and trips GCC 12's
// -Wmaybe-uninitialized under the sanitizers.)
#include <map>
#include <string>
#include <string_view>

namespace pof::bus {

class ChannelFilter {
 public:
  /// Throws pof::ConfigError naming the pattern and GLib's reason when it does not compile.
  explicit ChannelFilter(const std::string& regex);
  ~ChannelFilter();
  ChannelFilter(const ChannelFilter&) = delete;
  ChannelFilter& operator=(const ChannelFilter&) = delete;

  /// Whole-name match. Verdicts are cached per channel name (bounded), so the cost per message is
  /// a map lookup. Not thread-safe: one receive thread.
  bool matches(std::string_view channel);

 private:
  void* re_ = nullptr;  // GRegex*
  std::map<std::string, bool, std::less<>> cache_;
};

}  // namespace pof::bus
