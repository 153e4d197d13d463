// The compensated angle against the forward gap (see pof/gap/angle_gap.hpp; docs/gap.md, section
// 5, "Angle against the forward gap").
#include "pof/gap/angle_gap.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>

#include "pof/base/format.hpp"
#include "pof/core/model_selection.hpp"

namespace pof::gap {

using Eigen::Index;
using Eigen::VectorXd;
using nlohmann::json;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool is_hold(Phase p) { return p == Phase::kHold || p == Phase::kAfterStop; }

// Scan-to-scan noise sqrt(mean(diff^2) / 2) of x over the pairs of consecutive scans both in
// holds (hold = true) or both moving, both finite: a white noise's standard deviation, while a
// slow error (a bias, a wrong branch) adds almost nothing to it.
struct Diffs {
  double ss = 0;
  Index n = 0;
  void add(double d) { ss += d * d; ++n; }
  [[nodiscard]] double noise() const { return n > 0 ? std::sqrt(ss / static_cast<double>(n) / 2.0) : kNaN; }
};

struct Noise {
  Diffs hold, moving;
  [[nodiscard]] double all() const {
    Diffs d{hold.ss + moving.ss, hold.n + moving.n};
    return d.noise();
  }
  [[nodiscard]] json to_json() const { return {{"holds", hold.noise()}, {"moving", moving.noise()}, {"all", all()}}; }
};

template <class F>
Noise scan_to_scan(Index n, const std::vector<Phase>& phases, F value) {
  Noise out;
  for (Index i = 1; i < n; ++i) {
    const bool h0 = is_hold(phases[static_cast<std::size_t>(i - 1)]), h1 = is_hold(phases[static_cast<std::size_t>(i)]);
    if (h0 != h1) continue;
    const double d = value(i) - value(i - 1);
    if (!std::isfinite(d)) continue;
    (h1 ? out.hold : out.moving).add(d);
  }
  return out;
}

// One segment's angle error and forward residual.
struct Segment {
  std::string name;
  double s = 0, s2 = 0, f2 = 0;
  Index n = 0, nf = 0;
  [[nodiscard]] double rmse() const { return n > 0 ? std::sqrt(s2 / static_cast<double>(n)) : kNaN; }
  [[nodiscard]] double mean() const { return n > 0 ? s / static_cast<double>(n) : kNaN; }
  [[nodiscard]] double forward() const { return nf > 0 ? std::sqrt(f2 / static_cast<double>(nf)) : kNaN; }
  /// Its part of the angle's squared error beyond the forward residual's (sums over its scans).
  [[nodiscard]] double excess() const { return s2 - f2; }
};

// The value at fraction q of the sorted values (v is reordered).
double quantile(std::vector<double>& v, double q) {
  const auto at = v.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), at, v.end());
  return *at;
}

// Holds (hold and after_stop), reversals (the first 0.5 s of a movement against the previous
// one), and the other moving scans in terciles of |w|: classify_phases' labels, so the angle's
// error is split where the forward residual is localised.
std::vector<Segment> segments(const AngleGapInputs& in, const VectorXd& err) {
  const Index n = err.size();
  std::vector<double> speeds;
  for (Index i = 0; i < n; ++i) {
    const Phase p = in.phases[static_cast<std::size_t>(i)];
    if (std::isfinite(err(i)) && !is_hold(p) && p != Phase::kReversal) speeds.push_back(std::abs(in.k.w(i)));
  }
  double q1 = 0, q2 = 0;
  if (!speeds.empty()) {
    q1 = quantile(speeds, 1.0 / 3.0);
    q2 = quantile(speeds, 2.0 / 3.0);
  }
  // Each tercile named by the range of |w| it holds.
  std::vector<double> lo(3, std::numeric_limits<double>::infinity()), hi(3, 0.0);
  auto tercile = [&](double aw) { return aw <= q1 ? 0 : aw <= q2 ? 1 : 2; };
  std::vector<Segment> seg(5);
  seg[0].name = "holds";
  seg[1].name = "reversals";
  for (Index i = 0; i < n; ++i) {
    if (!std::isfinite(err(i))) continue;
    const Phase p = in.phases[static_cast<std::size_t>(i)];
    std::size_t s = 0;
    if (is_hold(p)) {
      s = 0;
    } else if (p == Phase::kReversal) {
      s = 1;
    } else {
      const double aw = std::abs(in.k.w(i));
      const auto t = static_cast<std::size_t>(tercile(aw));
      lo[t] = std::min(lo[t], aw);
      hi[t] = std::max(hi[t], aw);
      s = 2 + t;
    }
    Segment& g = seg[s];
    g.s += err(i);
    g.s2 += err(i) * err(i);
    ++g.n;
    if (std::isfinite(in.forward_deg(i))) { g.f2 += in.forward_deg(i) * in.forward_deg(i); ++g.nf; }
  }
  for (std::size_t t = 0; t < 3; ++t)
    seg[2 + t].name = "moving " + format_fixed(lo[t], 3) + "-" + format_fixed(hi[t], 3) + " rad/s";
  std::erase_if(seg, [](const Segment& g) { return g.n == 0; });
  return seg;
}

std::string signed_fixed(double v, int decimals) { return (v >= 0 ? "+" : "") + format_fixed(v, decimals); }

}  // namespace

AngleGap compare_angle(const AngleGapInputs& in) {
  const Index n = in.angle_deg.size();
  const VectorXd err = in.angle_deg - in.reference_deg;
  const core::HeldOutError all = core::error_stats(in.angle_deg, in.reference_deg);
  const double angle_rmse = all.rmse_deg;
  const double ratio = in.forward_gap_deg > 0 ? angle_rmse / in.forward_gap_deg : kNaN;

  // The output's noise on its error against the smoothed reference (the motion taken out, the
  // potentiometer's noise mostly too); the input's on the held-out residual at the local slope
  // (the motion is the model's, so what is left from scan to scan is the sensor's noise).
  const Noise out_noise =
      scan_to_scan(n, in.phases, [&](Index i) { return in.angle_deg(i) - in.smooth_reference_deg(i); });
  const Noise in_noise = scan_to_scan(n, in.phases, [&](Index i) { return in.input_noise_deg(i); });
  const double noise_out = out_noise.all(), noise_in = in_noise.all();
  const double noise_share = angle_rmse > 0 ? std::min(1.0, noise_out * noise_out / (angle_rmse * angle_rmse)) : 0.0;
  // What is to be explained is the angle's mean square beyond the forward gap's, and the noise's
  // part in it is the output's noise variance beyond the input's: the forward gap holds the
  // sensor's noise already.
  const double angle_excess = angle_rmse * angle_rmse - in.forward_gap_deg * in.forward_gap_deg;
  const double noise_excess = std::max(0.0, noise_out * noise_out - noise_in * noise_in);
  const double noise_share_of_excess = angle_excess > 0 ? std::min(1.0, noise_excess / angle_excess) : 0.0;

  const std::vector<Segment> seg = segments(in, err);
  // Where: the segment that adds the most squared error beyond the forward residual's, so a
  // short segment with a large error (the reversals) is named if it is what makes the difference,
  // and a long one with a small excess is not.
  double total_ss = 0, total_excess = 0;
  Index total_n = 0;
  for (const Segment& g : seg) { total_ss += g.s2; total_excess += g.excess(); total_n += g.n; }
  const Segment* top = nullptr;
  json segments_json = json::array();
  for (const Segment& g : seg) {
    segments_json.push_back({{"segment", g.name},
                             {"share_of_scans", static_cast<double>(g.n) / static_cast<double>(std::max<Index>(1, total_n))},
                             {"rmse_deg", g.rmse()},
                             {"mean_deg", g.mean()},
                             {"forward_rms_deg", g.forward()},
                             {"share_of_squared_error", total_ss > 0 ? g.s2 / total_ss : 0.0},
                             {"share_of_excess", total_excess > 0 ? g.excess() / total_excess : kNaN}});
    if (top == nullptr || g.excess() > top->excess()) top = &g;
  }

  std::string verdict = "comparable";
  if (ratio > kAngleGapRatio) verdict = noise_share_of_excess >= 0.5 ? "noise_amplification" : "bias";

  std::ostringstream o;
  o << "angle " << format_fixed(angle_rmse, 2) << " deg vs forward " << format_fixed(in.forward_gap_deg, 2) << " deg ("
    << format_fixed(ratio, 1) << "x)";
  const std::string noise_words = "output scan-to-scan noise " + format_fixed(noise_out, 2) + " deg against the sensor's " +
                                  format_fixed(noise_in, 2) + " deg (holds " + format_fixed(out_noise.hold.noise(), 2) + " vs " +
                                  format_fixed(in_noise.hold.noise(), 2) + ", moving " +
                                  format_fixed(out_noise.moving.noise(), 2) + " vs " + format_fixed(in_noise.moving.noise(), 2) + ")";
  if (verdict == "comparable") {
    o << ": within " << format_fixed(kAngleGapRatio, 1) << "x of the forward gap";
  } else {
    if (verdict == "noise_amplification") {
      o << ": noise amplification: " << noise_words;
    } else {
      o << ": bias";
      if (top != nullptr && total_excess > 0)
        o << ", mostly in " << top->name << " (RMSE " << format_fixed(top->rmse(), 2) << " deg against the forward "
          << format_fixed(top->forward(), 2) << ", mean " << signed_fixed(top->mean(), 2) << " deg; "
          << format_fixed(100 * top->excess() / total_excess, 0) << " % of the excess)";
      o << "; " << noise_words;
    }
    o << "\n  angle RMSE by segment (forward in brackets):";
    for (std::size_t i = 0; i < seg.size(); ++i)
      o << (i ? ", " : " ") << seg[i].name << " " << format_fixed(seg[i].rmse(), 2) << " (" << format_fixed(seg[i].forward(), 2) << ")";
    o << " deg";
  }

  AngleGap out;
  out.summary = o.str();
  out.report = {{"forward_gap_deg", in.forward_gap_deg},
                {"angle_rmse_deg", angle_rmse},
                {"angle_scans", all.n},
                {"ratio", ratio},
                {"ratio_threshold", kAngleGapRatio},
                {"verdict", verdict},
                {"where", verdict == "bias" && top != nullptr ? json(top->name) : json(nullptr)},
                {"noise",
                 {{"output_deg", out_noise.to_json()},
                  {"input_deg", in_noise.to_json()},
                  {"amplification", noise_in > 0 ? noise_out / noise_in : kNaN},
                  {"share_of_angle_mean_square", noise_share},
                  {"share_of_excess", noise_share_of_excess}}},
                {"segments", segments_json},
                {"summary", out.summary},
                {"how", "the found model's compensated angle on held-out blocks (compensated.rmse_after_deg) against the "
                        "forward gap (final_gap_deg), both in deg against the reference. Noise: sqrt(mean(diff^2)/2) over "
                        "consecutive scans both in holds or both moving; output: the angle minus the smoothed reference; "
                        "input: the held-out voltage residual over the model's local quasi-static slope. Verdict above "
                        "ratio_threshold: noise_amplification when the output's noise variance beyond the input's is at "
                        "least half the angle's mean square beyond the forward gap's (share_of_excess), else bias, "
                        "where = the segment adding the most squared error beyond the forward residual's (segments[].share_of_excess)"}};
  return out;
}

}  // namespace pof::gap
