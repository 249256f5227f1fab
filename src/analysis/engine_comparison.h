// `campaign compare`: the same sweep points on two engines, metric by metric, and what each
// engine cost. Pure functions over already-aggregated point metrics and per-run timings; the
// report renders the result and the CLI prints it (text or JSON).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/metrics.h"

namespace granary::analysis {

// One metric of one point on both engines: b / a with its standard error (first-order
// propagation of both se), and agreement within the combined uncertainty.
struct MetricAgreement {
  MetricDifference difference;        // a - b, its se and z
  double ratio = kNaN;                // b / a
  double ratio_se = kNaN;
  // |z| <= kAgreementSigmas; nullopt when it cannot be judged (no standard error on one side:
  // a single replica), which is neither agreement nor disagreement.
  std::optional<bool> agree;
};

// "yes", "no" or "n/a" (agreement unknown), as tables and the CLI show it.
std::string agreement_text(const std::optional<bool>& agree);

struct PointAgreement {
  nlohmann::json point;               // sweep values shared by both engines
  std::vector<MetricAgreement> metrics;
};

// What one engine cost over the compared runs: wall time and throughput of the discharge
// (disc-steps per second, disc = one sphere of a LIGGGHTS multisphere body).
struct RunTiming {
  double wall_s = kNaN;               // bed + discharge
  double discharge_wall_s = kNaN;
  double disc_steps_per_s = kNaN;
  int threads = 0;
};
struct EngineCost {
  std::string engine;
  int runs = 0;
  double wall_s = 0.0;                // sum over runs
  double discharge_wall_s = 0.0;
  MeanSe disc_steps_per_s;            // over runs
  int threads = 0;                    // per run (the largest seen)
};

struct EngineComparison {
  std::string engine_a, engine_b;     // ratios are b / a
  std::vector<PointAgreement> points;
  std::vector<EngineCost> costs;      // a, then b
};

// Two engines agree on a metric when their difference is within this many combined
// standard errors (about 95 % for normal errors).
constexpr double kAgreementSigmas = 2.0;

MetricAgreement agreement_of(const MetricDifference& d);
EngineCost engine_cost(const std::string& engine, const std::vector<RunTiming>& runs);
// Points are matched by their sweep values; points on only one engine are left out.
EngineComparison compare_engines(const std::string& engine_a, const std::vector<PointMetrics>& a,
                                 const std::vector<RunTiming>& timings_a, const std::string& engine_b,
                                 const std::vector<PointMetrics>& b, const std::vector<RunTiming>& timings_b);

// JSON of the comparison; an unknown agreement is null (not false), as are NaN numbers.
nlohmann::json to_json(const EngineComparison& c);

}  // namespace granary::analysis
