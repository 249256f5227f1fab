// Every registered analysis over every finished run of a campaign: one pass per run (runs in
// parallel, each pass reading its cache first), the campaign view, and each analysis' point
// metrics. The report, the export, the comparison and the database all start from this.
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include "analysis/analysis.h"
#include "analysis/campaign_view.h"
#include "analysis/registry.h"

namespace granary::analysis {

struct CampaignAnalysisOptions {
  int jobs = 0;  // threads; 0 = every hardware thread
  bool read_cache = true;
  bool write_cache = true;
  // Called after each run's pass (from worker threads, one call at a time).
  std::function<void(int done, int total)> progress;
};

struct CampaignAnalysis {
  CampaignView view;
  const AnalysisSetup* setup = nullptr;
  std::vector<AnalysisResults> results;         // per analysis (setup order): per used run
  std::vector<PointMetricTable> point_metrics;  // per analysis: per point (view.points order)
  int results_from_cache = 0;                   // run x analysis results read from the caches
  int results_computed = 0;

  // The per-run metrics of used run `run` from analysis `a`.
  std::vector<Metric> RunMetrics(std::size_t a, std::size_t run) const;
  // Every analysis' point metrics of point `p`, in setup order.
  std::vector<PointMetric> AllPointMetrics(std::size_t p) const;
};

// `info` and `runs` must outlive the result (the view points into them).
std::unique_ptr<CampaignAnalysis> AnalyseCampaign(const CampaignInfo& info, const std::vector<RunRecord>& runs,
                                                  const AnalysisSetup& setup,
                                                  const CampaignAnalysisOptions& options = {});

}  // namespace granary::analysis
