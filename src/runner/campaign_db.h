// The campaign's tables as operations: plan (idempotent, retire/add on edits), claim a run
// under a lease, record its end, heartbeats, and read-back for status and report. Every
// state change is one transaction; claims are BEGIN IMMEDIATE so two runners sharing a
// database never claim the same run (docs/cli.md, "Resume and leases").
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "runner/campaign_spec.h"
#include "runner/executor.h"
#include "runner/run_state.h"
#include "runner/store.h"

namespace granary::runner {

struct PlanSummary {
  int total = 0;      // runs in the spec
  int added = 0;      // new rows
  int unchanged = 0;  // already present (any state)
  int revived = 0;    // were retired, back in the spec
  int retired = 0;    // no longer in the spec
  int points = 0;
  std::vector<std::string> axes;
  std::map<std::string, std::vector<nlohmann::json>> axis_values;  // distinct values per axis, in order
  // New runs that continue an old one (Extends(): only an extendable key raised): the old
  // run's directory becomes the new run's, and its engine continues from the checkpoint.
  struct Extension {
    std::string from;  // the old run (retired)
    std::string to;    // the new run (planned, in the old run's directory)
  };
  std::vector<Extension> extended;
  // Extensions found but not made: the old directory is locked by an engine, or missing.
  std::vector<std::pair<Extension, std::string>> not_extended;
};

// Stores the campaign and its runs. `runs_root` is where run directories go. With
// dry_run, computes the summary and changes nothing. A new run that extends a native run of
// the campaign that is not running (its directory there, unlocked) takes over that run's
// directory, without its DONE, and the old run is retired to start over if it ever comes back.
PlanSummary PlanCampaign(Store& store, const CampaignSpec& spec, const std::vector<PlannedRun>& runs,
                         const std::string& runs_root, bool dry_run);

// Adaptive replicas (rundir/replica_rule.h): of `runs`, expanded up to the rule's max, the
// first `min` replicas of each point and those a runner added (in the database, not
// retired), so a re-plan of the same spec keeps what the runner added (plan stays idempotent).
std::vector<PlannedRun> WithAddedReplicas(Store& store, const CampaignSpec& spec, std::vector<PlannedRun> runs);

// The runner adds replicas (adaptive): `runs` become planned runs in one transaction; a run
// already there is left as it is (a retired one comes back). Returns how many changed, so a
// runner killed before, inside or after the transaction loses and repeats nothing.
int AddPlannedRuns(Store& store, const std::vector<PlannedRun>& runs, const std::string& runs_root);

struct RunRow {
  std::string run_id;
  std::int64_t seq = 0;
  std::string point_id;
  nlohmann::json point;
  int replica = 0;
  nlohmann::json params;
  RunState state = RunState::kPlanned;
  int attempts = 0;
  std::string engine;
  std::string engine_version;
  std::string host;
  double started_at = 0;  // unix seconds; 0 = never
  double ended_at = 0;
  double wall_s = 0;
  std::string end_reason;
  std::string run_dir;
  std::string failure;
  std::string lease_holder;
  std::string lease_host;
  int lease_pid = 0;
  double lease_heartbeat = 0;
  nlohmann::json progress;  // last progress.json seen, or null
  // Its place in a batch queue (docs/slurm.md) from its last submission; 0 = never queued.
  std::int64_t job_array = 0;
  int job_index = -1;
  std::string job_id;   // the array job id; "" until sbatch returned
  std::string job_dir;  // the submission's directory (manifest, scripts)
  std::string job_script;
  std::string job_name;
  std::string job_state;  // the queue state last seen
  // In a batch queue now: its job, not a runner, holds it.
  bool Queued() const { return state == RunState::kRunning && job_array != 0; }
};

struct CampaignRow {
  std::string name;
  nlohmann::json spec;
  std::string spec_hash;
  std::vector<std::string> axes;
  std::string granary_version;
  std::string git_commit;
};

std::optional<CampaignRow> LoadCampaign(Store& store);
// with_params = false skips parsing the resolved parameters (fast status on big campaigns).
std::vector<RunRow> LoadRuns(Store& store, bool with_params = true);

// The scalar results of one run (summary.json ingested by record_done): key -> number or text.
std::map<std::string, nlohmann::json> LoadResults(Store& store, const std::string& run_id);

// (resolved run spec, summary.json) of every done run with a summary, retired ones too: what
// the estimate learns the machine's speed from.
std::vector<std::pair<nlohmann::json, nlohmann::json>> LoadFinished(Store& store);

// The runs whose id starts with `prefix` (all of them for "").
std::vector<RunRow> FindRuns(Store& store, const std::string& prefix, bool with_params = true);

// A retired run whose directory was deleted (campaign clean) comes back as planned if a later
// plan brings it back, not as the done run it was.
void ForgetRetiredResults(Store& store, const std::string& run_id);

// Who holds a lease: host, pid and start time make it unique.
struct Holder {
  std::string id;  // "host:pid:start"
  std::string host;
  int pid = 0;
};
Holder ThisProcessHolder();

// A lease is expired when its heartbeat is older than this, or its pid is gone on this host.
// 60 s, or $GRANARY_LEASE_SECONDS (tests; clusters with slow shared file systems). Runners
// heartbeat every min(2 s, a fifth of it).
double LeaseStaleSeconds();

// Is the lease of a running row expired (stale heartbeat, or holder pid gone on `host`)?
bool LeaseExpired(const RunRow& row, const std::string& host, double now);

// Runs left `running` under an expired lease become `interrupted`. Returns how many. Runs in
// a batch queue are not: their jobs hold them (adopt_queued_runs).
int RecoverExpiredLeases(Store& store, const Holder& me, double now);

// Claims the first runnable run (planned, interrupted or failed; in plan order) that passes
// `accept` and is not in `skip`. Marks it running under `me`, attempts + 1, out of any queue
// (the row returned still names its last submission, which a resubmission reuses).
std::optional<RunRow> ClaimNext(Store& store, const Holder& me, double now,
                                const std::function<bool(const RunRow&)>& accept, const std::set<std::string>& skip);

// Done runs back to `planned` (their results deleted), e.g. when their run directory was
// deleted after they finished; `reason` is kept as the run's failure note. Returns how many.
int RequeueDoneRuns(Store& store, const std::vector<std::string>& run_ids, const std::string& reason);

// Refreshes the heartbeat of every run `me` holds and stores their progress. Returns the
// runs `me` still holds: a run missing from it was taken over (its lease expired and another
// runner recovered it) or retired by a re-plan, and its engine must stop.
std::set<std::string> Heartbeat(Store& store, const Holder& me, double now,
                                const std::map<std::string, nlohmann::json>& progress_by_run);

// End states are written only by the lease holder: each is one compare-and-set on
// (state 'running', lease_holder = holder) and returns false, changing nothing, when `holder`
// no longer holds the run.
// Ingests summary.json scalars into results, state done, lease cleared; one transaction.
bool RecordDone(Store& store, const std::string& run_id, const std::string& holder, const nlohmann::json& summary,
                double now, double wall_s);
// state failed or interrupted with the reason (and log tail); lease cleared.
bool RecordEnd(Store& store, const std::string& run_id, const std::string& holder, RunState state,
               const std::string& reason, double now, double wall_s);

// One run's metrics from one analysis (db/003_metrics.sql): what campaign report, export and
// compare store after analysing, so that the database answers queries without a report.
struct MetricRow {
  std::string name;
  std::string unit;
  double value = 0.0;  // NaN is stored as NULL
  double se = 0.0;
};
struct RunMetrics {
  std::string run_id;
  std::string analysis;
  int version = 0;
  nlohmann::json options;  // the analysis' run options
  std::vector<MetricRow> metrics;
};
// Replaces the stored metrics of each (run, analysis) given; one transaction.
void StoreMetrics(Store& store, const std::vector<RunMetrics>& runs, double now);
// Removes every stored metric of the given runs (damaged runs: kept out of every number).
void ForgetMetrics(Store& store, const std::vector<std::string>& run_ids);
// The stored metrics of every run, by run id (analysis and version filled, options not).
std::map<std::string, std::vector<RunMetrics>> LoadMetrics(Store& store);

// Flattens scalar values of summary.json ("timing/wall_s" -> 812.3), skipping "spec".
std::map<std::string, nlohmann::json> FlattenScalars(const nlohmann::json& summary);

double NowSeconds();

// ---- Runs in a batch queue (Slurm job arrays; docs/slurm.md)

// Records an array about to be submitted (before sbatch, so a runner that dies inside sbatch
// leaves a trace to find the job by), and puts its runs that `me` holds into it, state
// PENDING. One transaction.
void RecordJobArray(Store& store, const Holder& me, const JobArray& array, double now);
// The array job id sbatch printed.
void RecordJobId(Store& store, const std::string& script, const std::string& job_id);
// Queue states seen in one poll, run id -> state; one transaction.
void RecordJobStates(Store& store, const std::map<std::string, std::string>& state_by_run);
// Re-attach: the queued runs that no live runner watches (no lease, or an expired one) are
// taken under `me` and returned.
std::vector<RunRow> AdoptQueuedRuns(Store& store, const Holder& me, double now);
// campaign scan: sets a run's state from what its directory shows (done: `summary` ingested
// as record_done does), provided the row is still as the scan read it (same state, same
// lease holder), so whatever a runner recorded in between wins. Returns whether it wrote.
bool SettleRun(Store& store, const RunRow& seen, RunState state, const std::string& reason,
               const nlohmann::json* summary, double wall_s, double now);

// Detach: `me` stops watching its queued runs; they stay `running` in their jobs, for a
// later `campaign run` to adopt or `campaign scan` to settle. Returns how many.
int ReleaseQueuedRuns(Store& store, const Holder& me);

}  // namespace granary::runner
