// Regression of every registered analysis on stored run directories (tests/data/regression:
// three small native-engine campaigns — remove mode through clogs and discharges, a small
// outlet beside a large one, a lateral outlet — with frames and contact forces): every per-run
// metric (value, se) and every point metric (mean, se, n) against expected_metrics.json.
//
// Tolerance: relative 1e-9 (plus 1e-12 absolute for values near zero). The analyses are
// deterministic, so the same build reproduces the bits; the tolerance only absorbs a compiler
// or libm that rounds differently. A change of the numbers is a change of an analysis: bump
// its version, then regenerate the references deliberately with
//   build/bin/granary_analysis_regression --update-references
// and say why in the commit. The expected file of the first version was checked against the
// numbers of the analyses before they became registered units (commit message of that change).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/campaign_analysis.h"
#include "analysis/registry.h"
#include "stored_campaign.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

namespace fs = std::filesystem;
using testing::Load;
using testing::StoredCampaign;

bool g_update_references = false;

constexpr double kRelativeTolerance = 1e-9;
constexpr double kAbsoluteTolerance = 1e-12;
constexpr const char* kCampaigns[] = {"remove", "two-outlets", "lateral"};

fs::path DataDir() { return fs::path(GRANARY_SOURCE_DIR) / "tests" / "data" / "regression"; }

nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

// {"runs": {id: {metric: [value, se]}}, "points": {id: {metric: [mean, se, n]}}}
nlohmann::json MetricsOf(const CampaignAnalysis& a) {
  nlohmann::json runs = nlohmann::json::object(), points = nlohmann::json::object();
  for (std::size_t u = 0; u < a.view.used.size(); ++u) {
    nlohmann::json m = nlohmann::json::object();
    for (std::size_t k = 0; k < a.results.size(); ++k)
      for (const Metric& x : a.RunMetrics(k, u)) m[x.name] = {Number(x.value), Number(x.se)};
    runs[a.view.used[u].record->run_id] = m;
  }
  for (std::size_t p = 0; p < a.view.points.size(); ++p) {
    nlohmann::json m = nlohmann::json::object();
    for (const PointMetric& x : a.AllPointMetrics(p)) m[x.name] = {Number(x.mean), Number(x.se), x.n};
    points[a.view.points[p].id] = m;
  }
  return {{"runs", runs}, {"points", points}};
}

nlohmann::json Analyse(const std::string& name, bool cache, const fs::path& copy_to = {}) {
  fs::path dir = DataDir() / name;
  if (!copy_to.empty()) {
    fs::copy(dir, copy_to, fs::copy_options::recursive);
    dir = copy_to;
  }
  const StoredCampaign c = Load(dir);
  const AnalysisSetup setup = SetupAnalyses(c.info.spec);
  CampaignAnalysisOptions options;
  options.read_cache = options.write_cache = cache;  // never write into the source tree
  const auto a = AnalyseCampaign(c.info, c.runs, setup, options);
  EXPECT_EQ(a->view.unreadable.size(), 0u) << (a->view.unreadable.empty() ? "" : a->view.unreadable.front().second);
  return MetricsOf(*a);
}

bool Close(const nlohmann::json& a, const nlohmann::json& b) {
  if (a.is_null() || b.is_null()) return a.is_null() && b.is_null();
  const double x = a.get<double>(), y = b.get<double>();
  return std::abs(x - y) <= kRelativeTolerance * std::max(std::abs(x), std::abs(y)) + kAbsoluteTolerance;
}

// Every number of `expected` in `actual` and nothing more; failures name the place.
void ExpectSame(const nlohmann::json& expected, const nlohmann::json& actual, const std::string& where) {
  ASSERT_EQ(expected.size(), actual.size()) << where << ": expected " << expected.dump() << "\n got " << actual.dump();
  for (const auto& [key, e] : expected.items()) {
    ASSERT_TRUE(actual.contains(key)) << where << "/" << key << " is missing";
    const nlohmann::json& a = actual.at(key);
    if (e.is_object()) {
      ExpectSame(e, a, where + "/" + key);
      continue;
    }
    ASSERT_EQ(e.size(), a.size()) << where << "/" << key;
    for (std::size_t i = 0; i < e.size(); ++i)
      EXPECT_TRUE(Close(e[i], a[i])) << where << "/" << key << "[" << i << "]: expected " << e[i] << ", got " << a[i];
  }
}

TEST(Regression, StoredRunsGiveTheExpectedMetrics) {
  const fs::path file = DataDir() / "expected_metrics.json";
  nlohmann::json actual = nlohmann::json::object();
  for (const char* name : kCampaigns) actual[name] = Analyse(name, false);
  if (g_update_references) {
    std::ofstream(file) << actual.dump(1) << "\n";
    std::cout << "wrote " << file << "\n";
    return;
  }
  std::ifstream in(file);
  ASSERT_TRUE(in) << file << " is missing: run granary_analysis_regression --update-references";
  const nlohmann::json expected = nlohmann::json::parse(in);
  ExpectSame(expected, actual, "");
}

// Plan-time checks of figures and expectations (check_metric_references) trust each registry
// row's list of metrics: every point metric an analysis returns on the stored runs must be on
// its own row's list.
TEST(Regression, EveryPointMetricIsOnItsRegistryRowsList) {
  const std::vector<AnalysisEntry> rows = RegisteredAnalyses();
  int checked = 0;
  for (const char* name : kCampaigns) {
    const StoredCampaign c = Load(DataDir() / name);
    const AnalysisSetup setup = SetupAnalyses(c.info.spec);
    CampaignAnalysisOptions options;
    options.read_cache = options.write_cache = false;
    const auto a = AnalyseCampaign(c.info, c.runs, setup, options);
    for (std::size_t k = 0; k < setup.analyses.size(); ++k) {
      const std::string key = setup.analyses[k]->Key();
      const auto row = std::find_if(rows.begin(), rows.end(), [&](const AnalysisEntry& e) { return e.key == key; });
      ASSERT_NE(row, rows.end()) << key;
      for (const auto& point : a->point_metrics[k])
        for (const PointMetric& m : point) {
          EXPECT_TRUE(OffersMetric(*row, m.name))
              << name << ": " << key << " returns " << m.name << ", not on its row's list";
          ++checked;
        }
    }
  }
  EXPECT_GT(checked, 50);
}

TEST(Regression, CachedResultsAreTheSameNumbers) {
  // A copy, so that the caches are written beside the runs and read back.
  testing::TempDir tmp;
  const nlohmann::json cold = Analyse("two-outlets", true, tmp.Path() / "c");
  const StoredCampaign c = Load(tmp.Path() / "c");
  const AnalysisSetup setup = SetupAnalyses(c.info.spec);
  const auto warm = AnalyseCampaign(c.info, c.runs, setup);
  EXPECT_EQ(warm->results_computed, 0);
  EXPECT_EQ(warm->results_from_cache, static_cast<int>(c.runs.size() * setup.analyses.size()));
  EXPECT_EQ(MetricsOf(*warm), cold);
}

}  // namespace
}  // namespace granary::analysis

int main(int argc, char** argv) {
  std::vector<char*> args;
  for (int i = 0; i < argc; ++i) {
    if (std::string(argv[i]) == "--update-references") {
      granary::analysis::g_update_references = true;
      continue;
    }
    args.push_back(argv[i]);
  }
  int n = static_cast<int>(args.size());
  ::testing::InitGoogleTest(&n, args.data());
  return RUN_ALL_TESTS();
}
