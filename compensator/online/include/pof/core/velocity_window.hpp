#pragma once
// The compensator's velocity estimate: the least-squares slope of the last N angles, updated from
// running sums in O(1) per scan (docs/calibration.md, "Online compensation", step 3).
//
// For a constant velocity the slope is unbiased and refers to the window centre, so it lags by
// (N - 1) / 2 scans. With white angle noise sigma its standard deviation is
// sigma * sqrt(12 / (N (N^2 - 1))) per scan. The newest k angles give a shorter, faster slope
// (recent_slope: the reversal detector) and may be edited in place (back(): the step detector takes
// a model step out of them, then refresh()).
//
// Threading: used from one thread. Only the constructor allocates; nothing throws.
#include <cstdint>
#include <vector>

namespace pof::core {

class VelocityWindow {
 public:
  VelocityWindow() = default;
  /// A window of n >= 2 angles.
  explicit VelocityWindow(int n);

  /// Appends an angle [deg] (the oldest leaves a full window); returns slope().
  double push(double y) noexcept;
  /// The least-squares slope of the angles in the window [deg/scan], NaN with fewer than 2.
  [[nodiscard]] double slope() const noexcept;
  /// The least-squares slope of the newest k angles [deg/scan] in O(k), NaN if fewer are held.
  [[nodiscard]] double recent_slope(int k) const noexcept;
  /// The angle `back` scans before the newest (0 <= back < count()), to edit; refresh() after.
  double& back(int back) noexcept;
  /// Copies the newest k angles into x, newest first (k <= count()).
  void copy_newest(double* x, int k) const noexcept;
  /// Rebuilds the running sums from the angles held.
  void refresh() noexcept;
  /// Empties the window.
  void clear() noexcept;

  [[nodiscard]] int size() const noexcept { return n_; }
  [[nodiscard]] int count() const noexcept { return count_; }
  [[nodiscard]] bool full() const noexcept { return count_ >= n_; }

 private:
  int n_ = 2;
  std::vector<double> ring_;
  int head_ = 0, count_ = 0;
  double s0_ = 0, s1_ = 0;  // sum y_j, sum j*y_j over the window (j = 0 oldest)
  std::int64_t since_refresh_ = 0;
};

}  // namespace pof::core
