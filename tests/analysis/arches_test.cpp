// Arches found on constructed clogged configurations with known answers (arches.h): a half
// circle of discs, an arch of dumbbells, arches from the base to an obstacle, a dead-end
// branch, an arch over a side outlet; eq. 6.1's pressure and the contact types on hand-made
// contacts.
#include "analysis/arches.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "analysis/orientation.h"
#include "clog_builder.h"

namespace granary::analysis {
namespace {

constexpr double kPi = std::numbers::pi;
using testing::Clog;

nlohmann::json BaseOutlet(double width) { return {{"base_outlets", {{{"center", 0.0}, {"width", width}}}}}; }
nlohmann::json WithObstacle(nlohmann::json silo, double x, double y, double diameter) {
  silo["obstacles"] = {{{"x", x}, {"y", y}, {"diameter", diameter}}};
  return silo;
}

// Discs 0..n-1 touching along a half circle of radius 0.5 / sin(pi / (2 (n - 1))) centred on the
// outlet at height 0.5, from the base left of the gap (angle pi) to the base right of it (0).
double HalfCircle(Clog& c, int n) {
  const double radius = 0.5 / std::sin(kPi / (2 * (n - 1)));
  for (int k = 0; k < n; ++k) {
    const double a = kPi * (n - 1 - k) / (n - 1);
    c.Disc(radius * std::cos(a), 0.5 + radius * std::sin(a));
  }
  return radius;
}

std::vector<std::int64_t> Ids(const Arch& a) {
  std::vector<std::int64_t> ids;
  for (const ArchBody& b : a.bodies) ids.push_back(b.id);
  return ids;
}

TEST(Arches, AHalfCircleOfDiscsOverTheOutletIsItsArch) {
  Clog c(BaseOutlet(4));
  const double radius = HalfCircle(c, 8);
  c.Row(-5.5, 5.5, 0.5 + radius + 1.2);  // the bed above, not touching the arch
  const ClogArches clog = AnalyseClog(c.Made(), c.Spec());
  ASSERT_EQ(clog.arches.size(), 1u);
  EXPECT_EQ(clog.sealed_outlets, std::vector<int>{0});
  const Arch& a = clog.arches[0];
  EXPECT_EQ(Ids(a), (std::vector<std::int64_t>{0, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(a.n, 8);
  EXPECT_FALSE(a.obstacle);
  EXPECT_EQ(a.gaps, 0);
  EXPECT_TRUE(a.supported);
  EXPECT_TRUE(a.dead_ends.empty());
  EXPECT_NEAR(a.width, 2 * radius, 1e-9);
  EXPECT_NEAR(a.height, radius * std::sin(3 * kPi / 7), 1e-9);  // the highest pair of centres
  EXPECT_NEAR(a.perimeter, 7.0, 1e-9);
  // The circle through the ends and the highest body is the half circle itself.
  EXPECT_NEAR(a.arc, kPi * radius, 1e-9);
  EXPECT_NEAR(a.c_over_p, kPi * radius / 7, 1e-9);
  EXPECT_DOUBLE_EQ(a.elongated_fraction, 0.0);
  EXPECT_EQ(a.per_type, std::vector<int>{8});
  EXPECT_EQ(a.concave, 0);
  EXPECT_NEAR(a.max_angle, kPi - kPi / 7, 1e-9);  // every inner angle of a regular half polygon
  // Angular positions run from pi (left) to 0 (right).
  EXPECT_NEAR(a.bodies.front().theta, kPi - std::atan(0.5 / radius), 1e-9);
  EXPECT_NEAR(a.bodies.back().theta, std::atan(0.5 / radius), 1e-9);
}

// Four dumbbells: a leg standing on the base at each side of the gap, two lying across the top.
TEST(Arches, AnArchOfDumbbells) {
  Clog c(BaseOutlet(4));
  const double top = 1.936;  // the lying dumbbells touch the legs' upper discs
  const auto a = c.Dumbbell(-2.4, 0.5, -2.4, 1.5), b = c.Dumbbell(-1.5, top, -0.5, top);
  const auto d = c.Dumbbell(0.5, top, 1.5, top), e = c.Dumbbell(2.4, 1.5, 2.4, 0.5);
  c.Disc(-4.5, 0.5);  // a disc on the floor beside the arch: not part of it
  c.Row(-5.5, 5.5, 3.6);
  const ClogArches clog = AnalyseClog(c.Made(), c.Spec());
  ASSERT_EQ(clog.arches.size(), 1u);
  const Arch& arch = clog.arches[0];
  EXPECT_EQ(Ids(arch), (std::vector<std::int64_t>{a, b, d, e}));
  EXPECT_EQ(arch.gaps, 0);
  EXPECT_TRUE(arch.supported);
  EXPECT_DOUBLE_EQ(arch.elongated_fraction, 1.0);
  EXPECT_NEAR(arch.width, 4.8, 1e-9);
  EXPECT_NEAR(arch.height, top - 1.0, 1e-9);
  EXPECT_NEAR(arch.perimeter, 2 * std::hypot(1.4, top - 1.0) + 2.0, 1e-9);
  EXPECT_NEAR(arch.bodies[0].axis, kPi / 2, 1e-9);
  EXPECT_NEAR(arch.bodies[1].axis, 0, 1e-9);
  EXPECT_NEAR(arch.bodies[3].axis, kPi / 2, 1e-9);
  EXPECT_EQ(arch.concave, 0);
}

// Fig. 3.4's first type: from the base to an obstacle over the outlet and on to the base.
TEST(Arches, ArchesFromTheBaseToAnObstacleAreOneObstacleArch) {
  Clog c(WithObstacle(BaseOutlet(3), 0.0, 2.0, 2.0));
  // A disc touching the obstacle at 225 degrees, and one under it on the base, beyond the edge.
  const double px = -1.5 / std::sqrt(2.0), py = 2.0 - 1.5 / std::sqrt(2.0);
  const double fx = px - std::sqrt(1 - (py - 0.5) * (py - 0.5));
  const auto l0 = c.Disc(fx, 0.5), l1 = c.Disc(px, py), r1 = c.Disc(-px, py), r0 = c.Disc(-fx, 0.5);
  c.Row(-5.5, 5.5, 3.6);
  const ClogArches clog = AnalyseClog(c.Made(), c.Spec());
  ASSERT_EQ(clog.arches.size(), 1u);
  const Arch& arch = clog.arches[0];
  EXPECT_EQ(Ids(arch), (std::vector<std::int64_t>{l0, l1, r1, r0}));
  EXPECT_TRUE(arch.obstacle);
  EXPECT_EQ(arch.obstacles, std::vector<int>{0});
  EXPECT_EQ(arch.gaps, 0) << "the bodies either side of the obstacle touch it";
  EXPECT_NEAR(arch.width, -2 * fx, 1e-9);
  EXPECT_NEAR(arch.height, py - 0.5, 1e-9);

  // Without the obstacle's right arch the outlet is open: no arch.
  Clog open(WithObstacle(BaseOutlet(3), 0.0, 2.0, 2.0));
  open.Disc(fx, 0.5);
  open.Disc(px, py);
  EXPECT_TRUE(AnalyseClog(open.Made(), open.Spec()).arches.empty());
}

// A disc hanging under the arch from one arch disc, and a second hanging from it: a dead-end
// branch, a defect, not part of the arch; the arch and its metrics stay as without it.
TEST(Arches, ADeadEndBranchIsADefectOutsideTheArch) {
  Clog c(BaseOutlet(4));
  const double radius = HalfCircle(c, 8);
  c.Row(-5.5, 5.5, 0.5 + radius + 1.2);
  const ClogArches plain = AnalyseClog(c.Made(), c.Spec());
  // Straight down from the highest left disc (3) by one diameter, then one more.
  const double a = kPi * 4 / 7, x = radius * std::cos(a), y = 0.5 + radius * std::sin(a);
  const auto hang = c.Disc(x, y - 1.0), deeper = c.Disc(x, y - 2.0);
  const ClogArches clog = AnalyseClog(c.Made(), c.Spec());
  ASSERT_EQ(clog.arches.size(), 1u);
  const Arch& arch = clog.arches[0];
  EXPECT_EQ(Ids(arch), (std::vector<std::int64_t>{0, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(arch.dead_ends, (std::vector<std::int64_t>{hang, deeper}));
  EXPECT_DOUBLE_EQ(arch.perimeter, plain.arches[0].perimeter);
  EXPECT_DOUBLE_EQ(arch.c_over_p, plain.arches[0].c_over_p);
}

// A concavity (Garcimartin et al.'s defect): touching discs going up at 50 degrees, down at 20,
// up at 20 and down at 50; the angle at the dip, seen from the outlet, is 220 degrees.
TEST(Arches, ADipInTheArchIsAConcaveAngle) {
  Clog c(BaseOutlet(2));
  double x = -2.0, y = 0.5;
  const auto first = c.Disc(x, y);
  for (double degrees : {50.0, -20.0, 20.0, -50.0}) {
    x += std::cos(degrees * kPi / 180);
    y += std::sin(degrees * kPi / 180);
    c.Disc(x, y);
  }
  c.Row(-5.5, 5.5, 2.8);
  const ClogArches clog = AnalyseClog(c.Made(), c.Spec());
  ASSERT_EQ(clog.arches.size(), 1u);
  const Arch& arch = clog.arches[0];
  EXPECT_EQ(Ids(arch), (std::vector<std::int64_t>{first, first + 1, first + 2, first + 3, first + 4}));
  EXPECT_EQ(arch.concave, 1);
  EXPECT_NEAR(arch.max_angle, 220 * kPi / 180, 1e-9);
  EXPECT_EQ(arch.gaps, 0);
  EXPECT_TRUE(arch.supported);
}

// A half circle of discs in the silo in front of an outlet in the right wall, from the wall below
// it to the wall above it: the same arch as over a base outlet, in the outlet's frame.
TEST(Arches, AnArchOverASideOutlet) {
  Clog c({{"base_outlets", nlohmann::json::array()},
          {"side_outlets", {{{"wall", "right"}, {"bottom", 2.0}, {"width", 3.0}}}}});
  const double radius = 0.5 / std::sin(kPi / 14);
  for (int k = 0; k < 8; ++k) {
    const double a = -kPi / 2 + kPi * k / 7;
    c.Disc(5.5 - radius * std::cos(a), 3.5 + radius * std::sin(a));
  }
  const ClogArches clog = AnalyseClog(c.Made(), c.Spec());
  ASSERT_EQ(clog.arches.size(), 1u);
  const Arch& arch = clog.arches[0];
  EXPECT_EQ(Ids(arch), (std::vector<std::int64_t>{0, 1, 2, 3, 4, 5, 6, 7}));  // from below to above
  EXPECT_NEAR(arch.width, 2 * radius, 1e-9);
  EXPECT_NEAR(arch.height, radius * std::sin(3 * kPi / 7), 1e-9);
  EXPECT_NEAR(arch.c_over_p, kPi * radius / 7, 1e-9);
}

// Eq. 6.1: a disc squeezed from both sides along x by forces F has P = 2 F / (4 A); the pressure
// of a body is its discs' virial over its area.
TEST(Arches, PressureIsTheVirialOfEquationSixOneOverTheArea) {
  rundir::Frame f;
  f.discs = {{1, 0, 1, 0, 0, 0.5, 0, 0, 0, 0}, {2, 1, 1, -1, 0, 0.5, 0, 0, 0, 0}, {3, 2, 1, 1, 0, 0.5, 0, 0, 0, 0},
             {4, 3, 1, 0, 5, 0.5, 0, 0, 0, 0}, {5, 3, 1, 1, 5, 0.5, 0, 0, 0, 0},  {6, 4, 1, 2, 5, 0.5, 0, 0, 0, 0}};
  rundir::ContactFrame c;
  const double force = 3.0;
  // Body 0 pushed by 1 (left) and 2 (right); the dumbbell 3 (discs at 0 and 1) pushed at its
  // right disc by disc 4; a wall contact that eq. 6.1 leaves out.
  c.contacts = {{0, 1, 0, 0, -1, 0, -0.5, 0, force, 0},
                {2, 0, 1, 0, 0, 0, 0.5, 0, force, 0},
                {3, 4, 1, 5, 2, 5, 1.5, 5, -force, 0},
                {0, -1, 0, 0, 0, -0.5, 0, -0.5, 0, 7.0}};
  const std::vector<double> p = BodyPressures(f, c);
  ASSERT_EQ(p.size(), 5u);
  EXPECT_NEAR(p[0], 2 * force / (4 * kPi / 4), 1e-12);
  EXPECT_NEAR(p[1], force / (4 * kPi / 4), 1e-12);
  EXPECT_NEAR(p[3], force / (4 * 2 * kPi / 4), 1e-12);
  EXPECT_NEAR(p[4], force / (4 * kPi / 4), 1e-12);
  // Pulled apart (tension) is negative.
  c.contacts = {{0, 1, 0, 0, -1, 0, -0.5, 0, -force, 0}};
  EXPECT_LT(BodyPressures(f, c)[0], 0);
}

// Fig. 6.8's contact types between snowmen (small disc 0.5, big 0.75): small-small, large-small
// and large-large by the discs that touch; a disc alone makes `other`.
TEST(Arches, ContactTypesBySizeOfTheTouchingDiscs) {
  rundir::Frame f;
  // Snowmen 0..2 (small at x, big at x + 1.25), a lone disc 3.
  f.discs = {{1, 0, 1, 0, 0, 0.5, 0, 0, 0, 0},     {2, 0, 1, 1.25, 0, 0.75, 0, 0, 0, 0},
             {3, 1, 1, 0, 1, 0.5, 0, 0, 0, 0},     {4, 1, 1, 1.25, 1.5, 0.75, 0, 0, 0, 0},
             {5, 2, 1, 2.75, 0, 0.75, 0, 0, 0, 0}, {6, 2, 1, 4, 0, 0.5, 0, 0, 0, 0},
             {7, 3, 2, 4, 1, 0.5, 0, 0, 0, 0}};
  rundir::ContactFrame c;
  c.contacts = {{0, 1, 0, 0, 0, 1, 0, 0.5, 0, -1},              // small - small
                {0, 1, 1.25, 0, 1.25, 1.5, 1.25, 0.75, 0, -1},  // large - large
                {1, 2, 1.25, 1.5, 2.75, 0, 2, 0.75, -1, 1},     // large - large
                {2, 0, 2.75, 0, 0, 0, 2, 0, 1, 0},              // large (2) - small (0): disc nearest (0, 0) of body 0
                {2, 3, 4, 0, 4, 1, 4, 0.5, 0, -1},              // a lone disc
                {0, -1, 0, 0, 0, -0.5, 0, -0.5, 0, 1}};         // a wall: not a contact between discs
  const ContactTypes t = CountContactTypes(f, c);
  EXPECT_EQ(t.small_small, 1);
  EXPECT_EQ(t.large_large, 2);
  EXPECT_EQ(t.large_small, 1);
  EXPECT_EQ(t.other, 1);
  EXPECT_EQ(t.Total(), 5);
}

// Pooled over clogs: means over arches (n = arches), table 3.1's standard deviations, pressure
// and axis mode per angular position, pressure per N_t, contact fractions per clog; and the
// per-run JSON keeps everything.
TEST(Arches, ArchesPooledOverClogs) {
  auto body = [](double theta, double axis, double pressure) {
    ArchBody b;
    b.theta = theta;
    b.axis = axis;
    b.pressure = pressure;
    b.discs = 2;
    return b;
  };
  auto arch = [&](int n, double w, double h, double p, std::vector<ArchBody> bodies, bool obstacle = false) {
    Arch a;
    a.n = n;
    a.width = w;
    a.height = h;
    a.perimeter = p;
    a.c_over_p = 1.0;
    a.elongated_fraction = 1.0;
    a.bodies = std::move(bodies);
    double sum = 0;
    for (const ArchBody& b : a.bodies) sum += b.pressure;
    a.mean_pressure = sum / static_cast<double>(a.bodies.size());
    a.obstacle = obstacle;
    return a;
  };
  ClogArches one, two;
  one.sealed_outlets = {0};
  one.arches = {arch(3, 10, 6, 12, {body(0.1, 0.1, 1.0), body(1.6, 1.5, 3.0), body(3.0, 3.0, 5.0)})};
  one.contact_types = {1, 2, 1, 0};
  two.sealed_outlets = {0};
  two.arches = {
      arch(5, 12, 8, 16,
           {body(0.2, 0.15, 2.0), body(1.5, 1.55, 4.0), body(1.7, 1.6, 6.0), body(2.9, 2.9, 2.0), body(3.1, 3.0, 1.0)},
           true)};
  two.contact_types = {2, 2, 0, 0};
  const ArchSummary s = SummarizeArches({&one, &two}, {3, 6, true});
  EXPECT_EQ(s.clogs, 2);
  EXPECT_EQ(s.arches, 2);
  EXPECT_EQ(s.obstacle_arches, 1);
  EXPECT_EQ(s.particle_arches, 1);
  EXPECT_DOUBLE_EQ(s.n.mean, 4.0);
  EXPECT_EQ(s.n.n, 2);
  EXPECT_DOUBLE_EQ(s.width.mean, 11.0);
  EXPECT_NEAR(s.width_sd, std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(s.height_sd, std::sqrt(2.0), 1e-12);
  EXPECT_DOUBLE_EQ(s.perimeter.mean, 14.0);
  ASSERT_EQ(s.theta.size(), 3u);
  EXPECT_NEAR(s.theta[0].pressure.mean, 1.5, 1e-12);  // 1 and 2 at theta < pi/3
  EXPECT_NEAR(s.theta[1].pressure.mean, 13.0 / 3, 1e-12);
  EXPECT_NEAR(s.theta[2].pressure.mean, 8.0 / 3, 1e-12);
  // Axes in bins of pi/6: the middle third's axes (1.5, 1.55, 1.6) all fall in [pi/3, pi/2).
  EXPECT_NEAR(s.theta[1].axis_mode, 2.5 * kPi / 6, 1e-12);
  EXPECT_EQ(s.theta[1].elongated, 3);
  ASSERT_EQ(s.pressure_by_n.size(), 2u);
  EXPECT_EQ(s.pressure_by_n[0].n, 3);
  EXPECT_NEAR(s.pressure_by_n[0].pressure.mean, 3.0, 1e-12);
  EXPECT_NEAR(s.small_small.mean, (0.25 + 0.5) / 2, 1e-12);
  EXPECT_NEAR(s.large_large.mean, 0.125, 1e-12);
  // Only particle arches.
  EXPECT_EQ(SummarizeArches({&one, &two}, {3, 6, false}).n.n, 1);

  const ClogArches back = ClogArchesFromJson(to_json(two));
  ASSERT_EQ(back.arches.size(), 1u);
  EXPECT_EQ(to_json(back), to_json(two));
  EXPECT_TRUE(back.arches[0].obstacle);
  EXPECT_DOUBLE_EQ(back.arches[0].bodies[2].pressure, 6.0);
}

}  // namespace
}  // namespace granary::analysis
