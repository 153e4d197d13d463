#include "pof/core/segmentation.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "pof/core/offline.hpp"

namespace pof::core {

namespace {

struct Run {
  Direction kind;
  Eigen::Index begin, end;
};

double duration(const Eigen::VectorXd& t, const Run& r) { return t(r.end - 1) - t(r.begin); }

// Merges neighbouring runs of the same kind in place.
void coalesce(std::vector<Run>& runs) {
  std::vector<Run> out;
  for (const Run& r : runs) {
    if (!out.empty() && out.back().kind == r.kind)
      out.back().end = r.end;
    else
      out.push_back(r);
  }
  runs.swap(out);
}

// The median step [s], 1 where there is none (fewer than 2 scans, or a median step not > 0).
double median_dt(const Eigen::VectorXd& t) {
  const double dt = median_step_s(t);
  return dt > 0 ? dt : 1.0;
}

}  // namespace

Eigen::VectorXd centred_slope(const Eigen::VectorXd& t, const Eigen::VectorXd& y, double window_s) {
  const Eigen::Index n = std::min(t.size(), y.size());
  Eigen::VectorXd out = Eigen::VectorXd::Zero(n);
  if (n < 3) return out;
  const Eigen::Index half = std::max<Eigen::Index>(1, static_cast<Eigen::Index>(std::lround(window_s / median_dt(t) / 2)));
  // Prefix sums of t, y, t*t, t*y relative to t(0) (keeps the sums well conditioned); NaN y count
  // as missing through a separate count.
  std::vector<double> st(static_cast<std::size_t>(n + 1), 0), sy(st), stt(st), sty(st), cnt(st);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double ti = t(i) - t(0);
    const bool ok = std::isfinite(y(i));
    const double yi = ok ? y(i) : 0.0;
    const double c = ok ? 1.0 : 0.0;
    st[k + 1] = st[k] + c * ti;
    sy[k + 1] = sy[k] + yi;
    stt[k + 1] = stt[k] + c * ti * ti;
    sty[k + 1] = sty[k] + ti * yi;
    cnt[k + 1] = cnt[k] + c;
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto a = static_cast<std::size_t>(std::max<Eigen::Index>(0, i - half));
    const auto b = static_cast<std::size_t>(std::min<Eigen::Index>(n, i + half + 1));
    const double m = cnt[b] - cnt[a];
    if (m < 2) continue;
    const double St = st[b] - st[a], Sy = sy[b] - sy[a], Stt = stt[b] - stt[a], Sty = sty[b] - sty[a];
    const double den = m * Stt - St * St;
    if (den > 0) out(i) = (m * Sty - St * Sy) / den;
  }
  return out;
}

std::vector<Segment> segment(const Eigen::VectorXd& t_s, const Eigen::VectorXd& angle_deg,
                             const SegmentationSettings& s) {
  const Eigen::Index n = std::min(t_s.size(), angle_deg.size());
  std::vector<Segment> out;
  if (n == 0) return out;
  const Eigen::VectorXd v = centred_slope(t_s.head(n), angle_deg.head(n), s.velocity_window_s);

  // 2. Moving / holding with a dead band.
  std::vector<Run> runs;
  Direction state = Direction::kHold;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double vi = std::isfinite(angle_deg(i)) ? v(i) : 0.0;
    if (state == Direction::kHold) {
      if (vi > s.move_deg_s) state = Direction::kFlexion;
      else if (vi < -s.move_deg_s) state = Direction::kExtension;
    } else if (std::abs(vi) < s.hold_deg_s) {
      state = Direction::kHold;
    } else if (state == Direction::kFlexion && vi < -s.move_deg_s) {
      state = Direction::kExtension;
    } else if (state == Direction::kExtension && vi > s.move_deg_s) {
      state = Direction::kFlexion;
    }
    if (!runs.empty() && runs.back().kind == state)
      runs.back().end = i + 1;
    else
      runs.push_back({state, i, i + 1});
  }

  // 3. Absorb short runs (shortest first, into the longer neighbour), then bridge short pauses
  //    between sweeps of the same direction.
  bool changed = true;
  while (changed && runs.size() > 1) {
    changed = false;
    std::size_t shortest = runs.size();
    double shortest_d = s.min_run_s;
    for (std::size_t k = 0; k < runs.size(); ++k) {
      const double d = duration(t_s, runs[k]);
      if (d < shortest_d) {
        shortest_d = d;
        shortest = k;
      }
    }
    if (shortest == runs.size()) break;
    const std::size_t k = shortest;
    std::size_t into;
    if (k == 0) into = 1;
    else if (k + 1 == runs.size()) into = k - 1;
    else into = duration(t_s, runs[k - 1]) >= duration(t_s, runs[k + 1]) ? k - 1 : k + 1;
    runs[k].kind = runs[into].kind;
    coalesce(runs);
    changed = true;
  }
  for (std::size_t k = 1; k + 1 < runs.size(); ++k) {
    if (runs[k].kind == Direction::kHold && runs[k - 1].kind == runs[k + 1].kind &&
        duration(t_s, runs[k]) < s.max_pause_s)
      runs[k].kind = runs[k - 1].kind;
  }
  coalesce(runs);

  // 4. Too small to be movement.
  for (Run& r : runs)
    if (r.kind != Direction::kHold && std::abs(angle_deg(r.end - 1) - angle_deg(r.begin)) < s.min_sweep_deg)
      r.kind = Direction::kHold;
  coalesce(runs);

  // 5. Describe each segment.
  const double dt = median_dt(t_s.head(n));
  const auto trim = static_cast<Eigen::Index>(std::lround(s.trim_s / dt));
  for (const Run& r : runs) {
    Segment g;
    g.kind = r.kind;
    g.begin = r.begin;
    g.end = r.end;
    g.t_begin = t_s(r.begin);
    g.t_end = t_s(r.end - 1);
    g.angle_begin = angle_deg(r.begin);
    g.angle_end = angle_deg(r.end - 1);
    g.core_begin = r.begin;
    g.core_end = r.end;
    if (r.end - r.begin > 4 * trim + 2) {
      g.core_begin = r.begin + trim;
      g.core_end = r.end - trim;
    }
    if (g.kind != Direction::kHold) {
      // Median of the windowed slopes: the cruise speed, unmoved by a stutter inside the sweep
      // (a plain line through the sweep would average the stop in).
      std::vector<double> vs(v.data() + g.core_begin, v.data() + g.core_end);
      auto mid = vs.begin() + static_cast<std::ptrdiff_t>(vs.size() / 2);
      std::nth_element(vs.begin(), mid, vs.end());
      g.velocity_rad_s = *mid * std::numbers::pi / 180.0;
    }
    out.push_back(g);
  }
  return out;
}

}  // namespace pof::core
