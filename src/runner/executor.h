// Executors start engine processes on run directories and report when they end. Runs
// report only through their run directories (progress.json, summary.json, DONE), so an
// executor needs nothing but a command line: the local Boost.Process pool here, a Slurm
// executor next (style.md 8.3 item 12, after ninja's CommandRunner).
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
  int signal = 0;       // the signal that ended the process, or 0
};

class Executor {
 public:
  virtual ~Executor() = default;
  virtual bool can_start_more() const = 0;
  virtual void start(const Launch& launch) = 0;     // throws std::runtime_error naming the run
  virtual std::vector<Finished> poll() = 0;          // non-blocking: processes that ended since the last poll
  virtual void abort(const std::string& run_id, int signal) = 0;  // send a signal to one run
  virtual void abort_all(int signal) = 0;
  virtual std::size_t active() const = 0;
};

// Runs up to `slots` engines at once as child processes. Children get SIGKILL when the
// runner dies (prctl PR_SET_PDEATHSIG), so a killed runner never leaves an engine writing
// into a run directory that the next runner relaunches.
std::unique_ptr<Executor> make_local_executor(int slots);

}  // namespace granary::runner
