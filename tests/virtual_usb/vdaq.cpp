// pof-vdaq: runs the real pof-daqd against a virtual USB DAQ and checks what it publishes.
//
//   umockdev-wrapper pof-vdaq --model 6008 --scenario normal --duration 10 --daemon build/bin/pof-daqd
//
// The program must run under umockdev-wrapper (LD_PRELOAD of libumockdev-preload): it creates the
// testbed and the virtual device, fork/execs pof-daqd (which inherits the preload and the
// testbed), serves it from the testbed thread, listens to POF_RAW/POF_DAQ_STATUS on LCM, runs the
// scenario (unplug, stall, garbage, ...), stops the daemon with SIGTERM and checks:
// (the devices' analog inputs see the simulator's knee: analog_bench.hpp, --sim-scenario)
//   - every published volt equals what the device sent, within 1 LSB (decimation-aware);
//   - first_scan continuous across blocks unless FLAG_GAP; dropped scans counted;
//   - published rate and measured scan rate; timestamps against the device's own clock;
//   - scan-to-publish latency, the seam between finite segments, daemon CPU use;
//   - states seen, counters, clean exit 0 on SIGTERM.
// Prints a JSON report (and writes it to --report); exit 0 when every requested check passes,
// 1 otherwise, 2 on usage errors.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <CLI/CLI.hpp>
#pragma GCC diagnostic pop
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include "analog_bench.hpp"
#include "ni600x_model.hpp"
#include "pof/daq_status_t.hpp"
#include "pof/raw_block_t.hpp"
#include "usb1208ls_model.hpp"
#include "usbdevfs_device.hpp"

namespace {

using pof::vusb::Ni600xModel;
using pof::vusb::NiOptions;

std::int64_t now_us() { return g_get_real_time(); }

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::clamp(p / 100.0 * static_cast<double>(v.size() - 1), 0.0,
                                                     static_cast<double>(v.size() - 1)));
  return v[i];
}

long cpu_ticks(pid_t pid) {
  const std::string path = "/proc/" + std::to_string(pid) + "/stat";
  FILE* f = std::fopen(path.c_str(), "r");
  if (f == nullptr) return -1;
  char line[1024] = {};
  const bool ok = std::fgets(line, sizeof line, f) != nullptr;
  std::fclose(f);
  if (!ok) return -1;
  const std::string s(line);
  const auto rp = s.rfind(')');
  if (rp == std::string::npos) return -1;
  std::istringstream is(s.substr(rp + 2));
  std::string tok;
  long ut = 0;
  long st = 0;
  for (int field = 3; is >> tok; ++field) {
    if (field == 14) ut = std::stol(tok);
    if (field == 15) {
      st = std::stol(tok);
      break;
    }
  }
  return ut + st;
}

// Descriptors: device (18 bytes) + configuration, one interface, endpoints as listed.
std::string descriptors(std::uint16_t vid, std::uint16_t pid, const std::string& iface_and_eps_hex,
                        int iface_len, bool has_serial = false, std::uint16_t bcd_usb = 0x0210, int max_packet0 = 64) {
  char dev[64];
  std::snprintf(dev, sizeof dev, "1201%02x%02x000000%02x%02x%02x%02x%02x00010000%02x01", bcd_usb & 0xFF, bcd_usb >> 8,
                max_packet0, vid & 0xFF, vid >> 8, pid & 0xFF, pid >> 8, has_serial ? 3 : 0);
  char cfg[32];
  const int total = 9 + iface_len;
  std::snprintf(cfg, sizeof cfg, "0902%02x%02x0101008032", total & 0xFF, total >> 8);
  return std::string(dev) + cfg + iface_and_eps_hex;
}

struct Checker {
  // Set before the daemon starts.
  Ni600xModel* ni = nullptr;
  pof::vusb::Usb1208lsModel* mcc = nullptr;
  pof::vusb::AnalogBench* bench = nullptr;
  std::mutex* dev_mu = nullptr;
  int decimate = 1;
  double range_v = 10;
  std::int64_t warmup_end_us = 0;

  std::mutex mu;
  // Results.
  long blocks = 0;
  long scans = 0;
  long value_errors = 0;
  double max_value_error_lsb = 0;
  long index_jumps = 0;      // discontinuities without FLAG_GAP
  long gaps = 0;             // blocks with FLAG_GAP
  long seq_gaps = 0;
  long gap_scans = 0;        // index advance across FLAG_GAP blocks
  std::vector<std::pair<std::int64_t, long>> gap_events;  // (receive time [us], index advance) per FLAG_GAP block
  // USB-1208LS: scans its executions delivered in the session (the values' truth follows the
  // device, whatever index the daemon gives them), the seams matched, and their flagging.
  std::int64_t mcc_delivered = 0;
  std::size_t mcc_seams_seen = 0;  // of mcc->seams, those the published stream has passed
  std::int64_t single_gap_scans = 0;  // USB-1208LS single reads: scans the daemon's pacing gave up
  long seam_gaps = 0;              // seams published as FLAG_GAP
  long unflagged_seams = 0;        // seams published without FLAG_GAP
  double max_seam_length_error = 0;  // |published index advance - scans the device skipped|
  long seam_dropped = 0;           // the index advance over flagged seams
  long doubtful_blocks = 0;  // FLAG_DOUBTFUL: values not checked (the daemon does not vouch for them)
  long utime_backsteps = 0;  // blocks stamped at or before the previous one
  std::int64_t max_utime_backstep_us = 0;
  std::int64_t prev_utime = 0;
  long streaming_without_scans = 0;  // statuses saying `streaming` while the scan count is 0
  std::int64_t next_first = -1;
  std::int64_t prev_seq = -1;
  int session = 1;
  std::int64_t local = 0;    // session-local published scan index expected next
  double published_rate = 0;
  std::vector<double> age_publish_us;   // publish_utime - true time of the newest scan
  std::vector<double> age_receive_us;   // receive time - true time of the newest scan
  std::vector<double> ts_error_us;      // utime - true time of the first scan
  // (receive time in us, scans received so far) per block after the warm-up: the measured rate is
  // the least-squares slope, which one late block at either end of the window does not move (the
  // first and last receive times alone gave 1.6 % on a loaded host).
  std::vector<std::pair<double, double>> rate_points;
  std::int32_t flags_or = 0;
  bool simulated = false;
  std::string first_error;
  // Status.
  std::set<int> states;
  std::vector<std::string> state_texts;
  pof::daq_status_t last_status;
  long status_msgs = 0;
  // pof-daqd publishes `stopping` when its acquisition ends and once more, with the final counters,
  // after its last block (daq/daemon/daemon.cpp, publisher_main): the second one ends its stream.
  long stopping_msgs = 0;

  // Truth time of device scan `idx` of `session` (device mutex held).
  double truth_us(int sess, double idx) const {
    const auto& segs = ni->segments;
    for (auto it = segs.rbegin(); it != segs.rend(); ++it) {
      if (it->session == sess && idx >= static_cast<double>(it->first_index)) {
        return static_cast<double>(it->start_us) + (idx - static_cast<double>(it->first_index)) / it->rate_hz * 1e6;
      }
    }
    return kNaN;
  }

  void on_raw(const pof::raw_block_t& b) {
    const std::int64_t recv = now_us();
    std::lock_guard lock(mu);
    ++blocks;
    flags_or |= b.flags;
    published_rate = b.scan_rate_hz;
    if (prev_seq >= 0 && b.seq != prev_seq + 1) ++seq_gaps;
    prev_seq = b.seq;
    if (prev_utime != 0 && b.utime <= prev_utime) {  // utime is monotonic per stream
      ++utime_backsteps;
      max_utime_backstep_us = std::max(max_utime_backstep_us, prev_utime - b.utime);
    }
    prev_utime = b.utime;
    const bool doubtful = (b.flags & int32_t{pof::raw_block_t::FLAG_DOUBTFUL}) != 0;
    if (doubtful) ++doubtful_blocks;
    const bool gap = (b.flags & int32_t{pof::raw_block_t::FLAG_GAP}) != 0;
    bool handled = false;  // USB-1208LS: sessions and seams told from the device
    if (mcc != nullptr) {
      std::lock_guard dlock(*dev_mu);
      if (blocks == 1 || (gap && mcc->sessions != session)) {  // the device's current session
        if (gap) {
          ++gaps;
          if (next_first >= 0) gap_scans += b.first_scan - next_first;
          gap_events.emplace_back(recv, next_first >= 0 ? static_cast<long>(b.first_scan - next_first) : 0L);
        }
        session = mcc->sessions;
        local = 0;
        mcc_delivered = 0;
        mcc_seams_seen = 0;
        while (mcc_seams_seen < mcc->seams.size() && mcc->seams[mcc_seams_seen].session != session) ++mcc_seams_seen;
      } else {
        // Seams of this session the block's scans cross (at most one: executions are long).
        const std::int64_t advance = next_first >= 0 ? b.first_scan - next_first : 0;
        std::size_t k = mcc_seams_seen;
        while (k < mcc->seams.size() && mcc->seams[k].session != session) ++k;
        if (k < mcc->seams.size() && mcc->seams[k].scans_before <= mcc_delivered + std::int64_t{b.n_scans} * decimate - 1 &&
            mcc->seams[k].scans_before >= mcc_delivered - decimate) {
          const auto& sm = mcc->seams[k];
          if (gap) {
            ++seam_gaps;
            seam_dropped += advance;
            // The hole published: the scans not taken plus those of a partial decimation window
            // the daemon dropped with them (taken, never published), rounded to whole windows.
            const std::int64_t hole = sm.skipped + (sm.scans_before - mcc_delivered);
            max_seam_length_error = std::max(max_seam_length_error,
                                             std::abs(static_cast<double>(advance * decimate - hole)));
            mcc_delivered = sm.scans_before;  // a partial decimation window went with the hole
          } else {
            ++unflagged_seams;
            if (first_error.empty()) {
              first_error = "seam after scan " + std::to_string(sm.scans_before) + " (" + std::to_string(sm.skipped) +
                            " scans not taken) published without FLAG_GAP";
            }
          }
          mcc_seams_seen = k + 1;
        } else if (gap) {
          ++gaps;  // a gap the device did not cause
          gap_events.emplace_back(recv, static_cast<long>(advance));
          // Single reads: the device reads on, one after the other; the daemon's index jumped over
          // the scans its pacing gave up (docs/daq.md, "Continuous acquisition"). The k-th read
          // stays the truth of the next published scan.
          if (!mcc->scanned(session)) {
            single_gap_scans += advance;
            local -= advance;
          }
        }
        if (!gap && advance != 0) {
          ++index_jumps;
          if (first_error.empty()) {
            first_error = "first_scan " + std::to_string(b.first_scan) + " expected " + std::to_string(next_first);
          }
        }
        local += advance;
      }
      handled = true;
    }
    if (handled) {
    } else if (gap) {
      ++gaps;
      ++session;
      local = 0;
      if (next_first >= 0) gap_scans += b.first_scan - next_first;
      gap_events.emplace_back(recv, next_first >= 0 ? static_cast<long>(b.first_scan - next_first) : 0L);
    } else if (next_first >= 0 && b.first_scan != next_first) {
      ++index_jumps;
      if (first_error.empty()) {
        first_error = "first_scan " + std::to_string(b.first_scan) + " expected " + std::to_string(next_first);
      }
      local += b.first_scan - next_first;
    }
    next_first = b.first_scan + b.n_scans;
    scans += b.n_scans;
    if (ni == nullptr && mcc == nullptr) {  // sim backend: no device truth, use its own times
      if (recv >= warmup_end_us) {
        const double period = 1e6 / b.scan_rate_hz;
        const double t_last = static_cast<double>(b.utime) + (b.n_scans - 1) * period;
        age_publish_us.push_back(static_cast<double>(b.publish_utime) - (t_last + period));
        age_receive_us.push_back(static_cast<double>(recv) - (t_last + period));
        rate_points.emplace_back(static_cast<double>(recv), static_cast<double>(scans));
      }
      simulated = (b.flags & int32_t{pof::raw_block_t::FLAG_SIMULATED}) != 0;
      local += b.n_scans;
      return;
    }
    std::lock_guard dlock(*dev_mu);
    const double lsb = 2.0 * range_v / static_cast<double>(1U << (ni ? ni->bits() : 12U));
    for (std::int32_t k = 0; k < b.n_scans; ++k) {
      const std::int64_t j = local + k;
      for (int c = 0; c < b.n_channels; ++c) {
        double want = 0;
        for (int d = 0; d < decimate; ++d) {
          const std::int64_t idx = j * decimate + d;
          const auto ch = static_cast<std::size_t>(c);
          want += ni ? pof::daq::ni::code_to_volts(ni->code(session, idx, ch), ni->bits(), range_v)
                     : !mcc->scanned(session)
                         ? mcc->volts_single(session, idx, ch)
                         : mcc->volts_sent(session, mcc->bench_scan_of(session, mcc_delivered + k * decimate + d), ch);
        }
        want /= decimate;
        if (doubtful) continue;  // flagged: not published as good
        const double err = std::abs(static_cast<double>(b.volts[static_cast<std::size_t>(k)][static_cast<std::size_t>(c)]) - want);
        max_value_error_lsb = std::max(max_value_error_lsb, err / lsb);
        if (err > lsb + 1e-6) {
          ++value_errors;
          if (first_error.empty()) {
            first_error = "block seq " + std::to_string(b.seq) + " scan " + std::to_string(k) + " channel " +
                          std::to_string(c) + ": " + std::to_string(b.volts[static_cast<std::size_t>(k)][static_cast<std::size_t>(c)]) +
                          " V, device sent " + std::to_string(want) + " V";
          }
        }
      }
    }
    if (mcc == nullptr) bench->forget_before(session, local * decimate);  // verified: the bench may drop them
    else if (mcc->scanned(session)) bench->forget_before(session, mcc->bench_scan_of(session, mcc_delivered));
    else bench->forget_before(session, local * decimate);
    if (mcc != nullptr) mcc_delivered += std::int64_t{b.n_scans} * decimate;
    if (ni != nullptr) {
      const double half = (decimate - 1) / 2.0;
      const double t_first = truth_us(session, static_cast<double>(local * decimate) + half);
      const double t_last = truth_us(session, static_cast<double>((local + b.n_scans - 1) * decimate) + (decimate - 1));
      if (recv >= warmup_end_us && std::isfinite(t_first) && std::isfinite(t_last)) {
        ts_error_us.push_back(static_cast<double>(b.utime) - t_first);
        // The newest scan exists once its conversion ends, one device period after its start.
        const double period = 1e6 / ni->segments.back().rate_hz;
        age_publish_us.push_back(static_cast<double>(b.publish_utime) - (t_last + period));
        age_receive_us.push_back(static_cast<double>(recv) - (t_last + period));
      }
    }
    if (recv >= warmup_end_us) {
      rate_points.emplace_back(static_cast<double>(recv), static_cast<double>(scans));
    }
    local += b.n_scans;
  }

  void on_status(const pof::daq_status_t& s) {
    std::lock_guard lock(mu);
    ++status_msgs;
    states.insert(s.state);
    if (s.state == pof::daq_status_t::STATE_STOPPING) ++stopping_msgs;
    if (s.state == pof::daq_status_t::STATE_STREAMING && s.scans == 0) ++streaming_without_scans;
    const std::string t = std::to_string(s.state) + ": " + s.state_text;
    if (state_texts.empty() || state_texts.back() != t) state_texts.push_back(t);
    last_status = s;
  }
};

// Plain-function handlers (subscribeFunction): lcm's pointer-to-member path trips a GCC 12 UBSan
// false positive (see tests/functional/test_lcmtypes_roundtrip.cpp on main).
void on_raw(const lcm::ReceiveBuffer*, const std::string&, const pof::raw_block_t* m, Checker* c) {
  c->on_raw(*m);
}
void on_status(const lcm::ReceiveBuffer*, const std::string&, const pof::daq_status_t* m, Checker* c) {
  c->on_status(*m);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pof-vdaq: pof-daqd against a virtual USB DAQ (run under umockdev-wrapper)", "pof-vdaq"};
  std::string model = "6008";
  std::string scenario = "normal";
  std::string daemon = "pof-daqd";
  std::string report_path;
  double duration = 5;
  double warmup = 1;
  double event_at = 2;
  double unplug_for = 1.5;
  double unplug_every = 0;
  double rate = 2000;
  int decimate = 10;
  int block_scans = 1;
  long segment_scans = 0;
  std::string byte_order = "big";
  std::string daemon_byte_order = "auto";
  int reply_header = 0;
  bool padding_noise = false;
  double steady_volts = kNaN;
  int steady_noise_lsb = 1;
  std::string report_layout = "record-first";
  int report_bytes = 105;
  std::string se_scan_coding = "twos";
  bool refuse_feature = false;
  double max_seam_error = 1;
  double expect_rate = 0;
  long min_seams = 0;
  int ep0_per_frame = 1;
  std::string expect_variant;
  double clock_ppm = 0;
  int lcm_port = 0;
  int short_every = 7;
  int transfers = 4;
  // checks
  long max_dropped = 0;
  long max_paced_gaps = 0;
  bool expect_gap = false;
  bool expect_no_data = false;
  std::vector<int> expect_states;
  long min_reconnects = 0;
  long min_usb_errors = 0;
  double max_ts_error_us = -1;
  double min_rate_ratio = 0.99;
  std::string device_serial;
  pof::vusb::BenchOptions bench_opts;
  std::string record_pcap;
  std::string replay_pcap;
  std::vector<std::string> extra;
  app.add_option("--model", model, "6008, 6009, 1208ls, or sim (pof-daqd's sim:synthetic backend, no USB)")
      ->check(CLI::IsMember({"6008", "6009", "1208ls", "sim"}));
  app.add_option("--scenario", scenario)
      ->check(CLI::IsMember({"normal", "unplug", "stall", "short", "garbage", "padding", "silent", "absent"}));
  app.add_option("--daemon", daemon, "path of pof-daqd");
  app.add_option("--report", report_path, "write the JSON report here");
  app.add_option("--duration", duration, "seconds the daemon runs before SIGTERM");
  app.add_option("--warmup", warmup, "seconds ignored by the rate/latency/CPU figures");
  app.add_option("--event-at", event_at, "seconds: when the scenario's event happens");
  app.add_option("--unplug-for", unplug_for, "seconds unplugged");
  app.add_option("--unplug-every", unplug_every,
                 "scenario unplug: unplug again every this many seconds after --event-at while the run lasts (0 = once)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--rate", rate, "scan rate [scans/s]");
  app.add_option("--decimate", decimate);
  app.add_option("--block-scans", block_scans);
  app.add_option("--segment-scans", segment_scans, "0 = the daemon's default");
  app.add_option("--byte-order", byte_order, "the virtual NI device's sample byte order")
      ->check(CLI::IsMember({"big", "little"}));
  app.add_option("--daemon-byte-order", daemon_byte_order, "pof-daqd's acquisition.sample_byte_order")
      ->check(CLI::IsMember({"auto", "big", "little"}));
  app.add_option("--reply-header", reply_header, "NI replies begin 00 <this>: 0 (comedi) or 1 (6008 sources)")
      ->check(CLI::Range(0, 1));
  app.add_flag("--padding-noise", padding_noise, "NI samples carry noise in their padding bits");
  app.add_option("--steady-volts", steady_volts, "NI inputs at this level (+-1 LSB) instead of the knee");
  app.add_option("--steady-noise-lsb", steady_noise_lsb, "noise on the --steady-volts level: 1 (+-1 LSB) or 0 (none)")
      ->check(CLI::Range(0, 1));
  app.add_option("--report-layout", report_layout, "USB-1208LS feature-report layout")
      ->check(CLI::IsMember({"record-first", "data-first"}));
  app.add_option("--report-bytes", report_bytes,
                 "USB-1208LS scan report length on the wire: 105, or 104 (wjasper Python: data-first, no record number)")
      ->check(CLI::IsMember({104, 105}));
  app.add_option("--se-scan-coding", se_scan_coding,
                 "USB-1208LS single-ended scan samples: twos (12-bit two's complement) or offset (as the AIn reply)")
      ->check(CLI::IsMember({"twos", "offset"}));
  app.add_flag("--refuse-feature", refuse_feature,
               "USB-1208LS: every feature GET_REPORT stalls (hid_get_feature_report returns -1)");
  app.add_option("--max-seam-error", max_seam_error,
                 "USB-1208LS: bound on |published hole - scans the device did not take| per seam");
  app.add_option("--expect-rate", expect_rate,
                 "published scan_rate_hz expected (0 = --rate / --decimate; a USB-1208LS software-paced fallback runs slower)");
  app.add_option("--ep0-per-frame", ep0_per_frame,
                 "USB-1208LS (low speed): 8-byte control transactions the host moves per 1-ms frame "
                 "(1: one per frame, the usual figure; 0: control transfers complete at once)")
      ->check(CLI::Range(0, 3));
  app.add_option("--min-seams", min_seams, "USB-1208LS: seams (idle device between executions) that must be seen");
  app.add_option("--expect-variant", expect_variant,
                 "text the last status's protocol_variant must contain");
  app.add_option("--clock-ppm", clock_ppm, "device clock error [ppm]");
  app.add_option("--lcm-port", lcm_port, "0 = pick one from the process id (parallel tests and other "
                                         "LCM users on the host must not cross-talk)");
  app.add_option("--short-every", short_every, "scenario short: every Nth data URB is 2 bytes short");
  app.add_option("--transfers", transfers, "acquisition.transfers_in_flight");
  app.add_option("--max-dropped", max_dropped);
  app.add_option("--max-paced-gaps", max_paced_gaps,
                 "USB-1208LS single reads: flagged holes the daemon's host pacing may publish (a scan two "
                 "periods late on a loaded host); their scans count against --max-dropped");
  app.add_flag("--expect-gap", expect_gap);
  app.add_flag("--expect-no-data", expect_no_data);
  app.add_option("--expect-state", expect_states, "daq_status_t state that must be seen (repeatable)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app.add_option("--min-reconnects", min_reconnects);
  app.add_option("--min-usb-errors", min_usb_errors);
  app.add_option("--max-ts-error-us", max_ts_error_us, "bound on |utime - true scan time| (p99)");
  app.add_option("--min-rate-ratio", min_rate_ratio, "measured/published scan rate lower bound");
  app.add_option("--sim-scenario", bench_opts.scenario,
                 "what the device's analog inputs see: a pof sim scenario (built-in name or file), "
                 "looped; ai0 sensor, ai1 reference, ai2 pot");
  app.add_option("--sim-seed", bench_opts.seed, "the simulator's seed");
  app.add_option("--truth", bench_opts.truth_csv,
                 "write every simulated scan (volts and the true knee angle) to this CSV");
  app.add_option("--device-serial", device_serial, "the virtual NI device's serial number string");
  app.add_option("--record-pcap", record_pcap, "write the session as a usbmon capture (pcap)");
  app.add_option("--replay-pcap", replay_pcap,
                 "serve a recorded usbmon capture (umockdev pcap replay) instead of the model; the "
                 "values are checked against the model when the capture came from it");
  app.footer("Arguments after -- go to pof-daqd unchanged.");
  // Everything after the first "--" is pof-daqd's (split here: CLI11 lets a "--" right after a
  // vector option end that option instead of the option list).
  int own_argc = argc;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--") {
      own_argc = i;
      for (int j = i + 1; j < argc; ++j) extra.emplace_back(argv[j]);
      break;
    }
  }
  try {
    app.parse(own_argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // usage errors exit 2 (brief), whatever CLI11's code
  }

  const char* preload = std::getenv("LD_PRELOAD");
  if (preload == nullptr || std::string(preload).find("umockdev-preload") == std::string::npos) {
    std::fprintf(stderr, "pof-vdaq: not under umockdev-wrapper (LD_PRELOAD of libumockdev-preload)\n");
    return 2;
  }

  // The simulated knee on the analog inputs, sampled at the device's scan rate.
  std::unique_ptr<pof::vusb::AnalogBench> bench;
  try {
    bench_opts.scan_rate_hz = rate;
    bench = std::make_unique<pof::vusb::AnalogBench>(bench_opts);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pof-vdaq: --sim-scenario %s: %s\n", bench_opts.scenario.c_str(), e.what());
    return 2;
  }
  UMockdevTestbed* testbed = umockdev_testbed_new();
  std::unique_ptr<Ni600xModel> ni;
  std::unique_ptr<pof::vusb::Usb1208lsModel> mcc;
  std::unique_ptr<pof::vusb::UsbdevfsDevice> dev;
  const bool is_ni = model == "6008" || model == "6009";
  const bool is_sim = model == "sim";
  NiOptions no;
  no.usb6009 = model == "6009";
  no.order = byte_order == "big" ? pof::daq::ni::ByteOrder::kBig : pof::daq::ni::ByteOrder::kLittle;
  no.clock_ppm = clock_ppm;
  no.silent = scenario == "silent";
  no.short_every = scenario == "short" ? short_every : 0;
  no.serial = device_serial;
  no.reply_header = static_cast<std::uint8_t>(reply_header);
  no.padding_noise = padding_noise;
  no.steady_volts = steady_volts;
  no.steady_noise_lsb = steady_noise_lsb;
  std::mutex replay_mu;
  if (!replay_pcap.empty()) {
    bench->begin_session();  // the recorded device's one session (the model sees no commands)
    // The model only computes what the recorded device sent (the same simulated knee, seed and
    // rate give the same scans); the bytes come from the capture.
    ni = std::make_unique<Ni600xModel>(no, *bench);
    const std::string ifc = "09040000" "03ff0000" "00" "0705010240" "0000" "0705810240" "0000" "0705820240" "0000";
    pof::vusb::UsbdevfsDevice::replay(
        testbed, pof::vusb::UsbIds{0x3923, static_cast<std::uint16_t>(no.usb6009 ? 0x717b : 0x717a),
                                   descriptors(0x3923, no.usb6009 ? 0x717b : 0x717a, ifc, 9 + 21)},
        replay_pcap);
  } else if (scenario != "absent" && !is_sim) {
    if (is_ni) {
      ni = std::make_unique<Ni600xModel>(no, *bench);
      // Interface 0, vendor class, 3 bulk endpoints of 64 bytes: 0x01 OUT, 0x81 IN, 0x82 IN.
      const std::string ifc = "09040000" "03ff0000" "00" "0705010240" "0000" "0705810240" "0000" "0705820240" "0000";
      dev = std::make_unique<pof::vusb::UsbdevfsDevice>(
          testbed, pof::vusb::UsbIds{0x3923, static_cast<std::uint16_t>(no.usb6009 ? 0x717b : 0x717a),
                                     descriptors(0x3923, no.usb6009 ? 0x717b : 0x717a, ifc, 9 + 21,
                                                 !device_serial.empty())},
          *ni);
    } else {
      pof::vusb::MccOptions mo;
      mo.layout = report_layout == "data-first" || report_bytes == 104 ? pof::daq::mcc::ReportLayout::kDataFirst
                                                                       : pof::daq::mcc::ReportLayout::kRecordFirst;
      mo.report_bytes = static_cast<std::size_t>(report_bytes);
      mo.se_scan_offset = se_scan_coding == "offset";
      mo.refuse_feature = refuse_feature;
      mcc = std::make_unique<pof::vusb::Usb1208lsModel>(clock_ppm, *bench, mo);
      using M = pof::vusb::Usb1208lsModel;
      dev = std::make_unique<pof::vusb::UsbdevfsDevice>(
          testbed,
          pof::vusb::UsbIds{0x09db, 0x007a,
                            descriptors(0x09db, 0x007a, M::kInterfaceHex, M::kInterfaceLen, false, M::kBcdUsb,
                                        M::kMaxPacket0),
                            M::kSpeed, ep0_per_frame},
          *mcc);
    }
  }

  if (lcm_port == 0) lcm_port = 30000 + static_cast<int>(getpid() % 30000);
  // A group of our own as well as a port: other projects' tests use 239.255.76.67.
  const std::string url = "udpm://239.255.77.67:" + std::to_string(lcm_port) + "?ttl=0&recv_buf_size=4194304";
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "pof-vdaq: LCM %s unusable (multicast route? ./pofkit setup)\n", url.c_str());
    return 1;
  }
  Checker checker;
  checker.ni = ni.get();
  checker.mcc = mcc.get();
  checker.bench = bench.get();
  checker.dev_mu = dev ? &dev->mutex() : &replay_mu;
  if (dev && !record_pcap.empty()) dev->record_pcap(record_pcap);
  checker.decimate = decimate;
  lcm.subscribeFunction("POF_RAW", &on_raw, &checker)->setQueueCapacity(100000);
  lcm.subscribeFunction("POF_DAQ_STATUS", &on_status, &checker)->setQueueCapacity(1000);
  std::atomic<bool> lcm_stop{false};
  std::thread lcm_thread([&] {
    while (!lcm_stop.load()) lcm.handleTimeout(50);
  });

  std::vector<std::string> args = {daemon,
                                   "--config", "/dev/null",
                                   "--device", is_sim ? "sim:synthetic" : is_ni ? "usb" + model : "usb1208ls",
                                   "--lcm-url", url,
                                   "--rate", std::to_string(rate),
                                   "--decimate", std::to_string(decimate),
                                   "--block-scans", std::to_string(block_scans),
                                   "-s", "acquisition.sample_byte_order=\"" + daemon_byte_order + "\"",
                                   "-s", "acquisition.transfers_in_flight=" + std::to_string(transfers),
                                   "-s", "daemon.retry_ms=200",
                                   "-s", "acquisition.command_timeout_ms=300",
                                   "-s", "acquisition.data_timeout_ms=500"};
  if (segment_scans > 0) {
    args.push_back("-s");
    args.push_back("acquisition.segment_scans=" + std::to_string(segment_scans));
  }
  for (const auto& e : extra) args.push_back(e);
  // /dev/null is an empty TOML file without schema_version: give it on the command line.
  args.push_back("-s");
  args.push_back("schema_version=1");

  const std::int64_t t0 = now_us();
  checker.warmup_end_us = t0 + static_cast<std::int64_t>(warmup * 1e6);
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> av;
    for (auto& a : args) av.push_back(a.data());
    av.push_back(nullptr);
    execv(av[0], av.data());
    std::perror("pof-vdaq: execv pof-daqd");
    _exit(127);
  }

  auto sleep_until = [&](double s) {
    const std::int64_t until = t0 + static_cast<std::int64_t>(s * 1e6);
    while (now_us() < until) {
      int st = 0;
      if (waitpid(pid, &st, WNOHANG) == pid) return false;  // daemon died
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return true;
  };
  bool alive = true;
  long cpu_warm = -1;
  std::int64_t cpu_warm_us = 0;
  if (warmup < duration) {
    alive = sleep_until(warmup);
    cpu_warm = cpu_ticks(pid);
    cpu_warm_us = now_us();
  }
  std::vector<std::pair<std::int64_t, std::int64_t>> unplugs;  // (unplugged, replugged) [us]
  if (alive && (scenario == "unplug" || scenario == "stall" || scenario == "garbage" || scenario == "padding")) {
    alive = sleep_until(event_at);
    if (alive && scenario == "unplug") {
      // One cycle, or (--unplug-every) one every unplug_every seconds while a whole one still fits.
      for (double at = event_at; alive;) {
        {
          std::lock_guard l(dev->mutex());
          ni ? ni->power_cycle() : mcc->power_cycle();
        }
        const std::int64_t off = now_us();
        dev->unplug();
        alive = sleep_until(at + unplug_for);
        dev->replug();
        unplugs.emplace_back(off, now_us());
        at += unplug_every;
        if (unplug_every <= 0 || at + unplug_for >= duration) break;
        alive = alive && sleep_until(at);
      }
    } else if (alive && scenario == "stall") {
      {
        std::lock_guard l(dev->mutex());
        if (ni) ni->stop_scanning();
      }
      dev->inject_in_error(is_ni ? pof::daq::ni::kEpDataIn : 0x81, -EPIPE);
    } else if (alive && ni) {
      std::lock_guard l(dev->mutex());
      ni->send_garbage(scenario == "garbage");
    }
  }
  if (alive) alive = sleep_until(duration);
  const long cpu_end = alive ? cpu_ticks(pid) : -1;
  const std::int64_t cpu_end_us = now_us();

  // SIGTERM: the daemon must stop cleanly and quickly.
  int status = 0;
  double stop_s = -1;
  if (alive) {
    kill(pid, SIGTERM);
    const std::int64_t ts = now_us();
    for (;;) {
      if (waitpid(pid, &status, WNOHANG) == pid) break;
      if (now_us() - ts > 5'000'000) {
        kill(pid, SIGKILL);
        waitpid(pid, &status, 0);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    stop_s = static_cast<double>(now_us() - ts) / 1e6;
  } else {
    waitpid(pid, &status, 0);
  }
  // The daemon's last messages: until its final status arrived (2 s at most: a daemon that died
  // sends none, and the report says so).
  for (const std::int64_t until = now_us() + 2'000'000; now_us() < until;) {
    {
      std::lock_guard lock(checker.mu);
      if (checker.stopping_msgs >= 2) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  lcm_stop.store(true);
  lcm_thread.join();

  // --- Report ----------------------------------------------------------------------------------
  nlohmann::json r;
  std::vector<std::string> failures;
  std::lock_guard lock(checker.mu);
  const bool exited = WIFEXITED(status);
  const int code = exited ? WEXITSTATUS(status) : -1;
  r["model"] = model;
  r["scenario"] = scenario;
  r["duration_s"] = duration;
  long bench_misses = 0;
  if (bench) {
    std::lock_guard dl(*checker.dev_mu);
    bench_misses = bench->misses();
    r["sim_scenario"] = bench->scenario_name();
    r["sim_scans_generated"] = bench->scans_generated();
    r["sim_misses"] = bench_misses;
  }
  r["daemon_exit_code"] = code;
  r["daemon_stop_s"] = stop_s;
  r["blocks"] = checker.blocks;
  r["scans_published"] = checker.scans;
  r["value_errors"] = checker.value_errors;
  r["max_value_error_lsb"] = checker.max_value_error_lsb;
  r["index_jumps_without_gap_flag"] = checker.index_jumps;
  r["gap_blocks"] = checker.gaps;
  r["gap_scans"] = checker.gap_scans;
  r["single_read_gap_scans"] = checker.single_gap_scans;
  r["seq_gaps"] = checker.seq_gaps;
  // Per event, seconds since the daemon started: what a soak matches up (tools/soak/).
  r["gap_events"] = nlohmann::json::array();
  for (const auto& [at, n] : checker.gap_events) {
    r["gap_events"].push_back({{"received_s", static_cast<double>(at - t0) / 1e6}, {"scans", n}});
  }
  r["unplugs"] = nlohmann::json::array();
  for (const auto& [off, on] : unplugs) {
    r["unplugs"].push_back({{"unplugged_s", static_cast<double>(off - t0) / 1e6}, {"replugged_s", static_cast<double>(on - t0) / 1e6}});
  }
  r["doubtful_blocks"] = checker.doubtful_blocks;
  r["utime_backsteps"] = checker.utime_backsteps;
  r["max_utime_backstep_us"] = checker.max_utime_backstep_us;
  r["streaming_without_scans"] = checker.streaming_without_scans;
  r["published_rate_hz"] = checker.published_rate;
  double measured_rate = kNaN;
  if (checker.rate_points.size() >= 3) {
    double mt = 0, ms = 0;
    for (const auto& [t, n] : checker.rate_points) { mt += t; ms += n; }
    mt /= static_cast<double>(checker.rate_points.size());
    ms /= static_cast<double>(checker.rate_points.size());
    double stt = 0, sts = 0;
    for (const auto& [t, n] : checker.rate_points) { stt += (t - mt) * (t - mt); sts += (t - mt) * (n - ms); }
    if (stt > 0) measured_rate = sts / stt * 1e6;
  }
  r["measured_rate_hz"] = measured_rate;
  auto stats = [](const std::vector<double>& v) {
    return nlohmann::json{{"n", v.size()}, {"p50", percentile(v, 50)}, {"p99", percentile(v, 99)},
                          {"max", v.empty() ? kNaN : *std::max_element(v.begin(), v.end())},
                          {"min", v.empty() ? kNaN : *std::min_element(v.begin(), v.end())}};
  };
  std::vector<double> abs_ts;
  for (double e : checker.ts_error_us) abs_ts.push_back(std::abs(e));
  r["timestamp_error_us"] = stats(checker.ts_error_us);
  r["timestamp_abs_error_us"] = stats(abs_ts);
  r["scan_to_publish_us"] = stats(checker.age_publish_us);
  r["scan_to_receive_us"] = stats(checker.age_receive_us);
  if (cpu_warm >= 0 && cpu_end >= 0 && cpu_end_us > cpu_warm_us) {
    r["daemon_cpu_percent"] = 100.0 * static_cast<double>(cpu_end - cpu_warm) / static_cast<double>(sysconf(_SC_CLK_TCK)) /
                              (static_cast<double>(cpu_end_us - cpu_warm_us) / 1e6);
  }
  if (dev) {
    std::lock_guard dl(dev->mutex());
    r["reaps"] = dev->reaps();
    if (ni) {
      std::vector<double> seams(ni->seams_us.begin(), ni->seams_us.end());
      r["segments"] = ni->segments.size();
      r["seam_us"] = stats(seams);
      r["device_protocol_errors"] = ni->protocol_errors;
      r["device_requests_header_00"] = ni->requests_00;
      r["device_requests_header_01"] = ni->requests_01;
      // The daemon speaks to the device with the header its replies use (protocol [3]).
      if ((reply_header == 0 ? ni->requests_01 : ni->requests_00) != 0) {
        failures.push_back("requests with a header byte other than the device's replies");
      }
      r["device_hellos"] = ni->hellos;
      r["device_last_command"] = ni->last_command;
      r["device_interfaces_claimed_at_exit"] = dev->claimed();
      // SIGTERM must stop the scan and release the device, unless it never answered.
      if (!no.silent && ni->hellos > 0 && ni->last_command != "session 0D") {
        failures.push_back("the last command was '" + ni->last_command + "', not the stop sequence's 0D/00");
      }
      if (dev->claimed() != 0) failures.push_back("interface still claimed after pof-daqd exited");
      if (ni->protocol_errors != 0) failures.push_back("the daemon sent frames the device did not understand");
    }
    // What the bus timing imposed (docs/virtual-usb.md, "Bus timing").
    const auto& bus = dev->figures();
    if (!bus.control_ms.empty()) r["usb_control_ms"] = stats(bus.control_ms);
    if (!bus.out_ms.empty()) r["usb_interrupt_out_ms"] = stats(bus.out_ms);
    if (!bus.round_trip_ms.empty()) r["usb_round_trip_ms"] = stats(bus.round_trip_ms);
    if (mcc) {
      std::vector<double> skipped;
      for (const auto& sm : mcc->seams) skipped.push_back(static_cast<double>(sm.skipped));
      r["seams"] = mcc->seams.size();
      r["seam_scans_not_taken"] = stats(skipped);
      r["seam_gaps"] = checker.seam_gaps;
      r["seam_dropped_scans"] = checker.seam_dropped;
      r["unflagged_seams"] = checker.unflagged_seams;
      r["max_seam_length_error_scans"] = checker.max_seam_length_error;
      r["device_feature_refusals"] = mcc->feature_refusals;
      r["device_scan_sessions"] = mcc->scan_sessions.size();
      if (checker.unflagged_seams > 0) {
        failures.push_back(std::to_string(checker.unflagged_seams) + " seams between executions published without FLAG_GAP: " +
                           checker.first_error);
      }
      if (checker.max_seam_length_error > max_seam_error) {
        failures.push_back("a seam's published hole is " + std::to_string(checker.max_seam_length_error) +
                           " scans off what the device did not take");
      }
      if (static_cast<long>(mcc->seams.size()) < min_seams) {
        failures.push_back("seams " + std::to_string(mcc->seams.size()) + " < " + std::to_string(min_seams));
      }
      r["device_protocol_errors"] = mcc->protocol_errors;
      if (mcc->protocol_errors != 0) failures.push_back("the daemon sent commands the USB-1208LS refuses");
    }
  }
  const auto& s = checker.last_status;
  r["status"] = {{"messages", checker.status_msgs}, {"scans", s.scans}, {"blocks", s.blocks},
                 {"dropped_scans", s.dropped_scans}, {"usb_errors", s.usb_errors}, {"overruns", s.overruns},
                 {"reconnects", s.reconnects}, {"last_state", s.state}, {"last_text", s.state_text},
                 {"serial", s.serial}, {"vendor_id", s.vendor_id}, {"product_id", s.product_id},
                 {"protocol_variant", s.protocol_variant}, {"padding_set", s.padding_set}};
  r["states_seen"] = checker.state_texts;
  if (bench_misses > 0) {
    failures.push_back(std::to_string(bench_misses) + " lookups of scans the simulated bench never gave "
                       "(device and checker sessions out of step)");
  }
  if (is_sim && !checker.simulated) failures.push_back("sim blocks without FLAG_SIMULATED");
  if (!checker.first_error.empty()) r["first_error"] = checker.first_error;

  if (code != 0) failures.push_back("pof-daqd exited " + std::to_string(code) + " (expected 0 on SIGTERM)");
  if (stop_s > 2.0) failures.push_back("pof-daqd took " + std::to_string(stop_s) + " s to stop");
  if (checker.value_errors > 0) failures.push_back(std::to_string(checker.value_errors) + " samples differ from what the device sent by more than 1 LSB: " + checker.first_error);
  if (checker.index_jumps > 0) failures.push_back("scan index jumps without FLAG_GAP: " + checker.first_error);
  if (checker.seq_gaps > 0) failures.push_back("LCM sequence gaps (lost blocks)");
  if (checker.utime_backsteps > 0) {
    failures.push_back("utime stepped back " + std::to_string(checker.utime_backsteps) + " times (max " +
                       std::to_string(checker.max_utime_backstep_us) + " us)");
  }
  if (checker.streaming_without_scans > 0) failures.push_back("status 'streaming' published before any scan");
  if (!expect_variant.empty() && s.protocol_variant.find(expect_variant) == std::string::npos) {
    failures.push_back("protocol_variant '" + s.protocol_variant + "' does not contain '" + expect_variant + "'");
  }
  if (s.dropped_scans > max_dropped) failures.push_back("dropped_scans " + std::to_string(s.dropped_scans) + " > " + std::to_string(max_dropped));
  if (s.overruns > 0 && max_dropped == 0) failures.push_back("publisher overruns " + std::to_string(s.overruns));
  if (expect_gap && checker.gaps == 0) failures.push_back("expected a FLAG_GAP block, saw none");
  if (!expect_gap && checker.gaps > max_paced_gaps) {
    failures.push_back("unexpected FLAG_GAP blocks: " + std::to_string(checker.gaps));
  }
  if (expect_no_data && checker.blocks > 0) failures.push_back("expected no data, got blocks");
  if (!expect_no_data && checker.blocks == 0) failures.push_back("no POF_RAW blocks received");
  for (int st : expect_states) {
    if (checker.states.count(st) == 0U) failures.push_back("state " + std::to_string(st) + " never published");
  }
  if (s.reconnects < min_reconnects) failures.push_back("reconnects " + std::to_string(s.reconnects) + " < " + std::to_string(min_reconnects));
  if (s.usb_errors < min_usb_errors) failures.push_back("usb_errors " + std::to_string(s.usb_errors) + " < " + std::to_string(min_usb_errors));
  if (s.state != 4) failures.push_back("last published state is not 'stopping'");
  // A pcap replay's pace is umockdev's, not the capture's (a loaded CI run read 2.3x the recorded
  // rate, all scans intact), so its scan rate says nothing about the device: not checked.
  if (replay_pcap.empty() && !expect_no_data && std::isfinite(measured_rate) && checker.published_rate > 0 &&
      (measured_rate / checker.published_rate < min_rate_ratio || measured_rate / checker.published_rate > 2.0 - min_rate_ratio)) {
    failures.push_back("measured scan rate " + std::to_string(measured_rate) + " vs published " + std::to_string(checker.published_rate));
  }
  // The device's clock divisor rounds the configured rate (USB-1208LS: 6 MHz / 2^n / 8-bit timer).
  const double want_rate = expect_rate > 0 ? expect_rate : rate / decimate;
  if (!expect_no_data && std::abs(checker.published_rate - want_rate) > 0.005 * want_rate) {
    failures.push_back("published scan_rate_hz " + std::to_string(checker.published_rate) + " expected " + std::to_string(want_rate));
  }
  if (max_ts_error_us >= 0 && !abs_ts.empty() && percentile(abs_ts, 99) > max_ts_error_us) {
    failures.push_back("timestamp error p99 " + std::to_string(percentile(abs_ts, 99)) + " us > " + std::to_string(max_ts_error_us));
  }
  r["failures"] = failures;
  r["pass"] = failures.empty();
  const std::string text = r.dump(2);
  std::printf("%s\n", text.c_str());
  if (!report_path.empty()) std::ofstream(report_path) << text << "\n";
  dev.reset();
  g_object_unref(testbed);
  return failures.empty() ? 0 : 1;
}
