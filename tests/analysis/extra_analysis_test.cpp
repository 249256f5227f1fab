// An analysis registered inside this test alone — no other file knows it — appears in the
// report (its section, its headline metric in the per-run table), in the export at both
// levels and in the engine comparison, and its options come from /report/<its key>.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "analysis/engine_comparison.h"
#include "analysis/export.h"
#include "analysis/options.h"
#include "analysis/registry.h"
#include "analysis/report.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::ReadFile;
using testing::TempDir;
using testing::WriteFile;

// Exits per unit time over the whole run, scaled by /report/exit_rate/scale.
class ExitRate : public Analysis {
 public:
  explicit ExitRate(double scale) : scale_(scale) {}
  std::string Key() const override { return "exit_rate"; }
  int Version() const override { return 1; }
  nlohmann::json RunOptions() const override { return {{"scale", scale_}}; }
  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    class Acc : public RunAccumulator {
     public:
      explicit Acc(double rate) : rate_(rate) {}
      nlohmann::json Finish() override { return {{"rate", rate_}}; }

     private:
      double rate_;
    };
    return std::make_unique<Acc>(scale_ * static_cast<double>(run.data->events.size()) / run.t_end);
  }
  std::vector<Metric> RunMetrics(const nlohmann::json& r) const override {
    return {{"exit_rate", "1/sqrt(d/g)", r.at("rate").get<double>(), kNaN, "exits per unit time", true}};
  }
  std::optional<Section> BuildSection(const SectionInput& in) const override {
    Table t{"exit_rate", "Exit rate per point", {"point", "rate"}, {}, {"point", "exit_rate"}};
    for (std::size_t p = 0; p < in.view.points.size(); ++p) {
      const PointMetric* m = FindMetric(in.points[p], "exit_rate");
      t.rows.push_back({PointName(in.view, in.view.points[p]), Cell::Estimate(m ? m->Estimate() : MeanSe{})});
    }
    return Section{"exit-rate", "Exit rate (registered by a test)", {t}};
  }

 private:
  double scale_;
};

std::unique_ptr<Analysis> MakeExitRate(const nlohmann::json& options, const std::string& path) {
  double scale = 1.0;
  if (!options.is_null()) {
    OptionObject(options, path, {"scale"});
    scale = OptionNumber(options.at("scale"), path + "/scale", 0.0, 1e9);
  }
  return std::make_unique<ExitRate>(scale);
}

// A run of n exits at rate q on `engine`, ending at n / q.
RunRecord MakeRunRecord(const std::filesystem::path& root, const std::string& engine, double w, int replica, double q,
                        int n) {
  RunRecord r;
  r.engine = engine;
  r.point_id = engine + FormatNumber(w);
  r.run_id = r.point_id + "r" + std::to_string(replica);
  r.replica = replica;
  r.state = "done";
  r.point = {{"/silo/base_outlets/0/width", w}};
  r.spec = {{"engine", engine},
            {"silo", {{"width", 60}, {"base_outlets", {{{"center", 0.0}, {"width", w}}}}}},
            {"bodies", {{"count", 500}}},
            {"discharge", {{"mode", "reinject"}, {"stop_on_clog", false}}}};
  r.run_dir = root / r.run_id;
  std::ostringstream ev;
  ev.precision(17);
  ev << "time,body,shape,mass,outlet\n";
  for (int i = 1; i <= n; ++i) ev << (i / q) << "," << i << ",disc,1.0,0\n";
  WriteFile(r.run_dir / "events.csv", ev.str());
  WriteFile(r.run_dir / "summary.json", nlohmann::json{{"engine", engine},
                                                       {"end_reason", "time_limit"},
                                                       {"bodies", 500},
                                                       {"exited", n},
                                                       {"remaining", 500},
                                                       {"t_end", n / q}}
                                            .dump());
  WriteFile(r.run_dir / "run.json", r.spec.dump());
  return r;
}

TEST(ExtraAnalysis, RegisteredInATestAppearsInReportExportAndComparison) {
  TempDir dir;
  const std::size_t builtin = RegisteredAnalyses().size();
  CampaignInfo info;
  info.name = "extra";
  info.axes = {"/silo/base_outlets/0/width"};
  info.spec = {{"report", {{"exit_rate", {{"scale", 2.0}}}}}};
  std::vector<RunRecord> runs;
  for (const std::string engine : {"native", "liggghts"})
    for (double w : {6.0, 9.0})
      for (int rep = 0; rep < 2; ++rep)
        runs.push_back(MakeRunRecord(dir.Path(), engine, w, rep, w * (engine == "native" ? 1.0 : 1.5), 200));
  {
    const ScopedAnalysis registered({"exit_rate", MakeExitRate});
    EXPECT_EQ(RegisteredAnalyses().size(), builtin + 1);
    const AnalysisSetup setup = SetupAnalyses(info.spec);
    const auto a = AnalyseCampaign(info, runs, setup);

    ReportOptions o;
    o.out_dir = dir.Path() / "report";
    o.figures = false;
    const ReportSummary s = WriteReport(*a, o);
    const std::string md = ReadFile(s.markdown);
    EXPECT_NE(md.find("## Exit rate (registered by a test)"), std::string::npos);
    EXPECT_NE(ReadFile(o.out_dir / "data" / "per_run.csv").find(",exit_rate,"),
              std::string::npos);  // a headline metric
    // 200 exits in 200/q: rate q, scaled by 2 from the options.
    const std::string table = ReadFile(o.out_dir / "data" / "exit_rate.csv");
    EXPECT_EQ(table.substr(0, table.find('\n')), "point,exit_rate,exit_rate_se,exit_rate_n");
    EXPECT_NE(table.find("\"W = 9, engine = native\",18,0,2"), std::string::npos) << table;

    const ExportTable runs_table = MakeExportTable(*a, ExportLevel::kRun),
                      points_table = MakeExportTable(*a, ExportLevel::kPoint);
    for (const char* column : {"exit_rate", "exit_rate_se"})
      EXPECT_NE(std::find(runs_table.columns.begin(), runs_table.columns.end(), column), runs_table.columns.end())
          << column;
    EXPECT_NE(std::find(points_table.columns.begin(), points_table.columns.end(), "exit_rate_n"),
              points_table.columns.end());
    EXPECT_EQ(runs_table.rows.size(), 8u);
    EXPECT_EQ(points_table.rows.size(), 4u);

    // The comparison: LIGGGHTS exits 1.5 times as fast.
    ASSERT_FALSE(s.comparison.is_null());
    for (const auto& p : s.comparison["points"]) {
      ASSERT_TRUE(p["metrics"].contains("exit_rate")) << p.dump();
      EXPECT_NEAR(p["metrics"]["exit_rate"]["ratio"].get<double>(), 1.5, 1e-12);
      EXPECT_EQ(p["metrics"]["exit_rate"]["headline"], true);
    }
    // Its options are checked like every other's.
    try {
      SetupAnalyses({{"report", {{"exit_rate", {{"scale", -1}}}}}});
      FAIL() << "no error";
    } catch (const OptionError& e) {
      EXPECT_STREQ(e.what(), "/report/exit_rate/scale: must be in [0, 1e+09] (got -1)");
    }
  }
  EXPECT_EQ(RegisteredAnalyses().size(), builtin);
  EXPECT_THROW(SetupAnalyses(info.spec), OptionError);  // /report/exit_rate is unknown again
}

}  // namespace
}  // namespace granary::analysis
