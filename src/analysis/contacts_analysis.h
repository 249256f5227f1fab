// The contact statistics of clogged systems (key "contacts"; thesis ch. 6 fig. 6.8): in every
// clog an engine kept, the contacts between discs of different bodies by the size class of the
// two discs (small-small, large-small, large-large; arches.h ContactTypes), as fractions per
// clog, pooled per sweep point (mean ± se over clogs). No options.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/analysis.h"

namespace granary::analysis {

// A run's result: {"present", "clogs": [{"timestep", "time", "small_small", "large_small",
// "large_large", "other"}], "notes"}.
nlohmann::json ContactsRunResult(const rundir::RunData& run);

std::unique_ptr<Analysis> MakeContactsAnalysis(const nlohmann::json& options, const std::string& path);

}  // namespace granary::analysis
