// A one-node Slurm cluster on localhost for the Slurm tests: munged, slurmctld and slurmd
// from Debian's packages, started in the foreground as children of the test process in a
// private directory (mkdtemp) with free ports, and stopped by the destructor. Two test
// processes on one machine each get their own cluster. The recipe (docs/slurm.md):
// linuxproc proctrack, no task plugin, no accounting,
// select/cons_tres, the node line from `slurmd -C`.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

#include "test_util.h"  // WaitFor

namespace granary::runner::testing {

class SlurmCluster {
 public:
  struct Options {
    int max_array_size = 1001;
    int min_job_age = 300;  // seconds a finished job stays visible to squeue
  };
  // Starts the daemons and waits (bounded) until the node is idle; sets SLURM_CONF in this
  // process' environment so that every Slurm command started from here talks to it. Throws
  // std::runtime_error with the daemons' log tails when the cluster does not come up.
  explicit SlurmCluster(const Options& options);
  SlurmCluster() : SlurmCluster(Options{}) {}
  // Cancels every job, waits for the node to drain, stops the daemons and reaps every
  // process they left (the test process is their child subreaper).
  ~SlurmCluster();
  SlurmCluster(const SlurmCluster&) = delete;
  SlurmCluster& operator=(const SlurmCluster&) = delete;

  const std::filesystem::path& Dir() const { return dir_; }
  std::string Conf() const { return (dir_ / "slurm.conf").string(); }
  // The last lines of the daemons' logs, for failure messages.
  std::string LogTails() const;

 private:
  void Start(const Options& options);
  void Stop();
  std::filesystem::path dir_;
  std::vector<pid_t> daemons_;  // munged, slurmctld, slurmd: stopped in reverse order
};

}  // namespace granary::runner::testing
