// What a picture of the silo needs, from the spec alone: its walls (with the side the material
// is on), its outlets and its obstacles. The renderer draws it (src/render) and both engines
// write it beside their frames as silo.vtk, a triangle mesh OVITO and ParaView open
// (docs/run-directory.md).
#pragma once

#include <string>
#include <vector>

#include "rundir/run_spec.h"

namespace granary::silo {

// A straight piece from a to b; (ox, oy) the unit normal pointing out of the silo.
struct OutlineSegment {
  double ax = 0, ay = 0, bx = 0, by = 0, ox = 0, oy = 0;
};
struct OutlineCircle {
  double x = 0, y = 0, r = 0;
};

struct SiloOutline {
  std::vector<OutlineSegment> walls;    // the walls that stay (no plug)
  std::vector<OutlineSegment> outlets;  // the openings, in outlet order (base outlets, then side outlets)
  std::vector<OutlineCircle> obstacles;
};

// The outline of `silo` with side walls up to `wall_top` (the spec's height, or where a
// picture of the run ends when the spec leaves it automatic).
SiloOutline OutlineOf(const Silo& silo, double wall_top);

// silo.vtk: legacy ASCII VTK, an unstructured grid of triangles on the back face of the frames'
// box (z = -0.5, behind the discs), coloured per cell: walls grey bands `thickness` wide outside
// the silo, outlets red bands across the openings, obstacles dark grey discs.
std::string SiloVtk(const SiloOutline& outline, double thickness = 0.5);

}  // namespace granary::silo
