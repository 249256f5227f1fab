// Orientation on constructed fields with known answers (orientation.h): axes of dumbbells,
// snowmen and rods whatever their disc order, S of aligned, crossed and isotropic fields, the
// mean acute angle against s and against the angular position, the window's distribution.
#include "analysis/orientation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace granary::analysis {
namespace {

constexpr double kPi = std::numbers::pi;

// Discs of one body each: a dumbbell of unit discs centred at (x, y) with its axis at `angle`.
void Dumbbell(std::vector<rundir::Disc>& discs, double x, double y, double angle) {
  const std::int64_t body = discs.empty() ? 0 : discs.back().mol + 1;
  const double dx = 0.5 * std::cos(angle), dy = 0.5 * std::sin(angle);
  discs.push_back({static_cast<std::int64_t>(discs.size() + 1), body, 1, x - dx, y - dy, 0.5, kPi / 4, 0, 0, 0});
  discs.push_back({static_cast<std::int64_t>(discs.size() + 1), body, 1, x + dx, y + dy, 0.5, kPi / 4, 0, 0, 0});
}

silo::OutletFrame BaseOutlet() {
  silo::OutletFrame f;
  f.width = 6;
  return f;
}

TEST(Orientation, AxesOfDumbbellsSnowmenAndRodsWhateverTheDiscOrder) {
  std::vector<rundir::Disc> d;
  Dumbbell(d, 0, 0, 3 * kPi / 4);  // 135 degrees
  Dumbbell(d, 5, 0, -kPi / 4);     // the same axis pointing the other way
  // A snowman: big disc (0.75) at the origin, small (0.5) up and to the left, numbered big first.
  d.push_back({5, 2, 1, 10, 0, 0.75, 0, 0, 0, 0});
  d.push_back({6, 2, 1, 10 - 1.25 * std::cos(kPi / 3), 1.25 * std::sin(kPi / 3), 0.5, 0, 0, 0, 0});
  // A rod of three discs along 30 degrees, its middle disc numbered last.
  for (int k : {0, 2, 1})
    d.push_back({7 + k, 3, 1, 20 + k * std::cos(kPi / 6), k * std::sin(kPi / 6), 0.5, 0, 0, 0, 0});
  d.push_back({11, 4, 2, 30, 0, 0.7, 0, 0, 0, 0});  // a disc
  const std::vector<BodyAxis> a = BodyAxes(d);
  ASSERT_EQ(a.size(), 5u);
  EXPECT_NEAR(a[0].angle, 3 * kPi / 4, 1e-12);
  EXPECT_NEAR(a[1].angle, 3 * kPi / 4, 1e-12);
  EXPECT_TRUE(std::isnan(a[0].head));
  EXPECT_NEAR(a[2].angle, 2 * kPi / 3, 1e-12);
  EXPECT_NEAR(a[2].head, 2 * kPi / 3, 1e-12);  // from the big disc to the small one
  EXPECT_NEAR(a[3].angle, kPi / 6, 1e-12);
  EXPECT_FALSE(a[4].elongated);
  EXPECT_NEAR(Acute(3 * kPi / 4), kPi / 4, 1e-12);
  EXPECT_NEAR(Acute(kPi / 2), kPi / 2, 1e-12);
}

TEST(Orientation, OrderParameterOfAlignedCrossedAndIsotropicAxes) {
  EXPECT_NEAR(OrderParameter({kPi / 6, kPi / 6}, 0.0), 2 * std::cos(kPi / 6) * std::cos(kPi / 6) - 1, 1e-12);
  EXPECT_NEAR(OrderParameter({kPi / 2, kPi / 2}, kPi / 2), 1.0, 1e-12);
  EXPECT_NEAR(OrderParameter({0.0, 0.0}, kPi / 2), -1.0, 1e-12);
  std::vector<double> isotropic;
  for (int k = 0; k < 36; ++k) isotropic.push_back(k * kPi / 36);
  EXPECT_NEAR(OrderParameter(isotropic, 0.3), 0.0, 1e-12);
  EXPECT_TRUE(std::isnan(OrderParameter({}, 0.0)));
}

// A field vertical near the centre line, horizontal beside it (fig. 4.3a); dumbbells on a ring
// pointing at the outlet (fig. 4.3b); regions with known S (fig. 5.5); the window at pi/4.
TEST(Orientation, ProfilesRegionsAndTheWindowOfAConstructedField) {
  std::vector<rundir::Disc> d;
  for (double x = -9.5; x <= 9.5; x += 1.0) Dumbbell(d, x, 3.0, std::fabs(x) < 3 ? kPi / 2 : 0.0);
  // On the ring of radius 14 (above the row's band): axes along the radius, so the acute angle
  // is Acute(theta).
  for (int k = 0; k < 9; ++k) {
    const double theta = (k + 0.5) * kPi / 9;
    Dumbbell(d, 14 * std::cos(theta), 14 * std::sin(theta), theta);
  }
  OrientationOptions o;
  o.heights = {3};
  o.band = 1;
  o.s_range = 10;
  o.s_bins = 10;
  o.radii = {14};
  o.ring = 1;
  o.theta_bins = 9;
  o.regions = {{"centre", -2.5, 2.5, 2.5, 3.5, kPi / 2}, {"side", 4, 10, 2.5, 3.5, kPi / 2}};
  o.window_theta = kPi / 4;
  o.window_dtheta = kPi / 9;
  o.window_radius = 14;
  o.window_dr = 1;
  o.axis_bins = 4;
  OrientationSums sums;
  AddOrientationFrame(d, BaseOutlet(), 15, o, sums);
  AddOrientationFrame(d, BaseOutlet(), 15, o, sums);  // a second frame changes no mean
  EXPECT_EQ(sums.frames, 2);
  const OrientationProfile s = OrientationAgainstS(sums, o);
  ASSERT_EQ(s.mean.size(), 1u);
  ASSERT_EQ(s.centre.size(), 10u);
  EXPECT_NEAR(s.centre[5], 1.0, 1e-12);
  EXPECT_NEAR(s.mean[0][5], kPi / 2, 1e-12);  // s in [0, 2): vertical
  EXPECT_NEAR(s.mean[0][0], 0.0, 1e-12);      // s in [-10, -8): horizontal
  EXPECT_DOUBLE_EQ(s.count[0][5], 4.0);       // two bodies, two frames
  const OrientationProfile t = OrientationAgainstTheta(sums, o);
  ASSERT_EQ(t.mean[0].size(), 9u);
  for (int k = 0; k < 9; ++k)
    EXPECT_NEAR(t.mean[0][static_cast<std::size_t>(k)], Acute((k + 0.5) * kPi / 9), 1e-9) << k;
  const std::vector<double> order = OrderParameters(sums, o);
  ASSERT_EQ(order.size(), 2u);
  EXPECT_NEAR(order[0], 1.0, 1e-12);   // every axis vertical, the director vertical
  EXPECT_NEAR(order[1], -1.0, 1e-12);  // every axis horizontal
  // The window holds the ring's body at theta = 2.5 pi / 9 (50 degrees): one axis per frame, in
  // the second of four bins over [0, pi).
  EXPECT_EQ(sums.window_axes, (std::vector<double>{0, 2, 0, 0}));
  const std::vector<double> density = AxisDensity(sums.window_axes);
  EXPECT_NEAR(density[1], 1 / (kPi / 4), 1e-12);
  // Sums of two runs add up.
  OrientationSums both = sums;
  both.Add(sums);
  EXPECT_EQ(both.frames, 4);
  EXPECT_NEAR(OrientationAgainstS(both, o).mean[0][5], kPi / 2, 1e-12);
}

// The default region: the rectangle above the outlet, director along the outlet's normal.
TEST(Orientation, TheDefaultRegionIsAboveTheOutlet) {
  silo::OutletFrame side;  // an outlet in the right wall: normal -x
  side.cx = 20;
  side.cy = 8;
  side.ax = 0;
  side.ay = 1;
  side.nx = -1;
  side.ny = 0;
  const auto regions = OrientationRegions(OrientationOptions{}, side);
  ASSERT_EQ(regions.size(), 1u);
  EXPECT_NEAR(regions[0].x0, 10, 1e-12);
  EXPECT_NEAR(regions[0].x1, 20, 1e-12);
  EXPECT_NEAR(regions[0].y0, 3, 1e-12);
  EXPECT_NEAR(regions[0].y1, 13, 1e-12);
  EXPECT_NEAR(std::fabs(regions[0].director), kPi, 1e-12);
}

}  // namespace
}  // namespace granary::analysis
