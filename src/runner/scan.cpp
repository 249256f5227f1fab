// See scan.h.
#include "runner/scan.h"

#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

#include "rundir/files.h"
#include "rundir/layout.h"
#include "rundir/run_directory.h"
#include "rundir/summary.h"
#include "runner/campaign_db.h"
#include "runner/scheduler.h"
#include "runner/slurm_executor.h"

namespace granary::runner {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// The summary of a finished run (DONE and a readable summary.json), or null.
json FinishedSummary(const fs::path& dir) {
  if (!rundir::IsDone(dir)) return nullptr;
  try {
    return rundir::ReadSummary(dir / rundir::kSummaryFile).raw;
  } catch (const rundir::ReadError&) {
    return nullptr;
  }
}

}  // namespace

ScanReport scan_campaign(Store& store, const QueueQuery& queue, bool dry_run) {
  ScanReport report;
  const std::vector<RunRow> rows = load_runs(store, false);
  const Holder me = this_process_holder();
  const double now = now_seconds();

  // One squeue call for every queued run.
  std::set<std::string> job_ids;
  for (const auto& r : rows) {
    if (r.queued() && !r.job_id.empty()) job_ids.insert(r.job_id);
  }
  std::map<std::pair<std::string, int>, QueueEntry> seen;
  bool queue_known = true;
  if (!job_ids.empty()) {
    report.queue_asked = true;
    const auto entries = queue(job_ids, &report.queue_error);
    if (entries) {
      for (const auto& e : *entries) seen[{e.job_id, e.task}] = e;
    } else {
      queue_known = false;
    }
  }

  std::map<std::string, std::string> queue_states;
  for (const auto& r : rows) {
    if (r.state == "retired") continue;
    ++report.runs;
    const fs::path dir = r.run_dir;
    const json summary = FinishedSummary(dir);
    std::string to = r.state, reason;
    double wall = r.wall_s;
    if (summary.is_object()) {
      to = "done";
      if (const auto t = summary.find("timing"); t != summary.end() && t->is_object()) wall = t->value("wall_s", wall);
    } else if (r.queued()) {
      const auto e = seen.find({r.job_id, r.job_index});
      if (!queue_known || (e != seen.end() && is_queued_or_running(fate_of(e->second.state)))) {
        if (e != seen.end() && e->second.state != r.job_state) queue_states[r.run_id] = e->second.state;
      } else {
        const QueuePlace place{r.job_dir, r.job_script, r.job_name, r.job_index, r.job_id, r.job_state};
        // The time limit the task ran under is in its script; 124 from `timeout` says it was hit.
        const Finished f = slurm_task_end(r.run_id, r.run_dir, place, e == seen.end() ? "" : e->second.state,
                                          std::numeric_limits<double>::infinity(), "");
        std::tie(to, reason) = end_state_of(f, false, 0, (dir / rundir::kEngineLogFile).string());
        if (f.wall_s >= 0) wall = f.wall_s;
      }
    } else if (r.state == "running") {
      if (lease_expired(r, me.host, now)) {
        to = "interrupted";
        reason = "runner lost (lease expired); continues from its checkpoint";
      }
    } else if (r.state == "done" && !fs::exists(dir)) {
      // Its results are in the database; only --rerun-lost runs it again (docs/cli.md).
      report.lost.push_back(r.run_id);
    } else if (r.state == "done" && rundir::IsDone(dir)) {
      // DONE is there but summary.json cannot be read: the run finished and was damaged
      // since; it stays done and is reported damaged (scan --verify, report, status), not run
      // again over what is left.
    } else if (r.state == "done") {
      to = "interrupted";
      reason = "done in the database, but " + dir.string() + " has no DONE and summary.json (moved or deleted?)";
    }
    if (to != r.state) {
      ScanChange c{r.run_id, r.state, to, reason, false};
      // A live runner records its own runs.
      const bool held = r.state == "running" && !r.lease_holder.empty() && !lease_expired(r, me.host, now);
      if (!dry_run && !held) {
        c.written = settle_run(store, r, to, reason, summary.is_object() ? &summary : nullptr, wall, now);
      }
      if (held) c.reason = (c.reason.empty() ? "" : c.reason + "; ") + "left to the runner that holds it (" + r.lease_holder + ")";
      report.changes.push_back(c);
      ++report.counts[c.written || dry_run ? to : r.state];
    } else {
      ++report.counts[r.state];
    }
  }
  if (!dry_run) record_job_states(store, queue_states);
  return report;
}

std::map<std::string, rundir::Verification> check_done_runs(const std::vector<RunRow>& runs, rundir::VerifyLevel level,
                                                            const std::function<void(int, int)>& progress) {
  std::vector<const RunRow*> done;
  for (const RunRow& r : runs)
    if (r.state == "done" && fs::is_directory(r.run_dir)) done.push_back(&r);
  std::map<std::string, rundir::Verification> out;
  int n = 0;
  for (const RunRow* r : done) {
    try {
      out[r->run_id] = rundir::VerifyRun(r->run_dir, {level, true});
    } catch (const rundir::ReadError&) {
      // the directory went away under us: lost, said elsewhere
    }
    if (progress) progress(++n, static_cast<int>(done.size()));
  }
  return out;
}

IntegrityCounts count_integrity(const std::map<std::string, rundir::Verification>& checks) {
  IntegrityCounts c;
  for (const auto& [id, v] : checks) {
    if (v.integrity == rundir::Integrity::kWhole) ++c.whole;
    if (v.integrity == rundir::Integrity::kDamaged) ++c.damaged;
    if (v.integrity == rundir::Integrity::kNotVerifiable) ++c.not_verifiable;
  }
  return c;
}

}  // namespace granary::runner
