#pragma once
// Quality flags and movement phases of one compensated scan. The values are those of
// lcmtypes/angle_t.lcm (QUALITY_*, PHASE_*), repeated here because the core links no LCM;
// tests/unit/test_quality_flags.cpp fails if the two ever disagree.
#include <cstdint>

namespace pof::core {

namespace quality {
inline constexpr std::int32_t kReferenceLost = 1;          // reference power near 0 or far from its level
inline constexpr std::int32_t kOverRange = 2;              // a DAQ input at its range limit
inline constexpr std::int32_t kInvalidInput = 4;           // NaN/inf sample; angle is NaN
inline constexpr std::int32_t kScansLost = 8;              // scans lost before this one; estimator reset (QUALITY_GAP)
inline constexpr std::int32_t kVelocityExtrapolated = 16;  // |velocity| outside the calibrated range
inline constexpr std::int32_t kAngleExtrapolated = 32;     // angle outside the calibrated range
inline constexpr std::int32_t kSettling = 64;              // velocity estimator not yet settled
inline constexpr std::int32_t kLate = 128;                 // the scan's block came late (an acquisition stall's backlog)
}  // namespace quality

}  // namespace pof::core
