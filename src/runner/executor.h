// Executors start engine processes on run directories and report when they end. Runs
// report only through their run directories (progress.json, summary.json, DONE), so an
// executor needs nothing but a command line: the local Boost.Process pool here, a Slurm
// executor next (style.md 8.3 item 12, after ninja's CommandRunner). The interface says
// what the scheduler wants (start, stop and why), never how: no signals, no pids, no job
// ids, so every executor serves the same scheduler.
#pragma once

#include <memory>
#include <string>
#include <vector>

namespace granary::runner {

struct Launch {
  std::string run_id;
  std::vector<std::string> argv;  // argv[0] = executable path
  std::string log_file;           // stdout and stderr are appended here
};

struct Finished {
  std::string run_id;
  int exit_code = 0;    // valid when signal == 0
  int signal = 0;       // the signal that ended the engine, or 0 (as reported, e.g. by wait or Slurm)
};

// Why the scheduler stops a run. The executor chooses the means.
enum class StopReason {
  kInterrupt,   // the runner is stopping (Ctrl-C, SIGTERM): the engine should checkpoint and
                // exit; it is ended by force if it has not after a grace period
  kTimeLimit,   // over its wall-time limit: as kInterrupt (a hung engine is ended by force)
  kLeaseLost,   // another runner holds the run now: end the engine at once, nothing of it counts
};

const char* to_string(StopReason reason);

class Executor {
 public:
  virtual ~Executor() = default;
  virtual bool can_start_more() const = 0;
  virtual void start(const Launch& launch) = 0;     // throws std::runtime_error naming the run
  // Non-blocking: runs that ended since the last poll. Also where an executor escalates a
  // stop whose grace period has passed.
  virtual std::vector<Finished> poll() = 0;
  // Asks one run (or every run) to stop; it is reported by poll() once it has ended.
  virtual void stop(const std::string& run_id, StopReason reason) = 0;
  virtual void stop_all(StopReason reason) = 0;
  virtual std::size_t active() const = 0;
};

// Runs up to `slots` engines at once as child processes, each in its own process group.
// A stop for kInterrupt or kTimeLimit sends SIGTERM to the engine (which checkpoints and
// exits) and SIGKILL to its process group `grace_seconds` later; kLeaseLost sends SIGKILL to
// the group at once. Children get SIGKILL when the runner dies (prctl PR_SET_PDEATHSIG).
std::unique_ptr<Executor> make_local_executor(int slots, double grace_seconds = 10.0);

}  // namespace granary::runner
