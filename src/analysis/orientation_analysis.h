// The orientation analysis (key "orientation"; thesis ch. 4 fig. 4.3, ch. 5 fig. 5.5, ch. 6
// fig. 6.5): the long axes of elongated bodies (orientation.h) in the bed before the opening
// (the first frame at t <= 0), during steady flow (the frames of the pass' steady window) and
// in the arches of the kept clogs; the mean acute angle against s at chosen heights and against
// the angular position at chosen radii, the order parameter in chosen regions against their
// directors, and the distribution of axis angles in a window at a chosen angular position and
// radius. Options under /report/orientation (docs/analyses.md "Orientation"); angles in degrees.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/analysis.h"
#include "analysis/orientation.h"

namespace granary::analysis {

struct OrientationAnalysisOptions {
  OrientationOptions where;
  int outlet = 0;  // positions relative to this outlet (event order)
  // Region bounds given as expressions over the campaign's axes (thesis fig. 5.5: 10 < y <
  // W - 5 with W the point's outlet width), evaluated per run; where.regions holds NaN there
  // until then.
  struct Bound {
    std::size_t region = 0;
    int side = 0;      // 0 x0, 1 x1, 2 y0, 3 y1
    std::string text;  // "W_s - 5"
    std::string path;  // "/report/orientation/regions/0/y/1", for messages
  };
  std::vector<Bound> bounds;
};
// From /report/orientation (null: the defaults, heights 5 and 10 d, radii 5 and 10 d). Throws
// OptionError naming `path` and below.
OrientationAnalysisOptions ReadOrientationOptions(const nlohmann::json& options, const std::string& path);

nlohmann::json to_json(const OrientationSums& sums);
OrientationSums OrientationSumsFromJson(const nlohmann::json& j);

std::unique_ptr<Analysis> MakeOrientationAnalysis(const nlohmann::json& options, const std::string& path);

}  // namespace granary::analysis
