// See scheduler.h.
#include "runner/scheduler.h"

#include "runner/campaign_spec.h"

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

bool MatchesFilter(const RunRow& row, const std::string& filter) {
  return filter.empty() || RunFilter(std::vector<std::string>{filter}).Matches(row);
}

namespace {

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

}  // namespace

std::pair<RunState, std::string> EndStateOf(const Finished& f, bool timed_out, double time_limit,
                                            const std::string& log_file) {
  // The executor's words where it has them (a batch queue's state), else the status'.
  const auto said = [&](const std::string& status) {
    return (f.how.empty() ? status : f.how) + "\n" + TailOfFile(log_file, 20);
  };
  if (timed_out || f.timed_out) {
    return {RunState::kFailed, said(time_limit > 0 ? "wall-time limit of " + Number(time_limit) + " s exceeded"
                                                   : "wall-time limit exceeded")};
  }
  if (f.signal == 0 && f.exit_code == 0) {
    return {RunState::kFailed, "engine exited 0 without DONE and summary.json\n" + TailOfFile(log_file, 20)};
  }
  if (f.signal == 0 && f.exit_code == kExitRunDirectoryBusy) {
    // Another engine held the directory: nothing was touched; it runs again later.
    return {RunState::kInterrupted, said("engine " + How(f) + ": its run directory was locked by another engine")};
  }
  // Killed from outside: it continues from its checkpoint on the next attempt.
  if (f.signal != 0) return {RunState::kInterrupted, said("engine " + How(f))};
  return {RunState::kFailed, said("engine " + How(f))};
}

namespace {

std::string EngineExe(const CampaignRunOptions& o, const std::string& engine) {
  if (o.engine.find('/') != std::string::npos) return o.engine;
  return (fs::path(o.exe_dir) / EngineProgram(engine)).string();
}

Launch LaunchOf(const RunRow& row, const std::string& exe, int threads) {
  Launch l;
  l.run_id = row.run_id;
  l.argv = {exe, "run", row.run_dir, "--threads", std::to_string(threads)};
  l.log_file = (fs::path(row.run_dir) / rundir::kEngineLogFile).string();
  l.engine = row.engine;
  l.run_dir = row.run_dir;
  l.place = QueuePlace{row.job_dir, row.job_script, row.job_name, row.job_index, row.job_id, row.job_state};
  return l;
}

// Is the run's engine at work (so that its progress.json is worth reading)?
bool EngineAtWork(const std::string& queue_state) {
  return queue_state.empty() || DefaultBatchQueue().FateOf(queue_state) == TaskFate::kRunning;
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

ExitCode RunCampaign(Store& store, const CampaignRunOptions& options, Executor& executor, RunObserver& observer,
                     const volatile std::sig_atomic_t* stop) {
  if (options.engine.find('/') != std::string::npos && !fs::exists(options.engine)) {
    throw std::invalid_argument("engine executable not found: " + options.engine);
  }
  const Holder me = options.holder ? *options.holder : ThisProcessHolder();
  const std::function<double()> clock = options.clock ? options.clock : [] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  };
  const int recovered = RecoverExpiredLeases(store, me, NowSeconds());

  const RunFilter filter(options.only);
  auto accept = [&](const RunRow& r) {
    if ((options.engine == "native" || options.engine == "liggghts" || options.engine == "lammps") &&
        r.engine != options.engine)
      return false;
    return filter.Matches(r);
  };
  // Done runs whose directory was deleted: their results are in the database, but nothing
  // can analyse them. Said at every start; run again on request.
  std::vector<std::string> lost;
  for (const auto& r : LoadRuns(store, true))
    if (r.state == RunState::kDone && !fs::exists(r.run_dir) && accept(r)) lost.push_back(r.run_id);
  const int requeued = options.rerun_lost ? RequeueDoneRuns(store, lost, kLostRunDirectory) : 0;

  int total = 0, done = 0, failed = 0;
  for (const auto& r : LoadRuns(store, !filter.empty())) {
    if (r.state == RunState::kRetired || !filter.Matches(r)) continue;
    ++total;
    if (r.state == RunState::kDone) ++done;
    if (r.state == RunState::kFailed) ++failed;
  }
  observer.OnBegin(total, done, failed);
  if (recovered > 0) {
    observer.OnEvent("", ToString(RunState::kInterrupted),
                     std::to_string(recovered) + " run(s) of a lost runner will continue");
  }
  if (requeued > 0) {
    observer.OnEvent("", ToString(RunState::kPlanned),
                     std::to_string(requeued) + " done run(s) whose run directory was deleted will run again");
  } else if (!lost.empty()) {
    observer.OnEvent("", "lost",
                     std::to_string(lost.size()) +
                         " done run(s) have no run directory (deleted after they "
                         "finished; first " +
                         lost.front() +
                         "): their results are in the database only; "
                         "campaign run --rerun-lost runs them again");
  }

  std::set<std::string> skip;                      // exhausted in this invocation
  std::map<std::string, int> failures;             // failed attempts in this invocation
  std::map<std::string, Slot> slots;               // engines started
  std::map<std::string, RunRow> waiting;           // claimed, but another engine still holds the directory
  std::map<std::string, std::string> queue_state;  // runs in a batch queue: their last state
  bool any_final_failure = false;
  std::string storage_full;  // set when runs/ is full: no new runs start, the invocation ends with kStorage
  double last_heartbeat = clock();
  double last_tick = -1e300;
  bool replicas_due = true;  // adaptive replicas: a run was recorded done since the last look

  auto lease_lost = [&](const std::string& id, const std::string& what) {
    observer.OnEvent(
        id, "lease lost",
        "another runner holds this run now (this runner's lease expired, or a re-plan retired it); " + what);
  };

  // Records an end state under our lease; false (and nothing recorded) if it is not ours.
  auto end_run = [&](const std::string& id, RunState state, const std::string& reason, double wall) {
    if (!RecordEnd(store, id, me.id, state, reason, NowSeconds(), wall)) {
      lease_lost(id, std::string("its end (") + ToString(state) + ") is not recorded");
      return;
    }
    if (state == RunState::kFailed) ++failed;
    ++failures[id];
    if (failures[id] > options.retries) {
      skip.insert(id);
      replicas_due = true;  // the point's last run may have ended here
      if (state == RunState::kFailed) any_final_failure = true;
    } else if (state == RunState::kFailed) {
      --failed;  // will be retried: not counted as failed in the display
    }
    observer.OnEvent(id, ToString(state), reason);
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
    if (!RecordDone(store, row.run_id, me.id, summary.raw, NowSeconds(), wall)) {
      lease_lost(row.run_id, "its result is not recorded");
      return true;
    }
    ++done;
    replicas_due = true;
    if (row.state == RunState::kFailed) --failed;
    std::ostringstream what;
    what << (summary.end_reason.empty() ? std::string("finished") : summary.end_reason) << " at t = " << summary.t_end
         << ", " << summary.exited << " exits, " << static_cast<int>(wall) << " s";
    observer.OnEvent(row.run_id, ToString(RunState::kDone), what.str());
    return true;
  };

  // Starts the engine of a claimed run, or parks it while another engine holds its directory.
  auto launch = [&](const RunRow& row) {
    const std::string holder = RunDirectoryHolder(row.run_dir);
    if (!holder.empty()) {
      if (!waiting.count(row.run_id)) observer.OnEvent(row.run_id, "waiting", "its directory is locked by " + holder);
      waiting[row.run_id] = row;
      return;
    }
    waiting.erase(row.run_id);
    // A run whose engine finished but was never ingested (runner killed in between) is
    // ingested now instead of being run twice.
    if (finish_done(row, row.wall_s)) return;
    const std::string exe = EngineExe(options, row.engine);
    if (!fs::exists(exe)) {
      RecordEnd(store, row.run_id, me.id, RunState::kInterrupted, "engine executable not found: " + exe, NowSeconds(),
                0);
      throw std::invalid_argument("engine executable not found: " + exe + " (build it, or pass --engine PATH)");
    }
    try {
      rundir::WriteRunSpec(row.run_dir, row.params);
      executor.Start(LaunchOf(row, exe, options.threads_per_run));
    } catch (const std::exception& e) {
      if (const std::string full = FullFileSystem(row.run_dir); !full.empty()) {
        storage_full = full;
        end_run(row.run_id, RunState::kInterrupted, full + ": " + e.what(), 0);
      } else {
        end_run(row.run_id, RunState::kFailed, e.what(), 0);
      }
      return;
    }
    slots[row.run_id] = Slot{row, clock(), false, false};
    observer.OnEvent(row.run_id, ToString(RunState::kRunning),
                     "attempt " + std::to_string(row.attempts) + (executor.OutlivesRunner() ? ", to the queue" : ""));
  };

  // One ended engine: its end state, under our lease.
  auto finished = [&](const Finished& f, bool stopping) {
    const Slot slot = slots[f.run_id];
    slots.erase(f.run_id);
    queue_state.erase(f.run_id);
    // A batch queue knows the engine's own wall time; the runner's clock counts the wait too.
    const double wall = f.wall_s >= 0 ? f.wall_s : clock() - slot.started;
    const std::string log = (fs::path(slot.row.run_dir) / rundir::kEngineLogFile).string();
    if (slot.lease_lost) {
      lease_lost(f.run_id, "its engine was stopped and nothing is recorded");
    } else if (f.signal == 0 && f.exit_code == 0 && !f.timed_out && finish_done(slot.row, wall)) {
    } else if (f.signal == 0 && f.exit_code == kExitRunDirectoryBusy) {
      // Another engine took the directory between our look and the engine's lock.
      if (stopping)
        end_run(f.run_id, RunState::kInterrupted, "interrupted while waiting for its directory", wall);
      else
        waiting[f.run_id] = slot.row;
    } else if (stopping) {
      end_run(f.run_id, RunState::kInterrupted, "interrupted by the user (runner stopped)", wall);
    } else if (const std::string full = FullFileSystem(slot.row.run_dir); !full.empty()) {
      // Not the run's fault: it continues from its checkpoint once there is room.
      storage_full = full;
      end_run(f.run_id, RunState::kInterrupted, "engine " + How(f) + "; " + full + "\n" + TailOfFile(log, 20), wall);
    } else {
      const auto [state, reason] = EndStateOf(f, slot.timed_out, options.time_limit, log);
      end_run(f.run_id, state, reason, wall);
    }
  };

  // Runs a runner before this one put into the queue are watched again, never started twice.
  if (executor.OutlivesRunner()) {
    const auto adopted = AdoptQueuedRuns(store, me, NowSeconds());
    for (const auto& row : adopted) {
      const QueuePlace place = executor.Attach(LaunchOf(row, EngineExe(options, row.engine), options.threads_per_run));
      if (place.job_id != row.job_id) RecordJobId(store, row.job_script, place.job_id);
      slots[row.run_id] = Slot{row, clock(), false, false};
      queue_state[row.run_id] = row.job_state;
    }
    if (!adopted.empty()) {
      observer.OnEvent("", "attached",
                       std::to_string(adopted.size()) + " run(s) already in the queue: watching them again");
    }
  } else {
    int queued = 0;
    for (const auto& r : LoadRuns(store, false)) queued += r.Queued();
    if (queued > 0) {
      observer.OnEvent("", "queued",
                       std::to_string(queued) +
                           " run(s) are in a Slurm queue; campaign run --executor slurm watches them, "
                           "campaign scan settles them");
    }
  }

  // Places the runs started since the last call in the queue: places recorded first, then
  // submitted. An array the queue refuses leaves its runs interrupted, not retried here.
  auto submit_started = [&] {
    const std::vector<JobArray> placed = executor.Place();
    if (placed.empty()) return;
    for (const auto& a : placed) RecordJobArray(store, me, a, NowSeconds());
    for (const auto& a : executor.Submit()) {
      if (a.error.empty()) {
        RecordJobId(store, a.script, a.job_id);
        for (const auto& [id, index] : a.runs) {
          if (auto slot = slots.find(id); slot != slots.end()) slot->second.row.job_id = a.job_id;
        }
        observer.OnEvent("", "submitted",
                         "array job " + a.job_id + " (" + std::to_string(a.runs.size()) + " runs, --array=" + a.array +
                             "): " + a.script);
        continue;
      }
      for (const auto& [id, index] : a.runs) {
        if (!RecordEnd(store, id, me.id, RunState::kInterrupted, a.error, NowSeconds(), 0))
          lease_lost(id, "its end is not recorded");
        skip.insert(id);
        slots.erase(id);
        queue_state.erase(id);
      }
      any_final_failure = true;
      observer.OnEvent("", "not submitted", a.error + " (" + std::to_string(a.runs.size()) + " runs left interrupted)");
    }
  };

  // Leaves the queued runs to their jobs (a later runner or campaign scan collects them);
  // runs still waiting for their directory were never queued: they are interrupted.
  auto detach = [&](const std::string& what) {
    for (const auto& [id, row] : waiting)
      end_run(id, RunState::kInterrupted, "waiting for its directory when the runner detached", 0);
    waiting.clear();
    const int released = ReleaseQueuedRuns(store, me);
    observer.OnEvent("", "detached", std::to_string(released) + what);
    observer.OnEnd(done, failed, total);
  };

  // Heartbeat; engines of runs that are no longer ours are stopped at once (a batch queue's
  // job is left to the runner that holds its run now).
  auto check_leases = [&](const std::map<std::string, json>& progress) {
    const std::set<std::string> held = Heartbeat(store, me, NowSeconds(), progress);
    for (auto& [id, slot] : slots) {
      if (slot.lease_lost || held.count(id)) continue;
      slot.lease_lost = true;
      executor.Stop(id, StopReason::kLeaseLost);
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
      if (stop && *stop && executor.OutlivesRunner()) {
        // The jobs keep running; a later runner adopts them.
        detach(
            " run(s) stay in the queue; campaign run --executor slurm watches them again, campaign scan settles them");
        return ExitCode::kInterrupted;
      }
      if (stop && *stop) {
        // The engines checkpoint and exit (the executor ends them by force after a grace
        // period); they continue next time.
        executor.StopAll(StopReason::kInterrupt);
        while (executor.Active() > 0) {
          for (const auto& f : executor.Poll()) finished(f, true);
          if (executor.Active() > 0) std::this_thread::sleep_for(std::chrono::milliseconds(50));
        }
        for (const auto& [id, row] : waiting)
          end_run(id, RunState::kInterrupted, "interrupted while waiting for its directory", 0);
        observer.OnEnd(done, failed, total);
        return ExitCode::kInterrupted;
      }

      if (replicas_due && options.add_runs) {
        replicas_due = false;
        total += options.add_runs(observer);
      }
      // Runs waiting for their directory first, then new claims, while there are free slots.
      for (auto it = waiting.begin(); it != waiting.end() && executor.CanStartMore() && storage_full.empty();) {
        const RunRow row = (it++)->second;
        launch(row);
      }
      bool nothing_left = !storage_full.empty();  // a full runs/ starts nothing more
      while (!nothing_left && executor.CanStartMore()) {
        auto row = ClaimNext(store, me, NowSeconds(), accept, skip);
        if (!row) {
          nothing_left = true;
          break;
        }
        launch(*row);
      }
      submit_started();
      if (options.detach && nothing_left && executor.OutlivesRunner()) {
        detach(
            " run(s) in the queue; campaign status shows them, campaign scan or campaign run --executor slurm "
            "collects them");
        if (!storage_full.empty()) return ExitCode::kStorage;
        return any_final_failure ? ExitCode::kRunsFailed : ExitCode::kOk;
      }
      if (nothing_left && executor.Active() == 0 && (waiting.empty() || !storage_full.empty())) break;

      for (const auto& f : executor.Poll()) finished(f, false);
      if (auto changes = executor.QueueChanges(); !changes.empty()) {
        std::map<std::string, std::string> states;
        for (const auto& [id, place] : changes) {
          auto slot = slots.find(id);
          if (slot == slots.end() || slot->second.lease_lost) continue;
          queue_state[id] = states[id] = place.state;
          // A job found by its name after a runner died inside sbatch.
          if (place.job_id != slot->second.row.job_id) {
            RecordJobId(store, place.script, place.job_id);
            slot->second.row.job_id = place.job_id;
          }
        }
        RecordJobStates(store, states);
      }

      const double now = clock();
      if (options.time_limit > 0 && !executor.LimitsTime()) {
        for (auto& [id, slot] : slots) {
          if (!slot.timed_out && !slot.lease_lost && now - slot.started > options.time_limit) {
            slot.timed_out = true;
            executor.Stop(id, StopReason::kTimeLimit);
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
          if (auto q = queue_state.find(id); q != queue_state.end()) a.queue_state = q->second;
          // A queued run's directory is not read until its task runs (a shared file system).
          if (EngineAtWork(a.queue_state)) {
            if (const auto p = rundir::ReadProgress(slot.row.run_dir)) {
              a.progress = p->ToJson();
              progress[id] = a.progress;
            }
          }
          active.push_back(a);
        }
        observer.OnTick(active, done, failed, total);
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
    // `campaign run` recovers (this runner is gone by then). Jobs in a batch queue keep
    // running: their runs stay queued under this runner's lease, and the next runner adopts
    // them once it has expired.
    if (executor.OutlivesRunner()) {
      throw StoreError(e.Code(), std::string(e.what()) + "\ncampaign run stopped watching its " +
                                     DefaultBatchQueue().Name() +
                                     " jobs (they keep running; "
                                     "the next campaign run or campaign scan collects them). Free space "
                                     "(or fix the database) and run campaign run again.");
    }
    executor.StopAll(StopReason::kInterrupt);
    while (executor.Active() > 0) {
      for (const auto& f : executor.Poll()) slots.erase(f.run_id);
      if (executor.Active() > 0) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    int unrecorded = 0;
    std::vector<std::string> held;
    try {
      for (const auto& id : Heartbeat(store, me, NowSeconds(), {})) held.push_back(id);
    } catch (const StoreError&) {
      held.assign(1, "?");
    }
    for (const auto& id : held) {
      try {
        if (id == "?" || !RecordEnd(store, id, me.id, RunState::kInterrupted,
                                    "the database could not be written: " + std::string(e.what()), NowSeconds(), 0))
          ++unrecorded;
      } catch (const StoreError&) {
        ++unrecorded;
      }
    }
    throw StoreError(
        e.Code(), std::string(e.what()) + "\ncampaign run stopped its engines (they continue from their checkpoints)" +
                      (unrecorded > 0 ? "; runs it could not mark interrupted show as running with their runner gone "
                                        "until the next campaign run recovers them"
                                      : "") +
                      ". Free space (or fix the database) and run campaign run again.");
  }
  if (!storage_full.empty()) {
    for (const auto& [id, row] : waiting) end_run(id, RunState::kInterrupted, storage_full, 0);
    observer.OnEvent("", "stopped",
                     storage_full +
                         ": no more runs started; the interrupted ones continue from their "
                         "checkpoints once there is room (campaign run again)");
    observer.OnEnd(done, failed, total);
    return ExitCode::kStorage;
  }
  observer.OnEnd(done, failed, total);
  return any_final_failure ? ExitCode::kRunsFailed : ExitCode::kOk;
}

}  // namespace granary::runner
