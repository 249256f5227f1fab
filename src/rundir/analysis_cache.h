// DIR/analyses/<analysis>.json: one analysis' per-run result, kept in the run directory so
// that a second report reads it instead of the run's dumps (docs/run-directory.md). A cached
// result is valid while its key (the analysis' version and options) and the run's
// summary.json are unchanged; the analysis pass is its one writer and one reader.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace granary::rundir {

inline constexpr char kAnalysesDir[] = "analyses";

struct CachedResult {
  std::string analysis;      // the analysis' key
  nlohmann::json key;        // what the result depends on besides the run: version, options
  std::string summary_hash;  // hash_hex of summary.json: a run run again is analysed again
  nlohmann::json result;
};

// Writes DIR/analyses/<analysis>.json atomically (creating the folder).
void WriteCachedResult(const std::filesystem::path& dir, const CachedResult& cached);
// The cached result of `analysis`, or nothing if there is none or it cannot be read (a cache
// never fails a report: it is recomputed).
std::optional<CachedResult> ReadCachedResult(const std::filesystem::path& dir, const std::string& analysis);

}  // namespace granary::rundir
