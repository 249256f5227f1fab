#include "rundir/replica_rule.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <sstream>

#include "rundir/run_spec.h"

namespace granary {

using nlohmann::json;

namespace {

constexpr int kMaxReplicas = 100000;

int ReplicaCount(const json& j, const std::string& path) {
  if (!j.is_number_integer() || j.get<std::int64_t>() < 1 || j.get<std::int64_t>() > kMaxReplicas)
    throw SpecError(path, "must be an integer in [1, " + std::to_string(kMaxReplicas) + "] (got " + j.dump() + ")");
  return j.get<int>();
}

ReplicaTarget Target(const json& j, const std::string& path) {
  if (!j.is_object())
    throw SpecError(path, "must be an object {\"metric\": NAME, \"rel_se\": X} or {\"metric\": NAME, \"se\": X} (got " +
                              j.dump() + ")");
  for (const auto& [key, value] : j.items()) {
    if (key != "metric" && key != "rel_se" && key != "se")
      throw SpecError(path + "/" + key, "unknown key; allowed: metric, rel_se, se");
  }
  ReplicaTarget t;
  if (!j.contains("metric") || !j["metric"].is_string() || j["metric"].get<std::string>().empty() ||
      j["metric"].get<std::string>().find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_") != std::string::npos)
    throw SpecError(path + "/metric",
                    "must be the name of a point metric, e.g. \"avalanche_size\" (letters a-z, digits, _; got " +
                        (j.contains("metric") ? j["metric"].dump() : std::string("nothing")) + ")");
  t.metric = j["metric"];
  const bool rel = j.contains("rel_se"), abs = j.contains("se");
  if (rel == abs)
    throw SpecError(path,
                    std::string(rel ? "has both \"rel_se\" and \"se\"" : "has neither \"rel_se\" nor \"se\"") +
                        ": give one target, the relative standard error (se/|mean|) or the standard error itself");
  t.relative = rel;
  const std::string key = rel ? "rel_se" : "se";
  const json& v = j[key];
  if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() <= 0)
    throw SpecError(path + "/" + key, "must be a positive number (got " + v.dump() + ")");
  t.value = v.get<double>();
  return t;
}

std::string Number(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

}  // namespace

ReplicaRule ReplicaRule::FromJson(const json& j, const std::string& path) {
  ReplicaRule r;
  if (j.is_number()) {
    r.min = r.max = ReplicaCount(j, path);
    return r;
  }
  if (!j.is_object())
    throw SpecError(path, "must be an integer in [1, " + std::to_string(kMaxReplicas) +
                              "], or {\"min\": N, \"max\": M, \"until\": {\"metric\": NAME, \"rel_se\": X}} (got " +
                              j.dump() + ")");
  for (const auto& [key, value] : j.items()) {
    if (key != "min" && key != "max" && key != "until")
      throw SpecError(path + "/" + key, "unknown key; allowed: min, max, until");
  }
  r.min = j.contains("min") ? ReplicaCount(j["min"], path + "/min") : 2;
  if (!j.contains("max")) throw SpecError(path + "/max", "is required: the most replicas a point may get");
  r.max = ReplicaCount(j["max"], path + "/max");
  if (r.max < r.min)
    throw SpecError(path + "/max", "must be at least min (" + std::to_string(r.min) + "; got " + j["max"].dump() + ")");
  if (!j.contains("until"))
    throw SpecError(path + "/until",
                    "is required: {\"metric\": NAME, \"rel_se\": X} or a list of them (for a fixed "
                    "number of replicas write \"replicas\": N)");
  const json& u = j["until"];
  if (u.is_array()) {
    if (u.empty()) throw SpecError(path + "/until", "must name at least one target (got [])");
    for (std::size_t k = 0; k < u.size(); ++k) r.until.push_back(Target(u[k], path + "/until/" + std::to_string(k)));
  } else {
    r.until.push_back(Target(u, path + "/until"));
  }
  return r;
}

std::string ReplicaRule::Text() const {
  if (!Adaptive()) return std::to_string(min) + (min == 1 ? " replica" : " replicas") + " per point";
  std::string s = std::to_string(min) + " replicas per point, then more until ";
  for (std::size_t k = 0; k < until.size(); ++k) {
    const ReplicaTarget& t = until[k];
    s += (k == 0                  ? ""
          : k + 1 == until.size() ? " and "
                                  : ", ") +
         std::string(t.relative ? "se/|" : "se(") + t.metric + (t.relative ? "| <= " : ") <= ") + Number(t.value);
  }
  return s + ", at most " + std::to_string(max);
}

std::vector<TargetStatus> JudgeTargets(const ReplicaRule& rule, const std::map<std::string, MetricEstimate>& metrics) {
  std::vector<TargetStatus> out;
  for (const ReplicaTarget& t : rule.until) {
    TargetStatus s;
    s.target = t;
    if (const auto it = metrics.find(t.metric); it != metrics.end()) {
      s.known = true;
      s.estimate = it->second;
      const double v = s.estimate.value, se = s.estimate.se;
      if (std::isfinite(se) && se >= 0 && std::isfinite(v)) {
        if (!t.relative)
          s.achieved = se;
        else if (v != 0)
          s.achieved = se / std::fabs(v);
      }
      s.met = std::isfinite(s.achieved) && s.achieved <= t.value;
    }
    out.push_back(s);
  }
  return out;
}

const char* ToString(ReplicaVerdict v) {
  switch (v) {
    case ReplicaVerdict::kFixed: return "fixed";
    case ReplicaVerdict::kWaiting: return "waiting";
    case ReplicaVerdict::kMet: return "met";
    case ReplicaVerdict::kAtMax: return "at max";
    case ReplicaVerdict::kUnknown: return "unknown metric";
    case ReplicaVerdict::kMore: return "more";
  }
  return "?";
}

ReplicaDecision DecideReplicas(const ReplicaRule& rule, const PointReplicas& point) {
  ReplicaDecision d;
  if (!rule.Adaptive()) return d;
  d.targets = JudgeTargets(rule, point.metrics);
  if (point.unfinished > 0) {
    d.verdict = ReplicaVerdict::kWaiting;
    return d;
  }
  bool all_met = true;
  for (const TargetStatus& s : d.targets) all_met = all_met && s.met;
  if (all_met) {
    d.verdict = ReplicaVerdict::kMet;
    return d;
  }
  if (point.planned >= rule.max) {
    d.verdict = ReplicaVerdict::kAtMax;
    return d;
  }
  // A metric no analysis returns never reaches its target: planning to max would be a waste.
  for (const TargetStatus& s : d.targets) {
    if (!s.known) {
      d.verdict = ReplicaVerdict::kUnknown;
      return d;
    }
  }
  const int n = std::max(1, point.planned);
  double needed = n + 1;  // a target not judged yet: one more
  for (const TargetStatus& s : d.targets) {
    if (s.met || !std::isfinite(s.achieved)) continue;
    needed = std::max(needed, std::ceil(n * (s.achieved / s.target.value) * (s.achieved / s.target.value) - 1e-9));
  }
  const double add = std::clamp(needed - n, 1.0, static_cast<double>(n));
  d.add = std::min(static_cast<int>(add), rule.max - point.planned);
  d.verdict = ReplicaVerdict::kMore;
  return d;
}

}  // namespace granary
