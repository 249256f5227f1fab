// The adaptive-replica rule (rundir/replica_rule.h): parsing with JSON-path errors, the
// judgement of targets and the decision which points get more replicas, on constructed
// metrics with known answers.
#include "rundir/replica_rule.h"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "rundir/run_spec.h"

namespace granary {
namespace {

using nlohmann::json;

std::string ErrorPath(const json& j) {
  try {
    ReplicaRule::FromJson(j);
  } catch (const SpecError& e) {
    return e.Path();
  }
  return "(no error)";
}

TEST(ReplicaRule, ParsesAFixedCountAndTheAdaptiveBlock) {
  const ReplicaRule fixed = ReplicaRule::FromJson(json(4));
  EXPECT_FALSE(fixed.Adaptive());
  EXPECT_EQ(fixed.min, 4);
  EXPECT_EQ(fixed.max, 4);

  const ReplicaRule r = ReplicaRule::FromJson(
      json::parse(R"({"min": 5, "max": 100, "until": {"metric": "avalanche_size", "rel_se": 0.05}})"));
  ASSERT_TRUE(r.Adaptive());
  EXPECT_EQ(r.min, 5);
  EXPECT_EQ(r.max, 100);
  ASSERT_EQ(r.until.size(), 1u);
  EXPECT_EQ(r.until[0].metric, "avalanche_size");
  EXPECT_TRUE(r.until[0].relative);
  EXPECT_DOUBLE_EQ(r.until[0].value, 0.05);
  EXPECT_EQ(r.Text(), "5 replicas per point, then more until se/|avalanche_size| <= 0.05, at most 100");

  const ReplicaRule two = ReplicaRule::FromJson(json::parse(
      R"({"max": 8, "until": [{"metric": "q_count", "se": 0.1}, {"metric": "avalanche_size", "rel_se": 0.1}]})"));
  EXPECT_EQ(two.min, 2);  // the default: a standard error needs two
  ASSERT_EQ(two.until.size(), 2u);
  EXPECT_FALSE(two.until[0].relative);
}

TEST(ReplicaRule, ErrorsNameTheJsonPath) {
  EXPECT_EQ(ErrorPath(json(0)), "/replicas");
  EXPECT_EQ(ErrorPath(json("5")), "/replicas");
  EXPECT_EQ(ErrorPath(json::parse(R"({"min": 5, "until": {"metric": "a", "se": 1}})")), "/replicas/max");
  EXPECT_EQ(ErrorPath(json::parse(R"({"min": 5, "max": 4, "until": {"metric": "a", "se": 1}})")), "/replicas/max");
  EXPECT_EQ(ErrorPath(json::parse(R"({"min": 0, "max": 4, "until": {"metric": "a", "se": 1}})")), "/replicas/min");
  EXPECT_EQ(ErrorPath(json::parse(R"({"max": 4})")), "/replicas/until");
  EXPECT_EQ(ErrorPath(json::parse(R"({"max": 4, "until": []})")), "/replicas/until");
  EXPECT_EQ(ErrorPath(json::parse(R"({"max": 4, "unitl": []})")), "/replicas/unitl");
  EXPECT_EQ(ErrorPath(json::parse(R"({"max": 4, "until": {"metric": "a"}})")), "/replicas/until");
  EXPECT_EQ(ErrorPath(json::parse(R"({"max": 4, "until": {"metric": "a", "se": 1, "rel_se": 1}})")), "/replicas/until");
  EXPECT_EQ(ErrorPath(json::parse(R"({"max": 4, "until": [{"metric": "a", "se": 1}, {"metric": "b", "rel_se": -1}]})")),
            "/replicas/until/1/rel_se");
  EXPECT_EQ(ErrorPath(json::parse(R"({"max": 4, "until": {"metric": "Avalanche size", "se": 1}})")),
            "/replicas/until/metric");
  EXPECT_EQ(ErrorPath(json::parse(R"({"max": 4, "until": {"metric": "a", "se": 1, "n": 3}})")), "/replicas/until/n");
}

ReplicaRule Rule(double rel_se, int min = 5, int max = 100) {
  ReplicaRule r;
  r.min = min;
  r.max = max;
  r.until = {{"s", true, rel_se}};
  return r;
}

TEST(ReplicaRule, JudgesRelativeAndAbsoluteTargets) {
  ReplicaRule r = Rule(0.05);
  r.until.push_back({"q", false, 0.2});
  const auto t = JudgeTargets(r, {{"s", {10.0, 0.4, 50}}, {"q", {3.0, 0.3, 5}}});
  ASSERT_EQ(t.size(), 2u);
  EXPECT_TRUE(t[0].known);
  EXPECT_DOUBLE_EQ(t[0].achieved, 0.04);
  EXPECT_TRUE(t[0].met);
  EXPECT_DOUBLE_EQ(t[1].achieved, 0.3);
  EXPECT_FALSE(t[1].met);
  // No se yet (one run), a zero mean for a relative target, or a missing metric: not met.
  EXPECT_FALSE(JudgeTargets(Rule(0.05), {{"s", {10.0, NAN, 1}}})[0].met);
  EXPECT_FALSE(JudgeTargets(Rule(0.05), {{"s", {0.0, 0.0, 5}}})[0].met);
  const auto missing = JudgeTargets(Rule(0.05), {});
  EXPECT_FALSE(missing[0].known);
  EXPECT_FALSE(missing[0].met);
}

TEST(ReplicaRule, DecidesFromTheWorstTargetAtMostDoubling) {
  // rel se 0.1 after 5 runs, target 0.05: se ~ 1/sqrt(n) asks for 5 * 4 = 20, i.e. 15 more,
  // but at most as many as there are (5).
  PointReplicas p{5, 0, {{"s", {10.0, 1.0, 40}}}};
  ReplicaDecision d = DecideReplicas(Rule(0.05), p);
  EXPECT_EQ(d.verdict, ReplicaVerdict::kMore);
  EXPECT_EQ(d.add, 5);
  // rel se 0.06 after 10, target 0.05: 10 * 1.44 = 14.4 -> 15 in all, 5 more.
  p = {10, 0, {{"s", {10.0, 0.6, 80}}}};
  EXPECT_EQ(DecideReplicas(Rule(0.05), p).add, 5);
  // Just above the target: at least one more.
  p = {10, 0, {{"s", {10.0, 0.5001, 80}}}};
  EXPECT_EQ(DecideReplicas(Rule(0.05), p).add, 1);
  // Never past max.
  p = {95, 0, {{"s", {10.0, 1.0, 800}}}};
  EXPECT_EQ(DecideReplicas(Rule(0.05), p).add, 5);
  // Several targets: the worst decides.
  ReplicaRule two = Rule(0.05);
  two.until.push_back({"q", false, 0.1});
  p = {10, 0, {{"s", {10.0, 0.4, 80}}, {"q", {3.0, 0.12, 10}}}};  // s met; q: 10 * 1.44 -> 15
  EXPECT_EQ(DecideReplicas(two, p).add, 5);
}

TEST(ReplicaRule, WaitsMeetsStopsAtMaxAndRefusesUnknownMetrics) {
  PointReplicas p{5, 2, {{"s", {10.0, 1.0, 40}}}};
  EXPECT_EQ(DecideReplicas(Rule(0.05), p).verdict, ReplicaVerdict::kWaiting);
  EXPECT_EQ(DecideReplicas(Rule(0.05), p).add, 0);
  p = {5, 0, {{"s", {10.0, 0.5, 40}}}};
  EXPECT_EQ(DecideReplicas(Rule(0.05), p).verdict, ReplicaVerdict::kMet);
  p = {100, 0, {{"s", {10.0, 1.0, 800}}}};
  EXPECT_EQ(DecideReplicas(Rule(0.05), p).verdict, ReplicaVerdict::kAtMax);
  EXPECT_EQ(DecideReplicas(Rule(0.05), p).add, 0);
  p = {5, 0, {{"other", {10.0, 1.0, 40}}}};
  EXPECT_EQ(DecideReplicas(Rule(0.05), p).verdict, ReplicaVerdict::kUnknown);
  // A metric without a se yet (no avalanche, one run): one more.
  p = {1, 0, {{"s", {NAN, NAN, 0}}}};
  const ReplicaDecision d = DecideReplicas(Rule(0.05, 1), p);
  EXPECT_EQ(d.verdict, ReplicaVerdict::kMore);
  EXPECT_EQ(d.add, 1);
  EXPECT_EQ(DecideReplicas(ReplicaRule::FromJson(json(3)), p).verdict, ReplicaVerdict::kFixed);
}

// The runner applies the decision run after run: on a deterministic sequence of per-run
// values the number of replicas stops where the target is first met, or at max.
TEST(ReplicaRule, AppliedRepeatedlyStopsAtTheTarget) {
  const auto value = [](int r) { return r % 2 == 0 ? 9.0 : 11.0; };  // sd ~ 1, mean 10
  const auto point_after = [&](int n) {
    double sum = 0, sq = 0;
    for (int r = 0; r < n; ++r) sum += value(r);
    const double mean = sum / n;
    for (int r = 0; r < n; ++r) sq += (value(r) - mean) * (value(r) - mean);
    const double se = std::sqrt(sq / (n - 1) / n);
    return PointReplicas{n, 0, {{"s", {mean, se, n}}}};
  };
  for (const double target : {0.05, 0.02, 0.01}) {
    const ReplicaRule rule = Rule(target, 4, 1000);
    int n = rule.min;
    for (ReplicaDecision d; (d = DecideReplicas(rule, point_after(n))).verdict == ReplicaVerdict::kMore;) n += d.add;
    const auto t = JudgeTargets(rule, point_after(n).metrics);
    EXPECT_TRUE(t[0].met) << target;
    // Not far past the first n that meets it (the estimate asks for what se ~ 1/sqrt(n) says).
    int first = rule.min;
    while (!JudgeTargets(rule, point_after(first).metrics)[0].met) ++first;
    EXPECT_GE(n, first);
    EXPECT_LE(n, first + 2) << target;
  }
  const ReplicaRule capped = Rule(0.001, 4, 30);
  int n = capped.min;
  ReplicaDecision d;
  while ((d = DecideReplicas(capped, point_after(n))).verdict == ReplicaVerdict::kMore) n += d.add;
  EXPECT_EQ(d.verdict, ReplicaVerdict::kAtMax);
  EXPECT_EQ(n, 30);
}

}  // namespace
}  // namespace granary
