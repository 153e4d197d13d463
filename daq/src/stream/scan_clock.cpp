// Scan time reconstruction: see scan_clock.hpp for the model and the correction.
#include "pof/daq/stream/scan_clock.hpp"

#include <algorithm>
#include <cmath>

namespace pof::daq {

ScanClock::ScanClock(double rate_hz, double window_s)
    : rate_hz_(rate_hz),
      period_us_(1e6 / rate_hz),
      window_us_(static_cast<std::int64_t>(window_s * 1e6)) {}

void ScanClock::anchor(std::int64_t index, std::int64_t earliest_us, std::int64_t latest_us) {
  anchor_index_ = index;
  anchor_us_ = static_cast<double>(latest_us);
  floor_us_ = static_cast<double>(earliest_us);
  floor_valid_ = true;
  window_open_ = false;
  have_prev_ = false;  // the slope is measured within one segment
  shifts_us_ = 0;
}

double ScanClock::time_of_exact(double index) const {
  const double di = index - static_cast<double>(anchor_index_);
  return anchor_us_ + di * period_us_ * (1.0 - drift_);
}

std::int64_t ScanClock::time_of(double index) const { return std::llround(time_of_exact(index)); }

void ScanClock::observe(std::int64_t last_index, std::int64_t arrival_us) {
  const double pred = time_of_exact(static_cast<double>(last_index)) + period_us_;
  double residual = static_cast<double>(arrival_us) - pred;
  if (residual < 0) {  // causality: the scan existed before it arrived; move the anchor back
    double shift = residual;
    if (floor_valid_ && anchor_us_ + shift < floor_us_) shift = floor_us_ - anchor_us_;
    anchor_us_ += shift;
    shifts_us_ += shift;
    residual -= shift;
  }
  // Against the prediction without the causality shifts, so that they do not bias the slope.
  const double consistent = residual + shifts_us_;
  if (!window_open_) {
    window_open_ = true;
    window_start_us_ = arrival_us;
    window_min_ = consistent;
    return;
  }
  window_min_ = std::min(window_min_, consistent);
  if (arrival_us - window_start_us_ < window_us_) return;
  const std::int64_t mid = window_start_us_ + (arrival_us - window_start_us_) / 2;
  // A change of the minimum larger than the largest drift allowed (1000 ppm of the window) is
  // not a clock: the host or the bus stalled for a whole window. Skip it; re-sync the reference.
  const double max_step = 1e-3 * static_cast<double>(mid - prev_mid_us_);
  if (have_prev_ && mid > prev_mid_us_ && std::abs(window_min_ - prev_min_) <= max_step) {
    // The residual growing by `slope` us per us means the device clock is slower than modelled
    // (scans come later than predicted): longer periods, drift goes down.
    const double slope = (window_min_ - prev_min_) / static_cast<double>(mid - prev_mid_us_);
    // Rebase at the newest scan so that changing the drift does not move past predictions.
    anchor_us_ = time_of_exact(static_cast<double>(last_index));
    anchor_index_ = last_index;
    floor_valid_ = false;
    drift_ = std::clamp(drift_ - 0.5 * slope, -1e-3, 1e-3);
  }
  have_prev_ = true;
  prev_min_ = window_min_;
  prev_mid_us_ = mid;
  window_open_ = false;
}

}  // namespace pof::daq
