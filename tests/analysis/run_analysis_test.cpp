// One run's analyses: outlet geometry from the spec, outlet coordinates for lateral outlets,
// and analyse_run on a hand-written run directory with a side outlet.
#include "analysis/run_analysis.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::TempDir;
using testing::write_file;

const nlohmann::json kSpec = {
    {"silo",
     {{"width", 100},
      {"base_outlets", {{{"center", -20.0}, {"width", 8.0}}}},
      {"side_outlets", {{{"wall", "right"}, {"bottom", 3.5}, {"width", 25.0}}, {{"wall", "left"}, {"bottom", 0.0}, {"width", 10.0}}}}}},
    {"discharge", {{"mode", "reinject"}, {"clog_window", 3.0}}},
    {"bodies", {{"count", 10}}}};

TEST(Outlets, FromSpecInEventOrder) {
  const auto o = outlets_of(kSpec);
  ASSERT_EQ(o.size(), 3u);
  EXPECT_TRUE(o[0].base);
  EXPECT_DOUBLE_EQ(o[0].center, -20.0);
  EXPECT_FALSE(o[1].base);
  EXPECT_DOUBLE_EQ(o[1].center, 16.0);  // bottom + W/2
  EXPECT_DOUBLE_EQ(o[1].wall_x, 50.0);
  EXPECT_EQ(o[1].label, "side 1 (right)");
  EXPECT_FALSE(o[2].right_wall);
  EXPECT_DOUBLE_EQ(o[2].wall_x, -50.0);
  const auto d = outlets_of(nlohmann::json::object());  // run-spec defaults
  ASSERT_EQ(d.size(), 1u);
  EXPECT_DOUBLE_EQ(d[0].width, 10.0);
}

TEST(Outlets, OutletFrameOfLateralOutlets) {
  const auto o = outlets_of(kSpec);
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
  to_outlet_frame(o[1], discs, bodies);
  EXPECT_DOUBLE_EQ(bodies[0].x, 4.0);   // 20 - 16 along the outlet
  EXPECT_DOUBLE_EQ(bodies[0].y, 2.0);   // 2 from the wall
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
  to_outlet_frame(o[2], discs, bodies);
  EXPECT_DOUBLE_EQ(bodies[0].x, 15.0);  // 20 - 5
  EXPECT_DOUBLE_EQ(bodies[0].y, 2.0);
  EXPECT_DOUBLE_EQ(bodies[0].vy, -2.0);
  EXPECT_DOUBLE_EQ(bodies[0].omega, -0.5);
  // Base outlet: shift only.
  b.x = -18;
  b.y = 1;
  bodies = {b};
  to_outlet_frame(o[0], discs, bodies);
  EXPECT_DOUBLE_EQ(bodies[0].x, 2.0);
  EXPECT_DOUBLE_EQ(bodies[0].y, 1.0);
}

TEST(AnalyseRun, RegionBesideASideOutlet) {
  TempDir dir;
  write_file(dir.path() / "run.json", kSpec.dump());
  write_file(dir.path() / "summary.json", R"({"engine":"native","bodies":10,"exited":0,"remaining":10,"t_end":10})");
  write_file(dir.path() / "events.csv", "time,body,shape,mass,outlet\n");
  // One disc (r = 1) against the right wall next to the side outlet, one next to the base
  // outlet, moving out of each.
  write_file(dir.path() / "frames.dump",
             "ITEM: TIMESTEP\n30000\nITEM: TIME\n3.0\nITEM: NUMBER OF ATOMS\n2\n"
             "ITEM: ATOMS id mol x y radius vx vy omegaz\n"
             "1 0 48.5 16 1 3 0 0\n"
             "2 1 -20 1.5 1 0 -4 0\n");
  const RunAnalysis a = analyse_run(dir.path(), AnalysisOptions());
  ASSERT_TRUE(a.has_region);
  ASSERT_EQ(a.region_per_outlet.size(), 3u);
  // ch. 4 region of W = 25 beside the right wall: (25 + 2 sqrt2) x 5 sqrt2, holds the whole disc.
  const double area_side = (25.0 + 2.0 * std::numbers::sqrt2) * 5.0 * std::numbers::sqrt2;
  EXPECT_NEAR(a.region_per_outlet[1].phi.mean, std::numbers::pi / area_side, 1e-12);
  const double area_base = (8.0 + 2.0 * std::numbers::sqrt2) * 5.0 * std::numbers::sqrt2;
  EXPECT_NEAR(a.region.phi.mean, std::numbers::pi / area_base, 1e-12);
  EXPECT_NEAR(a.region_per_outlet[2].phi.mean, 0.0, 1e-15);
  EXPECT_DOUBLE_EQ(a.profile_per_outlet[1].v_max, 3.0);  // |v_n| of the disc leaving sideways
  EXPECT_DOUBLE_EQ(a.profile.v_max, 4.0);
  EXPECT_FALSE(a.flow.ok);
  EXPECT_FALSE(a.remove_mode);
  EXPECT_DOUBLE_EQ(a.clog_gap, 3.0);
}

TEST(AnalyseRun, WithoutAFlowWindowFramesStopAtTheFirstClog) {
  // 5 exits (too few for a flow rate), then a clog from t = 2.5 on; frames at t = 2.2
  // (flowing) and t = 15 (clogged): only the first may enter the region statistics.
  TempDir dir;
  write_file(dir.path() / "run.json", kSpec.dump());
  write_file(dir.path() / "summary.json", R"({"bodies":10,"exited":5,"remaining":10,"t_end":20,"end_reason":"time_limit","clogs":1})");
  write_file(dir.path() / "events.csv",
             "time,body,shape,mass,outlet\n2.1,0,disc,1,0\n2.2,1,disc,1,0\n2.3,2,disc,1,0\n2.4,3,disc,1,0\n2.5,4,disc,1,0\n");
  std::string frames;
  for (double t : {2.2, 15.0})
    frames += "ITEM: TIMESTEP\n1\nITEM: TIME\n" + std::to_string(t) +
              "\nITEM: NUMBER OF ATOMS\n1\nITEM: ATOMS id mol x y radius vx vy omegaz\n1 0 -20 1 0.5 0 -1 0\n";
  write_file(dir.path() / "frames.dump", frames);
  AnalysisOptions opt;
  opt.window.start_time = 1.0;
  const RunAnalysis a = analyse_run(dir.path(), opt);
  EXPECT_FALSE(a.flow.ok);
  ASSERT_TRUE(a.has_region);
  EXPECT_EQ(a.region.frames, 1);
  EXPECT_EQ(a.engine_clogs, 1);
  EXPECT_EQ(a.series.clogged.size(), 1u);
}

TEST(AnalyseRun, SummaryAndEventsDisagree) {
  TempDir dir;
  write_file(dir.path() / "summary.json", R"({"bodies":10,"exited":5,"remaining":5,"t_end":3,"end_reason":"time_limit"})");
  write_file(dir.path() / "events.csv", "time,body,shape,mass,outlet\n1,0,disc,1,0\n2,1,disc,1,0\n2.5,2,disc,1,0\n");
  const RunAnalysis a = analyse_run(dir.path(), AnalysisOptions());
  bool found = false;
  for (const auto& n : a.notes) found = found || n == "events.csv has 3 exits but summary.json says 5";
  EXPECT_TRUE(found);
  EXPECT_EQ(a.cumulative_n, (std::vector<double>{1, 2, 3}));
  EXPECT_TRUE(a.remove_mode);  // run-spec default without run.json
  EXPECT_EQ(a.engine_clogs, -1);  // the summary has no "clogs"
}

}  // namespace
}  // namespace granary::analysis
