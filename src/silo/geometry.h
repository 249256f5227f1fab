// Silo boundaries (docs/model.md "Boundaries"): walls are line segments, outlet edges are
// points, obstacles are fixed circles. Elements belong to named groups:
// the plug closes the outlets during bed preparation and is switched off at t = 0, when the
// outlet-edge points switch on (while the plug is in, a disc over an edge would otherwise
// touch both the edge point and the plug).
#pragma once

#include <vector>

#include "rundir/run_spec.h"

namespace granary::silo {

enum class ElementKind { kSegment, kPoint, kCircle };
enum class WallGroup { kAlways, kPlug, kOpen };

struct WallElement {
  ElementKind kind = ElementKind::kSegment;
  WallGroup group = WallGroup::kAlways;
  double ax = 0, ay = 0, bx = 0, by = 0;  // segment ends; point/circle centre in (ax, ay)
  double radius = 0;                      // circle only
};

// An outlet in its own frame: centre c, unit vector along the gap, unit normal pointing
// into the silo; local coordinates s = (p-c).along, h = (p-c).inward.
struct OutletFrame {
  double cx = 0, cy = 0, ax = 1, ay = 0, nx = 0, ny = 1, width = 0;
};

struct SiloGeometry {
  double half_width = 50.0;
  double wall_height = 0.0;
  std::vector<WallElement> elements;
  std::vector<OutletFrame> outlets;  // base outlets in spec order, then side outlets
};

// Builds the walls of `silo` with side walls up to `wall_height`.
SiloGeometry BuildGeometry(const Silo& silo, double wall_height);

// Closest point of element `e` to (px, py); for a point or circle, its centre; for a
// segment, the foot of the perpendicular, `valid` false when it falls outside the segment.
struct Closest {
  double qx, qy;
  bool valid;
};
Closest ClosestPoint(const WallElement& e, double px, double py);

// The three straight walls of a silo. A closed silo (no outlets) has exactly one segment per
// side, with element index equal to the side; with gaps, a side is split into segments.
enum class Side { kBase = 0, kLeft = 1, kRight = 2 };

// The side a wall segment lies on, or -1 for plug segments, points and circles.
int SideOf(const SiloGeometry& g, int element);
// The always-active segment of `side` whose interior is under (px, py), or -1 (over a gap).
int SegmentUnder(const SiloGeometry& g, Side side, double px, double py);

}  // namespace granary::silo
