// The Slurm executor's pure parts (docs/slurm.md): its options (flags of `campaign run
// --executor slurm` or the spec's "executor" block), the manifest that maps array indices to
// runs, the batch script of an array, the --array value, and reading what Slurm prints
// (`squeue`, `scontrol show config`) with what each job state means for a run. Nothing here
// runs a command; slurm_executor.cpp does.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "runner/executor.h"

namespace granary::runner {

struct SlurmOptions {
  std::string partition;                 // sbatch --partition; "" = the cluster's default
  std::string time;                      // sbatch --time in Slurm's format; "" = from the time limit
  std::string account;                   // sbatch --account
  int cpus_per_run = 1;                  // native: --cpus-per-task and threads; LIGGGHTS: MPI ranks
  int array_max = 0;                     // the %K throttle: tasks of the campaign running at once; 0 = none
  std::vector<std::string> sbatch_args;  // passed to sbatch as they are
  double poll_interval = 5;              // seconds between squeue calls at first; backs off to 12x
};

// The spec's "executor" block: {"type": a row of the executor table (executors.h), "partition",
// "time", "account", "cpus_per_run", "array_max", "sbatch_args": [...], "poll_interval"}: the
// options are Slurm's whatever the type, so `--executor slurm` can use a block of another type. Returns the type;
// errors (SpecError) name the JSON path under `path`.
std::string ParseExecutorBlock(const nlohmann::json& block, const std::string& path, SlurmOptions& options);

// Is `text` a Slurm time ("MM", "MM:SS", "HH:MM:SS", "D-HH", "D-HH:MM", "D-HH:MM:SS")?
bool IsSlurmTime(const std::string& text);
// Seconds as a Slurm --time value, rounded up to whole minutes ("D-HH:MM:00").
std::string SlurmTime(double seconds);

// One line of the manifest: which run an array index stands for.
struct ManifestEntry {
  int index = 0;
  std::string run_id;
  std::string engine;      // "native" or "liggghts"
  std::string executable;  // absolute path of granary-engine / granary-liggghts (or --engine PATH)
  std::string run_dir;     // absolute
};
// Tab-separated, one run a line after a comment line; throws std::invalid_argument when a
// field holds a tab or a newline.
std::string ManifestText(const std::vector<ManifestEntry>& entries);
std::vector<ManifestEntry> ParseManifest(const std::string& text);

// The --array value of `indices` (sorted, distinct): ranges where they are consecutive,
// e.g. {0,1,2,5,7,8} -> "0-2,5,7-8"; with throttle > 0, "%K" appended.
std::string ArraySpec(const std::vector<int>& indices, int throttle);

// Everything one sbatch call needs.
struct BatchJob {
  std::string job_name;
  std::string array;       // --array value
  std::string manifest;    // absolute path
  std::string log_dir;     // Slurm's own output of the script: LOG_DIR/%A_%a.out
  std::string engine;      // every run of one array uses one engine (threads or MPI ranks)
  std::string dependency;  // e.g. "afterany:123", or ""
  double time_limit = 0;   // per run, seconds from the task's start; 0 = none
  SlurmOptions options;
};
// The batch script: #SBATCH lines, then look up the task's run in the manifest, record the
// task in DIR/slurm-task.json, run the engine (under `timeout` when there is a time limit),
// record its exit status.
std::string BatchScript(const BatchJob& job);

// `squeue --noheader --array --states=all --format=kSqueueFormat` with SLURM_TIME_FORMAT=%s.
inline constexpr char kSqueueFormat[] = "%F|%K|%T|%S|%j|%r";
std::vector<QueueEntry> ParseSqueue(const std::string& text);

// MaxArraySize from `scontrol show config` (Slurm's default 1001 when absent).
int ParseMaxArraySize(const std::string& show_config);

// What a Slurm job state means for the run it carries (TaskFate in executor.h).
TaskFate FateOf(const std::string& state);

// DIR/slurm-task.json, written by the batch script: which task ran the run, when it started,
// and (once the engine ended) its exit status.
struct TaskRecord {
  std::string job;  // "ARRAYJOB_INDEX"
  std::string node;
  double started_at = 0;
  std::optional<int> exit_code;
  double ended_at = 0;
};
std::optional<TaskRecord> ParseTaskRecord(const std::string& text);

// Did the task's `timeout` end the engine at `time_limit`? Exit status 124 (stopped), or
// 128 + 9 (killed after the grace period) once the limit had passed.
bool EndedByTimeLimit(const TaskRecord& record, double time_limit);

}  // namespace granary::runner
