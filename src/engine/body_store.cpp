// The body store (body_store.h).
#include "engine/body_store.h"

#include <algorithm>
#include <cmath>

namespace granary::engine {

void BodyStore::Append(int tmpl, const silo::ShapeTemplate& t) {
  const int id = BodyCount();
  body_template_.push_back(tmpl);
  body_active_.push_back(1);
  body_x_.push_back(0);
  body_y_.push_back(0);
  body_angle_.push_back(0);
  body_cos_.push_back(1);
  body_sin_.push_back(0);
  body_vx_.push_back(0);
  body_vy_.push_back(0);
  body_spin_.push_back(0);
  body_fx_.push_back(0);
  body_fy_.push_back(0);
  body_torque_.push_back(0);
  body_mass_.push_back(t.mass);
  body_inertia_.push_back(t.inertia);
  body_inv_mass_.push_back(1.0 / t.mass);
  body_inv_inertia_.push_back(1.0 / t.inertia);
  body_first_disc_.push_back(DiscCount());
  body_disc_count_.push_back(static_cast<int>(t.r.size()));
  double reach = 0.0;
  for (std::size_t k = 0; k < t.r.size(); ++k) reach = std::max(reach, std::hypot(t.ox[k], t.oy[k]));
  body_reach_.push_back(reach);
  const int n = static_cast<int>(t.r.size());
  uniform_discs_ = id == 0 || uniform_discs_ == n ? n : -1;
  max_discs_ = std::max(max_discs_, n);
  for (std::size_t k = 0; k < t.r.size(); ++k) {
    disc_body_.push_back(id);
    disc_radius_.push_back(t.r[k]);
    disc_mass_.push_back(t.disc_mass[k]);
    disc_offset_x_.push_back(t.ox[k]);
    disc_offset_y_.push_back(t.oy[k]);
    disc_x_.push_back(0);
    disc_y_.push_back(0);
    disc_kin_.push_back({0.0, 0.0, 0.0, 0.0, t.r[k], 0.0});
    disc_fx_.push_back(0);
    disc_fy_.push_back(0);
    disc_torque_.push_back(0);
  }
}

void BodyStore::PlaceDiscs(int b) {
  const double x = body_x_[b], y = body_y_[b], c = body_cos_[b], s = body_sin_[b];
  const double vx = body_vx_[b], vy = body_vy_[b], w = body_spin_[b];
  const int d0 = body_first_disc_[b], d1 = d0 + body_disc_count_[b];
  for (int d = d0; d < d1; ++d) {  // (the drift does this the same way: integrator.cpp PlaceDisc)
    const double wx = c * disc_offset_x_[d] - s * disc_offset_y_[d];
    const double wy = s * disc_offset_x_[d] + c * disc_offset_y_[d];
    const double px = x + wx, py = y + wy;
    disc_x_[d] = px;
    disc_y_[d] = py;
    DiscKin& k = disc_kin_[d];
    k.x = px;
    k.y = py;
    k.vx = vx - w * wy;
    k.vy = vy + w * wx;
    k.w = w;
  }
}

}  // namespace granary::engine
