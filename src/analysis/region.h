// Region statistics above an outlet (ch. 3 and ch. 4-6): packing (area) fraction, the two
// granular temperatures and the v_x, v_y distributions. Pure functions over one frame plus
// an accumulator for time averages.
#pragma once

#include <cstddef>
#include <numbers>
#include <span>
#include <string>
#include <vector>

#include "rundir/frames.h"
#include "analysis/stats.h"

namespace granary::analysis {

struct Rect {
  double x0 = 0, x1 = 0, y0 = 0, y1 = 0;
  double Area() const { return (x1 - x0) * (y1 - y0); }
  bool Contains(double x, double y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
};

// Region size around an outlet of width W: (W + pad) x height, from the base upwards,
// centred on the outlet. Lengths in d, or in D_eq when `in_d_eq` (ch. 6's region R, whose
// size follows the body: RegionForRun in region_analysis.h turns it into d per run).
struct RegionSize {
  double pad = 2.0 * std::numbers::sqrt2;     // ch. 4-5: W + 2 sqrt(2) d
  double height = 5.0 * std::numbers::sqrt2;  // ch. 4-5: 5 sqrt(2) d
  std::string label = "ch. 4-5: (W + 2 sqrt2 d) x 5 sqrt2 d";
  bool in_d_eq = false;
};
RegionSize Chapter3Region();  // (W + 2d) x 10d
RegionSize Chapter4Region();  // (W + 2 sqrt2 d) x 5 sqrt2 d
RegionSize Chapter6Region();  // (W + 2 D_eq) x 5 D_eq
Rect RegionAboveOutlet(double center, double width, const RegionSize& size);

// Exact area of the intersection of a disc (centre cx, cy; radius r) with a rectangle.
// Used for the packing fraction so that discs cut by the region's edges count with the part
// that lies inside (no boundary bias from counting whole discs by their centres).
double DiscRectOverlap(double cx, double cy, double r, const Rect& rect);

// One frame. phi = sum of disc areas inside / region area (exact partial discs).
// Temperatures use the bodies whose centre of mass is inside:
//   tg_translational (ch. 3) = 1/2 <(v_x - <v_x>)^2 + (v_y - <v_y>)^2>
//   tg_full (ch. 4-5)        = 1/3 <m |v - <v>|^2 + I (Omega - <Omega>)^2>
// with <.> the unweighted average over those bodies in this frame. NaN with < 2 bodies.
struct RegionFrame {
  double phi = 0.0;
  double tg_translational = kNaN;
  double tg_full = kNaN;
  int bodies = 0;
};
RegionFrame MakeRegionFrame(std::span<const rundir::Disc> discs, std::span<const rundir::Body> bodies,
                            const Rect& region);

// Time average over frames: mean and se (over frames) of phi and the temperatures, and the
// distributions of the velocities of the bodies inside, over the frames added with
// `velocities` (those of steady flow: region_analysis.h).
struct RegionStats {
  Rect region;
  MeanSe phi, tg_translational, tg_full;
  GridHistogram vx, vy;  // counts of body velocities on a fixed grid (merge over replicas)
  int frames = 0;
  int velocity_frames = 0;  // the frames behind vx, vy
};

class RegionAccumulator {
 public:
  // `velocity_bin`: the grid width of the velocity histograms (sqrt(g d)).
  explicit RegionAccumulator(const Rect& region, double velocity_bin = 0.05) {
    stats_.region = region;
    stats_.vx.width = stats_.vy.width = velocity_bin;
  }
  void Add(std::span<const rundir::Disc> discs, std::span<const rundir::Body> bodies, bool velocities = true);
  RegionStats Result() const;

 private:
  RegionStats stats_;
  std::vector<double> phi_, tg_translational_, tg_full_;
};

}  // namespace granary::analysis
