// Per-sweep-point metrics: flow rate, packing fraction and granular temperatures above the
// outlet, clogging index and mean avalanche size, each as mean, standard error and n over
// the point's replicas. The entry point of `campaign compare` and of the report's tables.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/report.h"
#include "analysis/run_analysis.h"
#include "analysis/stats.h"

namespace granary::analysis {

// The same numbers for one outlet (runs with several outlets: ch. 5, 7), over replicas.
struct OutletMetrics {
  std::string label;                  // "base 0", "side 1 (right)"
  MeanSe q_count;                     // through this outlet
  MeanSe q_mass;
  MeanSe phi;                         // region next to this outlet
  MeanSe tg_translational;
  MeanSe tg_full;
  MeanSe v_max;
  MeanSe avalanche_size;              // exits between clogs of this outlet, pooled (n = avalanches)
  IntermittencyStats intermittency;   // t_f, t_c, N_u of this outlet, pooled over replicas
};

struct PointMetrics {
  std::string point_id;
  nlohmann::json point;               // sweep-axis values
  int runs = 0;                       // analysed runs (replicas) at this point
  MeanSe q_count;                     // bodies per sqrt(d/g), over replicas
  MeanSe q_mass;                      // mass per sqrt(d/g)
  MeanSe phi;                         // packing fraction in the region above outlet 0
  MeanSe tg_translational;            // ch. 3 definition
  MeanSe tg_full;                     // ch. 4-5 definition
  MeanSe v_max;
  ClogIndex clogging;                 // Psi (remove mode only; n = 0 otherwise)
  MeanSe avalanche_size;              // pooled over every avalanche of every replica (n = avalanches)
  std::vector<OutletMetrics> per_outlet;  // every outlet, in event order (base, then side outlets)
};

// A point's analysed runs.
struct PointRuns {
  std::string point_id;
  nlohmann::json point;
  std::vector<const RunAnalysis*> runs;
};

// Pure: aggregates already-analysed runs. Replica means use the runs where the quantity is
// defined (n says how many). `stagnant_fallback` (>= 0) is the N_u of eq. 3.1 to use when
// none of the point's own runs discharged freely (every run clogged); the caller takes it
// from comparable points (same silo, other widths). < 0: N_u = 0 in that case.
PointMetrics point_metrics(const PointRuns& point, const AnalysisOptions& options, double stagnant_fallback = -1.0,
                           const std::string& fallback_note = "");

// Mean number left in the silo by the runs that discharged without clogging (remove mode),
// or -1 if there are none: the stagnant-zone count N_u of eq. 3.1.
double stagnant_count(const std::vector<const RunAnalysis*>& runs);

// One metric of one sweep point in two campaigns (e.g. the native engine against LIGGGHTS):
// difference a - b, its standard error sqrt(se_a^2 + se_b^2) and z = difference / se
// (NaN when an se is unknown).
struct MetricDifference {
  std::string name;                   // "q_count", "phi", ...
  MeanSe a, b;
  double difference = kNaN;
  double se = kNaN;
  double z = kNaN;
};
struct PointComparison {
  nlohmann::json point;               // the sweep values both campaigns share
  std::string point_id_a, point_id_b;
  std::vector<MetricDifference> metrics;  // only metrics defined in both
};
// Pure. Points are matched by their sweep values (`point`), not by id; points present in
// only one list are left out.
std::vector<PointComparison> compare_points(const std::vector<PointMetrics>& a, const std::vector<PointMetrics>& b);

// Groups runs by point_id (in first-appearance order), analyses the finished ones (state
// "done") and aggregates. Runs that cannot be read are skipped. Points where every run
// clogged take N_u from all freely discharging runs of the campaign.
std::vector<PointMetrics> compute_point_metrics(const std::vector<RunRecord>& runs, const AnalysisOptions& options);

}  // namespace granary::analysis
