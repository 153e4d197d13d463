#include "pof/core/velocity_window.hpp"

#include <cmath>

namespace pof::core {

namespace {
// Running sums drift by rounding; rebuilding them from the window this often keeps the error at
// the 1e-12 level at a cost of N/4096 operations per scan.
constexpr std::int64_t kRefreshScans = 4096;
}  // namespace

VelocityWindow::VelocityWindow(int n) : n_(n), ring_(static_cast<std::size_t>(n), 0.0) {}

void VelocityWindow::clear() noexcept {
  head_ = count_ = 0;
  s0_ = s1_ = 0;
  since_refresh_ = 0;
}

double VelocityWindow::push(double y) noexcept {
  auto at = [this](int i) -> double& { return ring_[static_cast<std::size_t>(i)]; };
  if (count_ < n_) {
    s1_ += count_ * y;
    s0_ += y;
    at((head_ + count_) % n_) = y;
    ++count_;
  } else {
    const double old = at(head_);
    s1_ += -(s0_ - old) + (n_ - 1) * y;
    s0_ += y - old;
    at(head_) = y;
    head_ = (head_ + 1) % n_;
    if (++since_refresh_ >= kRefreshScans) refresh();
  }
  return slope();
}

double VelocityWindow::slope() const noexcept {
  const double m = count_;
  if (count_ < 2) return std::nan("");
  const double sj = m * (m - 1) / 2, sjj = (m - 1) * m * (2 * m - 1) / 6;
  return (m * s1_ - sj * s0_) / (m * sjj - sj * sj);
}

void VelocityWindow::refresh() noexcept {
  since_refresh_ = 0;
  s0_ = s1_ = 0;
  for (int j = 0; j < count_; ++j) {
    const double v = ring_[static_cast<std::size_t>((head_ + j) % n_)];
    s0_ += v;
    s1_ += j * v;
  }
}

double& VelocityWindow::back(int back) noexcept {
  // head_ + count_ - 1 - back lies in (-n_, 2 n_): one wrap instead of a division.
  int i = head_ + count_ - 1 - back;
  if (i >= n_) i -= n_;
  else if (i < 0) i += n_;
  return ring_[static_cast<std::size_t>(i)];
}

void VelocityWindow::copy_newest(double* x, int k) const noexcept {
  for (int back = 0, i = (head_ + count_ - 1) % n_; back < k; ++back, i = i == 0 ? n_ - 1 : i - 1)
    x[back] = ring_[static_cast<std::size_t>(i)];
}

double VelocityWindow::recent_slope(int k) const noexcept {
  // Direct least squares over the newest k scans of the ring: O(k).
  if (k < 2 || count_ < k) return std::nan("");
  const int newest = (head_ + count_ - 1) % n_;
  const double jbar = (k - 1) / 2.0;
  double sxy = 0;
  for (int j = 0; j < k; ++j) {
    const int i = (newest - (k - 1) + j + n_) % n_;
    sxy += (j - jbar) * ring_[static_cast<std::size_t>(i)];
  }
  return sxy / (k * (static_cast<double>(k) * k - 1) / 12.0);
}

}  // namespace pof::core
