// See scan.h.
#include "runner/scan.h"

#include <filesystem>
#include <nlohmann/json.hpp>

#include "rundir/files.h"
#include "rundir/layout.h"
#include "rundir/run_directory.h"
#include "rundir/summary.h"
#include "runner/campaign_db.h"
#include "runner/scheduler.h"

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

ScanReport ScanCampaign(Store& store, const BatchQueue& queue, bool dry_run) {
  ScanReport report;
  const std::vector<RunRow> rows = LoadRuns(store, false);
  const Holder me = ThisProcessHolder();
  const double now = NowSeconds();

  // One query of the queue for every queued run.
  std::set<std::string> job_ids;
  for (const auto& r : rows) {
    if (r.Queued() && !r.job_id.empty()) job_ids.insert(r.job_id);
  }
  std::map<std::pair<std::string, int>, QueueEntry> seen;
  bool queue_known = true;
  if (!job_ids.empty()) {
    report.queue_asked = true;
    const auto entries = queue.Query(job_ids, &report.queue_error);
    if (entries) {
      for (const auto& e : *entries) seen[{e.job_id, e.task}] = e;
    } else {
      queue_known = false;
    }
  }

  std::map<std::string, std::string> queue_states;
  for (const auto& r : rows) {
    if (r.state == RunState::kRetired) continue;
    ++report.runs;
    const fs::path dir = r.run_dir;
    const json summary = FinishedSummary(dir);
    RunState to = r.state;
    std::string reason;
    double wall = r.wall_s;
    if (summary.is_object()) {
      to = RunState::kDone;
      if (const auto t = summary.find("timing"); t != summary.end() && t->is_object()) wall = t->value("wall_s", wall);
    } else if (r.Queued()) {
      const auto e = seen.find({r.job_id, r.job_index});
      if (!queue_known || (e != seen.end() && IsQueuedOrRunning(queue.FateOf(e->second.state)))) {
        if (e != seen.end() && e->second.state != r.job_state) queue_states[r.run_id] = e->second.state;
      } else {
        const QueuePlace place{r.job_dir, r.job_script, r.job_name, r.job_index, r.job_id, r.job_state};
        const Finished f = queue.TaskEnd(r.run_id, r.run_dir, place, e == seen.end() ? "" : e->second.state);
        std::tie(to, reason) = EndStateOf(f, false, 0, (dir / rundir::kEngineLogFile).string());
        if (f.wall_s >= 0) wall = f.wall_s;
      }
    } else if (r.state == RunState::kRunning) {
      if (LeaseExpired(r, me.host, now)) {
        to = RunState::kInterrupted;
        reason = "runner lost (lease expired); continues from its checkpoint";
      }
    } else if (r.state == RunState::kDone && !fs::exists(dir)) {
      // Its results are in the database; only --rerun-lost runs it again (docs/cli.md).
      report.lost.push_back(r.run_id);
    } else if (r.state == RunState::kDone && rundir::IsDone(dir)) {
      // DONE is there but summary.json cannot be read: the run finished and was damaged
      // since; it stays done and is reported damaged (scan --verify, report, status), not run
      // again over what is left.
    } else if (r.state == RunState::kDone) {
      to = RunState::kInterrupted;
      reason = "done in the database, but " + dir.string() + " has no DONE and summary.json (moved or deleted?)";
    }
    if (to != r.state) {
      ScanChange c{r.run_id, r.state, to, reason, false};
      // A live runner records its own runs.
      const bool held = r.state == RunState::kRunning && !r.lease_holder.empty() && !LeaseExpired(r, me.host, now);
      if (!dry_run && !held) {
        c.written = SettleRun(store, r, to, reason, summary.is_object() ? &summary : nullptr, wall, now);
      }
      if (held)
        c.reason =
            (c.reason.empty() ? "" : c.reason + "; ") + "left to the runner that holds it (" + r.lease_holder + ")";
      report.changes.push_back(c);
      ++report.counts[ToString(c.written || dry_run ? to : r.state)];
    } else {
      ++report.counts[ToString(r.state)];
    }
  }
  if (!dry_run) RecordJobStates(store, queue_states);
  return report;
}

std::map<std::string, rundir::Verification> CheckDoneRuns(const std::vector<RunRow>& runs, rundir::VerifyLevel level,
                                                          const std::function<void(int, int)>& progress) {
  std::vector<const RunRow*> done;
  for (const RunRow& r : runs)
    if (r.state == RunState::kDone && fs::is_directory(r.run_dir)) done.push_back(&r);
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

IntegrityCounts CountIntegrity(const std::map<std::string, rundir::Verification>& checks) {
  IntegrityCounts c;
  for (const auto& [id, v] : checks) {
    if (v.integrity == rundir::Integrity::kWhole) ++c.whole;
    if (v.integrity == rundir::Integrity::kDamaged) ++c.damaged;
    if (v.integrity == rundir::Integrity::kNotVerifiable) ++c.not_verifiable;
  }
  return c;
}

}  // namespace granary::runner
