// `campaign show RUN` and `campaign clean`: what one run is and holds, and what a campaign can
// give back to the disk. Library functions over the database and the run directories; the
// CLI formats them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "runner/campaign_db.h"
#include "runner/store.h"

namespace granary::runner {

// Everything about one run: its row, parameters, the results ingested from summary.json,
// the files of its directory and the tail of engine.log. JSON keys: docs/cli.md "campaign show".
nlohmann::json RunDetails(Store& store, const RunRow& run, int log_lines = 20);

// Bytes of a file, or of everything under a directory (0 if it does not exist).
std::uintmax_t DiskBytes(const std::filesystem::path& path);

// "12.3 MB", "512 B": decimal units, three significant digits.
std::string HumanBytes(std::uintmax_t bytes);

struct CleanOptions {
  bool retired = true;    // directories of retired runs (no longer in the spec)
  bool failed = false;    // directories of failed runs (they start afresh when run again)
  bool beds = false;      // cached beds only this campaign's finished or retired runs use
  bool locks = true;      // lock files nobody holds (bed cache, run directories of runs not running)
  bool frames = false;    // frames and contact frames of done runs whose analyses are cached
  std::string cache_dir;  // the prepared-bed cache
};

struct CleanItem {
  std::string kind;  // "retired", "failed", "bed", "lock", "frames"
  std::filesystem::path path;
  std::string run_id;  // for run directories
  std::uintmax_t bytes = 0;
};

// What clean would remove (nothing is touched). `frames_kept`, if given, gets the done runs
// whose frames --frames keeps, as "RUN_ID: why" (no analysis cached yet; no manifest).
std::vector<CleanItem> PlanClean(Store& store, const CleanOptions& options,
                                 std::vector<std::string>* frames_kept = nullptr);

// The analyses cached in a run directory (DIR/analyses/<key>.json), by key.
std::vector<std::string> CachedAnalyses(const std::filesystem::path& run_dir);

// Removes the items; a retired run's results are forgotten (forget_retired_results) so that a
// later plan that brings it back runs it again; a dropped frames file is recorded in its run's
// manifest.json ("dropped", rundir::RecordDropped). Returns the bytes freed.
std::uintmax_t ExecuteClean(Store& store, const std::vector<CleanItem>& items);

}  // namespace granary::runner
