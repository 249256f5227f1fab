// `campaign run`: claims runs under leases, launches engines through an Executor, watches
// time limits and signals, and records every end in its own transaction the moment it is
// seen. The scheduler never prints: it reports to a RunObserver.
#pragma once

#include <csignal>
#include <functional>
#include <optional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "runner/campaign_db.h"
#include "runner/executor.h"
#include "runner/store.h"

namespace granary::runner {

// docs/cli.md "Exit codes".
enum class ExitCode : int { kOk = 0, kRunsFailed = 1, kUsage = 2, kStorage = 3, kInterrupted = 130 };
// report, export, scan --verify: finished runs are damaged (a file differs from the engine's
// manifest; the output was written without them).
inline constexpr int kExitDamagedRuns = 4;
// report, export: no finished run to analyse.
inline constexpr int kExitNothingToAnalyse = 5;

class RunObserver;

struct CampaignRunOptions {
  int jobs = 1;
  std::string engine;             // "" = each run's own; "native"/"liggghts" = only those; a path = that executable
  std::vector<std::string> only;  // --only filters with full pointers (run_filter.h); none = every run
  int threads_per_run = 1;
  double time_limit = 0;  // seconds of wall time per run; 0 = none
  int retries = 1;        // extra attempts per run within this invocation
  std::string exe_dir;    // where granary-engine / granary-liggghts live
  double poll_interval = 0.2;
  double tick_interval = 0.5;       // observer ticks (progress display)
  double heartbeat_interval = 2.0;  // lease heartbeats, and the check that the leases are still ours
  bool rerun_lost = false;          // run again the done runs whose run directory was deleted
  // Batch queues (executor.outlives_runner()): submit what is runnable, then exit and leave
  // the jobs to run (campaign scan or a later campaign run collects them).
  bool detach = false;
  // Adaptive replicas (rundir/replica_rule.h): called once at the start and after every run
  // recorded done, outside any transaction of the scheduler's; it adds planned runs to the
  // database (add_planned_runs) and returns how many, which the loop then claims like any
  // other. It reports what it did to the observer. None: a fixed number of replicas.
  std::function<int(RunObserver&)> add_runs;
  // Tests: who claims the runs (default ThisProcessHolder()), and the monotonic clock in
  // seconds that time limits, ticks and heartbeats are measured with (default steady_clock).
  std::optional<Holder> holder;
  std::function<double()> clock;
};

struct ActiveRun {
  std::string run_id;
  std::string point;  // the sweep point's JSON
  int replica = 0;
  int attempt = 0;
  double elapsed = 0;
  nlohmann::json progress;  // progress.json or null
  std::string queue_state;  // in a batch queue: PENDING, RUNNING, ...; "" for a local engine
};

class RunObserver {
 public:
  virtual ~RunObserver() = default;
  virtual void OnBegin(int total, int done, int failed) = 0;
  // `what`: the state the run entered (ToString(RunState)), or what happened to it ("waiting",
  // "lease lost", "not submitted", ...); run_id "" for the campaign as a whole.
  virtual void OnEvent(const std::string& run_id, const std::string& what, const std::string& message) = 0;
  virtual void OnTick(const std::vector<ActiveRun>& active, int done, int failed, int total) = 0;
  virtual void OnEnd(int done, int failed, int total) = 0;
};

// What is recorded for an engine that ended but did not finish its run (no DONE, or a failure):
// {failed | interrupted, reason with the tail of its log}. Killed from outside means
// interrupted (it continues from its checkpoint); a time limit (the scheduler's, `timed_out`,
// or the executor's, f.timed_out) or an exit status means failed.
std::pair<RunState, std::string> EndStateOf(const Finished& f, bool timed_out, double time_limit,
                                            const std::string& log_file);

// The failure note of a done run put back to planned because its directory was deleted.
extern const char kLostRunDirectory[];

// Does `row` pass the --only filter (one filter; RunFilter for several)?
bool MatchesFilter(const RunRow& row, const std::string& filter);

// Runs what is not done. `stop` is set asynchronously (signal handler) to request a clean stop.
ExitCode RunCampaign(Store& store, const CampaignRunOptions& options, Executor& executor, RunObserver& observer,
                     const volatile std::sig_atomic_t* stop);

}  // namespace granary::runner
