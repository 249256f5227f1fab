// The force pass (force_pass.h).
#include "engine/force_pass.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "engine/avx512_kernels.h"
#include "engine/kernel_clones.h"
#include "engine/pair_entries.h"
#include "engine/world.h"

namespace granary::engine {

namespace {

// Step 2 of SumPartForces: sums per disc in list order and reactions inside the block, for
// the block's discs [i0, i1). A part of a block after its start first takes the reactions
// of the entries from the block's earlier discs into it (`earlier`, ascending: the order in
// which the whole block's loop adds them), then continues as that loop, so a block summed
// in parts gives the bits of a block summed at once. An entry that does not touch adds
// +0.0, which leaves every sum as it was (they start at +0.0 and so are never -0.0). A
// function of its own, not inlined: inside the block's function the loop keeps its pointers
// on the stack, which costs (docs/benchmarks.md). Scalar, so no instruction-set variants.
[[gnu::noinline]] void SumBlock(int i0, int i1, const int* __restrict earlier, int n_earlier,
                                const int* __restrict nl_start, const int* __restrict nl_j,
                                const double* __restrict nl_fx, const double* __restrict nl_fy,
                                const double* __restrict nl_c, const double* __restrict dr, double* __restrict dfx,
                                double* __restrict dfy, double* __restrict dtz) {
  for (int i = i0; i < i1; ++i) dfx[i] = dfy[i] = dtz[i] = 0.0;
  for (int k = 0; k < n_earlier; ++k) {
    const int e = earlier[k], j = nl_j[e];
    dfx[j] -= nl_fx[e];
    dfy[j] -= nl_fy[e];
    dtz[j] += nl_c[e];
  }
  for (int i = i0; i < i1; ++i) {
    double sfx = 0.0, sfy = 0.0, sc = 0.0;
    const int e1 = nl_start[i + 1];
    for (int e = nl_start[i]; e < e1; ++e) {
      const int j = nl_j[e];
      const double fx = nl_fx[e], fy = nl_fy[e], c = nl_c[e];
      sfx += fx;
      sfy += fy;
      sc += c;
      if (j < i1) {
        dfx[j] -= fx;
        dfy[j] -= fy;
        dtz[j] += c;  // n x F_t is the same seen from j (both n and F_t flip)
      }
    }
    // Every reaction from this block has arrived (they come from lower i).
    dfx[i] += sfx;
    dfy[i] += sfy;
    dtz[i] = -dr[i] * (dtz[i] + sc);  // torque of tangential forces at the contact point -r n (LAMMPS)
  }
}

}  // namespace

// Eight entries at a time by the AVX-512 loop where the CPU has it, the rest (or all) by the
// portable loop; both give the same bits. (Inlined into PairEntriesOf's instruction-set variants.)
template <class Normal, bool kLiggghtsCap>
[[gnu::always_inline]] inline void ForcePass::PairRange(int e0, int e1) {
  const ContactParams& pp = params_->pair;
  const int e = use_avx512_ ? PairEntriesAvx512(e0, e1, lists_->pair_i_.data(), lists_->pair_j_.data(),
                                                lists_->pair_eff_radius_.data(), lists_->pair_eff_mass_.data(),
                                                lists_->pair_shear_x_.data(), lists_->pair_shear_y_.data(),
                                                lists_->pair_fx_.data(), lists_->pair_fy_.data(),
                                                lists_->pair_couple_.data(), bodies_->disc_kin_.data(), pp, params_->dt)
                            : e0;
  PairEntries<Normal, kLiggghtsCap>(e, e1, lists_->pair_i_.data(), lists_->pair_j_.data(),
                                    lists_->pair_eff_radius_.data(), lists_->pair_eff_mass_.data(),
                                    lists_->pair_shear_x_.data(), lists_->pair_shear_y_.data(), lists_->pair_fx_.data(),
                                    lists_->pair_fy_.data(), lists_->pair_couple_.data(), bodies_->disc_kin_.data(), pp,
                                    params_->dt);
}

GRANARY_KERNEL void ForcePass::PairEntriesOf(int i0, int i1) {
  WithContactLaw(
      params_->pair, [&](auto model, auto cap) __attribute__((always_inline)) {
        PairRange<decltype(model), decltype(cap)::value>(lists_->pair_start_[i0], lists_->pair_start_[i1]);
      });
}

// The wall entries [k0, k1) of a force block: the contact kernel with the closest point of
// the element as the partner (radius el.radius, at rest, infinite mass).
template <class Normal, bool kLiggghtsCap>
[[gnu::always_inline]] inline void ForcePass::WallEntries(int k0, int k1, const ContactParams& wp) {
  const LawConstants<double> law(wp, params_->dt);
  double* __restrict dfx = bodies_->disc_fx_.data();
  double* __restrict dfy = bodies_->disc_fy_.data();
  double* __restrict dtz = bodies_->disc_torque_.data();
  for (int k = k0; k < k1; ++k) {
    const int i = lists_->wall_disc_[k];
    const DiscKin& a = bodies_->disc_kin_[i];
    const silo::WallElement& el = geometry_->elements[lists_->wall_element_[k]];
    const silo::Closest q = silo::ClosestPoint(el, a.x, a.y);
    const double ddx = a.x - q.qx, ddy = a.y - q.qy;
    const double rsq = ddx * ddx + ddy * ddy;
    const double reach = a.r + el.radius;
    if (!q.valid || rsq >= reach * reach || rsq == 0.0) {
      lists_->wall_shear_x_[k] = lists_->wall_shear_y_[k] = lists_->wall_fx_[k] = lists_->wall_fy_[k] = 0.0;
      continue;
    }
    const ContactGeometry<double> g = Geometry(ddx, ddy, rsq, reach, a.vx, a.vy, a.r * a.w);
    const double reff = el.kind == silo::ElementKind::kCircle ? EffectiveRadius(a.r, el.radius) : a.r;
    const double meff = bodies_->body_mass_[bodies_->disc_body_[i]];
    const ContactForce<double> f =
        ContactLaw<Normal, kLiggghtsCap>(g, reff, meff, lists_->wall_shear_x_[k], lists_->wall_shear_y_[k], true, law);
    lists_->wall_shear_x_[k] = f.sx;
    lists_->wall_shear_y_[k] = f.sy;
    lists_->wall_fx_[k] = f.fx;
    lists_->wall_fy_[k] = f.fy;
    dfx[i] += f.fx;
    dfy[i] += f.fy;
    dtz[i] -= a.r * f.c;
  }
}

GRANARY_KERNEL void ForcePass::SumPartForces(int i0, int i1, const std::vector<int>& earlier) {
  const ContactParams wp = params_->wall;
  double* __restrict dfx = bodies_->disc_fx_.data();
  double* __restrict dfy = bodies_->disc_fy_.data();
  double* __restrict dtz = bodies_->disc_torque_.data();
  // 2. Sums per disc and reactions inside the block.
  SumBlock(i0, i1, earlier.data(), static_cast<int>(earlier.size()), lists_->pair_start_.data(), lists_->pair_j_.data(),
           lists_->pair_fx_.data(), lists_->pair_fy_.data(), lists_->pair_couple_.data(), bodies_->disc_radius_.data(),
           dfx, dfy, dtz);
  // 3. Wall contacts, added after each disc's pair sums as before, but in a loop of their
  // own over the block's few wall entries: the pair-sum loop above stays small (no disc
  // record, no wall state in registers).
  WithContactLaw(
      wp, [&](auto model, auto cap) __attribute__((always_inline)) {
        WallEntries<decltype(model), decltype(cap)::value>(lists_->wall_start_[i0], lists_->wall_start_[i1], wp);
      });
}

namespace {

// Whether the next drift may take a disc of a body farther than `limit` (half the skin)
// from its position at the last rebuild, `moved` away now: the drift moves the body by
// dt v' and turns it by dt w', v' and w' the velocities after its half kick (computed as
// DriftKernel does), so a disc ends within dt |v'| + |dt w'| R of where it is (R: the
// farthest disc centre from the body centre); 1e-9 d covers the rounding.
[[gnu::always_inline]] inline bool OutrunsSkin(double vx, double vy, double w, double fx, double fy, double tq,
                                               double inv_mass, double inv_inertia, double radius, double moved2,
                                               double half, double dt, double limit) {
  const double nvx = vx + half * fx * inv_mass;
  const double nvy = vy + half * fy * inv_mass;
  const double nw = w + half * tq * inv_inertia;
  const double reach = limit - (dt * std::sqrt(nvx * nvx + nvy * nvy) + std::fabs(dt * nw) * radius + 1e-9);
  return (reach <= 0.0) | (moved2 > reach * reach);
}

// Body sums of BodyForces for bodies [b0, b1) of kDiscs discs each, disc k of body b being
// kDiscs b + k: a straight loop over the bodies (it vectorizes), the same arithmetic as the
// general loop. An inactive body's discs have no contacts, so its sums are +0.0, the
// values Deactivate left; it gets no gravity, and its velocity is kept (select). Returns
// whether an active body OutrunsSkin.
template <int kDiscs, bool kKick>
[[gnu::always_inline]] inline bool BodySums(
    int b0, int b1, double g, double half, double dt, double limit, const std::uint8_t* __restrict active,
    const double* __restrict dfx, const double* __restrict dfy, const double* __restrict dtz,
    const double* __restrict dx, const double* __restrict dy, const double* __restrict refx,
    const double* __restrict refy, const double* __restrict bx, const double* __restrict by,
    const double* __restrict bmass, const double* __restrict binv_mass, const double* __restrict binv_inertia,
    const double* __restrict bradius, double* __restrict bfx_out, double* __restrict bfy_out,
    double* __restrict btq_out, double* __restrict bvx, double* __restrict bvy, double* __restrict bw) {
  int outrun = 0;
#pragma GCC ivdep  // each iteration reads its body's discs and writes its body only
  for (int b = b0; b < b1; ++b) {
    const bool on = active[b] != 0;
    double bfx = 0, bfy = 0, btq = 0, moved2 = 0;
    const double cx = bx[b], cy = by[b];
    const std::size_t i0 = static_cast<std::size_t>(kDiscs) * static_cast<std::size_t>(b);
    if constexpr (kDiscs == 1) {
      // A disc body's disc sits at its centre (offset +0.0, so dx == bx exactly): the lever
      // arms are +0.0 and the general sum below reduces to these, bit for bit (0.0 + -0.0
      // is +0.0 either way), without reading the disc positions.
      bfx += dfx[i0];
      bfy += dfy[i0];
      btq += dtz[i0];
      const double mx = cx - refx[i0], my = cy - refy[i0];
      moved2 = std::max(moved2, mx * mx + my * my);
    } else {
#pragma GCC unroll 8
      for (int k = 0; k < kDiscs; ++k) {
        const std::size_t i = i0 + static_cast<std::size_t>(k);
        bfx += dfx[i];
        bfy += dfy[i];
        btq += (dx[i] - cx) * dfy[i] - (dy[i] - cy) * dfx[i] + dtz[i];
        const double mx = dx[i] - refx[i], my = dy[i] - refy[i];
        moved2 = std::max(moved2, mx * mx + my * my);
      }
    }
    bfy = bfy - bmass[b] * (on ? g : 0.0);
    bfx_out[b] = bfx;
    bfy_out[b] = bfy;
    btq_out[b] = btq;
    double vx = bvx[b], vy = bvy[b], w = bw[b];
    if constexpr (kKick) {  // the second half kick of the step
      vx = on ? vx + half * bfx * binv_mass[b] : vx;
      vy = on ? vy + half * bfy * binv_mass[b] : vy;
      w = on ? w + half * btq * binv_inertia[b] : w;
      bvx[b] = vx;
      bvy[b] = vy;
      bw[b] = w;
    }
    outrun |=
        on & OutrunsSkin(vx, vy, w, bfx, bfy, btq, binv_mass[b], binv_inertia[b], bradius[b], moved2, half, dt, limit);
  }
  return outrun != 0;
}

// BodySums for bodies of one or two discs (mixtures of discs and dumbbells): a body's
// second disc is read at its first disc's index + 1, or again at its first when it has
// none, and added only if it exists (a select: 0.0 + x is not always x), so the loop has no
// branches and vectorizes (gathers); the same arithmetic as the general loop.
template <bool kKick>
[[gnu::always_inline]] inline bool BodySumsUpTo2(
    int b0, int b1, double g, double half, double dt, double limit, const std::uint8_t* __restrict active,
    const int* __restrict disc_begin, const int* __restrict disc_n, const double* __restrict dfx,
    const double* __restrict dfy, const double* __restrict dtz, const double* __restrict dx,
    const double* __restrict dy, const double* __restrict refx, const double* __restrict refy,
    const double* __restrict bx, const double* __restrict by, const double* __restrict bmass,
    const double* __restrict binv_mass, const double* __restrict binv_inertia, const double* __restrict bradius,
    double* __restrict bfx_out, double* __restrict bfy_out, double* __restrict btq_out, double* __restrict bvx,
    double* __restrict bvy, double* __restrict bw) {
  int outrun = 0;
#pragma GCC ivdep  // each iteration reads its body's discs and writes its body only
  for (int b = b0; b < b1; ++b) {
    const bool on = active[b] != 0;
    const double cx = bx[b], cy = by[b];
    const int i = disc_begin[b];
    const bool two = disc_n[b] > 1;
    const int j = two ? i + 1 : i;
    double bfx = 0.0 + dfx[i], bfy = 0.0 + dfy[i];
    double btq = 0.0 + ((dx[i] - cx) * dfy[i] - (dy[i] - cy) * dfx[i] + dtz[i]);
    const double mx = dx[i] - refx[i], my = dy[i] - refy[i];
    double moved2 = std::max(0.0, mx * mx + my * my);
    const double tj = (dx[j] - cx) * dfy[j] - (dy[j] - cy) * dfx[j] + dtz[j];
    const double mxj = dx[j] - refx[j], myj = dy[j] - refy[j];
    bfx = two ? bfx + dfx[j] : bfx;
    bfy = two ? bfy + dfy[j] : bfy;
    btq = two ? btq + tj : btq;
    moved2 = two ? std::max(moved2, mxj * mxj + myj * myj) : moved2;
    bfy = bfy - bmass[b] * (on ? g : 0.0);
    bfx_out[b] = bfx;
    bfy_out[b] = bfy;
    btq_out[b] = btq;
    double vx = bvx[b], vy = bvy[b], w = bw[b];
    if constexpr (kKick) {  // the second half kick of the step
      vx = on ? vx + half * bfx * binv_mass[b] : vx;
      vy = on ? vy + half * bfy * binv_mass[b] : vy;
      w = on ? w + half * btq * binv_inertia[b] : w;
      bvx[b] = vx;
      bvy[b] = vy;
      bw[b] = w;
    }
    outrun |=
        on & OutrunsSkin(vx, vy, w, bfx, bfy, btq, binv_mass[b], binv_inertia[b], bradius[b], moved2, half, dt, limit);
  }
  return outrun != 0;
}

}  // namespace

GRANARY_KERNEL bool ForcePass::BodyForces(int b0, int b1, bool kick) {
  if (b0 >= b1) return false;
  const double g = params_->gravity, half = 0.5 * params_->dt;
  const int* __restrict xl_start = lists_->cross_start_.data();
  const int* __restrict xl_entry = lists_->cross_entry_.data();
  const double* __restrict nl_fx = lists_->pair_fx_.data();
  const double* __restrict nl_fy = lists_->pair_fy_.data();
  const double* __restrict nl_c = lists_->pair_couple_.data();
  double* __restrict dfx = bodies_->disc_fx_.data();
  double* __restrict dfy = bodies_->disc_fy_.data();
  double* __restrict dtz = bodies_->disc_torque_.data();
  // 1. Reactions of entries from earlier blocks, ascending i (few discs have any; discs of
  // inactive bodies have no entries).
  const int d0 = bodies_->body_first_disc_[b0],
            d1 = bodies_->body_first_disc_[b1 - 1] + bodies_->body_disc_count_[b1 - 1];
  for (int i = d0; i < d1; ++i) {
    const int k0 = xl_start[i], k1 = xl_start[i + 1];
    if (k0 == k1) continue;
    double fx = dfx[i], fy = dfy[i], c = 0.0;
    for (int k = k0; k < k1; ++k) {
      const int e = xl_entry[k];
      fx -= nl_fx[e];
      fy -= nl_fy[e];
      c += nl_c[e];
    }
    dfx[i] = fx;
    dfy[i] = fy;
    dtz[i] -= bodies_->disc_radius_[i] * c;
  }
  // 2. Body sums, gravity (and the half kick).
  const double dt = params_->dt, limit = 0.5 * params_->skin;
  // Discs and dumbbells get the vectorized loop (no lambda: one called twice in a
  // target_clones function is compiled for baseline x86-64 only).
#define GRANARY_BODY_SUMS(kDiscs, kKick)                                                                            \
  BodySums<kDiscs, kKick>(b0, b1, g, half, dt, limit, bodies_->body_active_.data(), dfx, dfy, dtz,                  \
                          bodies_->disc_x_.data(), bodies_->disc_y_.data(), lists_->rebuild_x_.data(),              \
                          lists_->rebuild_y_.data(), bodies_->body_x_.data(), bodies_->body_y_.data(),              \
                          bodies_->body_mass_.data(), bodies_->body_inv_mass_.data(),                               \
                          bodies_->body_inv_inertia_.data(), bodies_->body_reach_.data(), bodies_->body_fx_.data(), \
                          bodies_->body_fy_.data(), bodies_->body_torque_.data(), bodies_->body_vx_.data(),         \
                          bodies_->body_vy_.data(), bodies_->body_spin_.data())
  if (bodies_->uniform_discs_ == 1) return kick ? GRANARY_BODY_SUMS(1, true) : GRANARY_BODY_SUMS(1, false);
  if (bodies_->uniform_discs_ == 2) return kick ? GRANARY_BODY_SUMS(2, true) : GRANARY_BODY_SUMS(2, false);
#undef GRANARY_BODY_SUMS
#define GRANARY_BODY_SUMS_UP_TO_2(kKick)                                                                               \
  BodySumsUpTo2<kKick>(b0, b1, g, half, dt, limit, bodies_->body_active_.data(), bodies_->body_first_disc_.data(),     \
                       bodies_->body_disc_count_.data(), dfx, dfy, dtz, bodies_->disc_x_.data(),                       \
                       bodies_->disc_y_.data(), lists_->rebuild_x_.data(), lists_->rebuild_y_.data(),                  \
                       bodies_->body_x_.data(), bodies_->body_y_.data(), bodies_->body_mass_.data(),                   \
                       bodies_->body_inv_mass_.data(), bodies_->body_inv_inertia_.data(), bodies_->body_reach_.data(), \
                       bodies_->body_fx_.data(), bodies_->body_fy_.data(), bodies_->body_torque_.data(),               \
                       bodies_->body_vx_.data(), bodies_->body_vy_.data(), bodies_->body_spin_.data())
  if (bodies_->max_discs_ <= 2) {  // a mixture of discs and dumbbells: eight bodies at a time by the AVX-512 loop
    bool outrun = false;
    if (use_avx512_) {
      const BodySumArrays arrays{bodies_->body_active_.data(),
                                 bodies_->body_first_disc_.data(),
                                 bodies_->body_disc_count_.data(),
                                 dfx,
                                 dfy,
                                 dtz,
                                 bodies_->disc_x_.data(),
                                 bodies_->disc_y_.data(),
                                 lists_->rebuild_x_.data(),
                                 lists_->rebuild_y_.data(),
                                 bodies_->body_x_.data(),
                                 bodies_->body_y_.data(),
                                 bodies_->body_mass_.data(),
                                 bodies_->body_inv_mass_.data(),
                                 bodies_->body_inv_inertia_.data(),
                                 bodies_->body_reach_.data(),
                                 bodies_->body_fx_.data(),
                                 bodies_->body_fy_.data(),
                                 bodies_->body_torque_.data(),
                                 bodies_->body_vx_.data(),
                                 bodies_->body_vy_.data(),
                                 bodies_->body_spin_.data()};
      b0 = kick ? BodySumsUpTo2Avx512<true>(b0, b1, arrays, d1, g, half, dt, limit, &outrun)
                : BodySumsUpTo2Avx512<false>(b0, b1, arrays, d1, g, half, dt, limit, &outrun);
    }
    return (kick ? GRANARY_BODY_SUMS_UP_TO_2(true) : GRANARY_BODY_SUMS_UP_TO_2(false)) || outrun;
  }
#undef GRANARY_BODY_SUMS_UP_TO_2
  bool outrun = false;
  for (int b = b0; b < b1; ++b) {
    if (!bodies_->body_active_[b]) continue;
    double bfx = 0, bfy = 0, btq = 0, moved2 = 0;
    const double cx = bodies_->body_x_[b], cy = bodies_->body_y_[b];
    const int e0 = bodies_->body_first_disc_[b], e1 = e0 + bodies_->body_disc_count_[b];
    for (int i = e0; i < e1; ++i) {
      bfx += dfx[i];
      bfy += dfy[i];
      btq += (bodies_->disc_x_[i] - cx) * dfy[i] - (bodies_->disc_y_[i] - cy) * dfx[i] + dtz[i];
      const double mx = bodies_->disc_x_[i] - lists_->rebuild_x_[i], my = bodies_->disc_y_[i] - lists_->rebuild_y_[i];
      moved2 = std::max(moved2, mx * mx + my * my);
    }
    bodies_->body_fx_[b] = bfx;
    bodies_->body_fy_[b] = bfy - bodies_->body_mass_[b] * g;
    bodies_->body_torque_[b] = btq;
    if (kick) {  // the second half kick of the step
      bodies_->body_vx_[b] += half * bodies_->body_fx_[b] * bodies_->body_inv_mass_[b];
      bodies_->body_vy_[b] += half * bodies_->body_fy_[b] * bodies_->body_inv_mass_[b];
      bodies_->body_spin_[b] += half * bodies_->body_torque_[b] * bodies_->body_inv_inertia_[b];
    }
    outrun =
        outrun || OutrunsSkin(bodies_->body_vx_[b], bodies_->body_vy_[b], bodies_->body_spin_[b], bodies_->body_fx_[b],
                              bodies_->body_fy_[b], bodies_->body_torque_[b], bodies_->body_inv_mass_[b],
                              bodies_->body_inv_inertia_[b], bodies_->body_reach_[b], moved2, half, dt, limit);
  }
  return outrun;
}

void ForcePass::PrepareThreads(int threads) {
  if (lead_sources_.size() < static_cast<std::size_t>(threads)) lead_sources_.resize(static_cast<std::size_t>(threads));
}

const std::vector<int>& ForcePass::LeadSources(int t, int i0, int i1) {
  LeadSourceCache& c = lead_sources_[static_cast<std::size_t>(t)];
  if (c.rebuild != lists_->Rebuilds() || c.i0 != i0 || c.i1 != i1) {  // the shares move with the lists only
    c.rebuild = lists_->Rebuilds();
    c.i0 = i0;
    c.i1 = i1;
    c.entries.clear();
    const int first = i0 / params_->force_block * params_->force_block;
    for (int e = lists_->pair_start_[first]; e < lists_->pair_start_[i0]; ++e)
      if (lists_->pair_j_[e] >= i0 && lists_->pair_j_[e] < i1) c.entries.push_back(e);
  }
  return c.entries;
}

// Called by every thread of a parallel region, each taking its share (PairShareStart): inside Step's
// region (one region per step: fewer forks and joins), elsewhere in the one Forces opens.
bool ForcePass::Run(bool kick, std::int64_t pass, bool await_drift, double* waited) {
  const int t = omp_get_thread_num(), nt = omp_get_num_threads();
  // 1. Pair and wall forces by blocks of discs; within a block the order is ascending i,
  // whichever thread runs it. Each thread takes a contiguous share, the same from step to
  // step, like the drift and body loops: its discs, bodies and list entries stay in its
  // core's cache (with dynamic blocks, 2 threads gave 1.2x instead of 1.7x). In a step, a
  // block first waits for the drift of the chunks holding its discs and their partners
  // (j > i: its own discs and a few beyond), not for a barrier after the whole drift.
  //
  // The shares are even in work (ChunkShareStart), so they split blocks: each thread computes
  // the entries and the sums of the discs in its share (SumPartForces: a block summed in
  // parts gives the bits of the block summed at once), so the sums of a disc are made where
  // its body's forces are. A block's stamp says that all its entries are computed and the
  // sums of the part in the share of its first disc: a later thread computes its part of
  // that block's entries first (share_done_), and its sums last (they need the earlier
  // parts' entries: LeadSources).
  const int n = bodies_->DiscCount(), block = params_->force_block;
  const int m0 = shares_->PairShareStart(t, nt), m1 = shares_->PairShareStart(t + 1, nt);
  auto await_drift_of = [&](int i, int blk) {
    if (!await_drift) return;
    const int c1 = bodies_->disc_body_[lists_->block_last_partner_[blk]] / ThreadShares::kBodyChunk;
    for (int c = bodies_->disc_body_[i] / ThreadShares::kBodyChunk; c <= c1; ++c)
      AwaitPass(shares_->ChunkDone(c).pass, pass, waited);
  };
  int i = m0;
  int lead_end = m0;  // [m0, lead_end): the part of a block that starts in an earlier share
  if (i < m1 && i % block != 0) {
    const int blk = i / block;
    lead_end = std::min({m1, n, (blk + 1) * block});
    await_drift_of(i, blk);
    PairEntriesOf(i, lead_end);
    i = lead_end;
  }
  shares_->ShareDone(t).pass.store(pass, std::memory_order_release);
  static const std::vector<int> kNone;
  while (i < m1) {  // blocks that start in the share
    const int blk = i / block, i1 = std::min(n, i + block), end = std::min(i1, m1);
    await_drift_of(i, blk);
    PairEntriesOf(i, end);
    SumPartForces(i, end, kNone);
    for (int u = t + 1; u < nt && shares_->PairShareStart(u, nt) < i1; ++u)
      AwaitPass(shares_->ShareDone(u).pass, pass, waited);
    shares_->BlockDone(blk).pass.store(pass, std::memory_order_release);
    i = i1;
  }
  // 2. Reactions across blocks, body forces, gravity, torques (and the half kick). A chunk
  // of bodies reads the sums of its discs' blocks and the reactions of entries from earlier
  // blocks, so it waits for those blocks only, not for a barrier. A thread past the first
  // takes its chunks last to first: the last read only its own blocks, and by the time it
  // reaches the first, which read the previous thread's last block, that is done. (Both
  // callers end their parallel region right after, which is a barrier.)
  const int nb = bodies_->BodyCount();
  const int ch0 = shares_->ChunkShareStart(t, nt), ch1 = shares_->ChunkShareStart(t + 1, nt);
  bool outrun = false;
  for (int k = 0; k < ch1 - ch0; k += ThreadShares::kChunksPerCall) {
    const int first = t == 0 ? ch0 + k : std::max(ch0, ch1 - k - ThreadShares::kChunksPerCall);
    const int last = t == 0 ? std::min(ch1, first + ThreadShares::kChunksPerCall) : ch1 - k;  // [first, last)
    const int b0 = first * ThreadShares::kBodyChunk, b1 = std::min(nb, last * ThreadShares::kBodyChunk);
    const int first_block = bodies_->body_first_disc_[b0] / params_->force_block;
    const int last_block =
        (bodies_->body_first_disc_[b1 - 1] + bodies_->body_disc_count_[b1 - 1] - 1) / params_->force_block;
    int from = first_block;
    for (int blk = first_block; blk <= last_block; ++blk) from = std::min(from, lists_->block_first_source_[blk]);
    for (int blk = from; blk <= last_block; ++blk) AwaitPass(shares_->BlockDone(blk).pass, pass, waited);
    if (lead_end > m0 && bodies_->body_first_disc_[b0] < lead_end) {  // (its block's stamp is awaited above)
      SumPartForces(m0, lead_end, LeadSources(t, m0, lead_end));
      lead_end = m0;
    }
    outrun = BodyForces(b0, b1, kick) || outrun;
  }
  return outrun;
}

}  // namespace granary::engine
