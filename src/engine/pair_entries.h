// The portable pair-force loop of a force block (world.cpp PairEntriesOf); avx512_kernels.h has
// the same loop in AVX-512 intrinsics, which must give the same bits.
#pragma once

#include "engine/contact_law.h"
#include "engine/world.h"

namespace granary::engine {

// Pair forces of list entries [e0, e1): new history and force (on i) and the tangential
// couple n x F_t into the entry's slots; zeros for an entry whose discs do not touch (its
// history resets). One straight loop over the entries, no branches: it vectorizes
// (gathers of the two discs' records), and each lane does exactly the scalar arithmetic.
template <bool kLiggghtsCap>
[[gnu::always_inline]] inline void PairEntries(int e0, int e1, const int* __restrict nl_i, const int* __restrict nl_j,
                        const double* __restrict nl_reff, const double* __restrict nl_meff,
                        double* __restrict nl_sx, double* __restrict nl_sy, double* __restrict nl_fx,
                        double* __restrict nl_fy, double* __restrict nl_c, const World::DiscKin* __restrict kin,
                        const ContactParams& pp, double dt) {
  for (int e = e0; e < e1; ++e) {
    const World::DiscKin& a = kin[nl_i[e]];
    const World::DiscKin& b = kin[nl_j[e]];
    const double ddx = a.x - b.x, ddy = a.y - b.y;
    const double rsq = ddx * ddx + ddy * ddy;
    const double radsum = a.r + b.r;
    const bool touch = rsq < radsum * radsum;
    const double r = std::sqrt(rsq);
    const double inv_r = 1.0 / r;
    const double nx = ddx * inv_r, ny = ddy * inv_r;
    const double delta = radsum - r;
    const double reff = nl_reff[e], meff = nl_meff[e];
    const double vrx = a.vx - b.vx, vry = a.vy - b.vy;
    const double vn = vrx * nx + vry * ny;
    const double wr = a.r * a.w + b.r * b.w;
    const double vtx = vrx - vn * nx + wr * ny;
    const double vty = vry - vn * ny - wr * nx;
    const double fn = NormalForce(delta, reff, meff, vn, pp);
    const Tangential t = TangentialForceT<kLiggghtsCap>(nl_sx[e], nl_sy[e], nx, ny, vtx, vty, delta, reff, meff, fn, dt, pp);
    nl_sx[e] = touch ? t.sx : 0.0;
    nl_sy[e] = touch ? t.sy : 0.0;
    nl_fx[e] = touch ? fn * nx + t.fx : 0.0;
    nl_fy[e] = touch ? fn * ny + t.fy : 0.0;
    nl_c[e] = touch ? nx * t.fy - ny * t.fx : 0.0;
  }
}


}  // namespace granary::engine
