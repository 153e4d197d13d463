#pragma once
// Reconstructs the host time of every scan from its index and the nominal rate, anchored to the
// host clock and corrected for drift (never the arrival time of the USB packet).
//
// Model: t(i) = anchor_us + (i - anchor_index) * period_us * (1 - drift), one anchor per device
// segment (the scan clock restarts at every finite-scan start, ni_usb600x.hpp [10]).
// Anchor: the device started between sending the start command and its acknowledgement
// [earliest, latest]; the anchor starts at `latest`.
// Correction: scan i is complete one period after it starts and cannot arrive before that, so
// arrival - (t(last scan of a transfer) + period) >= 0 (+ transport latency):
//  - a negative value means the anchor is late: it moves back at once (causality), never before
//    `earliest` while the segment's first anchor holds;
//  - the slope of the per-window (default 1 s) minimum of that value is the device clock's rate
//    error against the host: the drift estimate follows it with gain 0.5 per window, clamped to
//    +-1000 ppm (crystals are ~50 ppm), re-anchoring at the newest scan so past times stay put;
//    a window whose minimum moved by more than 1000 ppm is a host/bus stall and is skipped.
// What remains unobservable is the minimum transport latency (measured in the e2e tests).
#include <cstdint>

namespace pof::daq {

class ScanClock {
 public:
  explicit ScanClock(double rate_hz, double window_s = 1.0);

  /// The device's scan clock (re)started with scan `index` between host times `earliest_us` and
  /// `latest_us`. The drift estimate is kept (same crystal).
  void anchor(std::int64_t index, std::int64_t earliest_us, std::int64_t latest_us);
  /// Host time [us] of the start of scan `index` (fractional indices: decimated scans).
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
  double floor_us_ = 0;       // earliest possible anchor while the segment's anchor holds
  bool floor_valid_ = false;
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
