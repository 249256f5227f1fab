// The clogging index analysis (eq. 3.1) over constructed campaigns whose run directories hold
// only a summary: the stagnant count N_u of a point where every run clogged comes from the
// discharged runs of its group, and runs that reached their time limit are left out of Psi.
#include "analysis/clogging_index_analysis.h"

#include <gtest/gtest.h>

#include <cmath>

#include "analysis/campaign_analysis.h"
#include "analysis/report_document.h"
#include "analysis/registry.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::TempDir;
using testing::WriteFile;

nlohmann::json SpecFor(double w) {
  return {{"engine", "native"},
          {"silo", {{"width", 100}, {"base_outlets", {{{"center", 0.0}, {"width", w}}}}}},
          {"bodies", {{"count", 2000}, {"density", 1.0}}},
          {"discharge", {{"mode", "remove"}, {"clog_window", 5.0}}}};
}

// Remove-mode runs of 1000 bodies at two widths in two silos: at silo 100 one run discharged
// (40 left) and two clogged at W = 4 (540 and 240 left); at silo 200 one discharged (80 left).
CampaignInfo TwoSiloInfo() {
  CampaignInfo info;
  info.name = "nu";
  info.axes = {"/silo/base_outlets/0/width", "/silo/width"};
  return info;
}
std::vector<RunRecord> TwoSiloRuns(const TempDir& dir) {
  std::vector<RunRecord> runs;
  auto add = [&](const std::string& id, double w, double silo, bool clogged, int left) {
    RunRecord r;
    r.run_id = id;
    r.point_id = "W" + FormatNumber(w) + "S" + FormatNumber(silo);
    r.state = "done";
    r.point = {{"/silo/base_outlets/0/width", w}, {"/silo/width", silo}};
    r.spec = SpecFor(w);
    r.spec["silo"]["width"] = silo;
    r.run_dir = dir.Path() / id;
    WriteFile(r.run_dir / "run.json", r.spec.dump());
    WriteFile(r.run_dir / "events.csv", "time,body,shape,mass,outlet\n");
    WriteFile(r.run_dir / "summary.json", nlohmann::json{{"bodies", 1000},
                                                         {"exited", 1000 - left},
                                                         {"remaining", left},
                                                         {"end_reason", clogged ? "clogged" : "discharged"},
                                                         {"t_end", 10.0}}
                                              .dump());
    runs.push_back(r);
  };
  add("free-100", 20, 100, false, 40);  // silo 100: N_u = 40
  add("free-200", 20, 200, false, 80);  // silo 200: N_u = 80
  add("narrow-100-a", 4, 100, true, 540);
  add("narrow-100-b", 4, 100, true, 240);
  return runs;
}

// The stagnant count N_u of a point where every run clogged comes from the freely
// discharging runs of its group (the same silo at other widths), else of the campaign.
TEST(ClogIndexAnalysis, StagnantCountOfAPointWhereEveryRunClogged) {
  TempDir dir;
  const CampaignInfo info = TwoSiloInfo();
  const std::vector<RunRecord> runs = TwoSiloRuns(dir);
  const AnalysisSetup setup = SetupAnalyses({{"report", {{"window", {{"min_exits_before_clog", 0}}}}}});
  const auto a = AnalyseCampaign(info, runs, setup);
  for (std::size_t p = 0; p < a->view.points.size(); ++p) {
    if (a->view.points[p].id != "W4S100") continue;
    const std::vector<PointMetric> m = a->AllPointMetrics(p);
    EXPECT_DOUBLE_EQ(FindMetric(m, "n_stagnant")->mean, 40.0);  // the group silo=100, not the campaign (60)
    EXPECT_NEAR(FindMetric(m, "psi")->mean, (500.0 / 960.0 + 200.0 / 960.0) / 2.0, 1e-14);
    EXPECT_EQ(FindMetric(m, "psi")->note,
              "used 2 clogged and 0 discharged runs; N_u from the 1 discharged run of L = 100");
  }
}

// Eq. 3.1 discards runs that clogged before /report/window/min_exits_before_clog exits, the
// threshold that also makes their clog a start-up clog with no steady flow: at 500 the run
// that clogged after 460 exits is left out, the one after 760 is used.
TEST(ClogIndexAnalysis, DiscardsByTheFlowWindowsStartUpClogThreshold) {
  TempDir dir;
  const CampaignInfo info = TwoSiloInfo();
  const std::vector<RunRecord> runs = TwoSiloRuns(dir);
  const AnalysisSetup setup = SetupAnalyses({{"report", {{"window", {{"min_exits_before_clog", 500}}}}}});
  const auto a = AnalyseCampaign(info, runs, setup);
  bool seen = false;
  for (std::size_t p = 0; p < a->view.points.size(); ++p) {
    if (a->view.points[p].id != "W4S100") continue;
    seen = true;
    const std::vector<PointMetric> m = a->AllPointMetrics(p);
    EXPECT_DOUBLE_EQ(FindMetric(m, "discarded_runs")->mean, 1.0);
    EXPECT_NEAR(FindMetric(m, "psi")->mean, 200.0 / 960.0, 1e-14);
    EXPECT_NE(FindMetric(m, "psi")->note.find("clogged before 500 exits"), std::string::npos)
        << FindMetric(m, "psi")->note;
  }
  EXPECT_TRUE(seen);
}

// 8000 dumbbells, remove mode, W = 11 and 13 with a time limit, W = 14 to full
// discharge (860 left in the stagnant zones). At W = 11 two runs clogged (7000, 7286 left)
// and one reached the limit flowing (6080 inside): Psi = 0.88 with N_u = 860, not the 6080 of
// the time-limited run. At W = 13 every run reached the limit: no Psi (not 0).
TEST(ClogIndexAnalysis, LeavesOutRunsThatReachedTheirTimeLimit) {
  TempDir dir;
  CampaignInfo info;
  info.name = "psi";
  info.axes = {"/silo/base_outlets/0/width"};
  std::vector<RunRecord> runs;
  auto add = [&](const std::string& id, double w, int replica, const std::string& end, int left, double t_end) {
    RunRecord r;
    r.run_id = id;
    r.point_id = "W" + FormatNumber(w);
    r.replica = replica;
    r.state = "done";
    r.point = {{"/silo/base_outlets/0/width", w}};
    r.spec = SpecFor(w);
    r.run_dir = dir.Path() / id;
    WriteFile(r.run_dir / "run.json", r.spec.dump());
    WriteFile(r.run_dir / "events.csv", "time,body,shape,mass,outlet\n");
    WriteFile(r.run_dir / "summary.json",
              nlohmann::json{
                  {"bodies", 8000}, {"exited", 8000 - left}, {"remaining", left}, {"end_reason", end}, {"t_end", t_end}}
                  .dump());
    runs.push_back(r);
  };
  add("w11-a", 11, 0, "clogged", 7000, 40.0);
  add("w11-b", 11, 1, "time_limit", 6080, 150.0);
  add("w11-c", 11, 2, "clogged", 7286, 30.0);
  add("w13-a", 13, 0, "time_limit", 6080, 150.0);
  add("w13-b", 13, 1, "time_limit", 6100, 150.0);
  add("w14-a", 14, 0, "discharged", 860, 900.0);
  const auto a = AnalyseCampaign(info, runs, SetupAnalyses({}));
  auto metric = [&](const std::string& point, const std::string& name) {
    for (std::size_t p = 0; p < a->view.points.size(); ++p)
      if (a->view.points[p].id == point) {
        const std::vector<PointMetric> all = a->AllPointMetrics(p);
        if (const PointMetric* m = FindMetric(all, name)) return *m;
      }
    return PointMetric{};
  };
  EXPECT_DOUBLE_EQ(metric("W11", "n_stagnant").mean, 860.0);
  EXPECT_NEAR(metric("W11", "psi").mean, 0.88, 1e-3);
  EXPECT_EQ(metric("W11", "psi").n, 2);
  EXPECT_EQ(metric("W11", "unfinished_runs").mean, 1.0);
  EXPECT_EQ(metric("W11", "psi").note,
            "used 2 clogged and 0 discharged runs; left out replica 1: neither clogged nor discharged (time limit); "
            "N_u from the 1 discharged run of the campaign");
  EXPECT_EQ(metric("W13", "psi").n, 0);
  EXPECT_TRUE(std::isnan(metric("W13", "psi").mean));
  EXPECT_DOUBLE_EQ(metric("W13", "psi_low").mean, 0.0);
  EXPECT_NEAR(metric("W13", "psi_high").mean, (5220.0 + 5240.0) / 2.0 / 7140.0, 1e-12);
  EXPECT_NEAR(metric("W14", "psi").mean, 0.0, 1e-15);
  EXPECT_EQ(metric("W14", "discharged_runs").mean, 1.0);
}

}  // namespace
}  // namespace granary::analysis
