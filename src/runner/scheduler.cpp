// See scheduler.h.
#include "runner/scheduler.h"

#include <signal.h>
#include <unistd.h>

#include <chrono>
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
using nlohmann::json;

bool matches_filter(const RunRow& row, const std::string& filter) {
  return filter.empty() || RunFilter(std::vector<std::string>{filter}).matches(row);
}


namespace {

std::string EngineExe(const RunOptions& o, const std::string& engine) {
  if (o.engine.find('/') != std::string::npos) return o.engine;
  return (fs::path(o.exe_dir) / (engine == "liggghts" ? "granary-liggghts" : "granary-engine")).string();
}

struct Slot {
  RunRow row;
  std::chrono::steady_clock::time_point started;
  bool timed_out = false;
};

}  // namespace

ExitCode run_campaign(Store& store, const RunOptions& options, Executor& executor, RunObserver& observer,
                      const volatile std::sig_atomic_t* stop) {
  if (options.engine.find('/') != std::string::npos && !fs::exists(options.engine)) {
    throw std::invalid_argument("engine executable not found: " + options.engine);
  }
  const Holder me = this_process_holder();
  const int recovered = recover_expired_leases(store, me, now_seconds());

  const RunFilter filter(options.only);
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

  auto accept = [&](const RunRow& r) {
    if ((options.engine == "native" || options.engine == "liggghts") && r.engine != options.engine) return false;
    return filter.matches(r);
  };
  std::set<std::string> skip;             // exhausted in this invocation
  std::map<std::string, int> failures;    // failed attempts in this invocation
  std::map<std::string, Slot> slots;
  bool any_final_failure = false;
  bool stopping = false;
  auto last_heartbeat = std::chrono::steady_clock::now();
  auto last_tick = std::chrono::steady_clock::time_point{};

  auto end_run = [&](const std::string& id, const std::string& state, const std::string& reason, double wall) {
    record_end(store, id, state, reason, now_seconds(), wall);
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

  auto finish_done = [&](const RunRow& row, double wall) -> bool {
    const fs::path dir = row.run_dir;
    if (!rundir::IsDone(dir)) return false;
    rundir::Summary summary;
    try {
      summary = rundir::ReadSummary(dir / rundir::kSummaryFile);
    } catch (const rundir::ReadError&) {
      return false;
    }
    record_done(store, row.run_id, summary.raw, now_seconds(), wall);
    ++done;
    if (row.state == "failed") --failed;
    std::ostringstream what;
    what << (summary.end_reason.empty() ? std::string("finished") : summary.end_reason) << " at t = " << summary.t_end
         << ", " << summary.exited << " exits, " << static_cast<int>(wall) << " s";
    observer.on_event(row.run_id, "done", what.str());
    return true;
  };

  while (true) {
    if (stop && *stop && !stopping) {
      stopping = true;
      // The engines checkpoint and exit (the executor ends them by force after a grace
      // period); they continue next time.
      executor.stop_all(StopReason::kInterrupt);
      while (executor.active() > 0) {
        for (const auto& f : executor.poll()) {
          const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - slots[f.run_id].started).count();
          if (!(f.signal == 0 && f.exit_code == 0 && finish_done(slots[f.run_id].row, wall))) {
            record_end(store, f.run_id, "interrupted", "interrupted by the user (runner stopped)", now_seconds(), wall);
            observer.on_event(f.run_id, "interrupted", "stopped");
          }
          slots.erase(f.run_id);
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
      observer.on_end(done, failed, total);
      return ExitCode::kInterrupted;
    }

    // Start as many runs as there are free slots.
    bool nothing_left = false;
    while (executor.can_start_more()) {
      auto row = claim_next(store, me, now_seconds(), accept, skip);
      if (!row) {
        nothing_left = true;
        break;
      }
      // A run whose engine finished but was never ingested (runner killed in between) is
      // ingested now instead of being run twice.
      if (finish_done(*row, row->wall_s)) continue;
      const std::string exe = EngineExe(options, row->engine);
      if (!fs::exists(exe)) {
        record_end(store, row->run_id, "interrupted", "engine executable not found: " + exe, now_seconds(), 0);
        throw std::invalid_argument("engine executable not found: " + exe +
                                 " (build it, or pass --engine PATH)");
      }
      try {
        rundir::WriteRunSpec(row->run_dir, row->params);
        Launch launch;
        launch.run_id = row->run_id;
        launch.argv = {exe, "run", row->run_dir, "--threads", std::to_string(options.threads_per_run)};
        launch.log_file = (fs::path(row->run_dir) / rundir::kEngineLogFile).string();
        executor.start(launch);
      } catch (const std::exception& e) {
        end_run(row->run_id, "failed", e.what(), 0);
        continue;
      }
      slots[row->run_id] = Slot{*row, std::chrono::steady_clock::now(), false};
      observer.on_event(row->run_id, "running", "attempt " + std::to_string(row->attempts));
    }
    if (nothing_left && executor.active() == 0) break;

    for (const auto& f : executor.poll()) {
      Slot slot = slots[f.run_id];
      slots.erase(f.run_id);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - slot.started).count();
      const std::string log = (fs::path(slot.row.run_dir) / rundir::kEngineLogFile).string();
      if (f.signal == 0 && f.exit_code == 0) {
        if (finish_done(slot.row, wall)) continue;
        end_run(f.run_id, "failed", "engine exited 0 without DONE and summary.json\n" + TailOfFile(log, 20), wall);
      } else if (slot.timed_out) {
        end_run(f.run_id, "failed",
                "wall-time limit of " + json(options.time_limit).dump() + " s exceeded\n" + TailOfFile(log, 20),
                wall);
      } else if (f.signal != 0) {
        // Killed from outside: it continues from its checkpoint on the next attempt.
        end_run(f.run_id, "interrupted", "engine killed by signal " + std::to_string(f.signal) + "\n" + TailOfFile(log, 20), wall);
      } else {
        end_run(f.run_id, "failed", "engine exited with status " + std::to_string(f.exit_code) + "\n" + TailOfFile(log, 20), wall);
      }
    }

    const auto now = std::chrono::steady_clock::now();
    if (options.time_limit > 0) {
      for (auto& [id, slot] : slots) {
        if (!slot.timed_out && std::chrono::duration<double>(now - slot.started).count() > options.time_limit) {
          slot.timed_out = true;
          executor.stop(id, StopReason::kTimeLimit);
        }
      }
    }
    if (std::chrono::duration<double>(now - last_tick).count() >= 0.5) {
      last_tick = now;
      std::vector<ActiveRun> active;
      std::map<std::string, json> progress;
      for (const auto& [id, slot] : slots) {
        ActiveRun a;
        a.run_id = id;
        a.point = slot.row.point.dump();
        a.replica = slot.row.replica;
        a.attempt = slot.row.attempts;
        a.elapsed = std::chrono::duration<double>(now - slot.started).count();
        if (const auto p = rundir::ReadProgress(slot.row.run_dir)) {
          a.progress = p->ToJson();
          progress[id] = a.progress;
        }
        active.push_back(a);
      }
      observer.on_tick(active, done, failed, total);
      if (std::chrono::duration<double>(now - last_heartbeat).count() >= options.heartbeat_interval) {
        last_heartbeat = now;
        heartbeat(store, me, now_seconds(), progress);
      }
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(options.poll_interval));
  }
  observer.on_end(done, failed, total);
  return any_final_failure ? ExitCode::kRunsFailed : ExitCode::kOk;
}

}  // namespace granary::runner
