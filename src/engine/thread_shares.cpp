// The threads' shares of a step and their stamps (thread_shares.h).
#include "engine/thread_shares.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "engine/neighbour_lists.h"
#include "engine/world.h"

namespace granary::engine {

void WaitForPass(const std::atomic<std::int64_t>& stamp, std::int64_t pass, double* waited) {
  const auto start = std::chrono::steady_clock::now();
  for (int spins = 0; stamp.load(std::memory_order_acquire) < pass; ++spins) {
#if defined(__x86_64__)
    __builtin_ia32_pause();
#endif
    if (spins > 4096) std::this_thread::yield();  // the other thread may not be running now
  }
  if (waited) *waited += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::int64_t ThreadShares::NextPass() {
  const int nblocks = (bodies_->DiscCount() + params_->force_block - 1) / params_->force_block;
  if (nblocks != block_done_count_) {  // only when bodies are added
    block_done_ = std::make_unique<PassStamp[]>(static_cast<std::size_t>(nblocks));
    block_done_count_ = nblocks;
  }
  const int nchunks = (bodies_->BodyCount() + kBodyChunk - 1) / kBodyChunk;
  if (nchunks != chunk_done_count_) {
    chunk_done_ = std::make_unique<PassStamp[]>(static_cast<std::size_t>(nchunks));
    chunk_done_count_ = nchunks;
  }
  const int threads = omp_get_max_threads();
  if (threads > share_done_count_) {
    share_done_ = std::make_unique<PassStamp[]>(static_cast<std::size_t>(threads));
    share_done_count_ = threads;
    step_done_ = std::make_unique<StepDone[]>(static_cast<std::size_t>(threads));
    thread_busy_ = std::make_unique<ThreadClock[]>(static_cast<std::size_t>(threads));
    balance_team_ = 0;
  }
  share_starts_.resize(static_cast<std::size_t>(threads) + 1);
  for (int t = 0; t <= threads; ++t) share_starts_[static_cast<std::size_t>(t)] = FindShareStart(t, threads);
  share_team_ = threads;
  return ++pass_;
}

int ThreadShares::ChunkShareStart(int t, int nt) const {
  return nt == share_team_ ? share_starts_[static_cast<std::size_t>(t)] : FindShareStart(t, nt);
}

int ThreadShares::FindShareStart(int t, int nt) const {
  const int n = bodies_->DiscCount(), nchunks = (bodies_->BodyCount() + kBodyChunk - 1) / kBodyChunk;
  if (t <= 0) return 0;
  if (t >= nt) return nchunks;
  const std::vector<int>& pair_start = lists_->pair_start_;
  if (pair_start.size() != static_cast<std::size_t>(n) + 1)  // no lists yet (bodies added since)
    return static_cast<int>(static_cast<long>(nchunks) * t / nt);
  // A disc costs about as much as a list entry (its drift and body sums against an entry's
  // force and sums: measured), so the work before disc i is about pair_start[i] + i; the
  // measured shift (Rebalance) moves the target by what the threads' times say.
  const double shift = balance_team_ == nt ? share_shift_[static_cast<std::size_t>(t)] : params_->share_shift;
  const long target = std::lround((static_cast<double>(pair_start[n]) + n) * (static_cast<double>(t) / nt + shift));
  int lo = 0, hi = n;  // the first i with pair_start[i] + i >= target
  while (lo < hi) {
    const int mid = lo + (hi - lo) / 2;
    if (static_cast<long>(pair_start[mid]) + mid < target)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo >= n ? nchunks : std::min(nchunks, (bodies_->disc_body_[lo] + kBodyChunk / 2) / kBodyChunk);
}

void ThreadShares::Rebalance(int nt, int steps) {
  if (nt != balance_team_) {  // a new team: start from the split even in work
    share_shift_.assign(static_cast<std::size_t>(nt), params_->share_shift);
    for (int t = 0; t < nt; ++t) thread_busy_[t].busy = 0.0;
    balance_team_ = nt;
    balance_steps_ = 0;
    return;
  }
  balance_steps_ += steps;
  if (balance_steps_ < kBalanceEvery || !params_->rebalance_shares) return;
  balance_steps_ = 0;
  double total = 0.0;
  for (int t = 0; t < nt; ++t) total += thread_busy_[t].busy;
  double before = 0.0;  // busy seconds of the threads before boundary t
  for (int t = 1; t < nt && total > 0.0; ++t) {
    before += thread_busy_[t - 1].busy;
    // Threads before the boundary that worked more than their part give work to those after
    // (half the difference at a time, so that noise in the times does not swing the split).
    const double limit = 0.25 / nt;
    const std::size_t k = static_cast<std::size_t>(t);
    share_shift_[k] = std::clamp(share_shift_[k] + 0.5 * (static_cast<double>(t) / nt - before / total), -limit, limit);
  }
  for (int t = 0; t < nt; ++t) thread_busy_[t].busy = 0.0;
}

int ThreadShares::PairShareStart(int t, int nt) const {
  const int b = ChunkShareStart(t, nt) * kBodyChunk;
  return b >= bodies_->BodyCount() ? bodies_->DiscCount() : bodies_->body_first_disc_[b];
}

}  // namespace granary::engine
