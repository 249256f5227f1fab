// One engine run on a run directory (docs/run-directory.md): obtain the bed, open the
// outlets, discharge in remove or reinject mode, write events, frames, contacts, progress,
// checkpoints, summary.json and DONE.
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
  // Tests: a stop request (as SIGTERM) after this many discharge steps: the engine writes a
  // checkpoint and RunDirectory throws Stopped; < 0 = never.
  std::int64_t stop_after_steps = -1;
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

// Runs DIR/run.json under the directory's lock (files.h; throws RunDirectoryBusy);
// continues from DIR/checkpoint.bin, or checkpoint.prev.bin when that one is refused, if
// present. Throws on errors, and granary::Stopped (stop.h) after a stop request.
RunResult RunDirectory(const std::string& dir, const RunOptions& options);

// SIGTERM and SIGINT become stop requests: during the discharge the engine writes a
// checkpoint at the end of the current step and RunDirectory throws Stopped; before it (bed
// preparation, which is not checkpointed) and after it the signal ends the process at once.
void InstallStopHandlers();

}  // namespace granary::engine
