// Two loops of the step written with AVX-512 intrinsics: the same IEEE operations in the
// same order as their portable versions (pair_entries.h; world.cpp PlaceDisc), so the
// results are the same to the bit.
//
// Why by hand: both move whole 64-byte disc records (World::DiscKin), which GCC reads and
// writes element by element (~200 scalar loads or stores and inserts per 16 records).
// Here a record is one 64-byte load or store, and eight of them are transposed in registers.
#pragma once

#include "engine/contact_law.h"
#include "engine/world.h"

namespace granary::engine {

// Whether this CPU (and OS) runs AVX-512F code; false on other architectures.
bool Avx512Available();

// Pair forces of entries [e0, e0 + 8 k) for the largest such k with e0 + 8 k <= e1 (the
// caller does the rest with the portable loop); returns e0 + 8 k. Same arguments and
// outputs as PairEntries. Call only when Avx512Available().
template <bool kLiggghtsCap>
int PairEntriesAvx512(int e0, int e1, const int* nl_i, const int* nl_j, const double* nl_reff,
                      const double* nl_meff, double* nl_sx, double* nl_sy, double* nl_fx, double* nl_fy,
                      double* nl_c, const World::DiscKin* kin, const ContactParams& pp, double dt);
// (A branch-free loop would compute the slip rescale, two divisions and a square root, for
// every entry, though ~5 % of contacts slip: here only for the groups of eight where a
// touching lane slips.)

// Positions and kinematics of the discs of dumbbells (two discs per body, disc k of body b
// being 2 b + k) for bodies [b0, b0 + 8 k), the largest such k with b0 + 8 k <= b1, as
// world.cpp's DiscKernelUniform<2>; returns b0 + 8 k, and sets *moved if a disc has moved
// more than sqrt(limit) since the last rebuild. Call only when Avx512Available().
int PlaceDumbbellDiscsAvx512(int b0, int b1, double limit, const double* bx, const double* by, const double* bvx,
                             const double* bvy, const double* bw, const double* bc, const double* bs,
                             const double* dox, const double* doy, const double* dr, const double* refx,
                             const double* refy, double* dx, double* dy, World::DiscKin* kin, bool* moved);

}  // namespace granary::engine
