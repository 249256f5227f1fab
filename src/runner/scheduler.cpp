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
#include "runner/slurm.h"

namespace granary::runner {

namespace fs = std::filesystem;
using nlohmann::json;

bool matches_filter(const RunRow& row, const std::string& filter) {
  if (filter.empty()) return true;
  const auto eq = filter.find('=');
  if (eq == std::string::npos || filter[0] != '/') return row.run_id.rfind(filter, 0) == 0;
  const std::string pointer = filter.substr(0, eq);
  const std::string text = filter.substr(eq + 1);
  json::json_pointer ptr;
  try {
    ptr = json::json_pointer(pointer);
  } catch (const json::exception&) {
    return false;
  }
  if (!row.params.contains(ptr)) return false;
  const json value = json::parse(text, nullptr, false);
  const json& actual = row.params[ptr];
  if (!value.is_discarded()) {
    if (value.is_number() && actual.is_number()) return value.get<double>() == actual.get<double>();
    if (value == actual) return true;
  }
  return actual.is_string() && actual.get<std::string>() == text;
}


std::pair<std::string, std::string> end_state_of(const Finished& f, bool timed_out, double time_limit,
                                                 const std::string& log_file) {
  // The executor's words where it has them (a batch queue's state), else the status'.
  const auto said = [&](const std::string& status) { return (f.how.empty() ? status : f.how) + "\n" + TailOfFile(log_file, 20); };
  if (timed_out || f.timed_out) {
    return {"failed", said(time_limit > 0 ? "wall-time limit of " + json(time_limit).dump() + " s exceeded"
                                          : "wall-time limit exceeded")};
  }
  if (f.signal == 0 && f.exit_code == 0) {
    return {"failed", "engine exited 0 without DONE and summary.json\n" + TailOfFile(log_file, 20)};
  }
  // Killed from outside: it continues from its checkpoint on the next attempt.
  if (f.signal != 0) return {"interrupted", said("engine killed by signal " + std::to_string(f.signal))};
  return {"failed", said("engine exited with status " + std::to_string(f.exit_code))};
}

namespace {

std::string EngineExe(const RunOptions& o, const std::string& engine) {
  if (o.engine.find('/') != std::string::npos) return o.engine;
  return (fs::path(o.exe_dir) / (engine == "liggghts" ? "granary-liggghts" : "granary-engine")).string();
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
  return queue_state.empty() || fate_of(queue_state) == TaskFate::kRunning;
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

  int total = 0, done = 0, failed = 0;
  for (const auto& r : load_runs(store, false)) {
    if (r.state == "retired") continue;
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
    return matches_filter(r, options.only);
  };
  std::set<std::string> skip;             // exhausted in this invocation
  std::map<std::string, int> failures;    // failed attempts in this invocation
  std::map<std::string, Slot> slots;
  std::map<std::string, std::string> queue_state;  // runs in a batch queue: their last state
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
    observer.on_event(row.run_id, "done",
                      (summary.end_reason.empty() ? std::string("finished") : summary.end_reason) + " in " +
                          std::to_string(static_cast<int>(wall)) + " s");
    return true;
  };

  // Runs a runner before this one put into the queue are watched again, never started twice.
  if (executor.outlives_runner()) {
    const auto adopted = adopt_queued_runs(store, me, now_seconds());
    for (const auto& row : adopted) {
      const QueuePlace place = executor.attach(LaunchOf(row, EngineExe(options, row.engine), options.threads_per_run));
      if (place.job_id != row.job_id) record_job_id(store, row.job_script, place.job_id);
      slots[row.run_id] = Slot{row, std::chrono::steady_clock::now(), false};
      queue_state[row.run_id] = row.job_state;
    }
    if (!adopted.empty()) {
      observer.on_event("", "attached", std::to_string(adopted.size()) + " run(s) already in the queue: watching them again");
    }
  } else {
    int queued = 0;
    for (const auto& r : load_runs(store, false)) queued += r.queued();
    if (queued > 0) {
      observer.on_event("", "queued", std::to_string(queued) +
                                          " run(s) are in a Slurm queue; campaign run --executor slurm watches them, "
                                          "campaign scan settles them");
    }
  }

  // Places the runs started since the last call in the queue: places recorded first, then
  // submitted. An array the queue refuses leaves its runs interrupted, not retried here.
  auto submit_started = [&] {
    const std::vector<JobArray> placed = executor.place();
    if (placed.empty()) return;
    for (const auto& a : placed) record_job_array(store, me, a, now_seconds());
    for (const auto& a : executor.submit()) {
      if (a.error.empty()) {
        record_job_id(store, a.script, a.job_id);
        for (const auto& [id, index] : a.runs) {
          if (auto slot = slots.find(id); slot != slots.end()) slot->second.row.job_id = a.job_id;
        }
        observer.on_event("", "submitted", "array job " + a.job_id + " (" + std::to_string(a.runs.size()) + " runs, --array=" +
                                               a.array + "): " + a.script);
        continue;
      }
      for (const auto& [id, index] : a.runs) {
        record_end(store, id, "interrupted", a.error, now_seconds(), 0);
        skip.insert(id);
        slots.erase(id);
        queue_state.erase(id);
      }
      any_final_failure = true;
      observer.on_event("", "not submitted", a.error + " (" + std::to_string(a.runs.size()) + " runs left interrupted)");
    }
  };

  while (true) {
    if (stop && *stop && executor.outlives_runner()) {
      // The jobs keep running; a later runner adopts them.
      const int released = release_queued_runs(store, me);
      observer.on_event("", "detached", std::to_string(released) +
                                            " run(s) stay in the queue; campaign run --executor slurm watches them "
                                            "again, campaign scan settles them");
      observer.on_end(done, failed, total);
      return ExitCode::kInterrupted;
    }
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
        executor.start(LaunchOf(*row, exe, options.threads_per_run));
      } catch (const std::exception& e) {
        end_run(row->run_id, "failed", e.what(), 0);
        continue;
      }
      slots[row->run_id] = Slot{*row, std::chrono::steady_clock::now(), false};
      observer.on_event(row->run_id, "running",
                        "attempt " + std::to_string(row->attempts) + (executor.outlives_runner() ? ", to the queue" : ""));
    }
    submit_started();
    if (options.detach && nothing_left) {
      const int released = release_queued_runs(store, me);
      observer.on_event("", "detached", std::to_string(released) +
                                            " run(s) in the queue; campaign status shows them, campaign scan or "
                                            "campaign run --executor slurm collects them");
      observer.on_end(done, failed, total);
      return any_final_failure ? ExitCode::kRunsFailed : ExitCode::kOk;
    }
    if (nothing_left && executor.active() == 0) break;

    for (const auto& f : executor.poll()) {
      Slot slot = slots[f.run_id];
      slots.erase(f.run_id);
      queue_state.erase(f.run_id);
      const double wall = f.wall_s >= 0 ? f.wall_s : std::chrono::duration<double>(std::chrono::steady_clock::now() - slot.started).count();
      const std::string log = (fs::path(slot.row.run_dir) / rundir::kEngineLogFile).string();
      if (f.signal == 0 && f.exit_code == 0 && !f.timed_out && finish_done(slot.row, wall)) continue;
      const auto [state, reason] = end_state_of(f, slot.timed_out, options.time_limit, log);
      end_run(f.run_id, state, reason, wall);
    }
    if (auto changes = executor.queue_changes(); !changes.empty()) {
      std::map<std::string, std::string> states;
      for (const auto& [id, place] : changes) {
        auto slot = slots.find(id);
        if (slot == slots.end()) continue;
        queue_state[id] = states[id] = place.state;
        // A job found by its name after a runner died inside sbatch.
        if (place.job_id != slot->second.row.job_id) {
          record_job_id(store, place.script, place.job_id);
          slot->second.row.job_id = place.job_id;
        }
      }
      record_job_states(store, states);
    }

    const auto now = std::chrono::steady_clock::now();
    if (options.time_limit > 0 && !executor.limits_time()) {
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
        a.attempt = slot.row.attempts;
        a.elapsed = std::chrono::duration<double>(now - slot.started).count();
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
