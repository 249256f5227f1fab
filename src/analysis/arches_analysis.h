// The arch analysis (key "arches"; thesis ch. 3 fig. 3.4 and table 3.1, ch. 4 figs. 4.28-4.30,
// ch. 6 figs. 6.3-6.9): the arch over each sealed outlet of every clog an engine kept
// (clog_frames.dump, clog_contacts.dump; arches.h), its metrics per run and pooled per sweep
// point over arches, the pressure and the axis of arch bodies against their angular position,
// the mean arch pressure against N_t, and pictures of representative clogs.
// Options, /report/arches: {"theta_bins": 9, "axis_bins": 12, "obstacle_arches": true,
// "pictures": 1} (docs/analyses.md "Arches").
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/analysis.h"
#include "analysis/arches.h"

namespace granary::analysis {

struct ArchesOptions {
  ArchSummaryOptions summary;
  int pictures = 1;  // clogs drawn per point: those whose arch has the point's median N_t
};
// From /report/arches (null: the defaults); throws OptionError naming `path` and below.
ArchesOptions ReadArchesOptions(const nlohmann::json& options, const std::string& path);

// A run's result: {"present": whether the run has clog files, "clogs": [ToJson(ClogArches)],
// "notes": [..]}. A spec that describes no silo or malformed clog files give a note and no clogs.
nlohmann::json ArchesRunResult(const rundir::RunData& run);
// The clogs of a result.
std::vector<ClogArches> ClogsOf(const nlohmann::json& result);

// Clog `clog` (1-based) with `arch`'s bodies outlined, in a window around the arch: the
// pictures of representative clogs (figs. 3.4, 4.26, 6.3).
ClogPicture ArchPicture(int clog, const Arch& arch);

std::unique_ptr<Analysis> MakeArchesAnalysis(const nlohmann::json& options, const std::string& path);

}  // namespace granary::analysis
