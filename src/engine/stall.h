// What a stalled discharge is (docs/engine.md "How a run ends"). A silo whose flow has stopped is
// clogged when an arch seals an outlet from the material above it, and has discharged when every
// outlet still has an open path to the free surface: what is left lies in the dead zones of the
// flat bottom, on the obstacles or on the walls, and nothing can flow any more.
#pragma once

#include <vector>

#include "engine/world.h"

namespace granary::engine {

// For each outlet (geometry order: base outlets, then side outlets), whether it is sealed: a probe
// disc the size of the smallest disc of the world, started anywhere in the outlet's mouth, cannot
// move to above the highest disc without overlapping a disc, an active wall element or an
// obstacle. An arch of touching bodies seals the outlet whether it spans the opening itself or
// the passages beside an obstacle; the open crater of a discharged silo does not. Computed by a
// flood fill over a grid of a third of the probe radius.
std::vector<bool> SealedOutlets(const World& w);

// The same for any engine's discs (centre x, y and radius, one entry per disc of a body still in
// the silo) in `geometry` with its outlets open, the probe of radius `probe` (the LIGGGHTS
// backend classifies its stalls with this, from its final dump).
struct DiscAt {
  double x, y, r;
};
std::vector<bool> SealedOutlets(const SiloGeometry& geometry, const std::vector<DiscAt>& discs, double probe);

}  // namespace granary::engine
