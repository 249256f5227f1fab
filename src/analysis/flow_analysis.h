// The flow analysis (key "flow"): the flow rate Q of every run over its steady window, of all
// outlets together and through each outlet, the cumulative exits; per point Q against the x
// axis with the Beverloo, free-exponent and Mankoc fits and user models per group.
// Options, /report/flow: {"models": [{"name", "expression", "variable", "initial"}]}.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/analysis.h"

namespace granary::analysis {

std::unique_ptr<Analysis> MakeFlowAnalysis(const nlohmann::json& options, const std::string& path);

}  // namespace granary::analysis
