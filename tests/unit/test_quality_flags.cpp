// The core repeats angle_t's QUALITY_* and PHASE_* values (it links no LCM); they must agree.
#include <gtest/gtest.h>

#include <pof/angle_t.hpp>

#include "pof/core/model.hpp"
#include "pof/core/quality.hpp"

namespace q = pof::core::quality;
using A = pof::angle_t;

static_assert(q::kReferenceLost == A::QUALITY_REFERENCE_LOST);
static_assert(q::kOverRange == A::QUALITY_OVER_RANGE);
static_assert(q::kInvalidInput == A::QUALITY_INVALID_INPUT);
static_assert(q::kScansLost == A::QUALITY_GAP);
static_assert(q::kVelocityExtrapolated == A::QUALITY_VELOCITY_EXTRAPOLATED);
static_assert(q::kAngleExtrapolated == A::QUALITY_ANGLE_EXTRAPOLATED);
static_assert(q::kSettling == A::QUALITY_SETTLING);
static_assert(q::kLate == A::QUALITY_LATE);
static_assert(static_cast<int>(pof::core::Direction::kHold) == A::PHASE_HOLD);
static_assert(static_cast<int>(pof::core::Direction::kFlexion) == A::PHASE_FLEXION);
static_assert(static_cast<int>(pof::core::Direction::kExtension) == A::PHASE_EXTENSION);

TEST(QualityFlags, MatchAngleT) { SUCCEED() << "checked at compile time"; }
