#pragma once
// The model behind `pof spy`: each channel seen, its rate, counts, sequence gaps and the latest
// decoded value of pofkit's own types (lcmtypes/*.lcm); unknown channels are kept by fingerprint
// and size. At most pof::recorder::kMaxTrackedChannels names get a row (POF_* names a reserve
// beyond it: pof/recorder/channel_cap.hpp); messages on further names are counted together as
// "other channels", so that a flood of names cannot grow the spy without bound. No LCM, no terminal: messages in (bytes + receive time), text out, so it is unit-tested
// without a network. A message that still carries an authenticated-mode trailer (the spy was given
// no key, so nothing verified it) is shown from the LCM message in front of the trailer and counted
// as SIGNED, NOT VERIFIED on its channel.
//
// Thread safety: none; one thread feeds and renders (cmd_spy.cpp runs a single poll() loop).
#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include <pof/angle_t.hpp>
#include <pof/compensator_status_t.hpp>
#include <pof/cycle_stats_t.hpp>
#include <pof/daq_status_t.hpp>
#include <pof/raw_block_t.hpp>

#include "pof/bus/auth_trailer.hpp"
#include "pof/bus/fingerprint.hpp"
#include "pof/recorder/channel_cap.hpp"
#include "pof/recorder/pof_messages.hpp"

namespace pof::spy {

struct ChannelView {
  std::string name;
  uint64_t count = 0;
  uint64_t bytes = 0;
  uint64_t decode_errors = 0;     // fingerprint matched one of our types but it did not decode (bounded decoder)
  uint64_t unverified = 0;        // messages with an authenticated-mode trailer shown without verification (no key)
  std::size_t last_size = 0;
  uint64_t fingerprint = 0;
  bus::MessageType type = bus::MessageType::kUnknown;
  int64_t last_recv_utime = 0;
  double rate_hz = 0;             // over the last ~1 s of ticks
  recorder::SeqTracker seq;
  std::deque<std::pair<int64_t, uint64_t>> history;  // (tick utime, count) for the rate

  std::optional<pof::raw_block_t> raw;
  std::optional<pof::angle_t> angle;
  std::deque<pof::cycle_stats_t> stats;  // newest last, at most kStatsKept
  std::optional<pof::daq_status_t> status;
  std::optional<pof::compensator_status_t> compensator;
};

class Monitor {
 public:
  static constexpr std::size_t kStatsKept = 8;

  /// One received message. Never throws; undecodable messages are counted.
  void on_message(std::string_view channel, const void* data, std::size_t size, int64_t recv_utime);
  /// Updates the rates; call at the refresh rate with the current time [us].
  void tick(int64_t now_utime);

  [[nodiscard]] const std::map<std::string, ChannelView>& channels() const { return channels_; }
  [[nodiscard]] uint64_t total_messages() const { return total_; }
  /// Messages on channels beyond the bound (no row of their own).
  [[nodiscard]] const recorder::OtherChannels& other_channels() const { return other_; }

 private:
  std::map<std::string, ChannelView> channels_;
  recorder::OtherChannels other_;
  uint64_t total_ = 0;
};

struct RenderOptions {
  bool ansi = true;          // clear screen + bold headings (live view); false for --once snapshots
  int width = 100;           // columns available
  std::string url;
  double uptime_s = 0;
  uint64_t kernel_drops = 0; // UDP datagrams the kernel dropped on our socket
  uint64_t malformed_datagrams = 0;  // datagrams on the port that are not LCM (pof::bus::ReceiverStats)
  uint64_t incomplete_messages = 0;  // fragmented messages abandoned incomplete
  // Authenticated mode (pof::bus::ReceiverStats): messages the verifier dropped, per verdict.
  bool authenticated = false;
  std::string key_id;
  uint64_t auth_unsigned = 0, auth_bad_mac = 0, auth_stale = 0, auth_replayed = 0;
  int64_t now_utime = 0;
};

/// The whole screen as text (lines end with "\n"; with ansi, a cursor-home/clear prefix).
std::string render(const Monitor& m, const RenderOptions& o);

/// "OK" or the QUALITY_* names of angle_t.quality joined by '|'.
std::string quality_names(int32_t quality);
/// "HOLD", "FLEXION", "EXTENSION" or the number.
std::string phase_name(int8_t phase);
/// "STARTING", "STREAMING", ... or the number.
std::string daq_state_name(int8_t state);

}  // namespace pof::spy
