// The single pass over one run directory: the summary, spec and exit events are read once
// into a RunView, every analysis that has no valid cached result is started on it, and the
// frames (and contact frames) that any of them asked for are read and parsed once, their
// bodies rebuilt once, and handed to each in time order. Results are cached in the run
// directory (rundir/analysis_cache.h) under a key of the analysis' version and options, so a
// second pass reads only the cache and a changed option re-analyses only its analysis.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <vector>

#include "analysis/analysis.h"

namespace granary::analysis {

struct RunPassOptions {
  // >= 2: a second thread reads and parses the next frames (and rebuilds their bodies) while
  // the analyses consume the current one. The results are the same bits at any setting.
  int threads = 1;
  bool read_cache = true;
  bool write_cache = true;
};

struct RunPassResult {
  std::vector<nlohmann::json> results;  // per analysis, in the order given
  int from_cache = 0;                   // how many of them came from the cache
  int frames_parsed = 0;                // frames read in full (the others were skipped)
};

// Throws rundir::ReadError on a malformed run directory, or what an analysis throws.
RunPassResult AnalyseRun(const std::filesystem::path& dir, const std::vector<const Analysis*>& analyses,
                         const PassOptions& pass, const RunPassOptions& options = {});

// The RunView of a read run directory (analyses' tests start accumulators on it).
RunView MakeRunView(const rundir::RunData& data, const PassOptions& pass);

// What a cached result of `analysis` depends on besides the run: its key, version, run
// options and the pass options it uses.
nlohmann::json CacheKey(const Analysis& analysis, const PassOptions& pass);

}  // namespace granary::analysis
