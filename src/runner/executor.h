// Executors start engine processes on run directories and report when they end. Runs
// report only through their run directories (progress.json, summary.json, DONE), so an
// executor needs nothing but a command line: the local Boost.Process pool, or Slurm job
// arrays (slurm_executor.h) (after ninja's CommandRunner). The
// interface says what the scheduler wants (start, stop and why), never how: no signals, no
// pids, so every executor serves the same scheduler. A batch queue adds a place for each run
// (array, index, job id) that the scheduler records, so a restarted runner finds its jobs.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace granary::runner {

// A run's place in a batch queue: which submission (manifest) and array index, and the job.
struct QueuePlace {
  std::string dir;     // the submission's directory; "" = never queued
  std::string script;  // the batch script of the sbatch call that carries it
  std::string name;    // that call's job name
  int index = -1;      // the run's array index in the submission's manifest
  std::string job_id;  // the array job id; "" = unknown (the runner died inside sbatch)
  std::string state;   // the queue state last seen
};

struct Launch {
  std::string run_id;
  std::vector<std::string> argv;  // argv[0] = executable path
  std::string log_file;           // stdout and stderr are appended here
  std::string engine;             // "native" or "liggghts"
  std::string run_dir;
  QueuePlace place;  // where an earlier attempt was queued (a resubmission reuses it)
};

struct Finished {
  std::string run_id;
  int exit_code = 0;       // valid when signal == 0
  int signal = 0;          // the signal that ended the engine, or 0 (as reported, e.g. by wait or Slurm)
  bool timed_out = false;  // ended at its time limit by the executor (LimitsTime())
  std::string how;         // what ended it, in words, where the status alone does not say
  double wall_s = -1;      // the engine's wall time where the executor knows it better (< 0: the scheduler's clock)
};

// One submission to a batch queue (one sbatch call): the runs it carries, by array index.
struct JobArray {
  std::string dir;                                // the submission's directory
  std::string script;                             // this call's batch script (unique)
  std::string name;                               // the job name
  std::string array;                              // the --array value
  std::string job_id;                             // "" until submitted
  std::string error;                              // why the queue refused it (Submit())
  std::vector<std::pair<std::string, int>> runs;  // run id, array index
};

// Why the scheduler stops a run. The executor chooses the means.
enum class StopReason {
  kInterrupt,  // the runner is stopping (Ctrl-C, SIGTERM): the engine should checkpoint and
               // exit; it is ended by force if it has not after a grace period
  kTimeLimit,  // over its wall-time limit: as kInterrupt (a hung engine is ended by force)
  kLeaseLost,  // another runner holds the run now: end the engine at once, nothing of it counts
};

const char* ToString(StopReason reason);

class Executor {
 public:
  virtual ~Executor() = default;
  virtual bool CanStartMore() const = 0;
  virtual void Start(const Launch& launch) = 0;  // throws std::runtime_error naming the run
  // Non-blocking: runs that ended since the last poll. Also where an executor escalates a
  // stop whose grace period has passed.
  virtual std::vector<Finished> Poll() = 0;
  // Asks one run (or every run) to stop; it is reported by Poll() once it has ended.
  virtual void Stop(const std::string& run_id, StopReason reason) = 0;
  virtual void StopAll(StopReason reason) = 0;
  virtual std::size_t Active() const = 0;

  // Batch queues only (a local executor starts its engines in Start()).
  // Place(): gives the runs started since the last call their places in job arrays and
  // writes what the queue needs, submitting nothing, so that the scheduler records the
  // places before the jobs exist. Submit(): submits them; each comes back with its job id
  // or an error (its runs are then reported by neither Poll() nor Active()).
  virtual std::vector<JobArray> Place() { return {}; }
  virtual std::vector<JobArray> Submit() { return {}; }
  // A restarted runner takes over a run already in the queue (launch.place set). Returns its
  // place, with the job id found if it was unknown.
  virtual QueuePlace Attach(const Launch& launch) { return launch.place; }
  // Runs keep going after the runner exits: an interrupted runner detaches instead of
  // stopping them.
  virtual bool OutlivesRunner() const { return false; }
  // The executor ends a run at its time limit, counted from the run's own start
  // (Finished::timed_out); the scheduler does not time it.
  virtual bool LimitsTime() const { return false; }
  // Places whose queue state (PENDING, RUNNING, ...) or job id changed since the last call.
  virtual std::map<std::string, QueuePlace> QueueChanges() { return {}; }
};

// One task of a batch queue as the queue reports it.
struct QueueEntry {
  std::string job_id;     // the array job id
  int task = -1;          // the array index; -1 for a job that is not an array
  std::string state;      // the queue's word: PENDING, RUNNING, COMPLETED, ...
  double started_at = 0;  // unix seconds; 0 = not started
  std::string name;
  std::string reason;
};

// What a queue state means for the run its task carries.
enum class TaskFate {
  kQueued,     // waiting for a node (PENDING, REQUEUED, ...)
  kRunning,    // at work, or a state not understood (never resubmit what is not understood)
  kCompleted,  // ended normally: done if its run directory says so
  kFailed,     // the run failed (FAILED, OUT_OF_MEMORY)
  kTimedOut,   // the queue's time limit ran out (the run continues from its checkpoint if retried)
  kLost,       // cancelled, preempted, node failure: resubmitted, continues from its checkpoint
};
bool IsQueuedOrRunning(TaskFate fate);

// The batch queue that queued runs (RunRow::Queued()) are in, as the verbs that do not submit
// see it: status and scan ask it about runs a runner may no longer watch, the display asks
// which runs still wait. Only the batch executor's files know which queue it is.
class BatchQueue {
 public:
  virtual ~BatchQueue() = default;
  virtual const char* Name() const = 0;       // in messages: "Slurm"
  virtual const char* QueryTool() const = 0;  // the command Query() runs: "squeue"
  virtual TaskFate FateOf(const std::string& state) const = 0;
  // One query for these array jobs (every task, every state); nullopt when the queue could not
  // answer, with the reason in *error. A job the queue no longer knows is simply absent.
  virtual std::optional<std::vector<QueueEntry>> Query(const std::set<std::string>& job_ids,
                                                       std::string* error) const = 0;
  // How a task that left the queue's live states ended (`state`, or "" when the queue no longer
  // knows its job), from what its run directory says.
  virtual Finished TaskEnd(const std::string& run_id, const std::string& run_dir, const QueuePlace& place,
                           const std::string& state) const = 0;
};
const BatchQueue& DefaultBatchQueue();

// Runs up to `slots` engines at once as child processes, each in its own process group.
// A stop for kInterrupt or kTimeLimit sends SIGTERM to the engine (which checkpoints and
// exits) and SIGKILL to its process group `grace_seconds` later; kLeaseLost sends SIGKILL to
// the group at once. Children get SIGKILL when the runner dies (prctl PR_SET_PDEATHSIG).
std::unique_ptr<Executor> MakeLocalExecutor(int slots, double grace_seconds = 10.0);

// The local pool's row of the executor table (executors.h): --jobs engines at once.
struct ExecutorRow;
ExecutorRow LocalExecutorRow();

}  // namespace granary::runner
