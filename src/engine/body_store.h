// The bodies and their discs as a structure of arrays over the shape templates: what the
// neighbour lists, the force pass and the integrator read and write, and what the drivers,
// writers and tests read (World is one).
#pragma once

#include <cstdint>
#include <vector>

#include "engine/thread_shared.h"
#include "silo/shapes.h"

namespace granary::engine {

// What the pair loop reads of a partner disc, in one cache line: position, velocity,
// radius and the body's angular velocity (written with the disc positions each step).
struct alignas(64) DiscKin {
  double x, y, vx, vy, r, w;
  double pad0 = 0.0, pad1 = 0.0;  // written with the rest: the disc loop's stores fill the line
};

struct BodyStore {
  int BodyCount() const { return static_cast<int>(body_x_.size()); }
  int DiscCount() const { return static_cast<int>(disc_radius_.size()); }

  // Appends a body of template t (number `tmpl`) at the origin, at rest, and its discs.
  // Discs of a body are contiguous.
  void Append(int tmpl, const silo::ShapeTemplate& t);
  // Disc positions, velocities and records of body b from the body state (the drift does the
  // same for every body each step, Integrator).
  void PlaceDiscs(int b);

  // Per body: its template, whether it takes part, and its state.
  std::vector<int> body_template_;
  std::vector<std::uint8_t> body_active_;
  SharedVector<double> body_x_, body_y_, body_angle_, body_vx_, body_vy_, body_spin_;
  // The force and torque of the last force computation (gravity included).
  SharedVector<double> body_fx_, body_fy_, body_torque_;
  SharedVector<double> body_mass_, body_inertia_;
  // Orientation as (cos, sin), rotated by omega dt each step (no libm call per body and
  // step); the angle is integrated alongside for reference. Checkpoints store both.
  SharedVector<double> body_cos_, body_sin_;
  SharedVector<double> body_inv_mass_, body_inv_inertia_;  // 1/M and 1/I (the step multiplies)
  // The largest distance of a disc centre from the body's centre.
  std::vector<double> body_reach_;
  // The body's discs: [body_first_disc_[b], body_first_disc_[b] + body_disc_count_[b]).
  std::vector<int> body_first_disc_;
  std::vector<int> body_disc_count_;
  int uniform_discs_ = -1;  // discs per body if all bodies have as many, else -1
  int max_discs_ = 0;       // the most discs of any body

  // Per disc: owning body, radius, mass, offset in the body's frame, world position.
  std::vector<int> disc_body_;
  SharedVector<double> disc_radius_, disc_mass_, disc_offset_x_, disc_offset_y_, disc_x_, disc_y_;
  SharedVector<DiscKin> disc_kin_;
  // The contact force and the torque about the disc centre of the last force computation.
  SharedVector<double> disc_fx_, disc_fy_, disc_torque_;
};

}  // namespace granary::engine
