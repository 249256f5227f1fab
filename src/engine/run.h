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
  int threads = 0;     // 0 = OpenMP default
  bool quiet = false;  // no progress lines on stdout
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
  std::string end_reason;  // "discharged", "clogged", "time_limit", "aborted"
  int exited = 0;
  std::int64_t steps = 0;
  double t_end = 0.0;
  bool continued = false;
};

// Runs DIR/run.json under the directory's lock (files.h; throws RunDirectoryBusy);
// continues from DIR/checkpoint.bin, or checkpoint.prev.bin when that one is refused, if
// present. Throws on errors, and granary::Stopped (stop.h) after a stop request.
RunResult RunDirectory(const std::string& dir, const RunOptions& options);

// How another engine starts from the native engine's bed (the LAMMPS backend, docs/lammps.md):
// the bed of DIR/run.json, obtained as `run` obtains it (bed.cache_file, or DIR/bed.json),
// placed with the outlets open and the bodies an obstacle overlaps taken out, written into
// `file` as one frame at t = 0 (frames.dump format: disc ids, body ids, positions, radii,
// masses, velocities). Whatever the spec's engine. The bed's contact history is not in it.
struct StartState {
  std::string bed_file;
  bool bed_prepared_here = false;
  double bed_height = 0, settle_time = 0, bed_wall_s = 0;
  std::string bed_refused;
  int cleared_by_obstacles = 0;
};
StartState WriteStartFrame(const std::string& dir, const std::string& file, const RunOptions& options);

// SIGTERM and SIGINT become stop requests: during the discharge the engine writes a
// checkpoint at the end of the current step and RunDirectory throws Stopped; before it (bed
// preparation, which is not checkpointed) and after it the signal ends the process at once.
void InstallStopHandlers();

}  // namespace granary::engine
