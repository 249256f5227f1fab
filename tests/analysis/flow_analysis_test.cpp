// The flow analysis on constructed exit streams whose rates are counted by hand: one exit every
// 0.1 sqrt(d/g) alternating between two outlets (Q = 10 together, 5 through each), the light
// bodies (mass 1) through outlet 0 and the heavy ones (mass 3) through outlet 1; its metrics,
// its notes, and the errors of /report/flow.
#include "analysis/flow_analysis.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "analysis/options.h"
#include "analysis/run_pass.h"

namespace granary::analysis {
namespace {

// 200 exits of a bed of 1000 bodies (remove mode, so the bed never gets shallow): exit i at
// t = 0.1 i through outlet i % 2; `outlets` base outlets in the spec.
rundir::RunData StreamRun(int outlets) {
  rundir::RunData data;
  nlohmann::json base = nlohmann::json::array();
  for (int k = 0; k < outlets; ++k) base.push_back({{"center", -20.0 + 40.0 * k}, {"width", 6.0}});
  data.spec = {{"discharge", {{"mode", "remove"}, {"clog_window", 5.0}}},
               {"silo", {{"width", 100.0}, {"base_outlets", base}}}};
  data.has_summary = true;
  data.summary.end_reason = "time_limit";
  data.summary.bodies = 1000;
  data.summary.exited = 200;
  data.summary.remaining = 800;
  data.summary.t_end = 20.0;
  for (int i = 1; i <= 200; ++i) {
    const int outlet = outlets > 1 ? i % 2 : 0;
    data.events.push_back({0.1 * i, i, "disc", i % 2 == 0 ? 1.0 : 3.0, outlet});
  }
  return data;
}

struct Analysed {
  nlohmann::json result;
  std::vector<Metric> metrics;
};

Analysed Analyse(const rundir::RunData& data) {
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  const auto analysis = MakeFlowAnalysis(nullptr, "/report/flow");
  const auto accumulator = analysis->Start(view);
  // Everything comes from the exit events: no frames are asked for.
  EXPECT_TRUE(accumulator->Frames().windows.empty());
  Analysed a;
  a.result = accumulator->Finish();
  a.metrics = analysis->RunMetrics(a.result);
  return a;
}

TEST(FlowAnalysis, TotalAndPerOutletRatesOfTwoOutlets) {
  const Analysed a = Analyse(StreamRun(2));
  std::vector<std::string> names;
  for (const Metric& m : a.metrics) names.push_back(m.name);
  EXPECT_EQ(names, (std::vector<std::string>{"q_count", "q_mass", "q_count_outlet0", "q_mass_outlet0",
                                             "q_count_outlet1", "q_mass_outlet1"}));
  const Metric* q = FindMetric(a.metrics, "q_count");
  EXPECT_NEAR(q->value, 10.0, 1e-9);
  EXPECT_EQ(q->unit, "bodies/sqrt(d/g)");
  EXPECT_TRUE(q->headline);
  // Its error is the batch-means one of the result, not the least-squares one.
  EXPECT_TRUE(std::isfinite(q->se));
  EXPECT_DOUBLE_EQ(q->se, a.result.at("total").at("q_count_se").get<double>());
  // Every other exit weighs 3: 5 bodies of mass 1 and 5 of mass 3 per unit time.
  const Metric* qm = FindMetric(a.metrics, "q_mass");
  EXPECT_NEAR(qm->value, 20.0, 0.05);
  EXPECT_EQ(qm->unit, "rho d^2/sqrt(d/g)");
  EXPECT_FALSE(qm->headline);
  // Each outlet's stream is fitted over the window of all outlets together, whose ends need not
  // fall on that outlet's exits: its step count gives the rate to 1e-4, not to rounding.
  EXPECT_NEAR(FindMetric(a.metrics, "q_count_outlet0")->value, 5.0, 5e-3);
  EXPECT_NEAR(FindMetric(a.metrics, "q_count_outlet1")->value, 5.0, 5e-3);
  EXPECT_NEAR(FindMetric(a.metrics, "q_mass_outlet0")->value, 5.0, 5e-3);
  EXPECT_NEAR(FindMetric(a.metrics, "q_mass_outlet1")->value, 15.0, 15e-3);
  // Sampled at the same exit times, the outlets' rates add up to the total.
  EXPECT_NEAR(FindMetric(a.metrics, "q_count_outlet0")->value + FindMetric(a.metrics, "q_count_outlet1")->value,
              q->value, 1e-9);
  EXPECT_EQ(FindMetric(a.metrics, "q_count_outlet1")->title,
            "Q through " + a.result.at("outlets").at(1).get<std::string>());
  EXPECT_FALSE(FindMetric(a.metrics, "q_count_outlet1")->headline);
  // The cumulative exit count: 200 exits thinned to stride 1 (200 / 200), the last one 200 at t = 20.
  EXPECT_EQ(a.result.at("cumulative").at("n").size(), 200u);
  EXPECT_DOUBLE_EQ(a.result.at("cumulative").at("n").back().get<double>(), 200.0);
  EXPECT_NEAR(a.result.at("cumulative").at("t").back().get<double>(), 20.0, 1e-12);
  EXPECT_TRUE(a.result.at("notes").empty());
}

TEST(FlowAnalysis, OneOutletHasNoPerOutletMetrics) {
  const Analysed a = Analyse(StreamRun(1));
  ASSERT_EQ(a.metrics.size(), 2u);
  EXPECT_EQ(a.metrics[0].name, "q_count");
  EXPECT_EQ(a.metrics[1].name, "q_mass");
  EXPECT_NEAR(a.metrics[0].value, 10.0, 1e-9);
}

// Too few exits for a steady window: no rate (NaN, not 0), and the reason beside the run; a
// summary that disagrees with events.csv is noted too.
TEST(FlowAnalysis, NoSteadyWindowGivesNoRateAndSaysWhy) {
  rundir::RunData data = StreamRun(1);
  data.events.resize(5);  // t = 0.1 .. 0.5, all before the window's start time 2
  const Analysed a = Analyse(data);
  EXPECT_FALSE(a.result.at("total").at("ok").get<bool>());
  EXPECT_TRUE(std::isnan(FindMetric(a.metrics, "q_count")->value));
  EXPECT_TRUE(std::isnan(FindMetric(a.metrics, "q_count")->se));
  EXPECT_TRUE(std::isnan(FindMetric(a.metrics, "q_mass")->value));
  const nlohmann::json& notes = a.result.at("notes");
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_EQ(notes[0].get<std::string>().rfind("flow rate: ", 0), 0u);
  EXPECT_EQ(notes[1], "events.csv has 5 exits but summary.json says 200");
}

std::string ErrorOf(const nlohmann::json& options) {
  try {
    MakeFlowAnalysis(options, "/report/flow");
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no error";
}

TEST(FlowAnalysis, OptionErrorsNameTheirPath) {
  EXPECT_NO_THROW(MakeFlowAnalysis(
      {{"models", {{{"name", "power"}, {"expression", "C * x^b"}, {"initial", {{"C", 1}, {"b", 1.5}}}}}}},
      "/report/flow"));
  EXPECT_EQ(ErrorOf({{"fits", 1}}).rfind("/report/flow/fits: unknown key", 0), 0u);
  EXPECT_EQ(ErrorOf({{"models", "beverloo"}}).rfind("/report/flow/models: must be an array", 0), 0u);
  EXPECT_EQ(ErrorOf({{"models", {{{"name", "m"}}}}}).rfind("/report/flow/models/0: must be {", 0), 0u);
  EXPECT_EQ(ErrorOf({{"models", {{{"expression", "C * x^"}}}}}).rfind("/report/flow/models/0/expression: ", 0), 0u);
  EXPECT_EQ(ErrorOf({{"models", {{{"expression", "C * x"}, {"initial", {{"C", "one"}}}}}}})
                .rfind("/report/flow/models/0/initial/C: must be a number", 0),
            0u);
  EXPECT_EQ(ErrorOf({{"models", {{{"expression", "C * x"}, {"variable", 3}}}}})
                .rfind("/report/flow/models/0/variable: must be a name", 0),
            0u);
}

}  // namespace
}  // namespace granary::analysis
