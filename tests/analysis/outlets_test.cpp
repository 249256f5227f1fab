// Outlet geometry from the spec and outlet coordinates for lateral outlets.
#include "analysis/outlets.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace granary::analysis {
namespace {

const nlohmann::json kSpec = {
    {"silo",
     {{"width", 100},
      {"base_outlets", {{{"center", -20.0}, {"width", 8.0}}}},
      {"side_outlets",
       {{{"wall", "right"}, {"bottom", 3.5}, {"width", 25.0}}, {{"wall", "left"}, {"bottom", 0.0}, {"width", 10.0}}}}}},
    {"discharge", {{"mode", "reinject"}, {"clog_window", 3.0}}},
    {"bodies", {{"count", 10}}}};

TEST(Outlets, FromSpecInEventOrder) {
  const auto o = OutletsOf(kSpec);
  ASSERT_EQ(o.size(), 3u);
  EXPECT_TRUE(o[0].base);
  EXPECT_DOUBLE_EQ(o[0].center, -20.0);
  EXPECT_FALSE(o[1].base);
  EXPECT_DOUBLE_EQ(o[1].center, 16.0);  // bottom + W/2
  EXPECT_DOUBLE_EQ(o[1].wall_x, 50.0);
  EXPECT_EQ(o[1].label, "side 1 (right)");
  EXPECT_FALSE(o[2].right_wall);
  EXPECT_DOUBLE_EQ(o[2].wall_x, -50.0);
  const auto d = OutletsOf(nlohmann::json::object());  // run-spec defaults
  ASSERT_EQ(d.size(), 1u);
  EXPECT_DOUBLE_EQ(d[0].width, 10.0);
}

TEST(Outlets, OutletFrameOfLateralOutlets) {
  const auto o = OutletsOf(kSpec);
  rundir::Body b;
  b.x = 48;
  b.y = 20;
  b.vx = 2;  // leaving through the right wall
  b.vy = -1;
  b.omega = 0.5;
  std::vector<rundir::Disc> discs(1);
  discs[0].x = 48;
  discs[0].y = 20;
  std::vector<rundir::Body> bodies = {b};
  ToOutletFrame(o[1], discs, bodies);
  EXPECT_DOUBLE_EQ(bodies[0].x, 4.0);  // 20 - 16 along the outlet
  EXPECT_DOUBLE_EQ(bodies[0].y, 2.0);  // 2 from the wall
  EXPECT_DOUBLE_EQ(bodies[0].vx, -1.0);
  EXPECT_DOUBLE_EQ(bodies[0].vy, -2.0);  // outflow is v_y < 0 as at a base outlet
  EXPECT_DOUBLE_EQ(bodies[0].omega, 0.5);
  EXPECT_DOUBLE_EQ(discs[0].y, 2.0);
  // Left wall: mirror image.
  b.x = -48;
  b.vx = -2;
  bodies = {b};
  discs[0].x = -48;
  discs[0].y = 20;
  ToOutletFrame(o[2], discs, bodies);
  EXPECT_DOUBLE_EQ(bodies[0].x, 15.0);  // 20 - 5
  EXPECT_DOUBLE_EQ(bodies[0].y, 2.0);
  EXPECT_DOUBLE_EQ(bodies[0].vy, -2.0);
  EXPECT_DOUBLE_EQ(bodies[0].omega, -0.5);
  // Base outlet: shift only.
  b.x = -18;
  b.y = 1;
  bodies = {b};
  ToOutletFrame(o[0], discs, bodies);
  EXPECT_DOUBLE_EQ(bodies[0].x, 2.0);
  EXPECT_DOUBLE_EQ(bodies[0].y, 1.0);
}

}  // namespace
}  // namespace granary::analysis
