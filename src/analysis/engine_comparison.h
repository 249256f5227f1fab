// `campaign compare`: the same sweep points on two engines, every point metric of every
// registered analysis, and what each engine cost. Pure functions over already-aggregated
// point metrics and per-run timings; its report section is here too, and the CLI prints the
// result (text or JSON).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/analysis.h"
#include "analysis/campaign_view.h"
#include "analysis/report_document.h"

namespace granary::analysis {

// One metric of one sweep point in two campaigns (e.g. the native engine against LIGGGHTS):
// difference a - b, its standard error sqrt(se_a^2 + se_b^2) and z = difference / se
// (NaN when an se is unknown).
struct MetricDifference {
  std::string name;  // "q_count", "phi", ...
  MeanSe a, b;
  double difference = kNaN;
  double se = kNaN;
  double z = kNaN;
  std::string title{};
  bool headline = false;
};

// The point metrics of one point of one engine.
struct EnginePoint {
  nlohmann::json point;  // sweep values (without the engine)
  std::string point_id;
  std::vector<PointMetric> metrics;
};

struct PointComparison {
  nlohmann::json point;  // the sweep values both campaigns share
  std::string point_id_a, point_id_b;
  std::vector<MetricDifference> metrics;  // only metrics defined in both
};
// Pure. Points are matched by their sweep values (`point`), not by id; points present in
// only one list are left out. Metrics that are not to be compared (PointMetric::compare) are too.
std::vector<PointComparison> ComparePoints(const std::vector<EnginePoint>& a, const std::vector<EnginePoint>& b);

// One metric of one point on both engines: b / a with its standard error (first-order
// propagation of both se), and agreement within the combined uncertainty.
struct MetricAgreement {
  MetricDifference difference;  // a - b, its se and z
  double ratio = kNaN;          // b / a
  double ratio_se = kNaN;
  // |z| <= kAgreementSigmas; nullopt when it cannot be judged (no standard error on one side:
  // a single replica), which is neither agreement nor disagreement.
  std::optional<bool> agree;
};

// "yes", "no" or "n/a" (agreement unknown), as tables and the CLI show it.
std::string AgreementText(const std::optional<bool>& agree);

struct PointAgreement {
  nlohmann::json point;  // sweep values shared by both engines
  std::string name{};    // as the report names it ("W = 15, shape = disc"); "" unknown
  std::vector<MetricAgreement> metrics;
};

// What one engine cost over the compared runs: wall time and throughput of the discharge
// (disc-steps per second, disc = one sphere of a LIGGGHTS multisphere body).
struct EngineCost {
  std::string engine;
  int runs = 0;
  double wall_s = 0.0;  // sum over runs
  double discharge_wall_s = 0.0;
  MeanSe disc_steps_per_s;  // over runs
  int threads = 0;          // per run (the largest seen)
};

struct EngineComparison {
  std::string engine_a, engine_b;  // ratios are b / a
  std::vector<PointAgreement> points;
  std::vector<EngineCost> costs;  // a, then b
};

// Two engines agree on a metric when their difference is within this many combined
// standard errors (about 95 % for normal errors).
constexpr double kAgreementSigmas = 2.0;

MetricAgreement AgreementOf(const MetricDifference& d);
EngineCost SumEngineCost(const std::string& engine, const std::vector<RunTiming>& runs);
// Points are matched by their sweep values; points on only one engine are left out.
EngineComparison CompareEngines(const std::string& engine_a, const std::vector<EnginePoint>& a,
                                const std::vector<RunTiming>& timings_a, const std::string& engine_b,
                                const std::vector<EnginePoint>& b, const std::vector<RunTiming>& timings_b);

// JSON of the comparison; an unknown agreement is null (not false), as are NaN numbers.
nlohmann::json to_json(const EngineComparison& c);

// The comparison of the first two engines of a campaign (native is `a` when present), from
// every analysis' point metrics per point (CampaignView::points order); nothing with one engine.
std::optional<EngineComparison> EngineComparisonOf(const CampaignView& view,
                                                   const std::vector<std::vector<PointMetric>>& metrics);
// Its report section.
std::optional<Section> EngineComparisonSection(const CampaignView& view, const EngineComparison& comparison);

}  // namespace granary::analysis
