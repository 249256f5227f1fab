// The Slurm executor (docs/slurm.md): runs go to Slurm as job arrays, one task per run, each
// task running the engine on its run directory (nothing on a compute node touches SQLite).
// Place() writes a submission directory <root>/<campaign>-NNNN/ with manifest.tsv (array
// index -> run), the batch script job-K.sh and logs/; Submit() calls sbatch; Poll() calls
// squeue once for every job, backing off while nothing changes, and reports a task as ended
// when Slurm does, with what its run directory says (DONE, DIR/slurm-task.json). Dead tasks
// are resubmitted by the scheduler through Start() again: runs that were in one submission go
// back into it as an index list. Jobs outlive the runner; a new runner Attach()es to them.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "runner/executor.h"
#include "runner/slurm.h"

namespace granary::runner {

struct SlurmSettings {
  SlurmOptions options;
  std::string root;        // where submission directories go (<db dir>/slurm)
  std::string campaign;    // in directory and job names
  double time_limit = 0;   // per run, seconds from its task's start; 0 = none
  int max_array_size = 0;  // 0 = the cluster's, from `scontrol show config`
  // Estimated wall seconds of each run on its task (estimate.h). Without options.time and
  // time_limit, an array's --time is its longest run's estimate with kTimeMargin.
  std::map<std::string, double> estimate_s;
};

// --time from an estimate: twice the estimate (estimates aim at a factor of 2) plus ten
// minutes for a slow start, a shared file system, the checkpoint at the end.
inline double WithTimeMargin(double estimate_s) { return 2.0 * estimate_s + 600.0; }

// MaxArraySize from `scontrol show config`; throws std::runtime_error with scontrol's message.
int QueryMaxArraySize();

// The arrays `launches` would be submitted as, with their manifests and scripts; nothing is
// written (campaign run --executor slurm --dry-run).
struct PlannedArray {
  JobArray array;
  std::string manifest;  // manifest.tsv as it would be written ("" = an existing one is reused)
  std::string script;
  std::string sbatch;  // the sbatch command line
};
std::vector<PlannedArray> PlanSlurmArrays(const std::vector<Launch>& launches, const SlurmSettings& settings);

std::unique_ptr<Executor> MakeSlurmExecutor(const SlurmSettings& settings);

// Slurm's row of the executor table (executors.h): its flags (--partition, --time,
// --cpus-per-run, --array-max, --account, --sbatch-arg, --poll-interval, --dry-run, --detach)
// over the spec's executor block, the arrays' --time from the estimate, the dry run.
struct ExecutorRow;
ExecutorRow SlurmExecutorRow();

// One squeue call for these array jobs (every task, every state). nullopt when squeue could
// not answer (not installed, controller unreachable); `error` then says why. A job squeue no
// longer knows is simply absent.
std::optional<std::vector<QueueEntry>> QueryQueue(const std::set<std::string>& job_ids, std::string* error = nullptr);

// How a task that left the queue's live states ended (`state`, or "" when squeue no longer
// knows its job), from what its run directory says: DONE, then DIR/slurm-task.json if it is
// this task's, then the state. `time_limit` as given to the batch script.
Finished SlurmTaskEnd(const std::string& run_id, const std::string& run_dir, const QueuePlace& place,
                      const std::string& state, double time_limit, const std::string& slurm_time);

}  // namespace granary::runner
