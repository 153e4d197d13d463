#pragma once
// One search of `pof gap` from one baseline (docs/gap.md, sections 3-4): the structure fitted alone,
// then effects added one step at a time by the acceptance rule, each assessed on held-out blocks.
// analysis.cpp runs it from the paper structure and from the dynamic model and keeps one.
// Internal to pof_gap.
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "pof/gap/gap.hpp"
#include "pof/gap/localise.hpp"
#include "search.hpp"

namespace pof::gap {

struct Grown;

/// What a search reads besides its baseline: the recording, its kinematics and phases, the
/// options, the sensitivity gaps are reported at, and where progress goes.
struct Steps {
  const Signals* s = nullptr;
  const Kinematics* k0 = nullptr;  // the reference angle's kinematics without delay
  const std::vector<Phase>* phases = nullptr;
  const Options* opt = nullptr;
  double c9 = 1;  // |c9| of the paper fit [deg/V]: every gap in degrees at this sensitivity
  std::function<void(const std::string&)> say;
  /// Called with the search after each accepted step (may be empty): analysis.cpp's checkpoint.
  std::function<void(const Grown&)> accepted;
  /// Held-out RMS residual in degrees from a held-out residual sum of squares [V^2].
  [[nodiscard]] double gap_deg(double cv_rss) const;
  /// A residual [V] in degrees: positive when the sensor reads a larger angle than the model.
  [[nodiscard]] Eigen::VectorXd to_deg(const Eigen::VectorXd& r) const;
};

/// One search: its baseline, the state it grew to and the steps that grew it.
struct Grown {
  Search sx;
  State st;
  CurrentFit cur;
  Structure baseline;      // the structure alone, fitted on all data
  Eigen::VectorXd baseline_resid;  // its held-out residual [V]
  double baseline_gap = 0, final_gap = 0;
  std::vector<Step> steps;
  Eigen::VectorXd strict_resid;  // the held-out residual of the last accepted step [V]
  nlohmann::json last_rejected;  // the best candidate that was not accepted, and why
  /// Explanations this recording cannot tell apart (docs/gap.md, section 4, "Said, not hidden").
  nlohmann::json indistinguishable = nlohmann::json::array();
};

/// The baseline alone, relinearised (so what the refit left is not credited to a first candidate).
Grown baseline_alone(Search from, const Steps& ctx);

/// Adds effects while one passes the acceptance rule (at most opt.max_steps).
void grow(Grown& g, const Steps& ctx);

}  // namespace pof::gap
