#include "analysis/engine_comparison.h"

#include <algorithm>
#include <cmath>

namespace granary::analysis {

MetricAgreement agreement_of(const MetricDifference& d) {
  MetricAgreement m;
  m.difference = d;
  if (d.a.mean != 0.0 && std::isfinite(d.a.mean) && std::isfinite(d.b.mean)) {
    m.ratio = d.b.mean / d.a.mean;
    const double ra = d.a.se / d.a.mean, rb = d.b.mean != 0.0 ? d.b.se / d.b.mean : kNaN;
    m.ratio_se = std::fabs(m.ratio) * std::hypot(ra, rb);
  }
  if (std::isfinite(d.z)) m.agree = std::fabs(d.z) <= kAgreementSigmas;
  // Zero uncertainty on both sides (every replica alike, e.g. Psi = 0): equal values agree,
  // different ones do not.
  else if (d.se == 0.0 && std::isfinite(d.difference)) m.agree = d.difference == 0.0;
  // Otherwise an se is unknown (one replica): nothing can be said.
  return m;
}

std::string agreement_text(const std::optional<bool>& agree) {
  if (!agree) return "n/a";
  return *agree ? "yes" : "no";
}

EngineCost engine_cost(const std::string& engine, const std::vector<RunTiming>& runs) {
  EngineCost c;
  c.engine = engine;
  std::vector<double> rates;
  for (const RunTiming& t : runs) {
    ++c.runs;
    if (std::isfinite(t.wall_s)) c.wall_s += t.wall_s;
    if (std::isfinite(t.discharge_wall_s)) c.discharge_wall_s += t.discharge_wall_s;
    if (std::isfinite(t.disc_steps_per_s) && t.disc_steps_per_s > 0) rates.push_back(t.disc_steps_per_s);
    c.threads = std::max(c.threads, t.threads);
  }
  c.disc_steps_per_s = mean_se_finite(rates);
  return c;
}

EngineComparison compare_engines(const std::string& engine_a, const std::vector<PointMetrics>& a,
                                 const std::vector<RunTiming>& timings_a, const std::string& engine_b,
                                 const std::vector<PointMetrics>& b, const std::vector<RunTiming>& timings_b) {
  EngineComparison c;
  c.engine_a = engine_a;
  c.engine_b = engine_b;
  for (const PointComparison& pc : compare_points(a, b)) {
    PointAgreement p;
    p.point = pc.point;
    for (const MetricDifference& d : pc.metrics) p.metrics.push_back(agreement_of(d));
    c.points.push_back(std::move(p));
  }
  c.costs = {engine_cost(engine_a, timings_a), engine_cost(engine_b, timings_b)};
  return c;
}

namespace {
nlohmann::json number(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }
nlohmann::json mean_se_json(const MeanSe& m) {
  return {{"mean", number(m.mean)}, {"se", number(m.se)}, {"n", m.n}};
}
}  // namespace

nlohmann::json to_json(const EngineComparison& c) {
  nlohmann::json points = nlohmann::json::array();
  for (const PointAgreement& p : c.points) {
    nlohmann::json metrics = nlohmann::json::object();
    for (const MetricAgreement& m : p.metrics) {
      metrics[m.difference.name] = {{c.engine_a, mean_se_json(m.difference.a)},
                                    {c.engine_b, mean_se_json(m.difference.b)},
                                    {"ratio", number(m.ratio)},
                                    {"ratio_se", number(m.ratio_se)},
                                    {"z", number(m.difference.z)},
                                    {"agree", m.agree ? nlohmann::json(*m.agree) : nlohmann::json(nullptr)}};
    }
    points.push_back({{"point", p.point}, {"metrics", metrics}});
  }
  nlohmann::json costs = nlohmann::json::array();
  for (const EngineCost& e : c.costs) {
    costs.push_back({{"engine", e.engine},
                     {"runs", e.runs},
                     {"wall_s", e.wall_s},
                     {"discharge_wall_s", e.discharge_wall_s},
                     {"disc_steps_per_s", mean_se_json(e.disc_steps_per_s)},
                     {"threads", e.threads}});
  }
  return {{"engine_a", c.engine_a},
          {"engine_b", c.engine_b},
          {"ratio", c.engine_b + " / " + c.engine_a},
          {"agreement", "|z| <= " + std::to_string(static_cast<int>(kAgreementSigmas)) + " combined standard errors"},
          {"points", points},
          {"costs", costs}};
}

}  // namespace granary::analysis
