// The outlets of a run spec in event order (base outlets, then side outlets) and each
// outlet's own coordinates, so that one region and profile code serves base and lateral
// outlets (ch. 5a).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "rundir/frames.h"

namespace granary::analysis {

struct OutletGeometry {
  bool base = true;     // base outlet (x centre, width) or side outlet
  double center = 0.0;  // base: x of the centre; side: y of the centre
  double width = 10.0;
  bool right_wall = true;  // side outlets: in the right (x = +silo/2) or left wall
  double wall_x = 50.0;    // side outlets: x of that wall
  std::string label;       // "base 0", "side 1 (right)"
};
// Outlets of a resolved run spec in event order: base outlets, then side outlets. Missing
// keys take the run-spec defaults (one base outlet of width 10 at x = 0, silo width 100).
std::vector<OutletGeometry> OutletsOf(const nlohmann::json& spec);

// Edge-to-edge gap between base outlets 0 and 1 (L of ch. 5b and 7; L = 0 is one outlet of
// twice the width), or nothing if the spec has fewer than two base outlets.
std::optional<double> BaseOutletGap(const nlohmann::json& spec);

// Positions and velocities in the outlet's own frame: x = along the outlet from its centre,
// y = distance from the outlet's wall into the silo, v likewise (outflow has v_y < 0). The map
// is a rigid rotation or reflection, so packing fractions and temperatures are unchanged.
void ToOutletFrame(const OutletGeometry& outlet, std::vector<rundir::Disc>& discs, std::vector<rundir::Body>& bodies);

// The name suffix of outlet k's metrics: "_outlet<k>".
std::string OutletSuffix(std::size_t k);

}  // namespace granary::analysis
