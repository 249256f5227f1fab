// The clogging-index analysis (key "clogging_index", ch. 3 eq. 3.1), remove mode: per run
// whether it clogged and how many bodies it left; per point Psi with N_u, the stagnant count,
// from the point's freely discharging runs (else its group's, else the campaign's).
// Options, /report/clogging_index: none. Runs that clogged before
// /report/window/min_exits_before_clog exits (default 100) are discarded.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/analysis.h"

namespace granary::analysis {

std::unique_ptr<Analysis> MakeCloggingIndexAnalysis(const nlohmann::json& options, const std::string& path);

}  // namespace granary::analysis
