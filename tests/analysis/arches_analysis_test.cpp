// The arches analysis on run directories holding clogs made by hand (clog_builder.h): half
// circles of 8 and 10 touching discs over an outlet of width 4, whose arches have N_t = 8 and
// 10 and perimeters 7 and 9 (the centre-to-centre chain). What the analysis adds to arches.h:
// reading the kept clogs of a run, its per-run metrics (means over the run's arches), the
// per-point metrics pooled over the arches of every replica (not a mean of run means), and the
// errors of /report/arches.
#include "analysis/arches_analysis.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "analysis/campaign_view.h"
#include "analysis/run_pass.h"
#include "clog_builder.h"
#include "rundir/clogs.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

constexpr double kPi = std::numbers::pi;
using testing::Clog;
using testing::TempDir;

nlohmann::json Silo() { return {{"base_outlets", {{{"center", 0.0}, {"width", 4.0}}}}}; }

// The half circle of n touching discs from the base left of the outlet to the base right of
// it, with a row of discs above it (not touching); returns its radius.
double HalfCircle(Clog& c, int n) {
  const double radius = 0.5 / std::sin(kPi / (2 * (n - 1)));
  for (int k = 0; k < n; ++k) {
    const double a = kPi * (n - 1 - k) / (n - 1);
    c.Disc(radius * std::cos(a), 0.5 + radius * std::sin(a));
  }
  c.Row(-5.5, 5.5, 0.5 + radius + 1.2);
  return radius;
}

// A run directory in `dir` that kept one clog per entry of `arch_sizes`.
rundir::RunData ClogRun(const std::filesystem::path& dir, const std::vector<int>& arch_sizes) {
  rundir::ClogWriter writer = rundir::ClogWriter::Create(dir);
  rundir::RunData data;
  for (std::size_t k = 0; k < arch_sizes.size(); ++k) {
    Clog c(Silo());
    HalfCircle(c, arch_sizes[k]);
    rundir::ClogState clog = c.Made();
    clog.frame.time = clog.contacts.time = 10.0 * static_cast<double>(k + 1);
    clog.frame.timestep = clog.contacts.timestep = 100000 * static_cast<std::int64_t>(k + 1);
    writer.Write(clog);
    data.spec = c.Spec();
  }
  writer.Close();
  data.dir = dir;
  return data;
}

nlohmann::json ResultOf(const Analysis& analysis, const rundir::RunData& data) {
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  const auto accumulator = analysis.Start(view);
  // The clogs come from the clog files, not the frames of the pass.
  EXPECT_TRUE(accumulator->Frames().windows.empty());
  return accumulator->Finish();
}

double Radius(int n) { return 0.5 / std::sin(kPi / (2 * (n - 1))); }

TEST(ArchesAnalysis, RunMetricsAreMeansOverTheRunsArches) {
  TempDir dir;
  const auto analysis = MakeArchesAnalysis(nullptr, "/report/arches");
  const nlohmann::json result = ResultOf(*analysis, ClogRun(dir.Path(), {8, 10}));
  EXPECT_TRUE(result.at("present").get<bool>());
  ASSERT_EQ(result.at("clogs").size(), 2u);
  const std::vector<Metric> m = analysis->RunMetrics(result);
  std::vector<std::string> names;
  for (const Metric& x : m) names.push_back(x.name);
  EXPECT_EQ(names,
            (std::vector<std::string>{"arches", "obstacle_arches", "arch_n", "arch_width", "arch_height",
                                      "arch_perimeter", "arch_c_over_p", "arch_elongated_fraction", "arch_pressure"}));
  EXPECT_DOUBLE_EQ(FindMetric(m, "arches")->value, 2.0);
  EXPECT_TRUE(std::isnan(FindMetric(m, "arches")->se));
  EXPECT_DOUBLE_EQ(FindMetric(m, "obstacle_arches")->value, 0.0);
  // N_t 8 and 10: mean 9, se sqrt(2) / sqrt(2).
  EXPECT_DOUBLE_EQ(FindMetric(m, "arch_n")->value, 9.0);
  EXPECT_NEAR(FindMetric(m, "arch_n")->se, 1.0, 1e-12);
  EXPECT_TRUE(FindMetric(m, "arch_n")->headline);
  EXPECT_EQ(FindMetric(m, "arch_n")->unit, "bodies");
  EXPECT_NEAR(FindMetric(m, "arch_width")->value, Radius(8) + Radius(10), 1e-9);
  EXPECT_EQ(FindMetric(m, "arch_width")->unit, "d");
  EXPECT_NEAR(FindMetric(m, "arch_perimeter")->value, 8.0, 1e-9);
  EXPECT_NEAR(FindMetric(m, "arch_perimeter")->se, 1.0, 1e-9);
  // Discs only: no elongated body in any arch.
  EXPECT_DOUBLE_EQ(FindMetric(m, "arch_elongated_fraction")->value, 0.0);
  // The distribution of arch sizes is every arch's N_t.
  EXPECT_EQ(analysis->Distribution("arch_sizes", result).values, (std::vector<double>{8.0, 10.0}));
}

// Two replicas, one with arches of 8 and 10 bodies, one with an arch of 8: the point's mean is
// over its 3 arches (26 / 3), not over its 2 runs (8.5).
TEST(ArchesAnalysis, PointMetricsPoolTheArchesOfEveryReplica) {
  TempDir a, b;
  const auto analysis = MakeArchesAnalysis(nullptr, "/report/arches");
  CampaignView view;
  view.points.resize(1);
  view.points[0].runs = {0, 1};
  AnalysisResults results;
  results.view = &view;
  results.runs = {ResultOf(*analysis, ClogRun(a.Path(), {8, 10})), ResultOf(*analysis, ClogRun(b.Path(), {8}))};
  const std::vector<PointMetric> p = analysis->PointMetrics(results, 0);
  const PointMetric* n = FindMetric(p, "arch_n");
  ASSERT_NE(n, nullptr);
  EXPECT_NEAR(n->mean, 26.0 / 3.0, 1e-12);
  EXPECT_EQ(n->n, 3);
  // sd of {8, 10, 8} is 2 / sqrt(3); se = sd / sqrt(3).
  EXPECT_NEAR(n->se, 2.0 / 3.0, 1e-12);
  EXPECT_EQ(n->note, "fewer than 100 arches (the thesis averages >= 100)");
  const PointMetric* count = FindMetric(p, "arches");
  EXPECT_DOUBLE_EQ(count->mean, 3.0);
  EXPECT_EQ(count->n, 3);  // n = clogs
  EXPECT_FALSE(count->compare);
  // sigma_w of the three arches' widths 2 R(8), 2 R(10), 2 R(8).
  const double w8 = 2 * Radius(8), w10 = 2 * Radius(10), mean = (2 * w8 + w10) / 3;
  const double sd = std::sqrt((2 * (w8 - mean) * (w8 - mean) + (w10 - mean) * (w10 - mean)) / 2);
  EXPECT_NEAR(FindMetric(p, "arch_width_sd")->mean, sd, 1e-9);
  EXPECT_EQ(FindMetric(p, "arch_width_sd")->n, 3);
}

// A run directory written before engines kept clogs has no clog files: no metrics at all
// (not zero arches), and a point of such runs none either.
TEST(ArchesAnalysis, ARunWithoutClogFilesHasNoMetrics) {
  TempDir dir;
  rundir::RunData data;
  data.spec = {{"silo", Silo()}};
  data.dir = dir.Path();
  const auto analysis = MakeArchesAnalysis(nullptr, "/report/arches");
  const nlohmann::json result = ResultOf(*analysis, data);
  EXPECT_FALSE(result.at("present").get<bool>());
  EXPECT_TRUE(analysis->RunMetrics(result).empty());
  CampaignView view;
  view.points.resize(1);
  view.points[0].runs = {0};
  AnalysisResults results;
  results.view = &view;
  results.runs = {result};
  EXPECT_TRUE(analysis->PointMetrics(results, 0).empty());
  // Empty clog files (a run that never clogged): present, with zero arches.
  rundir::ClogWriter::Create(dir.Path()).Close();
  const std::vector<Metric> m = analysis->RunMetrics(ResultOf(*analysis, data));
  ASSERT_NE(FindMetric(m, "arches"), nullptr);
  EXPECT_DOUBLE_EQ(FindMetric(m, "arches")->value, 0.0);
}

TEST(ArchesAnalysis, OptionsAndTheirErrors) {
  const ArchesOptions o = ReadArchesOptions(
      {{"theta_bins", 3}, {"axis_bins", 6}, {"obstacle_arches", false}, {"pictures", 0}}, "/report/arches");
  EXPECT_EQ(o.summary.theta_bins, 3);
  EXPECT_EQ(o.summary.axis_bins, 6);
  EXPECT_FALSE(o.summary.obstacle_arches);
  EXPECT_EQ(o.pictures, 0);
  auto error = [](const nlohmann::json& options) -> std::string {
    try {
      MakeArchesAnalysis(options, "/report/arches");
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(error({{"theta_bins", 0}}).rfind("/report/arches/theta_bins: must be in [1, 180]", 0), 0u);
  EXPECT_EQ(error({{"axis_bins", 2.5}}).rfind("/report/arches/axis_bins: must be an integer", 0), 0u);
  EXPECT_EQ(error({{"obstacle_arches", 1}}).rfind("/report/arches/obstacle_arches: must be true or false", 0), 0u);
  EXPECT_EQ(error({{"pictures", 11}}).rfind("/report/arches/pictures: must be in [0, 10]", 0), 0u);
  EXPECT_EQ(error({{"bins", 3}}).rfind("/report/arches/bins: unknown key", 0), 0u);
  EXPECT_EQ(error(3).rfind("/report/arches: must be an object", 0), 0u);
}

}  // namespace
}  // namespace granary::analysis
