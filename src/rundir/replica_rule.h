// Adaptive replicas (docs/campaign-spec.md "Replicas"): the campaign spec's `replicas` as a
// rule — `min` runs per sweep point, more until every target metric's standard error is small
// enough, at most `max` — and the one decision that applies it, as pure functions. The runner
// applies DecideReplicas() after each finished run; `campaign status` and the report show
// JudgeTargets(). It lives here, beside the run spec, because the runner (which plans by
// it) and the analysis library (whose report states it) both read it and neither links the
// other.
#pragma once

#include <cmath>
#include <limits>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

namespace granary {

struct ReplicaTarget {
  std::string metric;    // a point metric of the analyses, e.g. "avalanche_size"
  bool relative = true;  // true: se/|value| <= value ("rel_se"); false: se <= value ("se")
  double value = 0;      // the target (> 0)
};

struct ReplicaRule {
  int min = 1;
  int max = 1;
  std::vector<ReplicaTarget> until;  // empty: a fixed number of replicas (min == max)

  bool Adaptive() const { return !until.empty(); }
  // `replicas` of a campaign spec: an integer N (fixed: min = max = N) or
  // {"min", "max", "until": {"metric", "rel_se" | "se"} or a list of them}. Throws SpecError
  // naming the JSON path under `path` (e.g. "/replicas/until/1/rel_se").
  static ReplicaRule FromJson(const nlohmann::json& j, const std::string& path = "/replicas");
  // The stopping rule in words, for plan, status and the report.
  std::string Text() const;
};

// A point metric as the analyses aggregate it (mean ± se over the point's replicas, or pooled).
struct MetricEstimate {
  double value = std::numeric_limits<double>::quiet_NaN();
  double se = std::numeric_limits<double>::quiet_NaN();
  int n = 0;
};

struct TargetStatus {
  ReplicaTarget target;
  MetricEstimate estimate;
  bool known = false;  // the analyses return this metric for the point
  // se or se/|value| (what the target bounds); NaN while it cannot be judged (no value, no se)
  double achieved = std::numeric_limits<double>::quiet_NaN();
  bool met = false;
};

// Every target of `rule` judged against a point's metrics.
std::vector<TargetStatus> JudgeTargets(const ReplicaRule& rule, const std::map<std::string, MetricEstimate>& metrics);

// What the runner knows of one sweep point.
struct PointReplicas {
  int planned = 0;     // runs of the point in the database (not retired): replicas 0..planned-1
  int unfinished = 0;  // of those, not yet ended (planned, running, interrupted, queued)
  std::map<std::string, MetricEstimate> metrics;  // its point metrics over the ended runs
};

enum class ReplicaVerdict {
  kFixed,    // not adaptive
  kWaiting,  // runs of the point are still to end: they decide first
  kMet,      // every target met
  kAtMax,    // max replicas planned and a target not met
  kUnknown,  // a target's metric is not among the point's metrics (a typo, or no analysis returns it)
  kMore,     // replicas added
};
const char* ToString(ReplicaVerdict v);

struct ReplicaDecision {
  ReplicaVerdict verdict = ReplicaVerdict::kFixed;
  int add = 0;  // replicas to plan now: planned .. planned+add-1
  std::vector<TargetStatus> targets;
};

// The decision for one point. More replicas only when every run of the point has ended and a
// target is not met: as many as se ~ 1/sqrt(n) says the worst target needs
// (n_needed = n * (achieved/target)^2 over the point's `planned` runs), at least 1, at most as
// many as it has (no more than doubling on a noisy se), and never past `max`. A target that
// cannot be judged yet (no se: a single run, no avalanche) asks for one more.
ReplicaDecision DecideReplicas(const ReplicaRule& rule, const PointReplicas& point);

}  // namespace granary
