// The export's tidy tables on a campaign with known flow rates: one row per run or per point,
// the swept parameters as numeric columns by their short path, metrics with _se (and _n), a
// run that did not finish left out, missing values empty in CSV and null in JSON.
#include "analysis/export.h"

#include <gtest/gtest.h>

#include <sstream>

#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::TempDir;
using testing::WriteFile;

// n exits at rate q through a base outlet of width w; remove mode with 1000 bodies.
RunRecord MakeRunRecord(const std::filesystem::path& root, double w, int replica, double q,
                        const std::string& state = "done") {
  RunRecord r;
  r.engine = "native";
  r.point_id = "W" + FormatNumber(w);
  r.run_id = r.point_id + "r" + std::to_string(replica);
  r.replica = replica;
  r.state = state;
  r.point = {{"/silo/base_outlets/0/width", w}, {"/bodies/species/0/shape", "disc"}};
  r.spec = {{"silo", {{"base_outlets", {{{"center", 0.0}, {"width", w}}}}}},
            {"bodies", {{"count", 1000}, {"species", {{{"shape", "disc"}}}}}},
            {"discharge", {{"mode", "remove"}}}};
  r.run_dir = root / r.run_id;
  if (state != "done") return r;
  std::ostringstream ev;
  ev.precision(17);
  ev << "time,body,shape,mass,outlet\n";
  for (int i = 1; i <= 500; ++i) ev << i / q << "," << i << ",disc,1,0\n";
  WriteFile(r.run_dir / "events.csv", ev.str());
  WriteFile(r.run_dir / "run.json", r.spec.dump());
  WriteFile(r.run_dir / "summary.json", nlohmann::json{{"engine", "native"},
                                                       {"end_reason", "time_limit"},
                                                       {"bodies", 1000},
                                                       {"exited", 500},
                                                       {"remaining", 500},
                                                       {"t_end", 500 / q}}
                                            .dump());
  return r;
}

TEST(Export, RunsAndPointsAsTidyTables) {
  TempDir dir;
  CampaignInfo info;
  info.name = "export";
  info.axes = {"/silo/base_outlets/0/width", "/bodies/species/0/shape"};
  const std::vector<RunRecord> runs = {MakeRunRecord(dir.Path(), 6, 0, 9.0), MakeRunRecord(dir.Path(), 6, 1, 11.0),
                                       MakeRunRecord(dir.Path(), 8, 0, 20.0),
                                       MakeRunRecord(dir.Path(), 8, 1, 0.0, "failed")};
  const AnalysisSetup setup = SetupAnalyses(nlohmann::json::object());
  const auto a = AnalyseCampaign(info, runs, setup);

  const ExportTable t = MakeExportTable(*a, ExportLevel::kRun);
  ASSERT_GE(t.columns.size(), 9u);
  EXPECT_EQ(std::vector<std::string>(t.columns.begin(), t.columns.begin() + 9),
            (std::vector<std::string>{"run_id", "point_id", "replica", "engine", "end_reason", "W", "shape", "q_count",
                                      "q_count_se"}));
  ASSERT_EQ(t.rows.size(), 3u);  // the failed run is not in it
  EXPECT_EQ(t.rows[0][0], "W6r0");
  EXPECT_EQ(t.rows[0][5], 6.0);     // a number, not text
  EXPECT_EQ(t.rows[0][6], "disc");  // a string axis stays a string
  EXPECT_NEAR(t.rows[0][7].get<double>(), 9.0, 1e-9);

  const ExportTable p = MakeExportTable(*a, ExportLevel::kPoint);
  EXPECT_EQ(
      std::vector<std::string>(p.columns.begin(), p.columns.begin() + 8),
      (std::vector<std::string>{"point_id", "engine", "runs", "W", "shape", "q_count", "q_count_se", "q_count_n"}));
  ASSERT_EQ(p.rows.size(), 2u);
  EXPECT_EQ(p.rows[0][2], 2);
  EXPECT_NEAR(p.rows[0][5].get<double>(), 10.0, 1e-9);  // (9 + 11) / 2
  EXPECT_NEAR(p.rows[0][6].get<double>(), 1.0, 1e-9);   // se of the two replicas
  EXPECT_EQ(p.rows[0][7], 2);
  EXPECT_EQ(p.rows[1][2], 1);           // W = 8: one finished run
  EXPECT_TRUE(p.rows[1][6].is_null());  // one replica: no se

  // CSV: full precision, missing values empty; JSON: keys in column order, null.
  const std::string csv = ToCsv(p);
  std::istringstream lines(csv);
  std::string header, first, second;
  std::getline(lines, header);
  std::getline(lines, first);
  std::getline(lines, second);
  EXPECT_EQ(header.rfind("point_id,engine,runs,W,shape,q_count,q_count_se,q_count_n,", 0), 0u);
  EXPECT_EQ(second.rfind("W8,native,1,8,disc,", 0), 0u) << second;
  EXPECT_NE(second.find(",,1,"), std::string::npos) << second;  // q_count_se empty, q_count_n 1
  const nlohmann::ordered_json j = to_json(p);
  ASSERT_EQ(j.size(), 2u);
  EXPECT_EQ(j[1].begin().key(), "point_id");
  EXPECT_TRUE(j[1]["q_count_se"].is_null());
}

}  // namespace
}  // namespace granary::analysis
