// One engine run on a run directory (docs/run-directory.md): obtain the bed, open the
// outlets, discharge in remove or reinject mode, write events, frames, contacts, progress,
// checkpoints, summary.json and DONE. Also the standard benchmark.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rundir/run_spec.h"

namespace granary::engine {

struct RunOptions {
  int threads = 0;              // 0 = OpenMP default
  bool quiet = false;           // no progress lines on stdout
  double progress_every_s = 3.0;
  // Tests: stop (as if killed) after this many discharge steps, leaving the checkpoint
  // behind; < 0 = never.
  std::int64_t abort_after_steps = -1;
  // Tests: parallelise even tiny systems (WorldParams::parallel_min_discs); < 0 = default.
  int parallel_min_discs = -1;
  // Tests: discs per force block (WorldParams::force_block), small to exercise the
  // reactions that cross blocks; < 1 = default.
  int force_block = 0;
};

struct RunResult {
  std::string end_reason;       // "discharged", "clogged", "time_limit", "aborted"
  int exited = 0;
  std::int64_t steps = 0;
  double t_end = 0.0;
  bool continued = false;
};

// Runs DIR/run.json; continues from DIR/checkpoint.bin if present. Throws on errors.
RunResult RunDirectory(const std::string& dir, const RunOptions& options);

struct BenchOptions {
  int bodies = 8000;
  std::int64_t steps = 2000;
  std::vector<int> threads = {1, 2};
  std::string bed_file;         // where to cache the settled bed ("" = a file in the temp dir)
  int repeat = 1;               // rounds over the thread counts (interleaved, for a shared machine)
};

struct BenchResult {
  int round;  // 1..repeat
  int threads;
  double disc_steps_per_s;
  double wall_s;
};

// The standard case: dumbbells settled in the chapter-3 silo (walls at +-50 d), outlet
// W = 14 d, reinject mode, a fixed number of steps per thread count; `repeat` rounds over
// the thread counts.
std::vector<BenchResult> RunBenchmark(const BenchOptions& options);

// The median of repeated bench rates (the mean of the middle two for an even count).
double BenchMedian(std::vector<double> rates);

}  // namespace granary::engine
