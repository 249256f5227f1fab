// The region analysis (key "region", ch. 3-6): packing fraction, both granular temperatures
// and the velocity distributions in a rectangle next to each outlet, over the frames of the
// steady window. The velocity distributions (thesis figs. 3.5, 4.6) take only the frames of a
// run's steady flow window (FindFlowWindow): a run that clogs before it has one gives none, so
// that a bed at rest adds no weight at v = 0. Options, /report/region: "ch3", "ch4" (default),
// "ch6" or {"pad": .., "height": .., "unit": "d" | "D_eq"}.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/analysis.h"
#include "analysis/region.h"

namespace granary::analysis {

// The region's size from /report/region (null: ch. 4's); throws OptionError naming `path`.
RegionSize ReadRegionSize(const nlohmann::json& options, const std::string& path);

// D_eq of a run's bodies (thesis ch. 6): the diameter of the disc of a body's area,
// sqrt(D_s^2 + D_b^2) for a snowman, sqrt(2) d for a dumbbell, d for a disc. A mixture takes
// the number-weighted mean body area. Throws std::invalid_argument if `run_spec` does not
// describe the bodies.
double EquivalentDiameter(const nlohmann::json& run_spec);

// `size` in d for the run of `run_spec`: a size in D_eq scaled by the run's D_eq.
RegionSize RegionForRun(const RegionSize& size, const nlohmann::json& run_spec);

std::unique_ptr<Analysis> MakeRegionAnalysis(const nlohmann::json& options, const std::string& path);

}  // namespace granary::analysis
