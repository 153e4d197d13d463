// The registry: every effect of the catalogue (pof/core/effects.hpp) mapped to its definition, and the
// basis functions several effects share.
#include <cmath>

#include "effect.hpp"

namespace pof::gap {

extern const EffectDef kStaticNonlinearity, kDrift, kCreep, kRateDependentHysteresis, kAccelerationDependence,
    kTimeDelay, kBacklash, kSourcePowerCoupling, kPeriodicInterference, kMemoryHysteresis, kViscoelasticRelaxation;

const EffectDef& effect_def(core::Effect e) {
  switch (e) {  // -Wswitch: an effect added to the catalogue without a definition does not compile
    case core::Effect::kStaticNonlinearity: return kStaticNonlinearity;
    case core::Effect::kDrift: return kDrift;
    case core::Effect::kCreep: return kCreep;
    case core::Effect::kRateDependentHysteresis: return kRateDependentHysteresis;
    case core::Effect::kAccelerationDependence: return kAccelerationDependence;
    case core::Effect::kTimeDelay: return kTimeDelay;
    case core::Effect::kBacklash: return kBacklash;
    case core::Effect::kSourcePowerCoupling: return kSourcePowerCoupling;
    case core::Effect::kPeriodicInterference: return kPeriodicInterference;
    case core::Effect::kMemoryHysteresis: return kMemoryHysteresis;
    case core::Effect::kViscoelasticRelaxation: return kViscoelasticRelaxation;
  }
  return kDrift;  // unreachable: every enumerator is handled above
}

namespace basis {

Eigen::VectorXd relaxation(const Eigen::VectorXd& angle, double dt, double tau_s) {
  Eigen::VectorXd out(angle.size());
  const double a = 1.0 - std::exp(-dt / tau_s);
  double x = angle.size() > 0 ? angle(0) : 0.0;
  for (Eigen::Index i = 0; i < angle.size(); ++i) {
    x += a * (angle(i) - x);
    out(i) = x - angle(i);
  }
  return out;
}

Eigen::VectorXd quasi_static_v(const Context& cx, const Kinematics& k) {
  return ((cx.m.c10 - k.angle.array()) / cx.m.c9).matrix();
}

std::vector<double> log_grid(double a, double b, int n) {
  std::vector<double> g;
  for (int i = 0; i < n; ++i) g.push_back(a * std::pow(b / a, static_cast<double>(i) / (n - 1)));
  return g;
}

std::vector<double> log_refine(double best) {
  std::vector<double> g;
  for (int j = -4; j <= 4; ++j)
    if (j != 0) g.push_back(best * std::pow(2.0, j / 16.0));
  return g;
}

std::vector<double> linear_refine(double best, double step, double min) {
  std::vector<double> g;
  for (int j = -9; j <= 9; ++j)
    if (j != 0 && best + j * step > min) g.push_back(best + j * step);
  return g;
}

}  // namespace basis
}  // namespace pof::gap
