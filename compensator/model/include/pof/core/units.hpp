#pragma once
// Unit conversions, one home for every part (models, fits, the simulator, `pof gap`).
#include <numbers>

namespace pof::core {

inline constexpr double kRadPerDeg = std::numbers::pi / 180.0;
inline constexpr double kDegPerRad = 180.0 / std::numbers::pi;

}  // namespace pof::core
