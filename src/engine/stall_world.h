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

// out[b] = 1 where body b lies alone on the flat floor: it has a contact force with a base
// segment and with nothing but straight walls (no other body, outlet edge or obstacle) in the
// last force computation. Such a body takes no part in a flow: nothing rests on it and nothing
// it rests on can move; it can only roll or slide along the floor. The contact law has no
// rolling resistance, so a disc rolling there keeps its speed for ever (a wall bounce reverses
// it) where a real grain would stop: the stall judgement must not wait for it.
inline void MarkBodiesAloneOnTheFloor(const World& w, std::vector<World::ContactView>& contacts,
                                      std::vector<std::uint8_t>& out) {
  w.CollectContacts(contacts);
  out.assign(static_cast<std::size_t>(w.BodyCount()), 0);
  std::vector<std::uint8_t> other(out.size(), 0);  // a contact with anything but straight walls
  for (const World::ContactView& c : contacts) {
    const auto b = static_cast<std::size_t>(w.disc_body_[c.disc_i]);
    if (c.disc_j >= 0) {
      other[b] = 1;
      other[static_cast<std::size_t>(w.disc_body_[c.disc_j])] = 1;
      continue;
    }
    const int side = silo::SideOf(w.Geometry(), c.element);
    if (side == static_cast<int>(silo::Side::kBase))
      out[b] = 1;
    else if (side < 0)
      other[b] = 1;
  }
  for (std::size_t b = 0; b < out.size(); ++b)
    if (other[b]) out[b] = 0;
}

inline std::vector<bool> SealedOutlets(const World& w) {
  const SiloDiscs s = DiscsInSilo(w);
  return silo::SealedOutlets(w.Geometry(), s.discs, silo::PassageProbe(s.discs, s.body_of));
}

}  // namespace granary::engine
