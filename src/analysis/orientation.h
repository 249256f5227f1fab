// Orientation of elongated bodies (thesis ch. 4 fig. 4.3, ch. 5 fig. 5.5, ch. 6 figs. 6.5-6.6;
// docs/analyses.md "Orientation"). Pure functions over bodies rebuilt from their discs.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "analysis/stats.h"
#include "rundir/frames.h"

namespace granary::analysis {

// The long axis of a body: the line through the centres of its two discs furthest apart (a
// dumbbell's, a snowman's or a rod's axis; whatever order the engine numbered its discs in).
struct BodyAxis {
  bool elongated = false;   // two discs or more (a disc has no axis)
  double angle = kNaN;      // the axis' angle with the horizontal, in [0, pi)
  // Snowmen (discs of two sizes): the direction from the centre of the big disc to the centre
  // of the small one (where the head points), in [0, 2 pi); NaN when the end discs are equal.
  double head = kNaN;
};
// The axes of the bodies of `discs`, in the order of rundir::BodiesOf (by body id).
std::vector<BodyAxis> body_axes(const std::vector<rundir::Disc>& discs);
BodyAxis axis_of(const std::vector<const rundir::Disc*>& body_discs);

// The acute angle of an axis with the horizontal, [0, pi/2]: what the thesis' mean orientation
// against position averages (fig. 4.3: 90 degrees is vertical whichever way it leans).
double acute(double axis_angle);

// The order parameter S = 2 <cos^2(angle - director)> - 1 of axis angles against a director
// (radians): 1 all along it, -1 all across it, 0 for isotropic axes (fig. 5.5). NaN when empty.
double order_parameter(const std::vector<double>& axis_angles, double director);

// The angular position of a point around an outlet's centre, atan2(h, s) in the outlet's frame
// (s along the outlet, h into the silo): 0 on the base on the s > 0 side, pi/2 straight above
// the centre, pi on the base on the s < 0 side (the thesis' theta, figs. 4.3c and 6.5c).
double angular_position(double s, double h);

}  // namespace granary::analysis
