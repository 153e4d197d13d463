#pragma once
// The bound on per-channel bookkeeping of `pof record` (its manifest's "channels") and `pof spy`
// (one row per channel). Any local process can publish on any channel name, so a table keyed by
// every name ever seen grows without bound: 200,000 names took `pof spy` to ~490 MB and gave a
// 10-MB log a 26-MB manifest. Each table keeps at most kMaxTrackedChannels names; pofkit's own
// (POF_*) get kPofChannelReserve more, so that foreign names seen first never crowd them out.
// Every message on a name beyond that is counted in one OtherChannels tally (events, bytes, the
// first few names as examples). Only the bookkeeping is bounded: `pof record` still writes every
// message to the log.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace pof::recorder {

/// Names of any kind tracked one by one.
inline constexpr std::size_t kMaxTrackedChannels = 1024;
/// Further POF_* names tracked once the table holds kMaxTrackedChannels (pofkit publishes five
/// per sensor: POF_RAW_<ID>, POF_DAQ_STATUS_<ID>, POF_ANGLE_<ID>, ...).
inline constexpr std::size_t kPofChannelReserve = 256;
/// Names of untracked channels kept as examples (each cut to kExampleChars).
inline constexpr std::size_t kOtherExamples = 4;
inline constexpr std::size_t kExampleChars = 64;

[[nodiscard]] inline bool is_pof_channel(std::string_view channel) { return channel.starts_with("POF_"); }

/// Whether a channel not yet in a table that tracks `tracked` names gets an entry of its own.
[[nodiscard]] inline bool admit_channel(std::string_view channel, std::size_t tracked) {
  if (tracked < kMaxTrackedChannels) return true;
  return is_pof_channel(channel) && tracked < kMaxTrackedChannels + kPofChannelReserve;
}

/// The messages on channels beyond the bound, together.
struct OtherChannels {
  std::uint64_t events = 0;
  std::uint64_t bytes = 0;
  std::vector<std::string> examples;  // the first kOtherExamples distinct names, cut

  void note(std::string_view channel, std::size_t size) {
    ++events;
    bytes += size;
    if (examples.size() >= kOtherExamples) return;
    const std::string_view cut = channel.substr(0, kExampleChars);
    if (std::find(examples.begin(), examples.end(), cut) == examples.end()) examples.emplace_back(cut);
  }
};

}  // namespace pof::recorder
