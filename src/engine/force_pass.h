// The force pass: the pair forces of the list entries, their sums per disc, the wall
// forces, the reactions across force blocks and the body sums (gravity, torques, and in a
// step the second half kick), each thread over its share (thread_shares.h).
//
// Determinism: every pair force is computed once, in a fixed block of discs
// (WorldParams::force_block), and summed per disc and per body in an order fixed by the disc
// numbering and the block size alone, so results do not depend on the thread count.
#pragma once

#include <cstdint>
#include <vector>

#include "engine/body_store.h"
#include "engine/contact_law.h"
#include "engine/neighbour_lists.h"
#include "engine/thread_shared.h"
#include "engine/thread_shares.h"
#include "silo/geometry.h"

namespace granary::engine {

struct WorldParams;

class ForcePass {
 public:
  ForcePass(const WorldParams& params, const silo::SiloGeometry& geometry, BodyStore& bodies, NeighbourLists& lists,
            ThreadShares& shares, bool use_avx512)
      : use_avx512_(use_avx512) {
    Bind(params, geometry, bodies, lists, shares);
  }
  // What the pass works on (again after the owner has moved).
  void Bind(const WorldParams& params, const silo::SiloGeometry& geometry, BodyStore& bodies, NeighbourLists& lists,
            ThreadShares& shares) {
    params_ = &params;
    geometry_ = &geometry;
    bodies_ = &bodies;
    lists_ = &lists;
    shares_ = &shares;
  }

  // Room for the per-thread caches of `threads` threads.
  void PrepareThreads(int threads);
  // Called by every thread of a parallel region, each taking its share: the pair entries,
  // block sums and body forces (with `kick`, the second half kick of a step). With
  // `await_drift`, pair entries first wait for the drift of the discs they read (the drift
  // publishes it with `pass`, Integrator::DriftShare). Returns whether the next drift may take
  // a disc of the thread's bodies beyond half the skin from its rebuild position (then the
  // next step must rebuild the lists). Adds the seconds the thread waited for others to
  // *waited, if given.
  bool Run(bool kick, std::int64_t pass, bool await_drift, double* waited = nullptr);

 private:
  // The kernels, each over a range that one thread owns (compiled for several instruction
  // sets, chosen at load time; the arithmetic is the same in each).
  void PairEntriesOf(int i0, int i1);  // the pair entries of discs [i0, i1)
  // Sums and wall forces of discs [i0, i1) of one force block; `earlier`: the entries from
  // the block's discs before i0 into them (LeadSources).
  void SumPartForces(int i0, int i1, const std::vector<int>& earlier);
  template <class Normal, bool kLiggghtsCap>
  void PairRange(int e0, int e1);  // the pair loop over list entries [e0, e1)
  template <class Normal, bool kLiggghtsCap>
  void WallEntries(int k0, int k1, const ContactParams& wp);  // the wall loop of a force block
  // Cross-block reactions, body sums, kick; returns whether the next drift may take a disc
  // of these bodies beyond half the skin from its rebuild position (OutrunsSkin).
  bool BodyForces(int b0, int b1, bool kick);
  // The entries from the discs of i0's force block before i0 into discs [i0, i1), ascending
  // (thread t's, kept until the lists or the bounds change).
  const std::vector<int>& LeadSources(int t, int i0, int i1);

  const WorldParams* params_;
  const silo::SiloGeometry* geometry_;
  BodyStore* bodies_;
  NeighbourLists* lists_;
  ThreadShares* shares_;
  bool use_avx512_;  // WorldParams::avx512_kernels and the CPU has AVX-512F
  struct alignas(kThreadSharedAlign) LeadSourceCache {
    std::int64_t rebuild = -1;
    int i0 = -1, i1 = -1;
    std::vector<int> entries;
  };
  std::vector<LeadSourceCache> lead_sources_;  // per thread (LeadSources)
};

}  // namespace granary::engine
