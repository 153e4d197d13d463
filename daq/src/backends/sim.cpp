// `sim:<scenario>` backend: scans from a SampleSource, paced by the host clock at the configured
// scan rate and handed over in the same chunk sizes a USB transfer would carry (~4 ms), so the
// daemon downstream behaves as with hardware. Used for CPU/latency figures without a spinning
// emulator (docs/virtual-usb.md, item 5).
//
// Test hook: $POF_SIM_STALL="<at_s>:<for_s>" blocks the acquisition thread once, <at_s> seconds
// into the stream, for <for_s> seconds without a word to the daemon, as a device read that hangs
// would; then the scans of that time are handed over at once (the pacing deadlines are absolute),
// as a device FIFO would. docs/daq.md, "Watchdog and stalls", says what the daemon must do then.

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "pof/daq/stream/backend.hpp"
#include "pof/daq/backends/pacing.hpp"
#include "pof/daq/backends/sample_source.hpp"
#include "pof/daq/stream/config.hpp"
#include "pof/base/errors.hpp"
#include "pof/sim/scenario.hpp"
#include "pof/sim/simulator.hpp"
#include "pof/lcm/utime.hpp"

namespace pof::daq {
namespace {

using pof::lcmutil::now_utime;

struct StallHook {
  double at_s = -1;  // < 0: none
  double for_s = 0;
};

// $POF_SIM_STALL, "<at_s>:<for_s>" (both >= 0, for_s <= 3600); anything else is a configuration
// error naming the variable, so that a test never runs without the stall it asked for.
StallHook stall_hook_from_env() {
  const char* env = std::getenv("POF_SIM_STALL");
  if (env == nullptr || *env == '\0') return {};
  const std::string v(env);
  const auto colon = v.find(':');
  StallHook h;
  try {
    std::size_t used_at = 0;
    std::size_t used_for = 0;
    if (colon == std::string::npos) throw std::invalid_argument("no ':'");
    h.at_s = std::stod(v.substr(0, colon), &used_at);
    h.for_s = std::stod(v.substr(colon + 1), &used_for);
    if (used_at != colon || used_for != v.size() - colon - 1 || !(h.at_s >= 0) || !(h.for_s >= 0) ||
        h.for_s > 3600)
      throw std::invalid_argument("out of range");
  } catch (const std::exception&) {
    throw pof::ConfigError("POF_SIM_STALL: expected <at_s>:<for_s> (seconds, e.g. 2:3), got '" + v + "'");
  }
  return h;
}

class SyntheticSource final : public SampleSource {
 public:
  SyntheticSource(double rate, bool ref, bool pot) : rate_(rate), ref_(ref), pot_(pot) {}
  std::size_t next(std::span<float> out) override {
    const std::size_t n_ch = 1U + (ref_ ? 1U : 0U) + (pot_ ? 1U : 0U);
    const std::size_t n = out.size() / n_ch;
    for (std::size_t k = 0; k < n; ++k, ++i_) {
      const double t = static_cast<double>(i_) / rate_;
      const double angle = 45.0 - 45.0 * std::cos(2.0 * std::numbers::pi * 0.5 * t);  // 0..90 deg
      std::size_t c = k * n_ch;
      out[c++] = static_cast<float>(4.35 - (4.35 - 2.38) * angle / 90.0);
      if (ref_) out[c++] = 5.0F;
      if (pot_) out[c++] = static_cast<float>(0.5 + 4.0 * angle / 90.0);
    }
    return n;
  }

 private:
  double rate_;
  bool ref_;
  bool pot_;
  std::uint64_t i_ = 0;
};

// The physics simulator (daq/sim/, docs/simulator.md) behind the same interface. The scans are
// already quantised by the simulated converter; the seed is fixed so that runs repeat.
class SimulatorSource final : public SampleSource {
 public:
  SimulatorSource(const pof::sim::Scenario& sc, double rate, bool ref, bool pot)
      : sim_(sc, 1, rate), ref_(ref), pot_(pot), scans_(4096) {}
  std::size_t next(std::span<float> out) override {
    const std::size_t n_ch = 1U + (ref_ ? 1U : 0U) + (pot_ ? 1U : 0U);
    const std::size_t want = std::min(out.size() / n_ch, scans_.size());
    const std::size_t n = sim_.next(std::span(scans_.data(), want));
    for (std::size_t k = 0; k < n; ++k) {
      std::size_t c = k * n_ch;
      out[c++] = static_cast<float>(scans_[k].sensor_v);
      if (ref_) out[c++] = static_cast<float>(scans_[k].reference_v);
      if (pot_) out[c++] = static_cast<float>(scans_[k].pot_v);
    }
    return n;
  }

 private:
  pof::sim::Simulator sim_;
  bool ref_;
  bool pot_;
  std::vector<pof::sim::Scan> scans_;
};

class SimBackend final : public Backend {
 public:
  explicit SimBackend(const DaqConfig& cfg)
      : cfg_(cfg),
        scenario_(cfg.device_kind.substr(4)),
        n_ch_(cfg.channels().size()) {
    source_ = make_sample_source(scenario_, cfg.scan_rate_hz, cfg.reference_ai >= 0, cfg.pot_ai >= 0);
    chunk_ = std::max<std::size_t>(1, static_cast<std::size_t>(cfg.scan_rate_hz * 0.004));
    buf_.assign(chunk_ * n_ch_, 0.0F);
    stall_ = stall_hook_from_env();
  }
  OpenStatus open(std::string&) override { return OpenStatus::kOk; }
  StreamEnd stream(ScanSink& sink, const std::atomic<bool>& stop, std::string& why) override {
    const timespec t0 = monotonic_now();
    const std::int64_t t_start = now_utime();
    sink.on_segment_start(t_start, t_start, false);
    std::uint64_t sent = 0;
    while (!stop.load(std::memory_order_relaxed)) {
      // Sleep until the chunk's last scan exists (absolute deadline: no accumulated drift).
      sleep_until(t0, static_cast<double>(sent + chunk_) / cfg_.scan_rate_hz);
      if (stall_.at_s >= 0 && static_cast<double>(sent) >= stall_.at_s * cfg_.scan_rate_hz) {
        stall_.at_s = -1;  // once per process
        hang(stop, stall_.for_s);
      }
      const std::size_t n = source_->next(buf_);
      if (n == 0) {
        why = "scenario '" + scenario_ + "' finished";
        return StreamEnd::kStopped;
      }
      sink.on_scans(buf_.data(), n, now_utime(), 0);
      sent += n;
    }
    return StreamEnd::kStopped;
  }
  void close() noexcept override {}
  [[nodiscard]] DeviceIdentity identity() const override { return {cfg_.device_kind, 0, 0, ""}; }
  [[nodiscard]] double device_scan_rate_hz() const override { return cfg_.scan_rate_hz; }

 private:
  // The stall hook: this thread does nothing for `s` seconds (it still sees a stop request, so
  // that a test's SIGTERM ends the daemon in time).
  static void hang(const std::atomic<bool>& stop, double s) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(s);
    while (std::chrono::steady_clock::now() < until && !stop.load(std::memory_order_relaxed))
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }

  DaqConfig cfg_;
  StallHook stall_;
  std::string scenario_;
  std::size_t n_ch_;
  std::unique_ptr<SampleSource> source_;
  std::size_t chunk_;
  std::vector<float> buf_;
};

}  // namespace

std::unique_ptr<SampleSource> make_sample_source(const std::string& scenario, double rate,
                                                 bool has_reference, bool has_pot) {
  if (scenario == "synthetic") return std::make_unique<SyntheticSource>(rate, has_reference, has_pot);
  pof::sim::Scenario sc;
  try {
    sc = pof::sim::scenario_by_name_or_path(scenario);
  } catch (const pof::NoInputError& e) {
    std::string names = "synthetic";
    for (const auto& n : pof::sim::builtin_scenario_names()) names += ", " + n;
    throw pof::ConfigError("device.kind: 'sim:" + scenario + "': " + e.what() +
                               " (built-in: " + names + ", or a scenario file path)");
  }
  return std::make_unique<SimulatorSource>(sc, rate, has_reference, has_pot);
}

std::unique_ptr<Backend> make_sim_backend(const DaqConfig& cfg) {
  return std::make_unique<SimBackend>(cfg);
}

}  // namespace pof::daq
