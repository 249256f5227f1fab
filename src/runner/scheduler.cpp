// See scheduler.h.
#include "runner/scheduler.h"

#include <signal.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "rundir/files.h"
#include "rundir/progress.h"
#include "rundir/run_directory.h"
#include "runner/run_filter.h"

namespace granary::runner {

namespace fs = std::filesystem;

const char kLostRunDirectory[] = "its run directory was deleted after it finished; run again (--rerun-lost)";
using nlohmann::json;

bool matches_filter(const RunRow& row, const std::string& filter) {
  return filter.empty() || RunFilter(std::vector<std::string>{filter}).matches(row);
}


namespace {

std::string EngineExe(const RunOptions& o, const std::string& engine) {
  if (o.engine.find('/') != std::string::npos) return o.engine;
  return (fs::path(o.exe_dir) / (engine == "liggghts" ? "granary-liggghts" : "granary-engine")).string();
}

// 5 -> "5", 0.5 -> "0.5" (json's dump would give "5.0").
std::string Number(double x) {
  std::ostringstream o;
  o << x;
  return o.str();
}

// "exited with status 3", "killed by signal 9 (Killed)".
std::string How(const Finished& f) {
  return f.signal != 0 ? "killed by " + SignalName(f.signal) : "exited with status " + std::to_string(f.exit_code);
}

// A message if the file system holding `dir` (or its nearest existing parent) is full, or
// "". Engines that fail on a full disk often cannot even write why into engine.log.
std::string FullFileSystem(fs::path dir) {
  constexpr double kFullBelowBytes = 1 << 20;
  std::error_code ec;
  while (!dir.empty() && !fs::exists(dir, ec)) dir = dir.parent_path();
  struct statvfs st {};
  if (dir.empty() || ::statvfs(dir.c_str(), &st) != 0) return "";
  const double free_bytes = static_cast<double>(st.f_bavail) * static_cast<double>(st.f_frsize);
  if (free_bytes >= kFullBelowBytes) return "";
  std::ostringstream o;
  o << "the file system of " << dir.string() << " is full (" << std::lround(free_bytes / 1024) << " KiB free)";
  return o.str();
}

struct Slot {
  RunRow row;
  double started = 0;
  bool timed_out = false;
  bool lease_lost = false;  // stopped because another runner holds the run: record nothing
};

}  // namespace

ExitCode run_campaign(Store& store, const RunOptions& options, Executor& executor, RunObserver& observer,
                      const volatile std::sig_atomic_t* stop) {
  if (options.engine.find('/') != std::string::npos && !fs::exists(options.engine)) {
    throw std::invalid_argument("engine executable not found: " + options.engine);
  }
  const Holder me = options.holder ? *options.holder : this_process_holder();
  const std::function<double()> clock = options.clock ? options.clock : [] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  };
  const int recovered = recover_expired_leases(store, me, now_seconds());

  const RunFilter filter(options.only);
  auto accept = [&](const RunRow& r) {
    if ((options.engine == "native" || options.engine == "liggghts") && r.engine != options.engine) return false;
    return filter.matches(r);
  };
  // Done runs whose directory was deleted: their results are in the database, but nothing
  // can analyse them. Said at every start; run again on request.
  std::vector<std::string> lost;
  for (const auto& r : load_runs(store, true))
    if (r.state == "done" && !fs::exists(r.run_dir) && accept(r)) lost.push_back(r.run_id);
  const int requeued = options.rerun_lost ? requeue_done_runs(store, lost, kLostRunDirectory) : 0;

  int total = 0, done = 0, failed = 0;
  for (const auto& r : load_runs(store, !filter.empty())) {
    if (r.state == "retired" || !filter.matches(r)) continue;
    ++total;
    if (r.state == "done") ++done;
    if (r.state == "failed") ++failed;
  }
  observer.on_begin(total, done, failed);
  if (recovered > 0) {
    observer.on_event("", "interrupted", std::to_string(recovered) + " run(s) of a lost runner will continue");
  }
  if (requeued > 0) {
    observer.on_event("", "planned", std::to_string(requeued) + " done run(s) whose run directory was deleted will run again");
  } else if (!lost.empty()) {
    observer.on_event("", "lost", std::to_string(lost.size()) + " done run(s) have no run directory (deleted after they "
                                  "finished; first " + lost.front() + "): their results are in the database only; "
                                  "campaign run --rerun-lost runs them again");
  }

  std::set<std::string> skip;             // exhausted in this invocation
  std::map<std::string, int> failures;    // failed attempts in this invocation
  std::map<std::string, Slot> slots;      // engines started
  std::map<std::string, RunRow> waiting;  // claimed, but another engine still holds the directory
  bool any_final_failure = false;
  std::string storage_full;  // set when runs/ is full: no new runs start, the invocation ends with kStorage
  double last_heartbeat = clock();
  double last_tick = -1e300;

  auto lease_lost = [&](const std::string& id, const std::string& what) {
    observer.on_event(id, "lease lost",
                      "another runner holds this run now (this runner's lease expired, or a re-plan retired it); " + what);
  };

  // Records an end state under our lease; false (and nothing recorded) if it is not ours.
  auto end_run = [&](const std::string& id, const std::string& state, const std::string& reason, double wall) {
    if (!record_end(store, id, me.id, state, reason, now_seconds(), wall)) {
      lease_lost(id, "its end (" + state + ") is not recorded");
      return;
    }
    if (state == "failed") ++failed;
    ++failures[id];
    if (failures[id] > options.retries) {
      skip.insert(id);
      if (state == "failed") any_final_failure = true;
    } else if (state == "failed") {
      --failed;  // will be retried: not counted as failed in the display
    }
    observer.on_event(id, state, reason);
  };

  // A run whose directory has DONE and summary.json is ingested; false if it has not.
  auto finish_done = [&](const RunRow& row, double wall) -> bool {
    const fs::path dir = row.run_dir;
    if (!rundir::IsDone(dir)) return false;
    rundir::Summary summary;
    try {
      summary = rundir::ReadSummary(dir / rundir::kSummaryFile);
    } catch (const rundir::ReadError&) {
      return false;
    }
    if (!record_done(store, row.run_id, me.id, summary.raw, now_seconds(), wall)) {
      lease_lost(row.run_id, "its result is not recorded");
      return true;
    }
    ++done;
    if (row.state == "failed") --failed;
    std::ostringstream what;
    what << (summary.end_reason.empty() ? std::string("finished") : summary.end_reason) << " at t = " << summary.t_end
         << ", " << summary.exited << " exits, " << static_cast<int>(wall) << " s";
    observer.on_event(row.run_id, "done", what.str());
    return true;
  };

  // Starts the engine of a claimed run, or parks it while another engine holds its directory.
  auto launch = [&](const RunRow& row) {
    const std::string holder = RunDirectoryHolder(row.run_dir);
    if (!holder.empty()) {
      if (!waiting.count(row.run_id)) observer.on_event(row.run_id, "waiting", "its directory is locked by " + holder);
      waiting[row.run_id] = row;
      return;
    }
    waiting.erase(row.run_id);
    // A run whose engine finished but was never ingested (runner killed in between) is
    // ingested now instead of being run twice.
    if (finish_done(row, row.wall_s)) return;
    const std::string exe = EngineExe(options, row.engine);
    if (!fs::exists(exe)) {
      record_end(store, row.run_id, me.id, "interrupted", "engine executable not found: " + exe, now_seconds(), 0);
      throw std::invalid_argument("engine executable not found: " + exe + " (build it, or pass --engine PATH)");
    }
    try {
      rundir::WriteRunSpec(row.run_dir, row.params);
      Launch l;
      l.run_id = row.run_id;
      l.argv = {exe, "run", row.run_dir, "--threads", std::to_string(options.threads_per_run)};
      l.log_file = (fs::path(row.run_dir) / rundir::kEngineLogFile).string();
      executor.start(l);
    } catch (const std::exception& e) {
      if (const std::string full = FullFileSystem(row.run_dir); !full.empty()) {
        storage_full = full;
        end_run(row.run_id, "interrupted", full + ": " + e.what(), 0);
      } else {
        end_run(row.run_id, "failed", e.what(), 0);
      }
      return;
    }
    slots[row.run_id] = Slot{row, clock(), false, false};
    observer.on_event(row.run_id, "running", "attempt " + std::to_string(row.attempts));
  };

  // One ended engine: its end state, under our lease.
  auto finished = [&](const Finished& f, bool stopping) {
    const Slot slot = slots[f.run_id];
    slots.erase(f.run_id);
    const double wall = clock() - slot.started;
    const std::string log = (fs::path(slot.row.run_dir) / rundir::kEngineLogFile).string();
    if (slot.lease_lost) {
      lease_lost(f.run_id, "its engine was stopped and nothing is recorded");
    } else if (f.signal == 0 && f.exit_code == 0 && finish_done(slot.row, wall)) {
    } else if (f.signal == 0 && f.exit_code == kExitRunDirectoryBusy) {
      // Another engine took the directory between our look and the engine's lock.
      if (stopping) end_run(f.run_id, "interrupted", "interrupted while waiting for its directory", wall);
      else waiting[f.run_id] = slot.row;
    } else if (stopping) {
      end_run(f.run_id, "interrupted", "interrupted by the user (runner stopped)", wall);
    } else if (const std::string full = FullFileSystem(slot.row.run_dir); !full.empty()) {
      // Not the run's fault: it continues from its checkpoint once there is room.
      storage_full = full;
      end_run(f.run_id, "interrupted", "engine " + How(f) + "; " + full + "\n" + TailOfFile(log, 20), wall);
    } else if (f.signal == 0 && f.exit_code == 0) {
      end_run(f.run_id, "failed", "engine exited 0 without DONE and summary.json\n" + TailOfFile(log, 20), wall);
    } else if (slot.timed_out) {
      end_run(f.run_id, "failed",
              "wall-time limit of " + Number(options.time_limit) + " s exceeded\n" + TailOfFile(log, 20), wall);
    } else if (f.signal != 0) {
      // Killed from outside: it continues from its checkpoint on the next attempt.
      end_run(f.run_id, "interrupted", "engine " + How(f) + "\n" + TailOfFile(log, 20), wall);
    } else {
      end_run(f.run_id, "failed", "engine " + How(f) + "\n" + TailOfFile(log, 20), wall);
    }
  };

  // Heartbeat; engines of runs that are no longer ours are stopped at once.
  auto check_leases = [&](const std::map<std::string, json>& progress) {
    const std::set<std::string> held = heartbeat(store, me, now_seconds(), progress);
    for (auto& [id, slot] : slots) {
      if (slot.lease_lost || held.count(id)) continue;
      slot.lease_lost = true;
      executor.stop(id, StopReason::kLeaseLost);
    }
    for (auto it = waiting.begin(); it != waiting.end();) {
      if (held.count(it->first)) {
        ++it;
        continue;
      }
      lease_lost(it->first, "it is no longer waiting for its directory");
      it = waiting.erase(it);
    }
  };

  try {
    while (true) {
      if (stop && *stop) {
        // The engines checkpoint and exit (the executor ends them by force after a grace
        // period); they continue next time.
        executor.stop_all(StopReason::kInterrupt);
        while (executor.active() > 0) {
          for (const auto& f : executor.poll()) finished(f, true);
          if (executor.active() > 0) std::this_thread::sleep_for(std::chrono::milliseconds(50));
        }
        for (const auto& [id, row] : waiting) end_run(id, "interrupted", "interrupted while waiting for its directory", 0);
        observer.on_end(done, failed, total);
        return ExitCode::kInterrupted;
      }

      // Runs waiting for their directory first, then new claims, while there are free slots.
      for (auto it = waiting.begin(); it != waiting.end() && executor.can_start_more() && storage_full.empty();) {
        const RunRow row = (it++)->second;
        launch(row);
      }
      bool nothing_left = !storage_full.empty();  // a full runs/ starts nothing more
      while (!nothing_left && executor.can_start_more()) {
        auto row = claim_next(store, me, now_seconds(), accept, skip);
        if (!row) {
          nothing_left = true;
          break;
        }
        launch(*row);
      }
      if (nothing_left && executor.active() == 0 && (waiting.empty() || !storage_full.empty())) break;

      for (const auto& f : executor.poll()) finished(f, false);

      const double now = clock();
      if (options.time_limit > 0) {
        for (auto& [id, slot] : slots) {
          if (!slot.timed_out && !slot.lease_lost && now - slot.started > options.time_limit) {
            slot.timed_out = true;
            executor.stop(id, StopReason::kTimeLimit);
          }
        }
      }
      if (now - last_tick >= options.tick_interval) {
        last_tick = now;
        std::vector<ActiveRun> active;
        std::map<std::string, json> progress;
        for (const auto& [id, slot] : slots) {
          ActiveRun a;
          a.run_id = id;
          a.point = slot.row.point.dump();
          a.replica = slot.row.replica;
          a.attempt = slot.row.attempts;
          a.elapsed = now - slot.started;
          if (const auto p = rundir::ReadProgress(slot.row.run_dir)) {
            a.progress = p->ToJson();
            progress[id] = a.progress;
          }
          active.push_back(a);
        }
        observer.on_tick(active, done, failed, total);
        if (now - last_heartbeat >= options.heartbeat_interval) {
          last_heartbeat = now;
          check_leases(progress);
        }
      }
      if (options.poll_interval > 0) std::this_thread::sleep_for(std::chrono::duration<double>(options.poll_interval));
    }
  } catch (const StoreError& e) {
    // The database cannot be written (full disk, read-only, busy past the timeout): nothing
    // more can be recorded. The engines are stopped (they checkpoint); runs that cannot be
    // marked interrupted stay `running` under this runner's lease, which the next
    // `campaign run` recovers (this runner is gone by then).
    executor.stop_all(StopReason::kInterrupt);
    while (executor.active() > 0) {
      for (const auto& f : executor.poll()) slots.erase(f.run_id);
      if (executor.active() > 0) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    int unrecorded = 0;
    std::vector<std::string> held;
    try {
      for (const auto& id : heartbeat(store, me, now_seconds(), {})) held.push_back(id);
    } catch (const StoreError&) {
      held.assign(1, "?");
    }
    for (const auto& id : held) {
      try {
        if (id == "?" || !record_end(store, id, me.id, "interrupted", "the database could not be written: " +
                                                                   std::string(e.what()), now_seconds(), 0))
          ++unrecorded;
      } catch (const StoreError&) {
        ++unrecorded;
      }
    }
    throw StoreError(e.code(), std::string(e.what()) + "\ncampaign run stopped its engines (they continue from their checkpoints)" +
                                   (unrecorded > 0 ? "; runs it could not mark interrupted show as running with their runner gone "
                                                     "until the next campaign run recovers them"
                                                   : "") +
                                   ". Free space (or fix the database) and run campaign run again.");
  }
  if (!storage_full.empty()) {
    for (const auto& [id, row] : waiting) end_run(id, "interrupted", storage_full, 0);
    observer.on_event("", "stopped", storage_full + ": no more runs started; the interrupted ones continue from their "
                                     "checkpoints once there is room (campaign run again)");
    observer.on_end(done, failed, total);
    return ExitCode::kStorage;
  }
  observer.on_end(done, failed, total);
  return any_final_failure ? ExitCode::kRunsFailed : ExitCode::kOk;
}

}  // namespace granary::runner
