// What a stalled discharge is (docs/engine.md "How a run ends"). A silo whose flow has stopped is
// clogged when an arch seals an outlet from the material above it, and has discharged when every
// outlet still has an open path to the free surface: what is left lies in the dead zones of the
// flat bottom, on the obstacles or on the walls, and nothing can flow any more.
// The same free space, traced along its edge, gives the arch itself (CavityUnder, used by the
// arch analysis, docs/analyses.md "Arches"). Geometry only: any engine's discs, no World (the
// native engine's adapter is stall_world.h).
#pragma once

#include <cstdint>
#include <vector>

#include "silo/geometry.h"

namespace granary::silo {

struct DiscAt {
  double x, y, r;
};

// The probe radius of SealedOutlets and CavityUnder: the narrowest gap some body in the silo could
// pass. A body passes no gap its largest disc cannot, so the probe is the smallest, over the bodies,
// of the body's largest disc radius (`body_of[i]` is the body of `discs[i]`). With the smallest
// disc instead, a snowman arch whose gaps admit a small disc but no snowman's large one would be
// judged open: a clog called a discharge, and an arch nobody could find. Infinity without discs.
double PassageProbe(const std::vector<DiscAt>& discs, const std::vector<std::int64_t>& body_of);

// For each outlet (geometry order: base outlets, then side outlets), whether it is sealed: a probe
// disc of radius `probe` (PassageProbe of the bodies in the silo), started anywhere in the outlet's
// mouth, cannot move to above the highest disc without overlapping a disc (one entry per disc of
// a body still in the silo), an active wall element or an obstacle of `geometry` with its outlets
// open. An arch of touching bodies seals the outlet whether it spans the opening itself or the
// passages beside an obstacle; the open crater of a discharged silo does not. Computed by a flood
// fill over a grid of a third of the probe radius.
std::vector<bool> SealedOutlets(const SiloGeometry& geometry, const std::vector<DiscAt>& discs, double probe);

// One object along the edge of the space under an arch.
struct CavityBound {
  enum class Kind { kDisc, kElement, kOpen };
  Kind kind = Kind::kOpen;
  int index = -1;       // kDisc: into `discs`; kElement: into geometry.elements; kOpen: -1
  double s = 0, h = 0;  // outlet frame (OutletFrame): where the edge first meets it
};

// The free space a probe reaches from outlet `outlet`'s mouth (the flood fill of SealedOutlets,
// without stopping at the top) and the objects that bound it, in order along its edge from the
// mouth's s < 0 end round to its s > 0 end (the mouth itself left out, consecutive repeats
// merged). The object of an edge cell is the one whose surface is nearest the cell. `sealed` is
// false when the space reaches above the highest disc (no arch; `edge` is then empty).
struct OutletCavity {
  bool sealed = false;
  std::vector<CavityBound> edge;
};
OutletCavity CavityUnder(const SiloGeometry& geometry, const std::vector<DiscAt>& discs, double probe, int outlet);

}  // namespace granary::silo
