// The estimate's arithmetic on constructed specs with known answers (estimate.h); its
// accuracy against real runs is EstimateAccuracy in cli_test.cpp.
#include "runner/estimate.h"

#include <gtest/gtest.h>

#include <cmath>

#include "rundir/frames.h"

namespace granary::runner {
namespace {

using nlohmann::json;

PlannedRun Planned(const std::string& id, json params, const std::string& point = "p") {
  PlannedRun r;
  r.run_id = id;
  r.point_id = point;
  r.point = {{"/x", point}};
  r.engine = "native";
  r.params_json = RunSpec::FromJson(params).ToJson().dump();
  return r;
}

json Reinject(const json& species, int count, double max_time) {
  return {{"bodies", {{"count", count}, {"species", species}}},
          {"silo", {{"width", 30}}},
          {"discharge", {{"mode", "reinject"}, {"max_time", max_time}, {"stop_on_clog", false}}}};
}

Calibration Rates(double disc, double clump) {
  Calibration c;
  c.disc_rate = disc;
  c.clump_rate = clump;
  c.source = "test";
  return c;
}

TEST(Estimate, MakespanSendsEachRunToTheSlotThatFreesFirst) {
  EXPECT_DOUBLE_EQ(Makespan({4, 3, 2, 1}, 1), 10);
  EXPECT_DOUBLE_EQ(Makespan({4, 3, 2, 1}, 2), 5);  // 4 | 3 2 -> 4+1 = 5
  EXPECT_DOUBLE_EQ(Makespan({4, 3, 2, 1}, 8), 4);
  EXPECT_DOUBLE_EQ(Makespan({}, 3), 0);
}

TEST(Estimate, AReinjectRunWithoutClogStopIsDiscsTimesStepsAtTheRate) {
  const RunSpec spec = RunSpec::FromJson(Reinject(json::array({{{"shape", "dumbbell"}}}), 400, 2.0));
  const RunEstimate e = EstimateRun(spec, Rates(1e7, 5e6), false);
  EXPECT_FALSE(e.open_end);
  EXPECT_DOUBLE_EQ(e.discs, 800);
  EXPECT_DOUBLE_EQ(e.bed_disc_steps, 0);
  EXPECT_NEAR(e.disc_steps_high, 800 * 2.0 / 1e-4, 1e-6);
  EXPECT_NEAR(e.core_s_high, 800 * 20000 / 5e6 + EstimateModel{}.run_overhead_s, 1e-9);
  EXPECT_DOUBLE_EQ(e.core_s_low, e.core_s_high);
  // Preparing the bed adds to it.
  EXPECT_GT(EstimateRun(spec, Rates(1e7, 5e6), true).core_s_high, e.core_s_high);
}

TEST(Estimate, AMixturePaysEachKindForItsShareOfTheDiscs) {
  const json species = json::array(
      {{{"shape", "dumbbell"}, {"fraction", 0.5}}, {{"shape", "disc"}, {"diameter", 1.414214}, {"fraction", 0.5}}});
  const RunSpec spec = RunSpec::FromJson(Reinject(species, 400, 1.0));
  const RunEstimate e = EstimateRun(spec, Rates(2e7, 5e6), false);
  EXPECT_DOUBLE_EQ(e.discs, 600);  // 200 dumbbells, 200 discs
  const double steps = 1.0 / 1e-4;
  EXPECT_NEAR(e.core_s_high, steps * (200 / 2e7 + 400 / 5e6) + EstimateModel{}.run_overhead_s, 1e-9);
}

TEST(Estimate, ARemoveRunEndsSomewhereInARange) {
  json j = Reinject(json::array({{{"shape", "disc"}}}), 500, 400.0);
  j["discharge"] = {{"mode", "remove"}, {"max_time", 400.0}};
  const RunSpec spec = RunSpec::FromJson(j);
  const RunEstimate e = EstimateRun(spec, Rates(1e7, 1e7), false);
  EXPECT_TRUE(e.open_end);
  EXPECT_DOUBLE_EQ(e.sim_low, spec.discharge.clog_window);
  EXPECT_LT(e.sim_high, 400.0);  // W = 10 empties 500 discs long before
  EXPECT_LT(e.core_s_low, e.core_s_high);
  // Bodies leave at a constant rate until the silo is empty, then the stall is judged after
  // clog_window: half the discs on average over the emptying, none after it.
  const double emptying = e.sim_high - spec.discharge.clog_window;
  EXPECT_NEAR(e.disc_steps_high, 0.5 * e.discs * emptying / 1e-4, 1e-9 * e.disc_steps_high);
  // An outlet no body passes (W below k body sizes) can only clog: the silo stays full.
  j["silo"]["base_outlets"] = json::array({{{"width", 1.2}}});
  const RunEstimate closed = EstimateRun(RunSpec::FromJson(j), Rates(1e7, 1e7), false);
  EXPECT_DOUBLE_EQ(closed.sim_high, 400.0);
}

TEST(Estimate, FramesAreCountedByTheirOwnWriter) {
  json j = Reinject(json::array({{{"shape", "disc"}}}), 300, 2.0);
  j["output"] = {{"frame_interval", 0.5}, {"checkpoint_interval", 0}};
  const RunSpec spec = RunSpec::FromJson(j);
  const RunEstimate e = EstimateRun(spec, Rates(1e7, 1e7), false);
  // 5 frames of 300 discs; a disc row of this writer is 60 to 120 bytes.
  rundir::Frame empty;
  const double header = static_cast<double>(rundir::FrameBytes(empty, false));
  EXPECT_GT(e.frame_bytes, header + 300 * 60);
  EXPECT_LT(e.frame_bytes, header + 300 * 120);
  EXPECT_NEAR(e.bytes_high, 5 * e.frame_bytes + 16384, 1e-6 * e.bytes_high + 45 * 400);
  // Compressed frames are smaller, contact frames add to them.
  j["output"]["compress"] = true;
  EXPECT_LT(EstimateRun(RunSpec::FromJson(j), Rates(1e7, 1e7), false).frame_bytes, 0.6 * e.frame_bytes);
  j["output"]["compress"] = false;
  j["output"]["contact_forces"] = true;
  EXPECT_GT(EstimateRun(RunSpec::FromJson(j), Rates(1e7, 1e7), false).frame_bytes, 1.8 * e.frame_bytes);
}

TEST(Estimate, ACampaignPreparesEachBedOnceAndNotThoseInTheCache) {
  json a = Reinject(json::array({{{"shape", "disc"}}}), 300, 1.0);
  a["bed"] = {{"cache_file", "/beds/1.bed"}};
  json b = a;
  b["silo"]["base_outlets"] = json::array({{{"width", 7}}});  // same bed
  json c = a;
  c["seed"] = 2;
  c["bed"]["cache_file"] = "/beds/2.bed";
  const std::vector<PlannedRun> runs = {Planned("r1", a, "p1"), Planned("r2", b, "p2"), Planned("r3", c, "p1")};
  const CampaignEstimate e = EstimateCampaign(runs, Rates(1e7, 1e7), 1);
  EXPECT_EQ(e.beds, 2);
  EXPECT_GT(e.runs.at("r1").bed_disc_steps, 0);
  EXPECT_EQ(e.runs.at("r2").bed_disc_steps, 0);
  EXPECT_GT(e.runs.at("r3").bed_disc_steps, 0);
  ASSERT_EQ(e.points.size(), 2u);
  EXPECT_EQ(e.points[0].runs, 2);
  EXPECT_NEAR(e.core_s_high, e.runs.at("r1").core_s_high + e.runs.at("r2").core_s_high + e.runs.at("r3").core_s_high,
              1e-9);
  EXPECT_NEAR(e.wall_s_high, e.core_s_high, 1e-9);  // one job
  const CampaignEstimate cached = EstimateCampaign(runs, Rates(1e7, 1e7), 3, {"/beds/2.bed"});
  EXPECT_EQ(cached.runs.at("r3").bed_disc_steps, 0);
  EXPECT_NEAR(cached.wall_s_high, cached.runs.at("r1").core_s_high, 1e-9);  // three jobs: the longest run
  // Without a calibration, no time; the disk still.
  const CampaignEstimate unknown = EstimateCampaign(runs, Calibration{}, 1);
  EXPECT_EQ(unknown.core_s_high, 0);
  EXPECT_NE(unknown.method.find("time not estimated"), std::string::npos);
  EXPECT_TRUE(to_json(unknown)["core_hours"].is_null());
}

TEST(Estimate, FinishedRunsScaleTheRatesByWhatTheyTook) {
  const json spec = RunSpec::FromJson(Reinject(json::array({{{"shape", "disc"}}}), 300, 1.0)).ToJson();
  // 300 discs x 10000 steps at 1e7/s + the start of a run = 0.8 s predicted; they took 1.6 s.
  const double predicted = 0.3 + EstimateModel{}.run_overhead_s;
  const json summary = {
      {"t_end", 1.0}, {"bed", {{"prepared_here", false}}}, {"timing", {{"wall_s", 2 * predicted}, {"threads", 1}}}};
  Calibration cal = Rates(1e7, 1e7);
  ScaleFromFinished(cal, {{spec, summary}, {spec, summary}});
  EXPECT_NEAR(cal.scale, 2.0, 1e-9);
  EXPECT_EQ(cal.scaled_from_runs, 2);
  // No bench: the rates come from the runs themselves.
  Calibration none;
  json measured = summary;
  measured["timing"]["disc_steps_per_s"] = 6e6;
  measured["timing"]["discharge_wall_s"] = 0.5;
  ScaleFromFinished(none, {{spec, measured}});
  EXPECT_NEAR(none.disc_rate, 6e6, 1e-3);
  EXPECT_TRUE(none.Valid());
}

}  // namespace
}  // namespace granary::runner
