#include "pof/core/model_selection.hpp"

#include <algorithm>
#include <cmath>

#include "pof/core/normalise.hpp"
#include "pof/core/offline.hpp"

namespace pof::core {

using Eigen::Index;
using Eigen::VectorXd;

HeldOutError error_stats(const VectorXd& a, const VectorXd& b) {
  HeldOutError e;
  std::vector<double> abs_err;
  double ss = 0;
  for (Index i = 0; i < std::min(a.size(), b.size()); ++i)
    if (std::isfinite(a(i)) && std::isfinite(b(i))) {
      const double d = a(i) - b(i);
      ss += d * d;
      abs_err.push_back(std::abs(d));
    }
  e.n = static_cast<Index>(abs_err.size());
  if (e.n == 0) return e;
  e.rmse_deg = std::sqrt(ss / static_cast<double>(e.n));
  auto p99 = abs_err.begin() + static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(abs_err.size() - 1));
  std::nth_element(abs_err.begin(), p99, abs_err.end());
  e.p99_abs_deg = *p99;
  e.max_abs_deg = *std::max_element(abs_err.begin(), abs_err.end());
  return e;
}

ModelComparison compare_held_out(const VectorXd& t, const VectorXd& sensor, const VectorXd& reference, const VectorXd& ang,
                                 const DynamicFitResult& dyn, const CalibrationSettings& ps, const DynamicFitSettings& ds,
                                 const CompensatorSettings& cs) {
  const Index n = t.size();
  ModelComparison cmp;
  const double nan = std::nan("");
  cmp.paper_deg = VectorXd::Constant(n, nan);
  cmp.dynamic_deg = VectorXd::Constant(n, nan);
  cmp.folds = static_cast<int>(dyn.fold_begin.size());
  const double level = ps.reference_level_v > 0 ? ps.reference_level_v : reference_level(reference);
  ReferenceGuard guard;
  guard.level_v = level;
  const VectorXd v = normalise(sensor, reference, guard);
  const std::vector<std::optional<DynamicModel>> refits = fold_models(dyn, t, v, ang, ds);
  for (std::size_t f = 0; f < dyn.fold_begin.size(); ++f) {
    const Index b = dyn.fold_begin[f], e = dyn.fold_end[f];
    const std::string which = "held-out block " + std::to_string(f + 1) + " (scans " + std::to_string(b) + "-" +
                              std::to_string(e - 1) + ")";
    VectorXd masked = ang;
    masked.segment(b, e - b).setConstant(nan);
    Calibration paper, dynamic;
    try {
      CalibrationSettings pf = ps;
      pf.reference_level_v = level;
      paper = calibrate(t, sensor, reference, masked, pf).cal;
    } catch (const CalibrationError& ex) {
      cmp.notes.push_back(which + ": the paper's model cannot be fitted without it (" + ex.what() + ")");
      continue;
    }
    if (!refits[f]) {
      cmp.notes.push_back(which + ": the dynamic model has no invertible refit without it");
      continue;
    }
    dynamic = paper;
    dynamic.dynamic = *refits[f];
    dynamic.estimator = dyn.estimator;  // two noise levels, not the model: taken from the whole recording
    dynamic.active = ModelKind::kDynamic;
    const OfflineResult rp = compensate_recording(t, sensor, reference, VectorXd(), paper, cs);
    const OfflineResult rd = compensate_recording(t, sensor, reference, VectorXd(), dynamic, cs);
    cmp.paper_deg.segment(b, e - b) = rp.angle_deg.segment(b, e - b);
    cmp.dynamic_deg.segment(b, e - b) = rd.angle_deg.segment(b, e - b);
    ++cmp.folds_used;
  }
  // Score both on the same scans: those where both produced an angle.
  VectorXd pa = cmp.paper_deg, dy = cmp.dynamic_deg;
  for (Index i = 0; i < n; ++i)
    if (!std::isfinite(pa(i)) || !std::isfinite(dy(i))) pa(i) = dy(i) = nan;
  cmp.paper = error_stats(pa, ang);
  cmp.dynamic = error_stats(dy, ang);
  return cmp;
}

}  // namespace pof::core
