// The avalanches analysis on a constructed exit stream with hand-counted avalanches: 4, 2 and
// 3 bodies between clogs (gaps of 6 and 9 against a clog gap of 5, the run ended clogged), and
// the same stream cut by the engine's unclogs instead (on_clog "unclog").
#include "analysis/avalanche_analysis.h"

#include <gtest/gtest.h>

#include <cmath>

#include "analysis/run_pass.h"

namespace granary::analysis {
namespace {

rundir::RunData StreamRun(const std::string& on_clog) {
  rundir::RunData data;
  data.has_summary = true;
  data.spec = {{"discharge", {{"mode", "remove"}, {"clog_window", 5.0}, {"on_clog", on_clog}}},
               {"silo", {{"base_outlets", {{{"center", 0.0}, {"width", 6.0}}}}}}};
  data.summary.end_reason = "clogged";
  data.summary.bodies = 100;
  data.summary.exited = 9;
  data.summary.remaining = 91;
  data.summary.t_end = 30.0;
  for (double t : {1.0, 2.0, 3.0, 4.0, 10.0, 11.0, 20.0, 21.0, 22.0})
    data.events.push_back({t, static_cast<std::int64_t>(data.events.size()), "dumbbell", 1.0, 0});
  return data;
}

std::vector<Metric> MetricsOf(const rundir::RunData& data, nlohmann::json* result = nullptr) {
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  const auto analysis = MakeAvalancheAnalysis(nullptr, "/report/avalanches");
  const nlohmann::json r = analysis->Start(view)->Finish();
  if (result) *result = r;
  return analysis->RunMetrics(r);
}

TEST(AvalancheAnalysis, SizesBetweenClogsOfTheExitStream) {
  nlohmann::json result;
  const std::vector<Metric> m = MetricsOf(StreamRun("stop"), &result);
  EXPECT_EQ(result.at("sizes"), (nlohmann::json{4.0, 2.0, 3.0}));
  ASSERT_NE(FindMetric(m, "avalanche_size"), nullptr);
  EXPECT_DOUBLE_EQ(FindMetric(m, "avalanche_size")->value, 3.0);
  EXPECT_DOUBLE_EQ(FindMetric(m, "avalanche_size")->se, 1.0 / std::sqrt(3.0));  // sizes' sd is 1
  EXPECT_DOUBLE_EQ(FindMetric(m, "avalanches")->value, 3.0);
  // Two clogs the stream recovered from and the one it ended in.
  EXPECT_DOUBLE_EQ(FindMetric(m, "clogs")->value, 3.0);
}

TEST(AvalancheAnalysis, AnEngineThatBrokeItsClogsCutsTheStreamAtItsUnclogs) {
  rundir::RunData data = StreamRun("unclog");
  // The engine's unclogs of clogs 1 and 2 (a second attempt on clog 2 is not a new cut), and
  // no gap rule: the stream's gaps no longer decide.
  data.unclogs = {{5.0, 50000, 1, 1, "kick", {}}, {15.0, 150000, 2, 1, "kick", {}}, {16.0, 160000, 2, 2, "kick", {}}};
  nlohmann::json result;
  const std::vector<Metric> m = MetricsOf(data, &result);
  EXPECT_EQ(result.at("sizes"), (nlohmann::json{4.0, 2.0, 3.0}));
  EXPECT_EQ(result.at("unclogs"), 2);
  EXPECT_DOUBLE_EQ(FindMetric(m, "clogs")->value, 3.0);
  // Cut elsewhere, the sizes follow the cuts, not the gaps.
  data.unclogs = {{2.5, 25000, 1, 1, "kick", {}}};
  EXPECT_EQ((MetricsOf(data, &result), result.at("sizes")), (nlohmann::json{2.0, 7.0}));
}

TEST(AvalancheAnalysis, AClogTheProtocolCouldNotBreakEndsTheLastAvalancheNotAnEmptyOne) {
  rundir::RunData data = StreamRun("unclog");
  // Clog 1 broken at 5; clog 2, after the exit at 11, met three attempts (15, 16, 25) after
  // which nothing left, and the run ended clogged: the stream is the first six exits.
  data.events.resize(6);
  data.unclogs = {{5.0, 50000, 1, 1, "remove_arch", {}},
                  {15.0, 150000, 2, 1, "remove_arch", {}},
                  {16.0, 160000, 2, 2, "remove_arch", {}},
                  {25.0, 250000, 2, 3, "remove_arch", {}}};
  nlohmann::json result;
  const std::vector<Metric> m = MetricsOf(data, &result);
  // 4 exits up to the unclog at 5, then 2 (at 10 and 11) that ended in the clog never broken.
  EXPECT_EQ(result.at("sizes"), (nlohmann::json{4.0, 2.0}));
  EXPECT_EQ(result.at("unclogs"), 1);
  EXPECT_DOUBLE_EQ(FindMetric(m, "clogs")->value, 2.0);
  EXPECT_DOUBLE_EQ(FindMetric(m, "avalanche_size")->value, 3.0);
}

TEST(AvalancheAnalysis, AFallbackKickAfterArchRemovalsIsOneUnclogAndItsAvalancheCounts) {
  rundir::RunData data = StreamRun("unclog");
  data.summary.end_reason = "max_clogs";
  // remove_arch with unclog/fallback "kick": clog 1 broken by its arch at 5; clog 2 (after the
  // exit at 11) first lost its arch at 12 and stalled again, then at 17 the arch finder found
  // none and the attempt kicked instead; the flow resumed (20, 21, 22) up to clog 3, which
  // ended the run at max_clogs (no row).
  data.unclogs = {{5.0, 50000, 1, 1, "remove_arch", {7, 9}},
                  {12.0, 120000, 2, 1, "remove_arch", {3}},
                  {17.0, 170000, 2, 2, "kick", {1, 2, 4}}};
  nlohmann::json result;
  const std::vector<Metric> m = MetricsOf(data, &result);
  // Cut at each clog's first attempt: 4 to clog 1, 2 to clog 2, 3 after the kick to clog 3.
  EXPECT_EQ(result.at("sizes"), (nlohmann::json{4.0, 2.0, 3.0}));
  EXPECT_EQ(result.at("unclogs"), 2);
  EXPECT_DOUBLE_EQ(FindMetric(m, "clogs")->value, 3.0);
}

TEST(AvalancheAnalysis, NoOptions) {
  EXPECT_THROW(MakeAvalancheAnalysis({{"bins", 3}}, "/report/avalanches"), std::exception);
}

}  // namespace
}  // namespace granary::analysis
