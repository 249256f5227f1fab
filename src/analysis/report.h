// `campaign report`: turns finished runs into report.md, report.html, figures and CSVs.
// The runner queries its database and hands the runs over as plain records; this layer
// never touches SQLite, and every analysis it calls is a pure function over a run's output.
#pragma once

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/fit.h"
#include "analysis/run_analysis.h"

namespace granary::analysis {

// One run of the campaign as the runner knows it.
struct RunRecord {
  std::string run_id;
  std::string state;              // planned, running, done, failed, interrupted, retired
  std::string engine;             // native or liggghts
  std::string point_id;           // id of the sweep point (runs differing only by replica share it)
  int replica = 0;
  nlohmann::json point;           // the sweep-axis values of this point, e.g. {"/silo/base_outlets/0/width": 10}
  nlohmann::json spec;            // the resolved run spec (run.json)
  std::filesystem::path run_dir;  // absolute
  std::string failure;            // failed runs: reason and log tail
};

struct CampaignInfo {
  std::string name;
  std::string spec_hash;
  nlohmann::json spec;            // the campaign spec as planned
  std::vector<std::string> axes;  // sweep axes (JSON pointers into the run spec), in spec order
  std::string granary_version;
  std::string git_commit;
};

struct ReportOptions {
  std::filesystem::path out_dir;  // created if missing
  bool figures = true;            // run gnuplot (off in quick tests)
  AnalysisOptions analysis;       // window, clog threshold, region size, ...
  // Extra models fitted to Q against the first outlet's W/d (besides the Beverloo forms);
  // campaign spec /report/models (array of {name, expression, variable, initial}) adds more.
  std::vector<FitModel> models;
  std::string gnuplot = "gnuplot";  // the executable
  // Draws a run for "The system": its first frame (the bed before the outlets open) or its last,
  // as a PNG at `png`; returns "" or why it could not. The runner sets it (src/render); unset,
  // the report has no pictures and says so.
  enum class Picture { kBed, kEnd };
  std::function<std::string(const std::filesystem::path& run_dir, Picture, const std::filesystem::path& png)> draw_run;
};

struct ReportSummary {
  int runs_used = 0;
  int runs_missing = 0;           // planned/running/interrupted
  int runs_failed = 0;
  std::filesystem::path markdown;
  std::filesystem::path html;
  nlohmann::json comparison;      // runs on two engines: analysis::to_json(EngineComparison), else null
};

// Reads the campaign spec's optional "/report" object into `options` (models, region,
// clog_gap, window, profile, min_exits_before_clog, frame_stride, max_frames); write_report
// calls it (applying it twice is harmless). Throws std::invalid_argument naming the JSON
// path and the bad value.
void apply_report_spec(const nlohmann::json& campaign_spec, ReportOptions& options);

ReportSummary write_report(const CampaignInfo& campaign, const std::vector<RunRecord>& runs,
                           const ReportOptions& options);

}  // namespace granary::analysis
