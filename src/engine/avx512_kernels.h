// Loops of the step with AVX-512 intrinsics: the pair loop runs the contact kernel
// (contact_law.h) on an eight-lane value type; the drift and body sums do the same IEEE
// operations in the same order as their portable versions (integrator.cpp PlaceDisc,
// BodySumsUpTo2), so the results are the same to the bit.
//
// Why by hand: both move whole 64-byte disc records (DiscKin), which GCC reads and
// writes element by element (~200 scalar loads or stores and inserts per 16 records).
// Here a record is one 64-byte load or store, and eight of them are transposed in registers.
#pragma once

#include <cstdint>

#include "engine/contact_law.h"
#include "engine/body_store.h"

namespace granary::engine {

// Whether this CPU (and OS) runs AVX-512F code; false on other architectures.
bool Avx512Available();

// Pair forces of entries [e0, e0 + 8 k) for the largest such k with e0 + 8 k <= e1 (the
// caller does the rest with the portable loop); returns e0 + 8 k. Same arguments and
// outputs as PairEntries with the law of pp (contact_law.h PairEntry on eight lanes).
// Call only when Avx512Available().
int PairEntriesAvx512(int e0, int e1, const int* nl_i, const int* nl_j, const double* nl_reff, const double* nl_meff,
                      double* nl_sx, double* nl_sy, double* nl_fx, double* nl_fy, double* nl_c, const DiscKin* kin,
                      const ContactParams& pp, double dt);
// (A branch-free loop would compute the slip rescale, two divisions and a square root, for
// every entry, though ~5 % of contacts slip: here only for the groups of eight where a
// touching lane slips; NeedAny.)

// The arrays a drift reads and writes (World's body and disc state).
struct DriftArrays {
  const std::uint8_t* active;
  double *bx, *by, *bth, *bvx, *bvy, *bw, *bc, *bs;
  const double *bfx, *bfy, *btq, *binv_mass, *binv_inertia;
  const double *dox, *doy, *dr, *refx, *refy;
  double *dx, *dy;
  DiscKin* kin;
};

// The drift of bodies of kDiscs discs each (1: discs, 2: dumbbells; disc k of body b being
// kDiscs b + k), eight at a time, as integrator.cpp's DriftKernel followed by
// DiscKernelUniform<kDiscs>: half kick, drift and rotation of the bodies, then their discs'
// positions and records. Stops before the first group of eight with a rotation of 0.01 rad
// or more (the caller's portable loop, with libm, takes that group) or with fewer than
// eight bodies left; returns where it stopped. Sets *beyond if an active body's centre left
// the box {xmin, xmax, ymin}, *moved if a disc moved more than sqrt(limit) since the last
// rebuild. Call only when Avx512Available().
template <int kDiscs>
int DriftUniformAvx512(int b0, int b1, const DriftArrays& arrays, double dt, const double box[3], double limit,
                       bool* beyond, bool* moved);

// The disc part of a drift for discs [d0, d0 + 8 k), the largest such k with d0 + 8 k <= d1,
// of bodies of any shape (disc d of body dbody[d], discs numbered body by body, every body
// with at least one, all of them before body_end), as integrator.cpp's DiscKernel: positions and
// records from the bodies' state after their drift. Returns d0 + 8 k; sets *moved as
// DriftUniformAvx512. Reads no body from body_end on, and only the disc and body-state
// arrays of `arrays`. Call only when Avx512Available().
int PlaceDiscsAvx512(int d0, int d1, double limit, const int* dbody, int body_end, const DriftArrays& arrays,
                     bool* moved);

// The arrays the body sums read and write (World's disc and body state).
struct BodySumArrays {
  const std::uint8_t* active;
  const int *disc_begin, *disc_n;
  const double *dfx, *dfy, *dtz, *dx, *dy, *refx, *refy;
  const double *bx, *by, *bmass, *binv_mass, *binv_inertia, *bradius;
  double *bfx, *bfy, *btq, *bvx, *bvy, *bw;
};

// The body sums (and with kKick the second half kick) of bodies of one or two discs, for
// bodies [b0, b0 + 8 k), the largest such k with b0 + 8 k <= b1, as force_pass.cpp's
// BodySumsUpTo2; reads no disc from disc_end on (the first disc after body b1 - 1). Returns
// b0 + 8 k; sets *outrun if an active body's next drift may take a disc beyond half the
// skin (OutrunsSkin). Call only when Avx512Available().
template <bool kKick>
int BodySumsUpTo2Avx512(int b0, int b1, const BodySumArrays& arrays, int disc_end, double g, double half, double dt,
                        double limit, bool* outrun);

}  // namespace granary::engine
