// The stall judgement (stall.h) of the native engine's world: the discs of the bodies still in
// the silo, and the probe of silo::PassageProbe.
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#include "silo/stall.h"
#include "engine/world.h"

namespace granary::engine {

// The discs of the bodies still in the silo, with each disc's body.
struct SiloDiscs {
  std::vector<silo::DiscAt> discs;
  std::vector<std::int64_t> body_of;
};
inline SiloDiscs DiscsInSilo(const World& w) {
  SiloDiscs s;
  for (int i = 0; i < w.DiscCount(); ++i) {
    if (!w.body_active_[w.disc_body_[i]]) continue;
    s.discs.push_back({w.disc_x_[i], w.disc_y_[i], w.disc_radius_[i]});
    s.body_of.push_back(w.disc_body_[i]);
  }
  return s;
}

inline std::vector<bool> SealedOutlets(const World& w) {
  const SiloDiscs s = DiscsInSilo(w);
  return silo::SealedOutlets(w.Geometry(), s.discs, silo::PassageProbe(s.discs, s.body_of));
}

}  // namespace granary::engine
