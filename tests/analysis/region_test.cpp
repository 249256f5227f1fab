// Region statistics of a hand-built frame, and the exact disc-rectangle overlap.
#include "analysis/region.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace granary::analysis {
namespace {

constexpr double kPi = std::numbers::pi;

// Reference: midpoint rule over x of the chord length inside [y0, y1].
double OverlapNumeric(double cx, double cy, double r, const Rect& q) {
  const int n = 200000;
  const double a = std::max(q.x0, cx - r), b = std::min(q.x1, cx + r);
  if (b <= a) return 0.0;
  const double h = (b - a) / n;
  double area = 0.0;
  for (int i = 0; i < n; ++i) {
    const double x = a + (i + 0.5) * h;
    const double s = std::sqrt(std::max(0.0, r * r - (x - cx) * (x - cx)));
    area += std::max(0.0, std::min(q.y1, cy + s) - std::max(q.y0, cy - s)) * h;
  }
  return area;
}

TEST(DiscRectOverlap, KnownCases) {
  const Rect q{0, 10, 0, 10};
  EXPECT_NEAR(DiscRectOverlap(5, 5, 1, q), kPi, 1e-14);        // inside
  EXPECT_NEAR(DiscRectOverlap(0, 5, 1, q), kPi / 2, 1e-14);    // cut through the centre
  EXPECT_NEAR(DiscRectOverlap(10, 10, 1, q), kPi / 4, 1e-14);  // corner
  EXPECT_NEAR(DiscRectOverlap(20, 5, 1, q), 0.0, 1e-14);       // outside
  // A segment: disc centre 0.5 outside the edge: r^2 acos(d/r) - d sqrt(r^2 - d^2)
  EXPECT_NEAR(DiscRectOverlap(-0.5, 5, 1, q), std::acos(0.5) - 0.5 * std::sqrt(0.75), 1e-13);
  // A rectangle thinner than the disc: a band through the middle.
  const Rect band{-10, 10, -0.5, 0.5};
  EXPECT_NEAR(DiscRectOverlap(0, 0, 1, band), kPi - 2 * (std::acos(0.5) - 0.5 * std::sqrt(0.75)), 1e-13);
}

TEST(DiscRectOverlap, MatchesQuadratureOnRandomCases) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (int k = 0; k < 40; ++k) {
    const double x0 = u(rng), y0 = u(rng);
    const Rect q{x0, x0 + std::abs(u(rng)) + 0.1, y0, y0 + std::abs(u(rng)) + 0.1};
    const double r = 0.3 + 0.5 * std::abs(u(rng));
    EXPECT_NEAR(DiscRectOverlap(0.0, 0.0, r, q), OverlapNumeric(0.0, 0.0, r, q), 1e-8)
        << "rect " << q.x0 << " " << q.x1 << " " << q.y0 << " " << q.y1 << " r " << r;
  }
}

TEST(RegionFrame, PackingAndBothTemperatures) {
  const Rect q{0, 10, 0, 10};
  // Discs: whole (pi), half (pi/2), quarter (pi/4), outside.
  std::vector<rundir::Disc> discs(4);
  discs[0].x = 5;
  discs[0].y = 5;
  discs[0].radius = 1;
  discs[1].x = 0;
  discs[1].y = 5;
  discs[1].radius = 1;
  discs[2].x = 10;
  discs[2].y = 10;
  discs[2].radius = 1;
  discs[3].x = 30;
  discs[3].y = 5;
  discs[3].radius = 1;
  // Bodies inside with velocities (1,0), (-1,0), (0,2), (0,-2), m = 2, I = 0.5, omega 1, -1, 0, 0;
  // one outside that must be ignored.
  auto body = [](double x, double y, double vx, double vy, double w) {
    rundir::Body b;
    b.x = x;
    b.y = y;
    b.vx = vx;
    b.vy = vy;
    b.omega = w;
    b.mass = 2.0;
    b.inertia = 0.5;
    return b;
  };
  const std::vector<rundir::Body> bodies = {body(1, 1, 1, 0, 1), body(2, 2, -1, 0, -1), body(3, 3, 0, 2, 0),
                                            body(4, 4, 0, -2, 0), body(11, 4, 50, 50, 50)};
  const RegionFrame f = MakeRegionFrame(discs, bodies, q);
  EXPECT_NEAR(f.phi, (kPi + kPi / 2 + kPi / 4) / 100.0, 1e-14);
  EXPECT_EQ(f.bodies, 4);
  EXPECT_NEAR(f.tg_translational, 0.5 * (1 + 1 + 4 + 4) / 4.0, 1e-14);                       // 1.25
  EXPECT_NEAR(f.tg_full, (2 * 1 + 0.5 + 2 * 1 + 0.5 + 2 * 4 + 2 * 4) / (3.0 * 4.0), 1e-14);  // 1.75

  // A uniform drift does not change the temperatures.
  std::vector<rundir::Body> moving = bodies;
  for (auto& b : moving) {
    b.vx += 3.0;
    b.vy -= 7.0;
    b.omega += 2.0;
  }
  const RegionFrame g = MakeRegionFrame(discs, moving, q);
  EXPECT_NEAR(g.tg_translational, 1.25, 1e-13);
  EXPECT_NEAR(g.tg_full, 1.75, 1e-13);

  RegionAccumulator acc(q);
  acc.Add(discs, bodies);
  acc.Add(discs, moving);
  const RegionStats s = acc.Result();
  EXPECT_EQ(s.frames, 2);
  EXPECT_NEAR(s.phi.mean, f.phi, 1e-14);
  EXPECT_NEAR(s.tg_full.mean, 1.75, 1e-13);
  EXPECT_EQ(s.vx.Total(), 8.0);  // 4 bodies inside, 2 frames
}

TEST(RegionAccumulator, VelocityHistogramsOnAFixedGridMergeExactly) {
  // v_x = 0.01 i for bodies i = 0..499 in two frames: bins of 0.05 hold 5 bodies each (the
  // first and last bins, centred on 0 and 5, half of that).
  const Rect q{0, 100, 0, 100};
  std::vector<rundir::Body> bodies(500);
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    bodies[i].x = 1.0 + 0.1 * static_cast<double>(i);
    bodies[i].y = 1.0;
    bodies[i].vx = 0.01 * static_cast<double>(i) + 1e-9;
  }
  RegionAccumulator a(q), b(q);
  a.Add({}, bodies);
  b.Add({}, bodies);
  RegionStats s = a.Result();
  EXPECT_EQ(s.vx.Total(), 500.0);
  EXPECT_EQ(s.vx.first, 0);
  ASSERT_EQ(s.vx.counts.size(), 101u);  // 0 .. 4.99 -> bins 0 .. 100
  EXPECT_EQ(s.vx.counts[0], 3.0);       // 0, 0.01, 0.02
  EXPECT_EQ(s.vx.counts[1], 5.0);
  s.vx.Merge(b.Result().vx);
  EXPECT_EQ(s.vx.Total(), 1000.0);
  EXPECT_EQ(s.vx.counts[1], 10.0);
  const Histogram h = s.vx.Coarse(30);  // 101 grid bins -> factor 4 -> 26 bins of 0.2
  EXPECT_EQ(h.counts.size(), 26u);
  EXPECT_NEAR(h.BinWidth(), 0.2, 1e-12);
  EXPECT_EQ(h.Total(), 1000.0);
  EXPECT_NEAR(h.lo, -0.025, 1e-12);
}

TEST(Region, ThesisSizes) {
  const Rect r3 = RegionAboveOutlet(0.0, 11.0, Chapter3Region());
  EXPECT_DOUBLE_EQ(r3.x1 - r3.x0, 13.0);
  EXPECT_DOUBLE_EQ(r3.y1, 10.0);
  const Rect r4 = RegionAboveOutlet(5.0, 20.0, Chapter4Region());
  EXPECT_NEAR(r4.x1 - r4.x0, 20.0 + 2.0 * std::sqrt(2.0), 1e-14);
  EXPECT_NEAR(0.5 * (r4.x0 + r4.x1), 5.0, 1e-14);
  EXPECT_NEAR(r4.y1, 5.0 * std::sqrt(2.0), 1e-14);
}

}  // namespace
}  // namespace granary::analysis
