// Building blocks shared by the engine tests: body species and wall segments.
#pragma once

#include "silo/geometry.h"
#include "rundir/run_spec.h"

namespace granary::engine {

inline Species DiscSpecies(double diameter) {
  Species s;
  s.name = "disc";
  s.shape = Shape::kDisc;
  s.diameter = diameter;
  return s;
}

inline Species DumbbellSpecies() {
  Species s;
  s.name = "dumbbell";
  s.shape = Shape::kDumbbell;
  s.diameter = 1.0;
  return s;
}

inline silo::WallElement WallSegment(double ax, double ay, double bx, double by) {
  silo::WallElement e;
  e.kind = silo::ElementKind::kSegment;
  e.ax = ax;
  e.ay = ay;
  e.bx = bx;
  e.by = by;
  return e;
}

}  // namespace granary::engine
