// The intermittency analysis on a constructed exit stream: flowing stretches of 4, 1 and 2
// time units (from the opening, then from each unclog to the last exit before a gap), clogs of
// 6 and 9 (the gaps), and the final clog censored by the end of the run at t = 30, so
// <t_f> = 7/3, <t_c> = 7.5 and N_u = 2 unclogs / 30.
#include "analysis/intermittency_analysis.h"

#include <gtest/gtest.h>

#include <cmath>

#include "analysis/run_pass.h"

namespace granary::analysis {
namespace {

rundir::RunData StreamRun() {
  rundir::RunData data;
  data.has_summary = true;
  data.spec = {{"discharge", {{"mode", "reinject"}, {"clog_window", 5.0}}},
               {"silo", {{"base_outlets", {{{"center", -10.0}, {"width", 6.0}}, {{"center", 10.0}, {"width", 6.0}}}}}}};
  data.summary.end_reason = "clogged";
  data.summary.bodies = 100;
  data.summary.t_end = 30.0;
  // Outlet 0: the stream above. Outlet 1: one exit at t = 1 and nothing after: blocked from
  // then on (a clog without an end).
  for (double t : {1.0, 2.0, 3.0, 4.0, 10.0, 11.0, 20.0, 21.0, 22.0})
    data.events.push_back({t, static_cast<std::int64_t>(data.events.size()), "disc", 1.0, 0});
  data.events.insert(data.events.begin() + 1, {1.0, 99, "disc", 1.0, 1});
  return data;
}

TEST(IntermittencyAnalysis, FlowingAndCloggedTimesAndTheUnclogRatePerOutlet) {
  const rundir::RunData data = StreamRun();
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  const auto analysis = MakeIntermittencyAnalysis(nullptr, "/report/intermittency");
  const std::vector<Metric> m = analysis->RunMetrics(analysis->Start(view)->Finish());
  const auto value = [&](const std::string& name) {
    const Metric* x = FindMetric(m, name);
    EXPECT_NE(x, nullptr) << name;
    return x ? x->value : kNaN;
  };
  EXPECT_DOUBLE_EQ(value("t_flowing_outlet0"), 7.0 / 3.0);
  EXPECT_DOUBLE_EQ(value("t_clogged_outlet0"), 7.5);
  EXPECT_DOUBLE_EQ(value("unclog_rate_outlet0"), 2.0 / 30.0);
  // Outlet 1 flowed for 1 and then stayed clogged to the end: one complete flowing stretch,
  // no complete clog, no unclog.
  EXPECT_DOUBLE_EQ(value("t_flowing_outlet1"), 1.0);
  EXPECT_TRUE(std::isnan(value("t_clogged_outlet1")));
  EXPECT_DOUBLE_EQ(value("unclog_rate_outlet1"), 0.0);
}

}  // namespace
}  // namespace granary::analysis
