#include "pof/core/statistics.hpp"

#include <cmath>
#include <numbers>

namespace pof::core {

void ErrorProfile::add(double angle_ref_deg, double err_comp, double err_uncomp) {
  const double b = std::floor(angle_ref_deg / kBinDeg);
  if (!(b >= 0 && b < kBins)) return;
  const auto k = static_cast<std::size_t>(b);
  sum_comp[k] += err_comp;
  sum_uncomp[k] += err_uncomp;
  sum_abs_comp[k] += std::abs(err_comp);
  sum_abs_uncomp[k] += std::abs(err_uncomp);
  ++count[k];
}

bool CycleStatistics::add(double t_s, const CompensatedScan& scan, double angle_ref_deg) noexcept {
  if (scan.phase == Direction::kHold) {
    if (!cur_.seen_extension || s_.close_after_hold_s <= 0) return false;
    if (cur_.hold_since < 0) cur_.hold_since = t_s;
    return t_s - cur_.hold_since >= s_.close_after_hold_s && close();
  }
  cur_.hold_since = -1;
  if (!std::isfinite(angle_ref_deg) || !std::isfinite(scan.angle_deg) || !std::isfinite(scan.angle_uncomp_deg))
    return false;
  bool closed = false;
  if (scan.phase == Direction::kFlexion && cur_.seen_extension) closed = close();
  const int k = scan.phase == Direction::kFlexion ? 0 : 1;
  if (k == 1) cur_.seen_extension = true;
  if (cur_.n == 0) cur_.t_start = t_s;
  cur_.t_end = t_s;
  ++cur_.n;
  const double ec = scan.angle_deg - angle_ref_deg, eu = scan.angle_uncomp_deg - angle_ref_deg;
  cur_.comp[k].add(angle_ref_deg, scan.angle_deg);
  cur_.uncomp[k].add(angle_ref_deg, scan.angle_uncomp_deg);
  cur_.sq_comp += ec * ec;
  cur_.sq_uncomp += eu * eu;
  cur_.speed[k].add(t_s, angle_ref_deg);
  if (std::abs(ec) > cur_.max_err) {
    cur_.max_err = std::abs(ec);
    cur_.max_err_angle = angle_ref_deg;
  }
  profile_.add(angle_ref_deg, ec, eu);
  return closed;
}

bool CycleStatistics::finish() noexcept { return close(); }

bool CycleStatistics::close() noexcept {
  const Current c = cur_;
  cur_ = Current{};
  if (c.n == 0) return false;
  auto span = [](const LineAccumulator& a) { return a.n > 0 ? a.x_max - a.x_min : 0.0; };
  const bool ok = c.comp[0].n >= static_cast<double>(s_.min_samples) && c.comp[1].n >= static_cast<double>(s_.min_samples) &&
                  span(c.comp[0]) >= s_.min_span_deg && span(c.comp[1]) >= s_.min_span_deg;
  const Hysteresis hc = hysteresis_eq1(c.comp[0], c.comp[1]);
  const Hysteresis hu = hysteresis_eq1(c.uncomp[0], c.uncomp[1]);
  if (!ok || !hc.valid || !hu.valid) {
    ++dropped_;
    return false;
  }
  CycleStats st;
  st.cycle = ++kept_;
  st.t_start_s = c.t_start;
  st.t_end_s = c.t_end;
  const double n = static_cast<double>(c.n);
  // The commanded speed of the sweeps (table 3's velocity), from the reference: a line through
  // each sweep, so the estimator's lag and the ramps at the ends barely move it.
  st.velocity_rad_s = 0.5 * (std::abs(c.speed[0].slope()) + std::abs(c.speed[1].slope())) * std::numbers::pi / 180.0;
  st.rmse_comp_deg = std::sqrt(c.sq_comp / n);
  st.rmse_uncomp_deg = std::sqrt(c.sq_uncomp / n);
  st.hysteresis_comp_pct = std::abs(hc.pct);
  st.hysteresis_uncomp_pct = std::abs(hu.pct);
  st.max_error_deg = c.max_err;
  st.max_error_angle_deg = c.max_err_angle;
  st.n_samples = c.n;
  last_ = st;
  tot_sq_comp_ += c.sq_comp;
  tot_sq_uncomp_ += c.sq_uncomp;
  tot_w_ += st.velocity_rad_s;
  tot_n_ += c.n;
  tot_h_comp_ += st.hysteresis_comp_pct;
  tot_h_uncomp_ += st.hysteresis_uncomp_pct;
  if (st.max_error_deg > tot_max_) tot_max_ = st.max_error_deg;
  return true;
}

CycleStats CycleStatistics::overall() const noexcept {
  CycleStats o;
  o.cycle = kept_;
  if (kept_ == 0 || tot_n_ == 0) {
    const double nan = std::nan("");
    o.velocity_rad_s = o.rmse_comp_deg = o.rmse_uncomp_deg = o.hysteresis_comp_pct = o.hysteresis_uncomp_pct = o.max_error_deg = nan;
    return o;
  }
  const double n = static_cast<double>(tot_n_);
  o.velocity_rad_s = tot_w_ / kept_;
  o.rmse_comp_deg = std::sqrt(tot_sq_comp_ / n);
  o.rmse_uncomp_deg = std::sqrt(tot_sq_uncomp_ / n);
  o.hysteresis_comp_pct = tot_h_comp_ / kept_;
  o.hysteresis_uncomp_pct = tot_h_uncomp_ / kept_;
  o.max_error_deg = tot_max_;
  o.n_samples = tot_n_;
  return o;
}

}  // namespace pof::core
