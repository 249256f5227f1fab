// The avalanche analysis (key "avalanches", ch. 4, 6): the bodies that leave between the
// opening (or an unclog) and a clog, from the exit stream of all outlets together and of each
// outlet; per point the sizes pooled over replicas, their mean, distribution and exponential tail.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/analysis.h"

namespace granary::analysis {

std::unique_ptr<Analysis> MakeAvalancheAnalysis(const nlohmann::json& options, const std::string& path);

}  // namespace granary::analysis
