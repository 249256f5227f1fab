// The stall judgement (stall.h) of the native engine's world: the discs of the bodies still in
// the silo, a probe the size of the smallest disc of any species.
#pragma once

#include <algorithm>
#include <limits>
#include <vector>

#include "silo/stall.h"
#include "engine/world.h"

namespace granary::engine {

inline std::vector<bool> SealedOutlets(const World& w) {
  double probe = std::numeric_limits<double>::max();
  for (double r : w.dr_) probe = std::min(probe, r);
  std::vector<silo::DiscAt> discs;
  for (int i = 0; i < w.disc_count(); ++i)
    if (w.active_[w.dbody_[i]]) discs.push_back({w.dx_[i], w.dy_[i], w.dr_[i]});
  return silo::SealedOutlets(w.geometry(), discs, probe);
}

}  // namespace granary::engine
