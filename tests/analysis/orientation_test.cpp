// Orientation on constructed fields with known answers (orientation.h): axes of dumbbells,
// snowmen and rods whatever their disc order, S of aligned, crossed and isotropic fields, the
// mean acute angle against s and against the angular position, the window's distribution, and
// S against the flow direction (bodies moving along or across their axes, the flow reversed, a
// region at rest).
#include "analysis/orientation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace granary::analysis {
namespace {

constexpr double kPi = std::numbers::pi;

// Discs of one body each: a dumbbell of unit discs centred at (x, y) with its axis at `angle`,
// both discs moving at (vx, vy).
void Dumbbell(std::vector<rundir::Disc>& discs, double x, double y, double angle, double vx = 0, double vy = 0) {
  const std::int64_t body = discs.empty() ? 0 : discs.back().mol + 1;
  const double dx = 0.5 * std::cos(angle), dy = 0.5 * std::sin(angle);
  discs.push_back({static_cast<std::int64_t>(discs.size() + 1), body, 1, x - dx, y - dy, 0.5, kPi / 4, vx, vy, 0});
  discs.push_back({static_cast<std::int64_t>(discs.size() + 1), body, 1, x + dx, y + dy, 0.5, kPi / 4, vx, vy, 0});
}
// A lone disc of diameter 1.4 at (x, y) moving at (vx, vy).
void Disc(std::vector<rundir::Disc>& discs, double x, double y, double vx, double vy) {
  const std::int64_t body = discs.empty() ? 0 : discs.back().mol + 1;
  discs.push_back({static_cast<std::int64_t>(discs.size() + 1), body, 2, x, y, 0.7, 0.49 * kPi, vx, vy, 0});
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
  const std::vector<double> order = OrderParameters(sums, RegionDirectors(sums, o.regions));
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

// Regions of a test silo, far from the outlet (nothing else is measured there): "flow" resolves
// to the direction of the region's mean velocity; each fixed director as given.
OrientationOptions FlowRegions(int n) {
  OrientationOptions o;
  o.heights.clear();
  o.radii.clear();
  for (int i = 0; i < n; ++i) o.regions.push_back({"r" + std::to_string(i), 20.0 * i, 20.0 * i + 10, 0, 10, 0, true});
  return o;
}

// Bodies moving at 45 degrees with their axes along their motion: S = 1 against the flow,
// cos(2 x 45) = 0 against a horizontal director, and -1 for axes across the motion. Speeds
// differ, so the mean is not any one body's velocity.
TEST(Orientation, FlowDirectorOfBodiesMovingAlongAndAcrossTheirAxes) {
  std::vector<rundir::Disc> d;
  for (int k = 0; k < 4; ++k) {
    const double speed = 0.5 + k;
    Dumbbell(d, 2 + 2 * k, 3, kPi / 4, speed, speed);       // region 0: along the motion
    Dumbbell(d, 22 + 2 * k, 6, 3 * kPi / 4, speed, speed);  // region 1: across it
  }
  OrientationOptions o = FlowRegions(2);
  OrientationSums sums;
  AddOrientationFrame(d, BaseOutlet(), 50, o, sums);
  EXPECT_NEAR(FlowDirection(sums, 0), kPi / 4, 1e-12);
  EXPECT_NEAR(FlowDirection(sums, 1), kPi / 4, 1e-12);
  const std::vector<double> flow = RegionDirectors(sums, o.regions);
  const std::vector<double> s = OrderParameters(sums, flow);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_NEAR(s[0], 1.0, 1e-12);
  EXPECT_NEAR(s[1], -1.0, 1e-12);
  o.regions[0].flow_director = o.regions[1].flow_director = false;  // director 0, horizontal
  const std::vector<double> horizontal = OrderParameters(sums, RegionDirectors(sums, o.regions));
  EXPECT_NEAR(horizontal[0], 0.0, 1e-12);
  EXPECT_NEAR(horizontal[1], 0.0, 1e-12);
  // The sums give what S over the axes gives, at any director.
  for (double director : {0.0, 0.4, kPi / 4, 2.0})
    EXPECT_NEAR(OrderParameters(sums, {director, director})[0], OrderParameter({kPi / 4}, director), 1e-12);
}

// Nematic: the flow reversed points the director the other way, the same axis line, and gives
// the same S; the reported direction says which way it went.
TEST(Orientation, FlowDirectorIsNematic) {
  const double axes[] = {kPi / 3, kPi / 3, 0.0, kPi / 2, 1.0};  // S neither 1 nor 0 against the flow
  for (double sign : {1.0, -1.0}) {
    std::vector<rundir::Disc> d;
    for (int k = 0; k < 5; ++k) Dumbbell(d, 1 + 2 * k, 5, axes[k], sign * 0.3, sign * 0.3 * std::sqrt(3.0));
    const OrientationOptions o = FlowRegions(1);
    OrientationSums sums;
    AddOrientationFrame(d, BaseOutlet(), 50, o, sums);
    EXPECT_NEAR(FlowDirection(sums, 0), sign > 0 ? kPi / 3 : -2 * kPi / 3, 1e-12) << sign;
    const std::vector<double> expected_axes(std::begin(axes), std::end(axes));
    const double s = OrderParameters(sums, RegionDirectors(sums, o.regions))[0];
    EXPECT_NEAR(s, OrderParameter(expected_axes, kPi / 3), 1e-12) << sign;
    EXPECT_GT(std::fabs(s - OrderParameter(expected_axes, 0.0)), 0.1);  // the director matters here
  }
}

// The direction is of all bodies in the region, discs too: dumbbells moving along +x and a disc
// moving up make a mean flow at 45 degrees, along the dumbbells' axes.
TEST(Orientation, FlowDirectionCountsEveryBody) {
  std::vector<rundir::Disc> d;
  Dumbbell(d, 2, 2, kPi / 4, 1, 0);
  Dumbbell(d, 4, 2, kPi / 4, 1, 0);
  Disc(d, 6, 2, 0, 2);
  Disc(d, 6, 12, 5, -5);  // outside the region
  const OrientationOptions o = FlowRegions(1);
  OrientationSums sums;
  // Ten frames: three body-frames scatter too much to tell the mean from zero (3 se).
  for (int frame = 0; frame < 10; ++frame) AddOrientationFrame(d, BaseOutlet(), 50, o, sums);
  EXPECT_EQ(sums.flow_count, std::vector<double>{30});
  EXPECT_EQ(sums.region_count, std::vector<double>{20});
  EXPECT_NEAR(FlowDirection(sums, 0), kPi / 4, 1e-12);
  EXPECT_NEAR(OrderParameters(sums, RegionDirectors(sums, o.regions))[0], 1.0, 1e-12);
}

// No flow, no director: a region at rest, one whose velocities cancel (bodies moving both ways
// across frames), one whose mean is within 3 standard errors of zero, and one without bodies
// all give NaN; a slow steady creep still has its direction (straight down here), and sums of
// two runs add their velocities.
TEST(Orientation, NoFlowDirectionWithoutAMeanFlow) {
  const OrientationOptions o = FlowRegions(5);
  std::vector<rundir::Disc> d;
  for (int k = 0; k < 3; ++k) Dumbbell(d, 2 + 2 * k, 5, kPi / 2);  // region 0: at rest
  Dumbbell(d, 22, 5, kPi / 2, 0.8, 0.1);                           // region 1: this frame one way
  const double noise[] = {1.0, -1.0, 1.0, -0.9};                   // region 2: mean 0.025, se 0.49
  for (int k = 0; k < 4; ++k) Dumbbell(d, 42 + 2 * k, 5, kPi / 2, noise[k], 0);
  for (int k = 0; k < 3; ++k) Dumbbell(d, 62 + 2 * k, 5, 0.3 * k, 0, -1e-4);  // region 3: creeping down
  // region 4 (80..90): nobody
  std::vector<rundir::Disc> back = d;  // the next frame: region 1's body moving back
  back[6].vx = back[7].vx = -0.8;
  back[6].vy = back[7].vy = -0.1;
  OrientationSums sums;
  AddOrientationFrame(d, BaseOutlet(), 50, o, sums);
  EXPECT_NEAR(FlowDirection(sums, 1), std::atan2(0.1, 0.8), 1e-12);  // one frame: it has a direction
  AddOrientationFrame(back, BaseOutlet(), 50, o, sums);
  EXPECT_TRUE(std::isnan(FlowDirection(sums, 0)));
  EXPECT_TRUE(std::isnan(FlowDirection(sums, 1)));
  EXPECT_TRUE(std::isnan(FlowDirection(sums, 2)));
  EXPECT_NEAR(FlowDirection(sums, 3), -kPi / 2, 1e-12);
  EXPECT_TRUE(std::isnan(FlowDirection(sums, 4)));
  const std::vector<double> s = OrderParameters(sums, RegionDirectors(sums, o.regions));
  ASSERT_EQ(s.size(), 5u);
  EXPECT_TRUE(std::isnan(s[0]));
  EXPECT_TRUE(std::isnan(s[1]));
  EXPECT_TRUE(std::isnan(s[2]));
  EXPECT_TRUE(std::isfinite(s[3]));
  EXPECT_TRUE(std::isnan(s[4]));
  // Against a fixed director the bodies at rest still have their S (upright against vertical).
  EXPECT_NEAR(OrderParameters(sums, {kPi / 2})[0], 1.0, 1e-12);
  OrientationSums both = sums;
  both.Add(sums);
  EXPECT_EQ(both.flow_count[3], 2 * sums.flow_count[3]);
  EXPECT_NEAR(both.vy_sum[3], 2 * sums.vy_sum[3], 1e-18);
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
