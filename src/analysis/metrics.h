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
};

// A point's analysed runs.
struct PointRuns {
  std::string point_id;
  nlohmann::json point;
  std::vector<const RunAnalysis*> runs;
};

// Pure: aggregates already-analysed runs. Replica means use the runs where the quantity is
// defined (n says how many).
PointMetrics point_metrics(const PointRuns& point, const AnalysisOptions& options);

// Groups runs by point_id (in first-appearance order), analyses the finished ones (state
// "done") and aggregates. Runs that cannot be read are skipped.
std::vector<PointMetrics> compute_point_metrics(const std::vector<RunRecord>& runs, const AnalysisOptions& options);

}  // namespace granary::analysis
