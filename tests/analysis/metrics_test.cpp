// PointMetrics aggregation over analysed runs (pure): replica statistics and the N_u fallback.
#include "analysis/metrics.h"

#include <gtest/gtest.h>

#include <cmath>

namespace granary::analysis {
namespace {

RunAnalysis run(bool clogged, int bodies, int left, double q) {
  RunAnalysis r;
  r.remove_mode = true;
  r.bodies = bodies;
  r.exited = bodies - left;
  r.clog = {clogged, bodies, left, bodies - left};
  r.flow.ok = true;
  r.flow.q_count = q;
  r.flow.q_mass = 2 * q;
  return r;
}

TEST(PointMetrics, ReplicaStatistics) {
  const RunAnalysis a = run(false, 1000, 40, 10.0), b = run(false, 1000, 60, 12.0);
  RunAnalysis c = run(true, 1000, 500, 0.0);
  c.flow.ok = false;  // no steady window: left out of Q, kept for Psi
  const PointRuns p{"p", {{"w", 1}}, {&a, &b, &c}};
  const PointMetrics m = point_metrics(p, AnalysisOptions());
  EXPECT_EQ(m.runs, 3);
  EXPECT_EQ(m.q_count.n, 2);
  EXPECT_DOUBLE_EQ(m.q_count.mean, 11.0);
  EXPECT_DOUBLE_EQ(m.q_count.se, 1.0);
  EXPECT_DOUBLE_EQ(m.q_mass.mean, 22.0);
  EXPECT_EQ(m.phi.n, 0);
  EXPECT_DOUBLE_EQ(m.clogging.n_stagnant, 50.0);
  EXPECT_EQ(m.clogging.psi.n, 3);
  EXPECT_NEAR(m.clogging.psi.mean, (450.0 / 950.0) / 3.0, 1e-14);  // free runs: -10/950 + 10/950
}

TEST(PointMetrics, StagnantCountFallbackWhenEveryRunClogged) {
  const RunAnalysis free1 = run(false, 1000, 40, 10.0);
  const RunAnalysis c1 = run(true, 1000, 540, 5.0), c2 = run(true, 1000, 240, 5.0);
  EXPECT_DOUBLE_EQ(stagnant_count({&free1}), 40.0);
  EXPECT_DOUBLE_EQ(stagnant_count({&c1, &c2}), -1.0);
  const PointRuns p{"narrow", {}, {&c1, &c2}};
  const PointMetrics m = point_metrics(p, AnalysisOptions(), 40.0, "from the wide outlets");
  EXPECT_DOUBLE_EQ(m.clogging.n_stagnant, 40.0);
  EXPECT_NEAR(m.clogging.psi.mean, (500.0 / 960.0 + 200.0 / 960.0) / 2.0, 1e-14);
  EXPECT_EQ(m.clogging.note, "from the wide outlets");
  // Without a fallback: N_u = 0, and said so.
  const PointMetrics z = point_metrics(p, AnalysisOptions());
  EXPECT_DOUBLE_EQ(z.clogging.n_stagnant, 0.0);
  EXPECT_NEAR(z.clogging.psi.mean, (0.54 + 0.24) / 2.0, 1e-14);
  EXPECT_FALSE(z.clogging.note.empty());
}

TEST(ComparePoints, MatchedBySweepValuesWithZScores) {
  PointMetrics a1, a2, b1;
  a1.point_id = "native-1";
  a1.point = {{"/silo/base_outlets/0/width", 10}};
  a1.q_count = {20.0, 0.3, 4};
  a1.phi = {0.8, 0.01, 4};
  a2.point = {{"/silo/base_outlets/0/width", 12}};  // no partner
  b1.point_id = "liggghts-7";
  b1.point = {{"/silo/base_outlets/0/width", 10}};
  b1.q_count = {19.0, 0.4, 5};
  b1.phi = {0.8, kNaN, 1};
  const auto c = compare_points({a1, a2}, {b1});
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].point_id_b, "liggghts-7");
  ASSERT_EQ(c[0].metrics.size(), 2u);  // q_count and phi; the rest undefined in both
  EXPECT_EQ(c[0].metrics[0].name, "q_count");
  EXPECT_DOUBLE_EQ(c[0].metrics[0].difference, 1.0);
  EXPECT_DOUBLE_EQ(c[0].metrics[0].se, 0.5);
  EXPECT_DOUBLE_EQ(c[0].metrics[0].z, 2.0);
  EXPECT_TRUE(std::isnan(c[0].metrics[1].z));  // se unknown on one side
}

}  // namespace
}  // namespace granary::analysis
