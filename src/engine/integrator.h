// The drift half of the velocity-Verlet step: the first half kick, the drift and rotation
// of the bodies, then their discs' positions and records (the second half kick comes with
// the forces, ForcePass), each thread over its share of body chunks (thread_shares.h).
#pragma once

#include <cstdint>

#include "engine/body_store.h"
#include "engine/neighbour_lists.h"
#include "engine/thread_shares.h"

namespace granary::engine {

struct WorldParams;

class Integrator {
 public:
  // DriftShare's flags: a disc moved more than half the skin since the last rebuild; an
  // active body's centre is outside the exit box.
  static constexpr int kDriftMoved = 1, kDriftBeyond = 2;

  Integrator(const WorldParams& params, BodyStore& bodies, const NeighbourLists& lists, ThreadShares& shares,
             bool use_avx512)
      : use_avx512_(use_avx512) {
    Bind(params, bodies, lists, shares);
  }
  // What the integrator moves (again after the owner has moved).
  void Bind(const WorldParams& params, BodyStore& bodies, const NeighbourLists& lists, ThreadShares& shares) {
    params_ = &params;
    bodies_ = &bodies;
    lists_ = &lists;
    shares_ = &shares;
  }

  // The exit box {xmin, xmax, ymin} that kDriftBeyond reports on.
  void SetExitBox(double xmin, double xmax, double ymin);
  bool ExitBoxSet() const { return exit_box_set_; }

  // Thread t's of nt share of the drift (body chunks), publishing each chunk with `pass`
  // (ThreadShares::chunk_done); returns the flags.
  int DriftShare(int t, int nt, std::int64_t pass);

 private:
  // Half kick and drift of bodies [b0, b1) and their discs; returns the flags.
  int DriftBodies(int b0, int b1);
  int DriftPortable(int b0, int b1);    // DriftBodies without the AVX-512 loops
  int DriftBodyKernel(int b0, int b1);  // its body part: returns kBeyond (integrator.cpp)

  const WorldParams* params_;
  BodyStore* bodies_;
  const NeighbourLists* lists_;
  ThreadShares* shares_;
  bool use_avx512_;  // WorldParams::avx512_kernels and the CPU has AVX-512F
  double exit_box_[3] = {0.0, 0.0, 0.0};
  bool exit_box_set_ = false;
};

}  // namespace granary::engine
