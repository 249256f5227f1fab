// The profile analysis over a constructed run directory, through the pass: two frames of discs
// (at t = 2 and 3, inside the steady window, which starts at /report/window/start_time = 2
// when the run has no flow window) above a base outlet of width 10 at x = 0, binned in two
// halves of x/W. In the band (0 <= y
// <= 2) and inside the outlet: one disc per half, falling at 1 then 2 (left) and at 3 (right);
// a disc above the band and one beside the outlet fall at 10 and must not count. So v_y is
// -1.5 and -3 per half, normalised -0.5 and -1, and V_max = 3.
#include "analysis/profile_analysis.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "analysis/run_pass.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::TempDir;
using testing::WriteFile;

std::string FrameText(int k, double left_vy) {
  const std::string t = std::to_string(k);
  return "ITEM: TIMESTEP\n" + t + "0000\nITEM: TIME\n" + t +
         ".0\nITEM: NUMBER OF ATOMS\n4\n"
         "ITEM: ATOMS id mol x y radius vx vy omegaz\n"
         "1 0 -2.5 1 0.5 0 " +
         std::to_string(left_vy) +
         " 0\n"
         "2 1 2.5 1 0.5 0.5 -3 0\n"
         "3 2 2.5 5 0.5 0 -10 0\n"
         "4 3 7 1 0.5 0 -10 0\n";
}

TEST(ProfileAnalysis, BodyVelocitiesAcrossTheOutletInTheBandOverTheFrames) {
  TempDir dir;
  WriteFile(dir.Path() / "run.json",
            nlohmann::json{{"silo", {{"width", 40}, {"base_outlets", {{{"center", 0.0}, {"width", 10.0}}}}}},
                           {"bodies", {{"count", 4}}}}
                .dump());
  WriteFile(dir.Path() / "summary.json", R"({"engine":"native","bodies":4,"exited":0,"remaining":4,"t_end":4})");
  WriteFile(dir.Path() / "events.csv", "time,body,shape,mass,outlet\n");
  WriteFile(dir.Path() / "frames.dump", FrameText(2, -1.0) + FrameText(3, -2.0));
  const auto analysis = MakeProfileAnalysis({{"bins", 2}}, "/report/profile");
  RunPassOptions no_cache;
  no_cache.read_cache = no_cache.write_cache = false;
  const RunPassResult pass = AnalyseRun(dir.Path(), {analysis.get()}, PassOptions{}, no_cache);
  const nlohmann::json& r = pass.results.at(0);
  ASSERT_TRUE(r.contains("profiles")) << r.dump();
  const nlohmann::json& p = r.at("profiles").at(0);
  EXPECT_EQ(r.at("frames"), 2);
  EXPECT_EQ(p.at("x_over_w"), (nlohmann::json{-0.25, 0.25}));
  EXPECT_EQ(p.at("samples"), (nlohmann::json{2.0, 2.0}));
  EXPECT_DOUBLE_EQ(p.at("vy")[0].get<double>(), -1.5);
  EXPECT_DOUBLE_EQ(p.at("vy")[1].get<double>(), -3.0);
  EXPECT_DOUBLE_EQ(p.at("vy_norm")[0].get<double>(), -0.5);
  EXPECT_DOUBLE_EQ(p.at("vx")[1].get<double>(), 0.5);
  const std::vector<Metric> m = analysis->RunMetrics(r);
  ASSERT_NE(FindMetric(m, "v_max"), nullptr);
  EXPECT_DOUBLE_EQ(FindMetric(m, "v_max")->value, 3.0);
}

TEST(ProfileAnalysis, OptionsAreCheckedAtTheirPath) {
  try {
    MakeProfileAnalysis({{"bins", 0}}, "/report/profile");
    ADD_FAILURE() << "no error";
  } catch (const std::exception& e) {
    EXPECT_EQ(std::string(e.what()), "/report/profile/bins: must be in [1, 1e+06] (got 0)");
  }
  EXPECT_EQ(MakeProfileAnalysis({{"bins", 8}}, "/report/profile")->RunOptions()["bins"], 8);
}

}  // namespace
}  // namespace granary::analysis
