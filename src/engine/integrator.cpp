// The drift of the velocity-Verlet step (integrator.h).
#include "engine/integrator.h"

#include <algorithm>
#include <cmath>

#include "engine/avx512_kernels.h"
#include "engine/kernel_clones.h"
#include "engine/world.h"

namespace granary::engine {

void Integrator::SetExitBox(double xmin, double xmax, double ymin) {
  exit_box_[0] = xmin;
  exit_box_[1] = xmax;
  exit_box_[2] = ymin;
  exit_box_set_ = true;
}

namespace {

// The body part of DriftBodies: half kick, drift, rotation of bodies [b0, b1), one straight
// loop (it vectorizes); an inactive body keeps its state (selects). Rotation angles of 0.01
// or more, which need libm, are left to the caller. Returns kWide if there were any, and
// kBeyond if an active body's centre has left the box {xmin, xmax, ymin}.
constexpr int kWide = 1, kBeyond = 2;
[[gnu::always_inline]] inline int DriftKernel(int b0, int b1, double dt, const double box[3],
                                              const std::uint8_t* __restrict active, double* __restrict bx,
                                              double* __restrict by, double* __restrict bth, double* __restrict bvx,
                                              double* __restrict bvy, double* __restrict bw, double* __restrict bc,
                                              double* __restrict bs, const double* __restrict bfx,
                                              const double* __restrict bfy, const double* __restrict btq,
                                              const double* __restrict binv_mass,
                                              const double* __restrict binv_inertia) {
  const double half = 0.5 * dt;
  const double xmin = box[0], xmax = box[1], ymin = box[2];
  int wide = 0, beyond = 0;
#pragma GCC ivdep  // each iteration reads and writes body b only
  for (int b = b0; b < b1; ++b) {
    const bool on = active[b] != 0;
    const double vx = bvx[b] + half * bfx[b] * binv_mass[b];
    const double vy = bvy[b] + half * bfy[b] * binv_mass[b];
    const double w = bw[b] + half * btq[b] * binv_inertia[b];
    const double a = dt * w;
    // Rotate (cos, sin) by a. For |a| < 0.01 the series to a^8 is exact to rounding; one
    // Newton step keeps |(c, s)| = 1 without a square root.
    const bool small = std::fabs(a) < 0.01;
    const double a2 = a * a;
    // (multiplications by constant reciprocals: divisions here cost as much as the rest)
    constexpr double k2 = 1.0 / 2, k12 = 1.0 / 12, k30 = 1.0 / 30, k56 = 1.0 / 56;
    constexpr double k6 = 1.0 / 6, k20 = 1.0 / 20, k42 = 1.0 / 42;
    const double ca = 1.0 - a2 * k2 * (1.0 - a2 * k12 * (1.0 - a2 * k30 * (1.0 - a2 * k56)));
    const double sa = a * (1.0 - a2 * k6 * (1.0 - a2 * k20 * (1.0 - a2 * k42)));
    const double c = bc[b] * ca - bs[b] * sa, s = bs[b] * ca + bc[b] * sa;
    const double f = 1.5 - 0.5 * (c * c + s * s);
    // (every value computed before the selects, and & not &&: no branches)
    const double x = bx[b] + dt * vx, y = by[b] + dt * vy, th = bth[b] + a;
    const double cn = c * f, sn = s * f;
    bx[b] = on ? x : bx[b];
    by[b] = on ? y : by[b];
    bth[b] = on ? th : bth[b];
    bvx[b] = on ? vx : bvx[b];
    bvy[b] = on ? vy : bvy[b];
    bw[b] = on ? w : bw[b];
    bc[b] = on & small ? cn : bc[b];
    bs[b] = on & small ? sn : bs[b];
    wide |= on & !small;
    beyond |= on & ((x < xmin) | (x > xmax) | (y < ymin));
  }
  return (wide != 0 ? kWide : 0) | (beyond != 0 ? kBeyond : 0);
}

// One disc d of a body with centre (x, y), velocity (vx, vy), orientation (c, s) and angular
// velocity w: its position and kinematics; returns whether it has moved more than sqrt(limit)
// since the last rebuild. Shared by both disc loops of the drift.
[[gnu::always_inline]] inline bool PlaceDisc(std::size_t d, double x, double y, double vx, double vy, double c,
                                             double s, double w, double limit, const double* __restrict dox,
                                             const double* __restrict doy, const double* __restrict dr,
                                             const double* __restrict refx, const double* __restrict refy,
                                             double* __restrict dx, double* __restrict dy, DiscKin* __restrict kin) {
  const double wx = c * dox[d] - s * doy[d];
  const double wy = s * dox[d] + c * doy[d];
  const double px = x + wx, py = y + wy;
  dx[d] = px;
  dy[d] = py;
  kin[d] = {px, py, vx - w * wy, vy + w * wx, dr[d], w};
  const double ddx = px - refx[d], ddy = py - refy[d];
  return ddx * ddx + ddy * ddy > limit;
}

// The disc part of DriftBodies: positions and velocities of discs [d0, d1) from their
// bodies (as UpdateDiscs), one straight loop; returns whether a disc has moved more than
// sqrt(limit) since the last rebuild.
[[gnu::always_inline]] inline bool DiscKernel(int d0, int d1, double limit, const int* __restrict dbody,
                                              const double* __restrict bx, const double* __restrict by,
                                              const double* __restrict bvx, const double* __restrict bvy,
                                              const double* __restrict bw, const double* __restrict bc,
                                              const double* __restrict bs, const double* __restrict dox,
                                              const double* __restrict doy, const double* __restrict dr,
                                              const double* __restrict refx, const double* __restrict refy,
                                              double* __restrict dx, double* __restrict dy, DiscKin* __restrict kin) {
  int moved = 0;
#pragma GCC ivdep  // each iteration writes disc d only, and reads no array it writes
  for (int d = d0; d < d1; ++d) {
    const int b = dbody[d];
    moved |= PlaceDisc(static_cast<std::size_t>(d), bx[b], by[b], bvx[b], bvy[b], bc[b], bs[b], bw[b], limit, dox, doy,
                       dr, refx, refy, dx, dy, kin);
  }
  return moved != 0;
}

// DiscKernel for bodies [b0, b1) of kDiscs discs each, disc k of body b being kDiscs b + k:
// a loop over the bodies, so the body state is read without gathers.
template <int kDiscs>
[[gnu::always_inline]] inline bool DiscKernelUniform(int b0, int b1, double limit, const double* __restrict bx,
                                                     const double* __restrict by, const double* __restrict bvx,
                                                     const double* __restrict bvy, const double* __restrict bw,
                                                     const double* __restrict bc, const double* __restrict bs,
                                                     const double* __restrict dox, const double* __restrict doy,
                                                     const double* __restrict dr, const double* __restrict refx,
                                                     const double* __restrict refy, double* __restrict dx,
                                                     double* __restrict dy, DiscKin* __restrict kin) {
  int moved = 0;
#pragma GCC ivdep  // each iteration writes its body's discs only, and reads no array it writes
  for (int b = b0; b < b1; ++b) {
    const double c = bc[b], s = bs[b], w = bw[b];
#pragma GCC unroll 8
    for (int k = 0; k < kDiscs; ++k) {
      const std::size_t d =
          static_cast<std::size_t>(kDiscs) * static_cast<std::size_t>(b) + static_cast<std::size_t>(k);
      moved |= PlaceDisc(d, bx[b], by[b], bvx[b], bvy[b], c, s, w, limit, dox, doy, dr, refx, refy, dx, dy, kin);
    }
  }
  return moved != 0;
}

}  // namespace

GRANARY_KERNEL int Integrator::DriftBodyKernel(int b0, int b1) {
  const double dt = params_->dt;
  const int flags = DriftKernel(
      b0, b1, dt, exit_box_, bodies_->body_active_.data(), bodies_->body_x_.data(), bodies_->body_y_.data(),
      bodies_->body_angle_.data(), bodies_->body_vx_.data(), bodies_->body_vy_.data(), bodies_->body_spin_.data(),
      bodies_->body_cos_.data(), bodies_->body_sin_.data(), bodies_->body_fx_.data(), bodies_->body_fy_.data(),
      bodies_->body_torque_.data(), bodies_->body_inv_mass_.data(), bodies_->body_inv_inertia_.data());
  if (flags & kWide) {  // the rotations the series does not cover
    for (int b = b0; b < b1; ++b) {
      const double a = dt * bodies_->body_spin_[b];
      if (!bodies_->body_active_[b] || std::fabs(a) < 0.01) continue;
      const double ca = std::cos(a), sa = std::sin(a);
      const double c = bodies_->body_cos_[b] * ca - bodies_->body_sin_[b] * sa,
                   s = bodies_->body_sin_[b] * ca + bodies_->body_cos_[b] * sa;
      const double f = 1.5 - 0.5 * (c * c + s * s);
      bodies_->body_cos_[b] = c * f;
      bodies_->body_sin_[b] = s * f;
    }
  }
  return flags & kBeyond;
}

GRANARY_KERNEL int Integrator::DriftPortable(int b0, int b1) {
  if (b0 >= b1) return 0;
  const int flags = DriftBodyKernel(b0, b1);
  // Discs of an inactive body are recomputed from its unchanged state, which gives the
  // values they have. They count in the displacement check, harmlessly: a body is switched
  // off or on only with a rebuild requested, and then it does not move.
  const double limit = 0.25 * params_->skin * params_->skin;
  const int beyond = flags & kBeyond ? kDriftBeyond : 0;
  // (no lambda: one called twice in a target_clones function is compiled for baseline x86-64 only)
  if (bodies_->uniform_discs_ == 1)
    return beyond | (DiscKernelUniform<1>(
                         b0, b1, limit, bodies_->body_x_.data(), bodies_->body_y_.data(), bodies_->body_vx_.data(),
                         bodies_->body_vy_.data(), bodies_->body_spin_.data(), bodies_->body_cos_.data(),
                         bodies_->body_sin_.data(), bodies_->disc_offset_x_.data(), bodies_->disc_offset_y_.data(),
                         bodies_->disc_radius_.data(), lists_->rebuild_x_.data(), lists_->rebuild_y_.data(),
                         bodies_->disc_x_.data(), bodies_->disc_y_.data(), bodies_->disc_kin_.data())
                         ? kDriftMoved
                         : 0);
  if (bodies_->uniform_discs_ == 2)
    return beyond | (DiscKernelUniform<2>(
                         b0, b1, limit, bodies_->body_x_.data(), bodies_->body_y_.data(), bodies_->body_vx_.data(),
                         bodies_->body_vy_.data(), bodies_->body_spin_.data(), bodies_->body_cos_.data(),
                         bodies_->body_sin_.data(), bodies_->disc_offset_x_.data(), bodies_->disc_offset_y_.data(),
                         bodies_->disc_radius_.data(), lists_->rebuild_x_.data(), lists_->rebuild_y_.data(),
                         bodies_->disc_x_.data(), bodies_->disc_y_.data(), bodies_->disc_kin_.data())
                         ? kDriftMoved
                         : 0);
  const int d0 = bodies_->body_first_disc_[b0],
            d1 = bodies_->body_first_disc_[b1 - 1] + bodies_->body_disc_count_[b1 - 1];
  return beyond | (DiscKernel(d0, d1, limit, bodies_->disc_body_.data(), bodies_->body_x_.data(),
                              bodies_->body_y_.data(), bodies_->body_vx_.data(), bodies_->body_vy_.data(),
                              bodies_->body_spin_.data(), bodies_->body_cos_.data(), bodies_->body_sin_.data(),
                              bodies_->disc_offset_x_.data(), bodies_->disc_offset_y_.data(),
                              bodies_->disc_radius_.data(), lists_->rebuild_x_.data(), lists_->rebuild_y_.data(),
                              bodies_->disc_x_.data(), bodies_->disc_y_.data(), bodies_->disc_kin_.data())
                       ? kDriftMoved
                       : 0);
}

int Integrator::DriftBodies(int b0, int b1) {
  if (b0 >= b1) return 0;
  if (!use_avx512_) return DriftPortable(b0, b1);
  const DriftArrays arrays{
      bodies_->body_active_.data(),   bodies_->body_x_.data(),           bodies_->body_y_.data(),
      bodies_->body_angle_.data(),    bodies_->body_vx_.data(),          bodies_->body_vy_.data(),
      bodies_->body_spin_.data(),     bodies_->body_cos_.data(),         bodies_->body_sin_.data(),
      bodies_->body_fx_.data(),       bodies_->body_fy_.data(),          bodies_->body_torque_.data(),
      bodies_->body_inv_mass_.data(), bodies_->body_inv_inertia_.data(), bodies_->disc_offset_x_.data(),
      bodies_->disc_offset_y_.data(), bodies_->disc_radius_.data(),      lists_->rebuild_x_.data(),
      lists_->rebuild_y_.data(),      bodies_->disc_x_.data(),           bodies_->disc_y_.data(),
      bodies_->disc_kin_.data()};
  const double limit = 0.25 * params_->skin * params_->skin;
  bool beyond = false, moved = false;
  if (bodies_->uniform_discs_ != 1 && bodies_->uniform_discs_ != 2) {
    // Bodies of several shapes on an AVX-512 CPU: the portable body loop, then the discs
    // eight at a time (their bodies' state gathered), the last few portably.
    const int flags = DriftBodyKernel(b0, b1);
    const int d0 = bodies_->body_first_disc_[b0],
              d1 = bodies_->body_first_disc_[b1 - 1] + bodies_->body_disc_count_[b1 - 1];
    const int d = PlaceDiscsAvx512(d0, d1, limit, bodies_->disc_body_.data(), b1, arrays, &moved);
    moved |= DiscKernel(d, d1, limit, bodies_->disc_body_.data(), bodies_->body_x_.data(), bodies_->body_y_.data(),
                        bodies_->body_vx_.data(), bodies_->body_vy_.data(), bodies_->body_spin_.data(),
                        bodies_->body_cos_.data(), bodies_->body_sin_.data(), bodies_->disc_offset_x_.data(),
                        bodies_->disc_offset_y_.data(), bodies_->disc_radius_.data(), lists_->rebuild_x_.data(),
                        lists_->rebuild_y_.data(), bodies_->disc_x_.data(), bodies_->disc_y_.data(),
                        bodies_->disc_kin_.data());
    return (flags & kBeyond ? kDriftBeyond : 0) | (moved ? kDriftMoved : 0);
  }
  // Discs or dumbbells on an AVX-512 CPU: eight bodies at a time in one pass; a group with a
  // rotation that needs libm, and the last few bodies, by the portable loops.
  int flags = 0;
  for (int b = b0; b < b1;) {
    b = bodies_->uniform_discs_ == 1
            ? DriftUniformAvx512<1>(b, b1, arrays, params_->dt, exit_box_, limit, &beyond, &moved)
            : DriftUniformAvx512<2>(b, b1, arrays, params_->dt, exit_box_, limit, &beyond, &moved);
    const int e = std::min(b1, b + 8);
    if (b < e) flags |= DriftPortable(b, e);
    b = e;
  }
  return flags | (beyond ? kDriftBeyond : 0) | (moved ? kDriftMoved : 0);
}

int Integrator::DriftShare(int t, int nt, std::int64_t pass) {
  const int nb = bodies_->BodyCount();
  const int ch0 = shares_->ChunkShareStart(t, nt), ch1 = shares_->ChunkShareStart(t + 1, nt);
  int flags = 0;
  for (int ch = ch0; ch < ch1; ch += ThreadShares::kChunksPerCall) {
    const int end = std::min(ch1, ch + ThreadShares::kChunksPerCall);
    flags |= DriftBodies(ch * ThreadShares::kBodyChunk, std::min(nb, end * ThreadShares::kBodyChunk));
    for (int c = ch; c < end; ++c) shares_->ChunkDone(c).pass.store(pass, std::memory_order_release);
  }
  return flags;
}

}  // namespace granary::engine
