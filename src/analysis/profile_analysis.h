// The velocity-profile analysis (key "profile", ch. 4, 5): body velocities across each outlet
// in a band above its wall, binned in x/W over the frames of the steady window; V_max = max |v_y|.
// Options, /report/profile: {"bins": 16, "band_low": 0, "band_high": 2}.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/analysis.h"

namespace granary::analysis {

std::unique_ptr<Analysis> MakeProfileAnalysis(const nlohmann::json& options, const std::string& path);

}  // namespace granary::analysis
