// A square lattice of discs (spacing 1, radius 0.5, mass pi/4) over x in [-12, 12],
// y in [0.5, 20.5], moving rigidly at vertical speed `vy`, with its contact frame: vertical
// chains in which each contact carries the weight (1 per disc) of the discs above it.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <utility>

#include "rundir/contacts.h"
#include "rundir/frames.h"

namespace granary::analysis::testing {

inline std::pair<rundir::Frame, rundir::ContactFrame> LatticeFrame(double t, double vy) {
  rundir::Frame f;
  f.time = t;
  f.timestep = std::llround(t * 1e4);
  rundir::ContactFrame c;
  c.time = t;
  c.timestep = f.timestep;
  std::int64_t id = 0;
  for (int row = 0; row <= 20; ++row)
    for (int col = 0; col <= 24; ++col) {
      rundir::Disc d;
      d.id = id + 1;
      d.mol = id;
      d.x = -12.0 + col;
      d.y = 0.5 + row;
      d.radius = 0.5;
      d.mass = std::numbers::pi * 0.25;
      d.vy = vy;
      f.discs.push_back(d);
      if (row > 0) c.contacts.push_back({id, id - 25, d.x, d.y, d.x, d.y - 1.0, d.x, d.y - 0.5, 0.0, 21.0 - row});
      ++id;
    }
  return {std::move(f), std::move(c)};
}

}  // namespace granary::analysis::testing
