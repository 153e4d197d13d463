// Property tests of the segmentation on randomised protocols: random speeds (table-1 range),
// amplitudes, pauses at reversals (including none), stutters within a sweep, partial first and
// last sweeps, potentiometer noise and quantisation.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "pof/testing/paper_protocol.hpp"
#include "pof/core/segmentation.hpp"

using pof::core::Direction;
using pof::core::Segment;

namespace {

struct TrueSweep {
  Direction kind;
  double speed_rad_s;
  double amplitude;
};

}  // namespace

TEST(Segmentation, RandomisedProtocolsGiveTheirSweepsDirectionsAndVelocities) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> speed(0.0209, 0.4304), pause(0.0, 1.5), hold(2.0, 6.0), u(0, 1);
  for (int trial = 0; trial < 25; ++trial) {
    pof::testing::ProtocolSettings p;
    p.seed = static_cast<std::uint64_t>(trial + 100);
    pof::testing::Trajectory tr(p.rate_hz, 0);
    std::vector<TrueSweep> truth;
    double angle = 0;
    tr.hold(hold(rng));
    const int n_sweeps = 4 + trial % 5;
    for (int k = 0; k < n_sweeps; ++k) {
      const double w = speed(rng);
      const double deg_s = w * 180 / std::numbers::pi;
      // alternate directions (two sweeps the same way without a stop are one movement whose speed
      // changed); amplitude 20-90 deg within [0, 90]
      const bool up = k % 2 == 0;
      const double target = up ? angle + 20 + u(rng) * (90 - angle - 20) : angle - 20 - u(rng) * (angle - 20);
      if (u(rng) < 0.3 && std::abs(target - angle) > 40 && deg_s < 10) {
        // a stutter: a short stop (< max_pause_s) half way, which must not split the sweep
        const double mid = 0.5 * (angle + target);
        tr.move_to(mid, deg_s, 0.2);
        tr.hold(0.4);
        tr.move_to(target, deg_s, 0.2);
      } else {
        tr.move_to(target, deg_s, 0.2);
      }
      truth.push_back({up ? Direction::kFlexion : Direction::kExtension, w, std::abs(target - angle)});
      angle = target;
      const double pz = pause(rng);
      if (pz > 0.2) tr.hold(pz);
    }
    tr.hold(hold(rng));
    const auto g = pof::testing::acquire(pof::core::paper_coefficients(), tr, p);

    const auto segs = pof::core::segment(g.t_s, g.angle_ref_deg);
    // Segments tile the recording.
    ASSERT_FALSE(segs.empty());
    EXPECT_EQ(segs.front().begin, 0);
    EXPECT_EQ(segs.back().end, g.size());
    for (std::size_t k = 1; k < segs.size(); ++k) EXPECT_EQ(segs[k].begin, segs[k - 1].end);

    std::vector<const Segment*> sweeps;
    for (const auto& s : segs)
      if (s.kind != Direction::kHold) sweeps.push_back(&s);
    if (sweeps.size() != truth.size()) {
      for (const auto& t : truth) std::printf("truth %d %.4f rad/s %.1f deg\n", static_cast<int>(t.kind), t.speed_rad_s, t.amplitude);
      for (const auto& s : segs)
        std::printf("seg %d %.2f-%.2f s %.1f->%.1f deg %.4f rad/s\n", static_cast<int>(s.kind), s.t_begin, s.t_end,
                    s.angle_begin, s.angle_end, s.velocity_rad_s);
    }
    ASSERT_EQ(sweeps.size(), truth.size()) << "trial " << trial;
    for (std::size_t k = 0; k < truth.size(); ++k) {
      EXPECT_EQ(sweeps[k]->kind, truth[k].kind) << "trial " << trial << " sweep " << k;
      EXPECT_NEAR(std::abs(sweeps[k]->amplitude_deg()), truth[k].amplitude, 0.5) << "trial " << trial << " sweep " << k;
      // The cruise speed is measurable when the cruise outlasts the slope window with room to spare.
      const double cruise_s = truth[k].amplitude / (truth[k].speed_rad_s * 180 / std::numbers::pi) - 0.2;
      if (cruise_s > 1.5) {
        EXPECT_NEAR(std::abs(sweeps[k]->velocity_rad_s), truth[k].speed_rad_s, 0.02 * truth[k].speed_rad_s)
            << "trial " << trial << " sweep " << k;
      }
    }

    // Partial cycles: cut the recording inside the first and the last sweep.
    const Eigen::Index a = (sweeps.front()->begin + sweeps.front()->end) / 2;
    const Eigen::Index b = (sweeps.back()->begin + sweeps.back()->end) / 2;
    const auto cut = pof::core::segment(g.t_s.segment(a, b - a), g.angle_ref_deg.segment(a, b - a));
    std::vector<const Segment*> cs;
    for (const auto& s : cut)
      if (s.kind != Direction::kHold) cs.push_back(&s);
    ASSERT_EQ(cs.size(), truth.size()) << "trial " << trial << ": partial sweeps are kept";
    EXPECT_EQ(cs.front()->kind, truth.front().kind);
    EXPECT_EQ(cs.back()->kind, truth.back().kind);
  }
}

TEST(Segmentation, NoisyHoldIsOneHold) {
  pof::testing::ProtocolSettings p;
  p.daq.noise_v = 0.01;  // ten times the protocol's noise
  pof::testing::Trajectory tr(p.rate_hz, 45);
  tr.hold(60);
  const auto g = pof::testing::acquire(pof::core::paper_coefficients(), tr, p);
  const auto segs = pof::core::segment(g.t_s, g.angle_ref_deg);
  ASSERT_EQ(segs.size(), 1u);
  EXPECT_EQ(segs[0].kind, Direction::kHold);
}
