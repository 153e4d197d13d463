#pragma once
// Reconstructs the host time of every scan from its index and the nominal rate, anchored to the
// host clock and corrected for drift (issue 5: never the arrival time of the USB packet).
//
// Model: t(i) = anchor_us + (i - anchor_index) * period_us * (1 - drift), one anchor per device
// segment (the scan clock restarts at every finite-scan start, ni_usb600x.hpp [10]).
// Correction: a scan cannot arrive before it was taken, so arrival - t(last scan of a transfer)
// is >= 0 plus transport latency. Its minimum over each window (default 1 s) is the lower envelope:
//  - a negative minimum means the anchor is late: it moves back by that much at once (causality);
//  - the slope of successive minima is the device clock's rate error against the host: the drift
//    estimate follows it with gain 0.5 per window, clamped to +-1000 ppm (crystals are ~50 ppm).
// A constant offset equal to the minimum transport latency cannot be observed and stays (< 1 ms on
// full-speed USB; measured in the e2e tests).
#include <cstdint>

namespace pof::daq {

class ScanClock {
 public:
  explicit ScanClock(double rate_hz, double window_s = 1.0);

  /// The device's scan clock (re)started with scan `index` at about host time `host_us`.
  /// The drift estimate is kept (same crystal).
  void anchor(std::int64_t index, std::int64_t host_us);
  /// Host time [us] of scan `index` (fractional indices allowed for decimated scans).
  [[nodiscard]] std::int64_t time_of(double index) const;
  /// A transfer whose newest scan is `last_index` arrived at host time `arrival_us`.
  void observe(std::int64_t last_index, std::int64_t arrival_us);

  [[nodiscard]] double drift_ppm() const { return drift_ * 1e6; }
  [[nodiscard]] double rate_hz() const { return rate_hz_; }

 private:
  [[nodiscard]] double time_of_exact(double index) const;

  double rate_hz_;
  double period_us_;
  std::int64_t window_us_;
  std::int64_t anchor_index_ = 0;
  double anchor_us_ = 0;
  double shifts_us_ = 0;      // sum of causality corrections in this segment [us]
  double drift_ = 0;          // fractional: device clock fast by drift -> periods shorter
  double window_min_ = 0;     // min residual in the current window [us]
  bool window_open_ = false;
  std::int64_t window_start_us_ = 0;
  bool have_prev_ = false;
  double prev_min_ = 0;
  std::int64_t prev_mid_us_ = 0;
};

}  // namespace pof::daq
