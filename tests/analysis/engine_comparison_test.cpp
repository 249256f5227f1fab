// The engine comparison: agreement and ratios with known numbers, point matching, engine
// costs, and write_report on a synthetic two-engine campaign whose flow rates differ by a
// known factor per point.
#include "analysis/engine_comparison.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "analysis/report.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::ReadFile;
using testing::TempDir;
using testing::WriteFile;

MeanSe Ms(double mean, double se, int n) { return MeanSe{mean, se, n}; }

TEST(EngineComparison, AgreementRatioAndItsError) {
  MetricDifference d{"q_count", Ms(10.0, 0.3, 4), Ms(11.2, 0.4, 4), -1.2, 0.5, -2.4};
  const MetricAgreement m = AgreementOf(d);
  EXPECT_DOUBLE_EQ(m.ratio, 1.12);
  EXPECT_NEAR(m.ratio_se, 1.12 * std::hypot(0.03, 0.4 / 11.2), 1e-12);
  EXPECT_EQ(m.agree, std::optional<bool>(false));  // 2.4 combined se apart
  d.b = Ms(10.9, 0.4, 4);
  d.difference = -0.9;
  d.z = -1.8;
  EXPECT_EQ(AgreementOf(d).agree, std::optional<bool>(true));
  // Unknown uncertainty (one replica): neither agreement nor disagreement, even for equal
  // values; exact equality with se 0 agrees, a difference with se 0 does not.
  EXPECT_EQ(AgreementOf(MetricDifference{"phi", Ms(0.8, kNaN, 1), Ms(0.8, kNaN, 1), 0.0, kNaN, kNaN}).agree,
            std::nullopt);
  EXPECT_EQ(AgreementOf(MetricDifference{"phi", Ms(0.8, 0.01, 3), Ms(0.5, kNaN, 1), 0.3, kNaN, kNaN}).agree,
            std::nullopt);
  EXPECT_EQ(AgreementOf(MetricDifference{"psi", Ms(0.0, 0.0, 3), Ms(0.0, 0.0, 3), 0.0, 0.0, kNaN}).agree,
            std::optional<bool>(true));
  EXPECT_EQ(AgreementOf(MetricDifference{"psi", Ms(0.0, 0.0, 3), Ms(0.1, 0.0, 3), -0.1, 0.0, kNaN}).agree,
            std::optional<bool>(false));
  EXPECT_EQ(AgreementText(std::nullopt), "n/a");
  EXPECT_EQ(AgreementText(true), "yes");
  EXPECT_EQ(AgreementText(false), "no");
}

EnginePoint Point(double w, double q, double se) {
  EnginePoint p;
  p.point = {{"/silo/base_outlets/0/width", w}};
  p.point_id = "p" + std::to_string(static_cast<int>(w));
  p.metrics = {{"q_count", "bodies/sqrt(d/g)", q, se, 3, "Q", true, ""}};
  return p;
}

TEST(ComparePoints, MatchedBySweepValuesWithZScores) {
  EnginePoint a1, a2, b1;
  a1.point_id = "native-1";
  a1.point = {{"/silo/base_outlets/0/width", 10}};
  a1.metrics = {{"q_count", "", 20.0, 0.3, 4, "", true, ""},
                {"phi", "", 0.8, 0.01, 4, "", true, ""},
                {"clogged_runs", "", 1.0, kNaN, 4, "", false, "", false},  // not compared
                {"v_max", "", kNaN, kNaN, 0, "", false, ""}};              // undefined
  a2.point = {{"/silo/base_outlets/0/width", 12}};                         // no partner
  b1.point_id = "liggghts-7";
  b1.point = {{"/silo/base_outlets/0/width", 10}};
  b1.metrics = {{"phi", "", 0.8, kNaN, 1, "", true, ""},
                {"q_count", "", 19.0, 0.4, 5, "", true, ""},
                {"clogged_runs", "", 2.0, kNaN, 5, "", false, "", false},
                {"v_max", "", 3.0, 0.1, 5, "", false, ""}};
  const auto c = ComparePoints({a1, a2}, {b1});
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].point_id_b, "liggghts-7");
  ASSERT_EQ(c[0].metrics.size(), 2u);  // q_count and phi
  EXPECT_EQ(c[0].metrics[0].name, "q_count");
  EXPECT_DOUBLE_EQ(c[0].metrics[0].difference, 1.0);
  EXPECT_DOUBLE_EQ(c[0].metrics[0].se, 0.5);
  EXPECT_DOUBLE_EQ(c[0].metrics[0].z, 2.0);
  EXPECT_TRUE(std::isnan(c[0].metrics[1].z));  // se unknown on one side
}

TEST(EngineComparison, MatchesPointsBySweepValuesAndSumsCosts) {
  const std::vector<EnginePoint> a = {Point(10, 20, 1), Point(14, 40, 1), Point(18, 60, 1)};
  const std::vector<EnginePoint> b = {Point(14, 44, 1), Point(10, 19, 1), Point(22, 80, 1)};
  const EngineComparison c =
      CompareEngines("native", a, {{10.0, 8.0, 2e7, 1}, {20.0, 16.0, 4e7, 1}}, "liggghts", b, {{100.0, 90.0, 5e6, 1}});
  ASSERT_EQ(c.points.size(), 2u);  // W = 18 and 22 are on one engine only
  EXPECT_EQ(c.points[0].point["/silo/base_outlets/0/width"], 10);
  EXPECT_DOUBLE_EQ(c.points[0].metrics[0].ratio, 19.0 / 20.0);
  EXPECT_EQ(c.points[0].metrics[0].agree, std::optional<bool>(true));
  EXPECT_DOUBLE_EQ(c.points[1].metrics[0].ratio, 1.1);
  EXPECT_EQ(c.points[1].metrics[0].agree, std::optional<bool>(false));  // 4 / sqrt(2) = 2.8 se apart
  ASSERT_EQ(c.costs.size(), 2u);
  EXPECT_EQ(c.costs[0].runs, 2);
  EXPECT_DOUBLE_EQ(c.costs[0].wall_s, 30.0);
  EXPECT_DOUBLE_EQ(c.costs[0].discharge_wall_s, 24.0);
  EXPECT_DOUBLE_EQ(c.costs[0].disc_steps_per_s.mean, 3e7);
  EXPECT_DOUBLE_EQ(c.costs[1].disc_steps_per_s.mean, 5e6);
  const nlohmann::json j = to_json(c);
  EXPECT_EQ(j["points"][1]["metrics"]["q_count"]["liggghts"]["mean"], 44.0);
  EXPECT_EQ(j["points"][1]["metrics"]["q_count"]["agree"], false);
  EXPECT_EQ(j["costs"][1]["engine"], "liggghts");
}

// A run of n exits at rate q through one outlet of width w, on `engine`.
void WriteRun(const std::filesystem::path& dir, const std::string& engine, double w, double q, int n, double rate) {
  std::ostringstream ev;
  ev.precision(17);
  ev << "time,body,shape,mass,outlet\n";
  for (int i = 1; i <= n; ++i) ev << (i / q) << "," << i % 500 << ",disc,1.0,0\n";
  WriteFile(dir / "events.csv", ev.str());
  const nlohmann::json spec = {{"engine", engine},
                               {"silo", {{"width", 60}, {"base_outlets", {{{"center", 0.0}, {"width", w}}}}}},
                               {"bodies", {{"count", 500}}},
                               {"discharge", {{"mode", "reinject"}, {"stop_on_clog", false}}}};
  nlohmann::json summary = {
      {"engine", engine},
      {"engine_version", "x"},
      {"run_id", dir.filename().string()},
      {"spec", spec},
      {"end_reason", "time_limit"},
      {"bodies", 500},
      {"exited", n},
      {"remaining", 500},
      {"exits_per_outlet", {n}},
      {"t_end", n / q + 0.5},
      {"timing", {{"wall_s", 10.0}, {"discharge_wall_s", 8.0}, {"disc_steps_per_s", rate}, {"threads", 1}}}};
  if (engine == "liggghts") {
    summary["tangential_cap"] = "liggghts";
    summary["reinject_position"] = "periodic";
  }
  WriteFile(dir / "summary.json", summary.dump());
  WriteFile(dir / "run.json", spec.dump());
  WriteFile(dir / "DONE", "");
}

TEST(EngineComparison, ReportOfATwoEngineCampaign) {
  TempDir dir;
  CampaignInfo info;
  info.name = "two-engines";
  info.axes = {"/silo/base_outlets/0/width"};
  std::vector<RunRecord> runs;
  // LIGGGHTS' flow rate is 1 % above the native one at W = 10 (agrees within the 1 %
  // replica scatter) and 6 % above at W = 14 (does not).
  const std::map<double, double> factor = {{10.0, 1.01}, {14.0, 1.06}};
  for (const auto& [w, f] : factor) {
    for (const std::string engine : {"native", "liggghts"}) {
      for (int rep = 0; rep < 2; ++rep) {
        RunRecord r;
        r.engine = engine;
        r.point_id = engine + std::to_string(static_cast<int>(w));
        r.run_id = r.point_id + "r" + std::to_string(rep);
        r.replica = rep;
        r.state = "done";
        r.point = {{"/silo/base_outlets/0/width", w}};
        r.run_dir = dir.Path() / r.run_id;
        const double q = 10.0 * w * (engine == "native" ? 1.0 : f) * (rep == 0 ? 0.99 : 1.01);
        WriteRun(r.run_dir, engine, w, q, 400, engine == "native" ? 2e7 : 4e6);
        r.spec = nlohmann::json::parse(ReadFile(r.run_dir / "run.json"));
        runs.push_back(r);
      }
    }
  }
  ReportOptions o;
  o.out_dir = dir.Path() / "report";
  o.figures = false;
  const ReportSummary s = WriteReport(info, runs, o);
  ASSERT_FALSE(s.comparison.is_null());
  const nlohmann::json& c = s.comparison;
  EXPECT_EQ(c["engine_a"], "native");
  EXPECT_EQ(c["engine_b"], "liggghts");
  ASSERT_EQ(c["points"].size(), 2u);
  for (const auto& p : c["points"]) {
    const double w = p["point"]["/silo/base_outlets/0/width"];
    const auto& q = p["metrics"]["q_count"];
    EXPECT_NEAR(q["ratio"].get<double>(), factor.at(w), 1e-3) << "W = " << w;
    ASSERT_TRUE(q["agree"].is_boolean()) << "W = " << w;
    EXPECT_EQ(q["agree"].get<bool>(), w == 10.0) << "W = " << w;
    EXPECT_EQ(q["native"]["n"], 2);
    EXPECT_EQ(p["name"], "W = " + FormatNumber(w)) << "the JSON keeps the sweep values and adds the name";
  }
  EXPECT_DOUBLE_EQ(c["costs"][0]["disc_steps_per_s"]["mean"].get<double>(), 2e7);
  EXPECT_DOUBLE_EQ(c["costs"][1]["disc_steps_per_s"]["mean"].get<double>(), 4e6);
  const std::string md = ReadFile(s.markdown);
  EXPECT_NE(md.find("Engine comparison: native and liggghts"), std::string::npos);
  // The engine is one more axis: every table keeps the engines apart.
  EXPECT_NE(md.find("| W = 10, engine = liggghts |"), std::string::npos) << "short point names in tables";
  EXPECT_EQ(md.find("base_outlets.0.width="), std::string::npos) << "no JSON paths as point names";
  EXPECT_NE(md.find("`liggghts` the spring part only"), std::string::npos);
  // The synthetic native runs reinject at random, the LIGGGHTS ones say "periodic".
  EXPECT_NE(md.find("Reinjection: native `random`, liggghts `periodic`"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(o.out_dir / "data" / "engine_comparison.csv"));
  EXPECT_TRUE(std::filesystem::exists(o.out_dir / "data" / "engine_cost.csv"));
  EXPECT_TRUE(std::filesystem::exists(o.out_dir / "data" / "engine_ratio--Q_bodies_sqrt_d_g.csv"));
}

// One replica per point and engine: no standard error, so agreement cannot be judged. The
// report and its JSON say "n/a" / null for every metric, never "no" / false.
TEST(EngineComparison, OneReplicaIsNotJudged) {
  TempDir dir;
  CampaignInfo info;
  info.name = "one-replica";
  info.axes = {"/silo/base_outlets/0/width"};
  std::vector<RunRecord> runs;
  for (const double w : {10.0, 14.0})
    for (const std::string engine : {"native", "liggghts"}) {
      RunRecord r;
      r.engine = engine;
      r.point_id = engine + std::to_string(static_cast<int>(w));
      r.run_id = r.point_id + "r0";
      r.state = "done";
      r.point = {{"/silo/base_outlets/0/width", w}};
      r.run_dir = dir.Path() / r.run_id;
      WriteRun(r.run_dir, engine, w, w * (engine == "native" ? 1.0 : 1.5), 300, 1e7);
      r.spec = nlohmann::json::parse(ReadFile(r.run_dir / "run.json"));
      runs.push_back(r);
    }
  ReportOptions o;
  o.out_dir = dir.Path() / "report";
  o.figures = false;
  const ReportSummary s = WriteReport(info, runs, o);
  ASSERT_EQ(s.comparison["points"].size(), 2u);
  int metrics = 0;
  for (const auto& p : s.comparison["points"])
    for (const auto& [name, m] : p["metrics"].items()) {
      EXPECT_TRUE(m["agree"].is_null()) << name << ": " << m.dump();
      EXPECT_TRUE(m["z"].is_null()) << name;
      ++metrics;
    }
  EXPECT_GT(metrics, 2) << ReadFile(s.markdown);
  const std::string table = ReadFile(o.out_dir / "data" / "engine_comparison.csv");
  EXPECT_NE(table.find("n/a"), std::string::npos);
  EXPECT_EQ(table.find(",no"), std::string::npos) << table;
  EXPECT_EQ(table.find(",yes"), std::string::npos) << table;
}

TEST(EngineComparison, OneEngineMeansNoComparison) {
  TempDir dir;
  CampaignInfo info;
  info.name = "one";
  RunRecord r;
  r.engine = "native";
  r.point_id = "p";
  r.run_id = "r";
  r.state = "done";
  r.run_dir = dir.Path() / "r";
  WriteRun(r.run_dir, "native", 10, 50, 100, 1e7);
  ReportOptions o;
  o.out_dir = dir.Path() / "report";
  o.figures = false;
  EXPECT_TRUE(WriteReport(info, {r}, o).comparison.is_null());
  EXPECT_EQ(ReadFile(o.out_dir / "report.md").find("Engine comparison"), std::string::npos);
}

}  // namespace
}  // namespace granary::analysis
