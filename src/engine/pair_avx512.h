// The pair-force loop of a force block written with AVX-512 intrinsics, eight list entries
// at a time: the same IEEE operations in the same order as the portable loop
// (world.cpp PairEntries, contact_law.h), so the results are the same to the bit.
//
// Why by hand: GCC assembles the eight lanes' disc records element by element (~200 scalar
// loads and inserts per 16 entries), and a branch-free loop computes the slip rescale
// (two divisions and a square root) for every entry though ~1 % of contacts slip. Here a
// record is one 64-byte load, eight of them are transposed in registers, and the slip
// arithmetic runs only for the rare groups of eight where some touching lane slips.
#pragma once

#include "engine/contact_law.h"
#include "engine/world.h"

namespace granary::engine {

// Whether this CPU (and OS) runs AVX-512F code; false on other architectures.
bool PairAvx512Available();

// Pair forces of entries [e0, e0 + 8 k) for the largest such k with e0 + 8 k <= e1 (the
// caller does the rest with the portable loop); returns e0 + 8 k. Same arguments and
// outputs as PairEntries. Call only when PairAvx512Available().
template <bool kLiggghtsCap>
int PairEntriesAvx512(int e0, int e1, const int* nl_i, const int* nl_j, const double* nl_reff,
                      const double* nl_meff, double* nl_sx, double* nl_sy, double* nl_fx, double* nl_fy,
                      double* nl_c, const World::DiscKin* kin, const ContactParams& pp, double dt);

}  // namespace granary::engine
