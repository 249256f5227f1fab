// The table of analyses: one row per analysis, in the order their sections appear in the
// report. Adding an analysis = its file pair plus one row here (docs/architecture.md).
#pragma once

#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/analysis.h"

namespace granary::analysis {

struct AnalysisEntry {
  std::string key;  // also the analysis' options key: /report/<key>
  // Makes the analysis from its options (null json when /report/<key> is absent); returns
  // nullptr for an analysis that is off (one that runs only when asked for, like "fields").
  // Throws OptionError naming `path` and below.
  std::function<std::unique_ptr<Analysis>(const nlohmann::json& options, const std::string& path)> make;
  // Instead of `make`, for a row whose options name several analyses, each with its own key
  // (/report/python: one analysis per script, python_analysis.h).
  std::function<std::vector<std::unique_ptr<Analysis>>(const nlohmann::json& options, const std::string& path)>
      make_all = {};
  // The point metrics the analysis can return, for checking a spec's figures, expectations and
  // replica targets before anything runs: names, or families "prefix*" (per-outlet variants,
  // one per region or field). Empty: known only when it runs (Python). A test holds these
  // lists to what the analyses return on stored runs.
  std::vector<std::string> metrics = {};
};

// Whether `name` is one of row's metrics (a name, or a name a family "prefix*" covers).
bool OffersMetric(const AnalysisEntry& row, const std::string& name);

// The built-in table.
const std::vector<AnalysisEntry>& BuiltinAnalyses();
// The table in use: the built-in rows, then rows added by ScopedAnalysis.
std::vector<AnalysisEntry> RegisteredAnalyses();

// Adds a row for the lifetime of the object (tests register an analysis of their own).
class ScopedAnalysis {
 public:
  explicit ScopedAnalysis(AnalysisEntry entry);
  ~ScopedAnalysis();
  ScopedAnalysis(const ScopedAnalysis&) = delete;
  ScopedAnalysis& operator=(const ScopedAnalysis&) = delete;

 private:
  std::string key_;
};

// The analyses of a campaign, configured from its spec's /report object: the shared pass
// options (window, clog_gap, frame_stride, max_frames) and one Analysis per table row.
struct AnalysisSetup {
  PassOptions pass;
  std::vector<std::unique_ptr<Analysis>> analyses;
  std::vector<const Analysis*> List() const;
};

// Throws OptionError naming the JSON path (unknown keys list the known ones).
AnalysisSetup SetupAnalyses(const nlohmann::json& campaign_spec);

}  // namespace granary::analysis
