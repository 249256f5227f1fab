// `campaign report`: report.md, report.html, figures and numeric CSVs of a campaign's finished
// runs. The runner queries its database and hands the runs over as plain records; this layer
// never touches SQLite. The report opens with the reproduction table (Key results, the spec's
// /expect) and the spec's figures (/report/figures), then each registered analysis' section in
// table order (registry.h), the engine comparison when the runs come from two engines, the
// campaign view's own sections (the system, runs, provenance, per-run results) and a gallery
// of every point.
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/campaign_analysis.h"
#include "analysis/campaign_view.h"

namespace granary::analysis {

struct ReportOptions {
  std::filesystem::path out_dir;     // created if missing
  bool figures = true;               // run gnuplot (off in quick tests)
  std::string gnuplot = "gnuplot";   // the executable
  CampaignAnalysisOptions analysis;  // threads, cache, progress
  // Draws a run for "The system" and the pictures figures: its first frame (the bed before the
  // outlets open) or its last, with a figure's marks, as a PNG at `png`; returns "" or why it
  // could not. The runner sets it (src/render); unset, the report has no pictures and says so.
  enum class Picture { kBed, kEnd };
  struct RunPicture {
    Picture kind = Picture::kEnd;
    std::vector<PictureMark> marks;
    bool colour_by_disc = false;
    std::optional<std::array<double, 4>> window;  // x_lo, x_hi, y_lo, y_hi (d): a zoom; else the whole silo
  };
  std::function<std::string(const std::filesystem::path& run_dir, const RunPicture& picture,
                            const std::filesystem::path& png)>
      draw_run;
  // Draws a kept clog with its arch outlined (the arches section); set by the runner like draw_run.
  DrawClog draw_clog;
};

struct ReportSummary {
  int runs_used = 0;
  int runs_missing = 0;        // planned/running/interrupted
  int runs_failed = 0;         // failed, or finished but unreadable
  int runs_lost = 0;           // done, but their run directories were deleted afterwards
  int runs_damaged = 0;        // done, but a file differs from the engine's manifest: not used
  int runs_unverifiable = 0;   // used, but written before manifests (not verifiable)
  int results_from_cache = 0;  // run x analysis results read from the run directories' caches
  int results_computed = 0;
  std::filesystem::path markdown;
  std::filesystem::path html;
  nlohmann::json comparison;  // runs on two engines: analysis::ToJson(EngineComparison), else null
  std::string expectations;   // the spec has /expect: "7 agree, 1 disagrees, 3 not yet"; else ""
};

// Checks the campaign spec's /report object (throws OptionError naming the JSON path).
void CheckReportSpec(const nlohmann::json& campaign_spec);

// Analyses every finished run (setup from campaign.spec's /report) and writes the report.
ReportSummary WriteReport(const CampaignInfo& campaign, const std::vector<RunRecord>& runs,
                          const ReportOptions& options);
// The report of an analysed campaign.
ReportSummary WriteReport(const CampaignAnalysis& analysis, const ReportOptions& options);

}  // namespace granary::analysis
