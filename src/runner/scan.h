// `campaign scan`: every run's state rebuilt from its run directory, and for runs in a batch
// queue from one squeue call, at any time, also while jobs run (docs/cli.md). A run whose
// directory has DONE and summary.json is done (and ingested); a queued run whose task left
// the queue ended as its directory and the queue say (slurm_task_end); a run the database
// calls done whose directory lost DONE is not (one whose directory is gone stays done: its
// results are in the database; campaign run --rerun-lost runs it again). Rows held by a live runner are reported, not
// written: that runner records them.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "rundir/manifest.h"
#include "runner/campaign_db.h"
#include "runner/executor.h"
#include "runner/run_state.h"
#include "runner/store.h"

namespace granary::runner {

struct ScanChange {
  std::string run_id;
  RunState from;  // state in the database
  RunState to;    // state the directory (and queue) shows
  std::string reason;
  bool written = false;  // false: dry run, or a live runner holds the row
};

struct ScanReport {
  int runs = 0;                       // not retired
  std::map<std::string, int> counts;  // by state, after the scan
  std::vector<ScanChange> changes;
  bool queue_asked = false;       // some runs were in a queue
  std::string queue_error;        // squeue could not answer: queued runs were left as they were
  std::vector<std::string> lost;  // done runs whose directory was deleted: left done (campaign run --rerun-lost)
};

ScanReport ScanCampaign(Store& store, const BatchQueue& queue, bool dry_run);

// The done runs among `runs` (directory present) checked against their manifests
// (rundir::VerifyRun at `level`), by run id; `progress(done, total)` after each, when set.
// kSizes for status and show (a stat per file), kChecksums for scan --verify (every byte).
std::map<std::string, rundir::Verification> CheckDoneRuns(const std::vector<RunRow>& runs, rundir::VerifyLevel level,
                                                          const std::function<void(int, int)>& progress = {});

// What a check of a campaign found, for the CLI's lines and --json.
struct IntegrityCounts {
  int whole = 0, damaged = 0, not_verifiable = 0;
};
IntegrityCounts CountIntegrity(const std::map<std::string, rundir::Verification>& checks);

}  // namespace granary::runner
