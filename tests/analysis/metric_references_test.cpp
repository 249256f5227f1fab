// Plan-time checks of the names a campaign spec's figures, expectations and replica targets use
// (check_metric_references, expectations.h): specs only, no runs.
#include <gtest/gtest.h>

#include <string>

#include "analysis/expectations.h"
#include "analysis/options.h"
#include "analysis/registry.h"

namespace granary::analysis {
namespace {

nlohmann::json SpecWith(const nlohmann::json& report, const nlohmann::json& expect = nullptr) {
  nlohmann::json s = {{"name", "names"},
                      {"base", {{"silo", {{"width", 40}}}}},
                      {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {6, 8}}, {"/contact/mu", {0, 0.5}}}}}},
                      {"axes", {{"W_over_2", "W / 2"}}},
                      {"report", report}};
  if (!expect.is_null()) s["expect"] = expect;
  return s;
}

// The OptionError's message, or "" when the spec passes.
std::string ErrorOf(const nlohmann::json& spec) {
  try {
    CheckMetricReferences(spec);
  } catch (const OptionError& e) {
    return e.what();
  }
  return "";
}

TEST(MetricReferences, MetricsAxesAndDerivedAxesPass) {
  const nlohmann::json spec =
      SpecWith({{"figures",
                 {{{"name", "a"}, {"y", "q_count / W^(1.5 + mu/2)"}, {"x", "W"}},
                  {{"name", "b"}, {"y", "psi"}, {"x", "W_over_2"}},
                  {{"name", "c"}, {"y", "q_count_outlet1 + v_max"}},
                  {{"name", "d"}, {"kind", "pictures"}}}}},
               {{{"metric", "arch_width_sd * W_over_2"}, {"at", {{"W", 6}}}, {"value", 1}, {"source", "s"}}});
  EXPECT_EQ(ErrorOf(spec), "");
}

TEST(MetricReferences, AnUnknownNameIsRefusedWithItsPathAndWhatExists) {
  const std::string fig =
      ErrorOf(SpecWith({{"figures", {{{"name", "a"}, {"y", "psi"}}, {{"name", "b"}, {"y", "2 * psii"}}}}}));
  EXPECT_NE(fig.find("/report/figures/1/y"), std::string::npos) << fig;
  EXPECT_NE(fig.find("\"psii\" names no metric"), std::string::npos) << fig;
  EXPECT_NE(fig.find("psi,"), std::string::npos) << fig;                       // what the analyses offer
  EXPECT_NE(fig.find("no axis (mu, W, W_over_2)"), std::string::npos) << fig;  // and the axes
  // A list of y: the path names the one at fault.
  const std::string listed =
      ErrorOf(SpecWith({{"figures", {{{"name", "a"}, {"y", {"q_count", "contact_sss"}}, {"x", "W"}}}}}));
  EXPECT_NE(listed.find("/report/figures/0/y/1: \"contact_sss\" names no metric"), std::string::npos) << listed;

  const std::string exp = ErrorOf(SpecWith(nlohmann::json::object(), {{{"metric", "q_cnt"}, {"value", 1}}}));
  EXPECT_NE(exp.find("/expect/0/metric"), std::string::npos) << exp;
  EXPECT_NE(exp.find("\"q_cnt\""), std::string::npos) << exp;

  nlohmann::json adaptive = SpecWith(nlohmann::json::object());
  adaptive["replicas"] = {
      {"min", 2},
      {"max", 5},
      {"until", {{{"metric", "q_count"}, {"rel_se", 0.1}}, {{"metric", "avalanche"}, {"rel_se", 0.1}}}}};
  const std::string rep = ErrorOf(adaptive);
  EXPECT_NE(rep.find("/replicas/until/1/metric"), std::string::npos) << rep;
}

TEST(MetricReferences, AMetricOfAnAnalysisTheSpecLeavesOffSaysHowToTurnItOn) {
  const nlohmann::json y = {{"figures", {{{"name", "a"}, {"y", "cg_speed"}}}}};
  const std::string off = ErrorOf(SpecWith(y));
  EXPECT_NE(off.find("/report/figures/0/y"), std::string::npos) << off;
  EXPECT_NE(off.find("metric of the fields analysis, which this spec leaves off (turn it on with /report/fields)"),
            std::string::npos)
      << off;
  nlohmann::json on = y;
  on["fields"] = true;
  EXPECT_EQ(ErrorOf(SpecWith(on)), "");
}

TEST(MetricReferences, FamiliesCoverTheirVariantsOnly) {
  const auto rows = BuiltinAnalyses();
  const AnalysisEntry& flow = rows.front();
  ASSERT_EQ(flow.key, "flow");
  EXPECT_TRUE(OffersMetric(flow, "q_count"));
  EXPECT_TRUE(OffersMetric(flow, "q_count_outlet1"));
  EXPECT_FALSE(OffersMetric(flow, "q_count_outlet"));  // a family needs something after its prefix
  EXPECT_FALSE(OffersMetric(flow, "q_counts"));
  EXPECT_FALSE(OffersMetric(flow, "psi"));
}

}  // namespace
}  // namespace granary::analysis
