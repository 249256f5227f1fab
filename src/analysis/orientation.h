// Orientation of elongated bodies (thesis ch. 4 fig. 4.3, ch. 5 fig. 5.5, ch. 6 figs. 6.5-6.6;
// docs/analyses.md "Orientation"). Pure functions over bodies rebuilt from their discs.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "analysis/stats.h"
#include "silo/geometry.h"
#include "rundir/frames.h"

namespace granary::analysis {

// The long axis of a body: the line through the centres of its two discs furthest apart (a
// dumbbell's, a snowman's or a rod's axis; whatever order the engine numbered its discs in).
struct BodyAxis {
  bool elongated = false;  // two discs or more (a disc has no axis)
  double angle = kNaN;     // the axis' angle with the horizontal, in [0, pi)
  // Snowmen (discs of two sizes): the direction from the centre of the big disc to the centre
  // of the small one (where the head points), in [0, 2 pi); NaN when the end discs are equal.
  double head = kNaN;
};
// The axes of the bodies of `discs`, in the order of rundir::BodiesOf (by body id).
std::vector<BodyAxis> BodyAxes(const std::vector<rundir::Disc>& discs);
BodyAxis AxisOf(const std::vector<const rundir::Disc*>& body_discs);

// The acute angle of an axis with the horizontal, [0, pi/2]: what the thesis' mean orientation
// against position averages (fig. 4.3: 90 degrees is vertical whichever way it leans).
double Acute(double axis_angle);

// The order parameter S = 2 <cos^2(angle - director)> - 1 of axis angles against a director
// (radians): 1 all along it, -1 all across it, 0 for isotropic axes (fig. 5.5). NaN when empty.
double OrderParameter(const std::vector<double>& axis_angles, double director);

// The angular position of a point around an outlet's centre, atan2(h, s) in the outlet's frame
// (s along the outlet, h into the silo): 0 on the base on the s > 0 side, pi/2 straight above
// the centre, pi on the base on the s < 0 side (the thesis' theta, figs. 4.3c and 6.5c).
double AngularPosition(double s, double h);

// Where orientation is measured. Lengths in d; positions relative to an outlet in its frame
// (s along it from its centre, h into the silo), regions in silo coordinates; angles in
// radians here (the campaign spec takes degrees).
struct OrientationOptions {
  // Fig. 4.3a: the mean acute orientation against s in bands h +- band/2 at these heights.
  std::vector<double> heights = {2, 5, 10, 20};
  double band = 2.0;
  double s_range = 0.0;  // bins over [-s_range, s_range]; 0: the silo's half width
  int s_bins = 24;
  // Fig. 4.3b: against the angular position theta in [0, pi], in rings r +- ring/2 around the
  // outlet's centre.
  std::vector<double> radii = {5, 10, 15};
  double ring = 2.0;
  int theta_bins = 18;
  // Fig. 5.5: the order parameter in rectangles against a director: a fixed angle, or the flow
  // direction (the thesis' "director vector which indicates the flow direction"), resolved from
  // the region's mean body velocity over the same frames (FlowDirection).
  struct Region {
    std::string name;
    double x0 = 0, x1 = 0, y0 = 0, y1 = 0;
    double director = 1.5707963267948966;  // vertical; unused when flow_director
    bool flow_director = false;
  };
  std::vector<Region> regions;  // empty: the region above the outlet (|s| < 5, 0 < h < 10), vertical
  // Fig. 6.5: distributions of the axis angle in a window at angular position `window_theta`
  // (+- window_dtheta / 2) and radius `window_radius` (+- window_dr / 2).
  double window_theta = 0.7853981633974483;  // pi/4
  double window_radius = 10.0;
  double window_dtheta = 0.5235987755982988;  // pi/6
  double window_dr = 4.0;
  int axis_bins = 18;  // over [0, pi)
};

// Sums over frames (one run's, or several runs' added up), from which the profiles follow.
struct OrientationSums {
  int frames = 0;
  std::vector<std::vector<double>> s_sum, s_count;          // [height][s bin]: acute angles
  std::vector<std::vector<double>> theta_sum, theta_count;  // [radius][theta bin]
  // [region]: the elongated bodies' count and sums of cos 2 psi, sin 2 psi, from which S against
  // any director psi_d follows, S = cos 2 psi_d <cos 2 psi> + sin 2 psi_d <sin 2 psi>, so that a
  // director resolved after the pass (the flow's) needs no second pass.
  std::vector<double> region_count, cos2psi_sum, sin2psi_sum;
  // [region]: every body's (discs too) count and sums of vx, vy and vx^2 + vy^2: the mean flow.
  std::vector<double> flow_count, vx_sum, vy_sum, v2_sum;
  std::vector<double> window_axes;  // [axis bin]: counts in the window
  double s_range = 0;               // the range used
  void Add(const OrientationSums& other);
};

// Adds one frame's elongated bodies (`discs`: every disc of the frame) to `sums`, positions
// relative to `outlet`; `half_width` is the silo's (the default s range).
void AddOrientationFrame(const std::vector<rundir::Disc>& discs, const silo::OutletFrame& outlet, double half_width,
                         const OrientationOptions& options, OrientationSums& sums);

// The regions actually used (options.regions, or the default one above `outlet`).
std::vector<OrientationOptions::Region> OrientationRegions(const OrientationOptions& options,
                                                           const silo::OutletFrame& outlet);

// Profiles from sums: the mean acute angle per bin (NaN where empty) and its count.
struct OrientationProfile {
  std::vector<double> centre;             // bin centres (s, or theta in radians)
  std::vector<std::vector<double>> mean;  // [height or radius][bin]
  std::vector<std::vector<double>> count;
};
OrientationProfile OrientationAgainstS(const OrientationSums& sums, const OrientationOptions& options);
OrientationProfile OrientationAgainstTheta(const OrientationSums& sums, const OrientationOptions& options);
// The direction of region `region`'s mean body velocity <v>, atan2(<vy>, <vx>) in (-pi, pi]; NaN
// when the region held no body or <v> is not told apart from zero: |<v>| <= 3 standard errors of
// the mean, se^2 = (<|v|^2> - |<v>|^2) / n (n body-frames taken as independent), so a bed at rest
// (every velocity 0, or only jitter around 0) has no flow direction rather than a noisy one.
double FlowDirection(const OrientationSums& sums, std::size_t region);
// The directors the regions are measured against (radians): each fixed one, or its flow
// direction (NaN where that is undefined).
std::vector<double> RegionDirectors(const OrientationSums& sums,
                                    const std::vector<OrientationOptions::Region>& regions);
// S per region against `directors` (nematic: psi_d and psi_d + pi give the same S). NaN without
// elongated bodies or with a NaN director.
std::vector<double> OrderParameters(const OrientationSums& sums, const std::vector<double>& directors);
// The window's distribution as a probability density over [0, pi) (sums to 1 / bin width x bins).
std::vector<double> AxisDensity(const std::vector<double>& counts);

}  // namespace granary::analysis
