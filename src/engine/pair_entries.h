// The portable pair-force loop of a force block (force_pass.cpp ForcePass::PairEntriesOf); avx512_kernels.cpp
// runs the same PairEntry (contact_law.h) on eight entries at a time.
#pragma once

#include "engine/contact_law.h"
#include "engine/body_store.h"

namespace granary::engine {

// Pair forces of list entries [e0, e1): new history and force (on i) and the tangential
// couple n x F_t into the entry's slots; zeros for an entry whose discs do not touch (its
// history resets). One straight loop over the entries, no branches: it vectorizes
// (gathers of the two discs' records), and each lane does exactly the scalar arithmetic.
template <class Normal, bool kLiggghtsCap>
[[gnu::always_inline]] inline void PairEntries(int e0, int e1, const int* __restrict nl_i, const int* __restrict nl_j,
                                               const double* __restrict nl_reff, const double* __restrict nl_meff,
                                               double* __restrict nl_sx, double* __restrict nl_sy,
                                               double* __restrict nl_fx, double* __restrict nl_fy,
                                               double* __restrict nl_c, const DiscKin* __restrict kin,
                                               const ContactParams& pp, double dt) {
  const LawConstants<double> law(pp, dt);
  for (int e = e0; e < e1; ++e) {
    const DiscKin& a = kin[nl_i[e]];
    const DiscKin& b = kin[nl_j[e]];
    PairEntry<Normal, kLiggghtsCap>(DiscState<double>{a.x, a.y, a.vx, a.vy, a.r, a.w},
                                    DiscState<double>{b.x, b.y, b.vx, b.vy, b.r, b.w}, nl_reff + e, nl_meff + e,
                                    nl_sx + e, nl_sy + e, nl_fx + e, nl_fy + e, nl_c + e, law);
  }
}

}  // namespace granary::engine
