// How the threads of a step divide the work and wait for each other: each thread owns a
// contiguous share of body chunks (and their discs), about even in work, and publishes what it
// has finished in stamps that the others wait for, instead of meeting at barriers.
//
// Which thread computes what changes no bit (force_pass.h): the shares move the work, not the
// order of any sum.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "engine/body_store.h"
#include "engine/thread_shared.h"

namespace granary::engine {

struct WorldParams;
class NeighbourLists;

// Which pass a piece of work (a force block, a body chunk, a thread's share) has finished.
// A pair of cache lines each (thread_shared.h).
struct alignas(kThreadSharedAlign) PassStamp {
  std::atomic<std::int64_t> pass{-1};
};

// Per thread, in a region of several steps (World::StepsInOneRegion): the last step it has
// finished and its drift and force flags, in a slot by the step's parity (a thread is at
// most one step ahead of another when it reads them).
struct alignas(kThreadSharedAlign) StepDone {
  std::atomic<std::int64_t> pass{-1};
  int flags[2] = {0, 0};
};

struct alignas(kThreadSharedAlign) ThreadClock {
  double busy = 0.0;  // seconds worked, not waited, since the last Rebalance
};

// Waits until `stamp` holds `pass` or a later one (another thread publishes it when its work
// is done; passes only grow). Adds the seconds waited to *waited, if given.
void WaitForPass(const std::atomic<std::int64_t>& stamp, std::int64_t pass, double* waited);
inline void AwaitPass(const std::atomic<std::int64_t>& stamp, std::int64_t pass, double* waited = nullptr) {
  if (stamp.load(std::memory_order_acquire) >= pass) return;  // (most calls: inline)
  WaitForPass(stamp, pass, waited);
}

class ThreadShares {
 public:
  static constexpr int kBodyChunk = 64;     // bodies per parallel work item (small: even shares)
  static constexpr int kChunksPerCall = 8;  // chunks per call of the drift and body loops (fewer calls)

  ThreadShares(const WorldParams& params, const BodyStore& bodies, const NeighbourLists& lists) {
    Bind(params, bodies, lists);
  }
  // What the shares divide (again after the owner has moved).
  void Bind(const WorldParams& params, const BodyStore& bodies, const NeighbourLists& lists) {
    params_ = &params;
    bodies_ = &bodies;
    lists_ = &lists;
  }

  // Numbers a force pass, sizes the stamps and works out the shares for
  // omp_get_max_threads() threads (before the parallel region: lists and shares do not
  // change inside one).
  std::int64_t NextPass();
  // After a region of several steps whose first pass was NextPass()'s: the last one taken.
  void SetLastPass(std::int64_t pass) { pass_ = pass; }

  // Thread t's of nt shares, contiguous and about even in work: body chunks
  // [ChunkShareStart(t), ChunkShareStart(t + 1)) for the drift and the body sums, and their
  // discs [PairShareStart(t), PairShareStart(t + 1)) for the pair entries and sums.
  // The shares start even in list entries + discs; Rebalance moves them towards even
  // measured times.
  int ChunkShareStart(int t, int nt) const;
  int PairShareStart(int t, int nt) const;

  // Every kBalanceEvery steps in regions of a team of nt threads, moves the share boundaries
  // towards even measured work times (thread_busy, waits excluded): a disc or an entry does
  // not cost the same in every part of the bed, nor next to another core's share (its data
  // cross between the cores).
  void Rebalance(int nt, int steps);

  // Which force pass each force block has finished (ForcePass): a thread's body forces wait
  // for the blocks they read, not for every thread at a barrier.
  PassStamp& BlockDone(int block) { return block_done_[block]; }
  // Which pass each body chunk's drift has finished: a pair block waits for the chunks that
  // hold its discs and partners (from the first disc to NeighbourLists::block_last_partner_).
  PassStamp& ChunkDone(int chunk) { return chunk_done_[chunk]; }
  // Per thread: the pass whose pair entries it has computed in the block an earlier thread
  // sums (ForcePass).
  PassStamp& ShareDone(int t) { return share_done_[t]; }
  StepDone& StepDoneOf(int t) { return step_done_[t]; }
  ThreadClock& ThreadBusy(int t) { return thread_busy_[t]; }

 private:
  static constexpr int kBalanceEvery = 100;
  int FindShareStart(int t, int nt) const;

  const WorldParams* params_;
  const BodyStore* bodies_;
  const NeighbourLists* lists_;
  std::int64_t pass_ = 0;
  SharedVector<int> share_starts_;  // ChunkShareStart(t, share_team_) for t = 0..share_team_
  int share_team_ = 0;
  std::unique_ptr<PassStamp[]> block_done_;
  int block_done_count_ = 0;
  std::unique_ptr<PassStamp[]> chunk_done_;
  int chunk_done_count_ = 0;
  std::unique_ptr<PassStamp[]> share_done_;
  int share_done_count_ = 0;
  std::unique_ptr<StepDone[]> step_done_;
  std::unique_ptr<ThreadClock[]> thread_busy_;
  std::vector<double> share_shift_;  // per share boundary t: shift of its work target (a fraction of all work)
  int balance_team_ = 0;             // the team share_shift_ is for (0: none yet)
  int balance_steps_ = 0;
};

}  // namespace granary::engine
