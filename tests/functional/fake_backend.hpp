#pragma once
// A scripted pof::daq::Backend (daq/include/pof/daq/stream/backend.hpp) for driving pof-daqd's
// state machine (daq/daemon/daemon.hpp) in-process, in test_daqd_states.cpp.
//
// The test scripts one Attempt per open(): the device is absent, faulty, throws (breaking the
// never-throws contract, as a bug would), or opens and then streams a list of steps: scans, read
// errors, a hold (the session pauses until the test calls release(), so the test can see the
// state it is in before moving on), then an end (disconnect, error, a finished source, a throw).
// A session whose steps run out without an end goes silent, as a stalled device does, until the
// daemon asks it to stop. When the script runs out, open() reports the device absent.
//
// Synchronisation without sleeps: the test waits on the daemon's messages or on wait_held()
// (a condition variable). The backend checks the daemon's stop flag every millisecond while it
// holds or stalls, as a real backend's event loop turns with a timeout (usb600x.cpp,
// libusb_handle_events_timeout_completed); it never blocks longer than kMaxBlock, so a daemon
// that fails to pass on a stop request makes a test fail instead of hang.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "pof/daq/stream/backend.hpp"
#include "pof/lcm/utime.hpp"

namespace pof::test {

class FakeBackend final : public pof::daq::Backend {
 public:
  static constexpr auto kMaxBlock = std::chrono::seconds(30);
  static constexpr std::size_t kScansPerCall = 32;  // per on_scans(), as one USB transfer

  struct Step {
    enum class Kind { kScans, kUsbError, kHold, kEnd, kThrow };
    Kind kind = Kind::kScans;
    std::size_t n = 0;
    pof::daq::StreamEnd end = pof::daq::StreamEnd::kStopped;
    std::string why;
  };

  /// One open() and, when it succeeds, the stream() after it.
  struct Attempt {
    enum class Open { kOk, kAbsent, kFault, kThrow };
    Open open = Open::kOk;
    std::string reason;  // open()'s `why`, or the exception's what()
    std::vector<Step> steps;

    static Attempt opens() { return {}; }
    static Attempt absent(std::string why) { return {Open::kAbsent, std::move(why), {}}; }
    static Attempt fault(std::string why) { return {Open::kFault, std::move(why), {}}; }
    static Attempt throws(std::string what) { return {Open::kThrow, std::move(what), {}}; }

    /// `n` scans whose channel c holds 1000 c + (the backend's running scan count).
    Attempt& scans(std::size_t n) { return add({Step::Kind::kScans, n, {}, {}}); }
    /// One failed transfer, reported through on_usb_error(); the session goes on.
    Attempt& usb_error() { return add({Step::Kind::kUsbError, 0, {}, {}}); }
    /// Pauses until release() (the n-th hold of the run ends at the n-th release) or stop.
    Attempt& hold() { return add({Step::Kind::kHold, 0, {}, {}}); }
    Attempt& disconnect(std::string why) { return end(pof::daq::StreamEnd::kDisconnected, std::move(why)); }
    Attempt& error(std::string why) { return end(pof::daq::StreamEnd::kError, std::move(why)); }
    /// A finite source that is over (kStopped without a stop request).
    Attempt& finish(std::string why) { return end(pof::daq::StreamEnd::kStopped, std::move(why)); }
    Attempt& stream_throws(std::string what) { return add({Step::Kind::kThrow, 0, {}, std::move(what)}); }

   private:
    Attempt& end(pof::daq::StreamEnd e, std::string why) { return add({Step::Kind::kEnd, 0, e, std::move(why)}); }
    Attempt& add(Step s) {
      steps.push_back(std::move(s));
      return *this;
    }
  };

  FakeBackend(std::size_t n_channels, double scan_rate_hz) : n_ch_(n_channels), rate_(scan_rate_hz) {}

  /// Appends to the script (any thread).
  void push(Attempt a) {
    std::lock_guard lock(mu_);
    script_.push_back(std::move(a));
  }
  /// Ends the oldest hold not yet released (any thread).
  void release() {
    {
      std::lock_guard lock(mu_);
      ++releases_;
    }
    cv_.notify_all();
  }
  /// Waits until `n` holds have been reached in all (false after `timeout`).
  bool wait_held(int n, std::chrono::milliseconds timeout) {
    std::unique_lock lock(mu_);
    return cv_.wait_for(lock, timeout, [&] { return holds_ >= n; });
  }
  /// Waits until the acquisition thread is inside stream() with nothing left to do but wait for
  /// stop (a stalled session), false after `timeout`.
  bool wait_stalled(std::chrono::milliseconds timeout) {
    std::unique_lock lock(mu_);
    return cv_.wait_for(lock, timeout, [&] { return stalled_; });
  }
  [[nodiscard]] int opens() const {
    std::lock_guard lock(mu_);
    return opens_;
  }
  [[nodiscard]] int closes() const {
    std::lock_guard lock(mu_);
    return closes_;
  }

  pof::daq::OpenStatus open(std::string& why) override {
    std::lock_guard lock(mu_);
    ++opens_;
    if (script_.empty()) {
      why = "fake: not attached (no attempt scripted)";
      return pof::daq::OpenStatus::kAbsent;
    }
    current_ = std::move(script_.front());
    script_.pop_front();
    switch (current_.open) {
      case Attempt::Open::kOk: return pof::daq::OpenStatus::kOk;
      case Attempt::Open::kAbsent: why = current_.reason; return pof::daq::OpenStatus::kAbsent;
      case Attempt::Open::kFault: why = current_.reason; return pof::daq::OpenStatus::kFault;
      case Attempt::Open::kThrow: throw std::runtime_error(current_.reason);
    }
    return pof::daq::OpenStatus::kFault;
  }

  pof::daq::StreamEnd stream(pof::daq::ScanSink& sink, const std::atomic<bool>& stop,
                             std::string& why) override {
    using pof::lcmutil::now_utime;
    const std::int64_t t = now_utime();
    sink.on_segment_start(t, t, false);  // a new session: not continuous with the last one
    std::vector<float> volts(kScansPerCall * n_ch_);
    for (const Step& s : current_.steps) {
      switch (s.kind) {
        case Step::Kind::kScans:
          for (std::size_t done = 0; done < s.n;) {
            const std::size_t n = std::min(kScansPerCall, s.n - done);
            for (std::size_t k = 0; k < n; ++k) {
              for (std::size_t c = 0; c < n_ch_; ++c) {
                volts[k * n_ch_ + c] = static_cast<float>(1000 * c + sent_ + k);
              }
            }
            sink.on_scans(volts.data(), n, now_utime(), 0);
            sent_ += n;
            done += n;
          }
          break;
        case Step::Kind::kUsbError: sink.on_usb_error(); break;
        case Step::Kind::kHold: {
          std::unique_lock lock(mu_);
          const int mine = ++holds_;
          cv_.notify_all();
          if (!wait_or_stop(lock, stop, [&] { return releases_ >= mine; })) {
            return stopped_or_timeout(stop, why, "held");
          }
          break;
        }
        case Step::Kind::kEnd: why = s.why; return s.end;
        case Step::Kind::kThrow: throw std::runtime_error(s.why);
      }
    }
    std::unique_lock lock(mu_);
    stalled_ = true;
    cv_.notify_all();
    (void)wait_or_stop(lock, stop, [] { return false; });
    stalled_ = false;
    return stopped_or_timeout(stop, why, "stalled");
  }

  void close() noexcept override {
    std::lock_guard lock(mu_);
    ++closes_;
  }
  [[nodiscard]] pof::daq::DeviceIdentity identity() const override { return {"fake", 0x1234, 0x5678, "FAKE0001"}; }
  [[nodiscard]] double device_scan_rate_hz() const override { return rate_; }

 private:
  // True once `done()`, false on stop or after kMaxBlock.
  template <class Done>
  bool wait_or_stop(std::unique_lock<std::mutex>& lock, const std::atomic<bool>& stop, Done done) {
    const auto deadline = std::chrono::steady_clock::now() + kMaxBlock;
    while (!done()) {
      if (stop.load() || std::chrono::steady_clock::now() >= deadline) return false;
      cv_.wait_for(lock, std::chrono::milliseconds(1));
    }
    return true;
  }
  static pof::daq::StreamEnd stopped_or_timeout(const std::atomic<bool>& stop, std::string& why,
                                                const char* what) {
    if (stop.load()) return pof::daq::StreamEnd::kStopped;
    why = std::string("fake: ") + what + " for 30 s without a stop request";
    return pof::daq::StreamEnd::kError;
  }

  const std::size_t n_ch_;
  const double rate_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Attempt> script_;
  Attempt current_;  // acquisition thread only, once taken off the script
  std::size_t sent_ = 0;
  int opens_ = 0;
  int closes_ = 0;
  int holds_ = 0;
  int releases_ = 0;
  bool stalled_ = false;
};

}  // namespace pof::test
