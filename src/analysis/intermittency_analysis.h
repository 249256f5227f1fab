// The intermittency analysis (key "intermittency", ch. 7): each outlet's exit stream cut into
// flowing and clogged stretches; per point the mean flowing and clogged times <t_f>, <t_c>
// pooled over replicas and the unclogging rate N_u.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/analysis.h"

namespace granary::analysis {

std::unique_ptr<Analysis> MakeIntermittencyAnalysis(const nlohmann::json& options, const std::string& path);

}  // namespace granary::analysis
