// The region analysis (key "region", ch. 3-6): packing fraction, both granular temperatures
// and the velocity distributions in a rectangle next to each outlet, over the frames of the
// steady window. The velocity distributions (thesis figs. 3.5, 4.6) take only the frames of a
// run's steady flow window (FindFlowWindow): a run that clogs before it has one gives none, so
// that a bed at rest adds no weight at v = 0. Options, /report/region: "ch3", "ch4" (default)
// or {"pad": .., "height": ..}.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/analysis.h"
#include "analysis/region.h"

namespace granary::analysis {

// The region's size from /report/region (null: ch. 4's); throws OptionError naming `path`.
RegionSize ReadRegionSize(const nlohmann::json& options, const std::string& path);

std::unique_ptr<Analysis> MakeRegionAnalysis(const nlohmann::json& options, const std::string& path);

}  // namespace granary::analysis
