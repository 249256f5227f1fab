// See slurm_executor.h.
#include "runner/slurm_executor.h"

#include <limits>
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <boost/asio.hpp>
#include <boost/process.hpp>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "rundir/files.h"
#include "rundir/layout.h"
#include "rundir/run_directory.h"
#include "runner/calibration.h"
#include "runner/campaign_db.h"
#include "runner/campaign_spec.h"
#include "runner/cli/common.h"
#include "runner/executors.h"
#include "runner/run_filter.h"

namespace granary::runner {

namespace fs = std::filesystem;
namespace bp = boost::process;

namespace {

using Clock = std::chrono::steady_clock;

struct CommandResult {
  int code = -1;
  std::string out;
  std::string err;
};

// Runs a Slurm client command (found on PATH) and collects its output; times print as unix
// seconds (SLURM_TIME_FORMAT=%s).
CommandResult RunCommand(const std::vector<std::string>& argv, const fs::path& cwd = ".") {
  CommandResult r;
  const fs::path exe = bp::search_path(argv[0]).string();
  if (exe.empty()) {
    r.code = 127;
    r.err = argv[0] + ": not found on PATH (install Slurm's client commands, Debian package slurm-client)";
    return r;
  }
  boost::asio::io_context io;
  std::future<std::string> out, err;
  auto env = boost::this_process::environment();
  env["SLURM_TIME_FORMAT"] = "%s";
  std::error_code ec;
  bp::child child(exe.string(), bp::args(std::vector<std::string>(argv.begin() + 1, argv.end())),
                  bp::std_in<bp::null, bp::std_out> out, bp::std_err > err, bp::start_dir = cwd.string(), env, io, ec);
  if (ec) {
    r.err = "cannot start " + exe.string() + ": " + ec.message();
    return r;
  }
  io.run();
  child.wait(ec);
  r.code = child.exit_code();
  r.out = out.get();
  r.err = err.get();
  return r;
}

std::string Trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ' || s.back() == '\r')) s.pop_back();
  return s;
}

// The last line a command printed on failure: Slurm's clients end with the one that matters
// ("fatal: Could not establish a configuration source").
std::string LastLine(const CommandResult& r) {
  const std::string text = Trim(r.err.empty() ? r.out : r.err);
  const auto nl = text.rfind('\n');
  return nl == std::string::npos ? text : text.substr(nl + 1);
}

// Campaign names become part of directory and job names: letters, digits, '-', '_', '.'.
std::string SafeName(const std::string& campaign) {
  std::string out;
  for (char c : campaign.substr(0, 32))
    out += std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' ? c : '_';
  return out.empty() ? "campaign" : out;
}

std::string ReadText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Creates the first free <root>/<base>-NNNN (create = false: only finds it, skipping `taken`).
fs::path NewSubmissionDir(const fs::path& root, const std::string& base, bool create, std::set<std::string>& taken) {
  if (create) fs::create_directories(root);
  for (int n = 1;; ++n) {
    char suffix[16];
    std::snprintf(suffix, sizeof suffix, "-%04d", n);
    const fs::path dir = root / (base + suffix);
    if (taken.count(dir.string())) continue;
    if (create ? fs::create_directory(dir) : !fs::exists(dir)) {
      taken.insert(dir.string());
      return dir;
    }
  }
}

// The next free DIR/job-K.sh, claimed by creating it (create = false: only found).
fs::path NewScript(const fs::path& dir, bool create, int& number) {
  for (int k = 1;; ++k) {
    const fs::path script = dir / ("job-" + std::to_string(k) + ".sh");
    if (!create) {
      if (fs::exists(script)) continue;
    } else {
      const int fd = ::open(script.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0755);
      if (fd < 0) {
        if (errno == EEXIST) continue;
        throw std::runtime_error("cannot create " + script.string() + ": " + std::strerror(errno));
      }
      ::close(fd);
    }
    number = k;
    return script;
  }
}

struct Prepared {
  JobArray array;
  std::string manifest;  // "" = the submission's existing manifest
  std::string script;
  int depends_on = -1;  // index of the array (in this batch) this one waits for: the campaign-wide throttle
  std::vector<Launch> launches;
  std::vector<int> indices;
};

// Does the manifest in place.dir still hold this run at place.index?
bool CanResubmitInPlace(const Launch& l) {
  if (l.place.dir.empty() || l.place.index < 0) return false;
  try {
    for (const auto& e : ParseManifest(ReadText(fs::path(l.place.dir) / "manifest.tsv"))) {
      if (e.index == l.place.index) {
        return e.run_id == l.run_id && e.run_dir == l.run_dir && e.executable == l.argv[0] && e.engine == l.engine;
      }
    }
  } catch (const std::exception&) {
  }
  return false;
}

// Groups launches into arrays: runs that were in a submission go back into it as an index
// list; the others, by engine, into new submissions of at most max_array_size runs.
std::vector<Prepared> PlanArrays(const std::vector<Launch>& launches, const SlurmSettings& s, bool create) {
  const int max_size = std::max(1, s.max_array_size);
  const SlurmOptions& o = s.options;
  std::map<std::string, std::vector<Launch>> again;  // submission dir -> runs
  std::map<std::string, std::vector<Launch>> fresh;  // engine -> runs
  for (const auto& l : launches) {
    if (CanResubmitInPlace(l))
      again[l.place.dir].push_back(l);
    else
      fresh[l.engine].push_back(l);
  }
  std::vector<Prepared> out;
  const auto script_of = [&](Prepared& p, const fs::path& dir, const std::string& engine) {
    int k = 0;
    const fs::path script = NewScript(dir, create, k);
    p.array.dir = dir.string();
    p.array.script = script.string();
    p.array.name = "granary-" + dir.filename().string() + "-" + std::to_string(k);
    p.array.array = ArraySpec(p.indices, o.array_max);
    BatchJob job;
    job.job_name = p.array.name;
    job.array = p.array.array;
    job.manifest = (dir / "manifest.tsv").string();
    job.log_dir = (dir / "logs").string();
    job.engine = engine;
    job.time_limit = s.time_limit;
    job.options = o;
    if (o.time.empty() && s.time_limit <= 0) {
      double longest = 0;
      for (const auto& [run_id, index] : p.array.runs)
        if (const auto it = s.estimate_s.find(run_id); it != s.estimate_s.end())
          longest = std::max(longest, it->second);
      if (longest > 0) job.options.time = SlurmTime(WithTimeMargin(longest));
    }
    p.script = BatchScript(job);
  };
  for (auto& [dir, runs] : again) {
    std::sort(runs.begin(), runs.end(), [](const Launch& a, const Launch& b) { return a.place.index < b.place.index; });
    Prepared p;
    for (const auto& l : runs) {
      p.indices.push_back(l.place.index);
      p.array.runs.emplace_back(l.run_id, l.place.index);
    }
    p.launches = runs;
    script_of(p, dir, runs.front().engine);
    out.push_back(std::move(p));
  }
  std::set<std::string> taken;
  const std::string base = SafeName(s.campaign);
  for (auto& [engine, runs] : fresh) {
    int first_of_engine = -1;
    for (std::size_t start = 0; start < runs.size(); start += static_cast<std::size_t>(max_size)) {
      const std::size_t end = std::min(runs.size(), start + static_cast<std::size_t>(max_size));
      Prepared p;
      const fs::path dir = NewSubmissionDir(s.root, base, create, taken);
      std::vector<ManifestEntry> entries;
      for (std::size_t i = start; i < end; ++i) {
        const int index = static_cast<int>(i - start);
        entries.push_back({index, runs[i].run_id, engine, runs[i].argv[0], runs[i].run_dir});
        p.indices.push_back(index);
        p.array.runs.emplace_back(runs[i].run_id, index);
        p.launches.push_back(runs[i]);
      }
      p.manifest = ManifestText(entries);
      script_of(p, dir, engine);
      // With a throttle, the arrays of one campaign run one after the other, so that K holds
      // for the campaign, not for each array.
      if (o.array_max > 0 && first_of_engine >= 0) p.depends_on = static_cast<int>(out.size()) - 1;
      if (first_of_engine < 0) first_of_engine = static_cast<int>(out.size());
      out.push_back(std::move(p));
    }
  }
  return out;
}

std::string SbatchLine(const Prepared& p, const std::string& dependency) {
  return "sbatch --parsable" + (dependency.empty() ? std::string() : " --dependency=afterany:" + dependency) + " " +
         p.array.script;
}

class SlurmExecutor : public Executor {
 public:
  explicit SlurmExecutor(const SlurmSettings& settings) : s_(settings), interval_(settings.options.poll_interval) {
    if (s_.max_array_size <= 0) s_.max_array_size = QueryMaxArraySize();
  }

  bool CanStartMore() const override { return true; }  // the queue (and its %K throttle) decides
  void Start(const Launch& launch) override { started_.push_back(launch); }

  std::vector<JobArray> Place() override {
    if (started_.empty()) return {};
    std::vector<Prepared> arrays = PlanArrays(started_, s_, true);
    started_.clear();
    const int offset = static_cast<int>(prepared_.size());
    std::vector<JobArray> out;
    for (auto& p : arrays) {
      const fs::path dir = p.array.dir;
      fs::create_directories(dir / "logs");
      if (!p.manifest.empty()) WriteAtomically(dir / "manifest.tsv", p.manifest);
      WriteAtomically(p.array.script, p.script);
      fs::permissions(p.array.script, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                          fs::perms::others_read | fs::perms::others_exec);
      for (std::size_t i = 0; i < p.launches.size(); ++i) {
        QueuePlace place;
        place.dir = p.array.dir;
        place.script = p.array.script;
        place.name = p.array.name;
        place.index = p.indices[i];
        place.state = "PENDING";
        runs_[p.launches[i].run_id] = Tracked{p.launches[i], place};
      }
      out.push_back(p.array);
      if (p.depends_on >= 0) p.depends_on += offset;
      prepared_.push_back(std::move(p));
    }
    return out;
  }

  std::vector<JobArray> Submit() override {
    std::vector<JobArray> out;
    for (std::size_t i = 0; i < prepared_.size(); ++i) {
      Prepared& p = prepared_[i];
      std::vector<std::string> argv = {"sbatch", "--parsable"};
      if (p.depends_on >= 0 && !prepared_[static_cast<std::size_t>(p.depends_on)].array.job_id.empty()) {
        argv.push_back("--dependency=afterany:" + prepared_[static_cast<std::size_t>(p.depends_on)].array.job_id);
      }
      argv.push_back(p.array.script);
      const CommandResult r = RunCommand(argv, p.array.dir);
      const std::string id = Trim(r.out).substr(0, Trim(r.out).find(';'));
      if (r.code != 0 || id.empty() || id.find_first_not_of("0123456789") != std::string::npos) {
        p.array.error = "sbatch refused " + p.array.script + ": " + LastLine(r);
        for (const auto& [run_id, index] : p.array.runs) runs_.erase(run_id);
      } else {
        p.array.job_id = id;
        for (const auto& [run_id, index] : p.array.runs) runs_[run_id].place.job_id = id;
      }
      out.push_back(p.array);
    }
    prepared_.clear();
    // New jobs: look at the queue soon.
    interval_ = s_.options.poll_interval;
    next_poll_ = Clock::now();
    return out;
  }

  QueuePlace Attach(const Launch& launch) override {
    QueuePlace place = launch.place;
    // The runner that submitted it died inside sbatch: find the job by its name and script.
    if (place.job_id.empty() && !FindJob(place)) unfound_.insert(launch.run_id);
    runs_[launch.run_id] = Tracked{launch, place};
    next_poll_ = Clock::now();
    return place;
  }

  std::vector<Finished> Poll() override {
    std::vector<Finished> out = std::move(ready_);
    ready_.clear();
    const auto now = Clock::now();
    if (runs_.empty() || now < next_poll_) return out;
    // A job the last look by name could not settle (squeue did not answer) is looked for
    // again; until squeue has answered, nothing is concluded about its run.
    for (auto it = unfound_.begin(); it != unfound_.end();) {
      auto t = runs_.find(*it);
      if (t == runs_.end() || FindJob(t->second.place)) {
        if (t != runs_.end() && !t->second.place.job_id.empty()) changes_[t->first] = t->second.place;
        it = unfound_.erase(it);
      } else {
        ++it;
      }
    }
    std::set<std::string> ids;
    for (const auto& [id, t] : runs_) {
      if (!t.place.job_id.empty()) ids.insert(t.place.job_id);
    }
    std::map<std::pair<std::string, int>, QueueEntry> seen;
    if (!ids.empty()) {
      // One call for every job of the campaign; a failure (controller unreachable) proves
      // nothing: try again later.
      const auto entries = QueryQueue(ids);
      if (!entries) {
        Backoff(false);
        return out;
      }
      for (const auto& e : *entries) seen[{e.job_id, e.task}] = e;
    }
    bool changed = false;
    for (auto it = runs_.begin(); it != runs_.end();) {
      Tracked& t = it->second;
      if (unfound_.count(it->first)) {
        ++it;
        continue;
      }
      auto e = seen.find({t.place.job_id, t.place.index});
      std::string state;
      if (e != seen.end()) {
        state = e->second.state;
        if (state != t.place.state) {
          t.place.state = state;
          changes_[it->first] = t.place;
          changed = true;
        }
        if (IsQueuedOrRunning(FateOf(state))) {
          ++it;
          continue;
        }
      }
      out.push_back(SlurmTaskEnd(it->first, t.launch.run_dir, t.place, state, s_.time_limit, s_.options.time));
      changed = true;
      it = runs_.erase(it);
    }
    Backoff(changed);
    return out;
  }

  void Stop(const std::string& run_id, StopReason reason) override {
    auto it = runs_.find(run_id);
    if (it == runs_.end()) return;
    if (reason == StopReason::kLeaseLost) {
      // Another runner watches the job now; it keeps running.
      Finished f;
      f.run_id = run_id;
      f.signal = SIGTERM;
      f.how = "another runner watches its job now";
      ready_.push_back(f);
      runs_.erase(it);
      return;
    }
    const QueuePlace& p = it->second.place;
    if (!p.job_id.empty()) RunCommand({"scancel", p.job_id + "_" + std::to_string(p.index)});
    next_poll_ = Clock::now();
  }

  void StopAll(StopReason reason) override {
    std::vector<std::string> ids;
    for (const auto& [id, t] : runs_) ids.push_back(id);
    for (const auto& id : ids) Stop(id, reason);
  }

  // A run let go (lease lost) is active until Poll hands its end over: else the scheduler, seeing
  // nothing active, ends before it says the lease was lost.
  std::size_t Active() const override { return started_.size() + runs_.size() + ready_.size(); }
  bool OutlivesRunner() const override { return true; }
  bool LimitsTime() const override { return true; }
  std::map<std::string, QueuePlace> QueueChanges() override {
    std::map<std::string, QueuePlace> c;
    c.swap(changes_);
    return c;
  }

 private:
  struct Tracked {
    Launch launch;
    QueuePlace place;
  };

  // Looks for the array job of `place` by its job name and script (squeue --name). True once
  // squeue has answered: place.job_id is then the job's id, or "" if there is no such job
  // (never submitted, or ended long ago: its run directory decides).
  static bool FindJob(QueuePlace& place) {
    if (place.name.empty()) return true;
    const CommandResult r =
        RunCommand({"squeue", "--noheader", "--states=all", "--name=" + place.name, "--format=%F|%o"});
    if (r.code != 0) return false;
    std::istringstream lines(r.out);
    std::string line;
    while (std::getline(lines, line)) {
      const auto bar = line.find('|');
      if (bar != std::string::npos && line.substr(bar + 1) == place.script) place.job_id = line.substr(0, bar);
    }
    return true;
  }

  // Every squeue that changes nothing doubles the wait, up to 12 times the first.
  void Backoff(bool changed) {
    interval_ = changed ? s_.options.poll_interval : std::min(interval_ * 2, s_.options.poll_interval * 12);
    next_poll_ = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(interval_));
  }

  SlurmSettings s_;
  std::vector<Launch> started_;
  std::vector<Prepared> prepared_;
  std::map<std::string, Tracked> runs_;  // placed: about to be submitted, queued or running
  std::vector<Finished> ready_;          // ended without the queue's word (lease lost)
  std::map<std::string, QueuePlace> changes_;
  std::set<std::string> unfound_;  // attached runs whose job id is still to be found by name
  double interval_;
  Clock::time_point next_poll_{};
};

}  // namespace

Finished SlurmTaskEnd(const std::string& run_id, const std::string& run_dir, const QueuePlace& place,
                      const std::string& state, double time_limit, const std::string& slurm_time) {
  Finished f;
  f.run_id = run_id;
  const fs::path dir = run_dir;
  const std::string task = place.job_id.empty() ? "of " + place.name : place.job_id + "_" + std::to_string(place.index);
  std::optional<TaskRecord> record = ParseTaskRecord(ReadText(dir / rundir::kSlurmTaskFile));
  if (record && (place.job_id.empty() || record->job != task)) record.reset();  // an earlier attempt's
  if (record && record->started_at > 0) {
    f.wall_s = std::max(0.0, (record->ended_at > 0 ? record->ended_at : NowSeconds()) - record->started_at);
  }
  if (rundir::IsDone(dir)) return f;  // the scheduler ingests it
  const std::string slurm_log = TailOfFile(fs::path(place.dir) / "logs" / (task + ".out"), 10);
  const std::string where = "Slurm task " + task + (state.empty() ? "" : " " + state);
  const std::string log_note = slurm_log.empty() ? "" : "\n--- Slurm's log of the task ---\n" + slurm_log;
  // Slurm's own verdicts first: an engine it killed for memory or time records only a signal.
  if (state == "OUT_OF_MEMORY") {
    f.exit_code = 1;
    f.how = where + ": the engine ran out of memory (ask for more, e.g. --sbatch-arg=--mem-per-cpu=4G)" + log_note;
    return f;
  }
  if (!state.empty() && FateOf(state) == TaskFate::kTimedOut) {
    f.timed_out = true;
    f.exit_code = 1;
    f.how = where + ": Slurm's time limit for the task ran out" +
            (slurm_time.empty() ? "" : " (--time " + slurm_time + ")") +
            "; with --retries it continues from its checkpoint" + log_note;
    return f;
  }
  if (record && record->exit_code) {
    f.exit_code = *record->exit_code;
    if (EndedByTimeLimit(*record, time_limit)) {
      f.timed_out = true;
    } else if (f.exit_code > 128 && f.exit_code < 128 + 65) {
      f.exit_code = 0;
      f.signal = *record->exit_code - 128;
      f.how = where + ": engine killed by signal " + std::to_string(f.signal) + "; it continues from its checkpoint";
    } else if (f.exit_code != 0) {
      f.how = where + ": engine exited with status " + std::to_string(f.exit_code);
    }
    return f;
  }
  const TaskFate fate = state.empty() ? TaskFate::kLost : FateOf(state);
  switch (fate) {
    case TaskFate::kCompleted: return f;  // exit 0 without DONE: the scheduler says so
    case TaskFate::kFailed:
      f.exit_code = 1;
      f.how = where + (record ? " while its engine ran" : " before its engine started") + log_note;
      return f;
    default:
      f.signal = SIGTERM;
      f.how = (state.empty() ? "Slurm task " + task + " left the queue" : where) +
              (record ? " while its engine ran" : " before its engine started") + "; it continues from its checkpoint" +
              log_note;
      return f;
  }
}

std::optional<std::vector<QueueEntry>> QueryQueue(const std::set<std::string>& job_ids, std::string* error) {
  if (job_ids.empty()) return std::vector<QueueEntry>{};
  std::string list;
  for (const auto& id : job_ids) list += (list.empty() ? "" : ",") + id;
  const CommandResult r = RunCommand(
      {"squeue", "--noheader", "--array", "--states=all", "--jobs=" + list, std::string("--format=") + kSqueueFormat});
  // squeue fails when it knows none of the jobs any more: they all left the queue.
  if (r.code != 0 && r.err.find("Invalid job id") == std::string::npos) {
    if (error) *error = LastLine(r);
    return std::nullopt;
  }
  return ParseSqueue(r.code == 0 ? r.out : "");
}

int QueryMaxArraySize() {
  const CommandResult r = RunCommand({"scontrol", "show", "config"});
  if (r.code != 0) throw std::runtime_error("scontrol show config failed: " + LastLine(r));
  return ParseMaxArraySize(r.out);
}

std::vector<PlannedArray> PlanSlurmArrays(const std::vector<Launch>& launches, const SlurmSettings& settings) {
  std::vector<PlannedArray> out;
  const std::vector<Prepared> arrays = PlanArrays(launches, settings, false);
  for (const auto& p : arrays) {
    const std::string dependency =
        p.depends_on >= 0 ? "<job id of " + arrays[static_cast<std::size_t>(p.depends_on)].array.name + ">" : "";
    out.push_back({p.array, p.manifest, p.script, SbatchLine(p, dependency)});
  }
  return out;
}

std::unique_ptr<Executor> MakeSlurmExecutor(const SlurmSettings& settings) {
  return std::make_unique<SlurmExecutor>(settings);
}

namespace {
class SlurmQueue : public BatchQueue {
 public:
  const char* Name() const override { return "Slurm"; }
  const char* QueryTool() const override { return "squeue"; }
  TaskFate FateOf(const std::string& state) const override { return runner::FateOf(state); }
  std::optional<std::vector<QueueEntry>> Query(const std::set<std::string>& job_ids,
                                               std::string* error) const override {
    return QueryQueue(job_ids, error);
  }
  // The time limit the task ran under is in its script; 124 from `timeout` says it was hit.
  Finished TaskEnd(const std::string& run_id, const std::string& run_dir, const QueuePlace& place,
                   const std::string& state) const override {
    return SlurmTaskEnd(run_id, run_dir, place, state, std::numeric_limits<double>::infinity(), "");
  }
};
}  // namespace

const BatchQueue& DefaultBatchQueue() {
  static const SlurmQueue kQueue;
  return kQueue;
}

namespace {

using cli::UsageError;
using nlohmann::json;

class SlurmSetup : public ExecutorSetup {
 public:
  SlurmSetup(SlurmSettings settings, bool dry_run) : settings_(std::move(settings)), dry_run_(dry_run) {}

  void Prepare(Store& store, CampaignRunOptions& options, std::ostream& out) override {
    if (const auto campaign = LoadCampaign(store)) settings_.campaign = campaign->name;
    options.threads_per_run = settings_.options.cpus_per_run;
    if (!settings_.options.time.empty() || settings_.time_limit > 0) return;
    // Each array's --time from the estimate of its longest run, with a margin.
    const CampaignEstimate e = EstimateRuns(RunsLeft(store), &store, options.exe_dir, 1, true,
                                            [&](const std::string& line) { out << line << std::endl; });
    if (e.calibration.Valid())
      for (const auto& [id, run] : e.runs) settings_.estimate_s[id] = run.core_s_high;
  }

  // The arrays and scripts `campaign run --executor slurm` would submit; nothing is written.
  std::optional<int> DryRun(Store& store, const CampaignRunOptions& o, std::ostream& out) override {
    if (!dry_run_) return std::nullopt;
    RunFilter filter;
    if (const auto campaign = LoadCampaign(store); campaign && !o.only.empty()) {
      try {
        filter = ResolveFilters(o.only, *campaign, LoadRuns(store, true));
      } catch (const FilterError& e) {
        throw UsageError(e.what());
      }
    }
    std::string size_note;
    try {
      settings_.max_array_size = QueryMaxArraySize();
    } catch (const std::exception& e) {
      settings_.max_array_size = 1001;
      size_note = " (Slurm's default; " + std::string(e.what()) + ")";
    }
    std::vector<Launch> launches;
    for (const auto& r : LoadRuns(store, true)) {
      if (!Runnable(r.state)) continue;
      if ((o.engine == "native" || o.engine == "liggghts" || o.engine == "lammps") && r.engine != o.engine) continue;
      if (!filter.Matches(r)) continue;
      Launch l;
      l.run_id = r.run_id;
      l.argv = {o.engine.find('/') != std::string::npos ? o.engine
                                                        : (fs::path(o.exe_dir) / EngineProgram(r.engine)).string()};
      l.engine = r.engine;
      l.run_dir = r.run_dir;
      l.place = QueuePlace{r.job_dir, r.job_script, r.job_name, r.job_index, r.job_id, r.job_state};
      launches.push_back(l);
    }
    const auto arrays = PlanSlurmArrays(launches, settings_);
    out << "campaign run --executor slurm --dry-run: " << launches.size() << " runs in " << arrays.size()
        << " array(s); MaxArraySize " << settings_.max_array_size << size_note << "; nothing is submitted\n";
    for (const auto& p : arrays) {
      out << "\n== " << p.sbatch << "\n";
      if (p.manifest.empty()) {
        out << "-- resubmits indices " << p.array.array << " of " << (fs::path(p.array.dir) / "manifest.tsv").string()
            << "\n";
      } else {
        out << "-- " << (fs::path(p.array.dir) / "manifest.tsv").string() << " (" << p.array.runs.size() << " runs)\n";
        std::istringstream lines(p.manifest);
        std::string line;
        int shown = 0;
        while (std::getline(lines, line)) {
          if (++shown <= 11) out << line << "\n";
        }
        if (shown > 11) out << "... (" << shown - 11 << " more)\n";
      }
      out << "-- " << p.array.script << "\n" << p.script;
    }
    return 0;
  }

  std::unique_ptr<Executor> Make(const CampaignRunOptions&) const override { return MakeSlurmExecutor(settings_); }

 private:
  SlurmSettings settings_;
  bool dry_run_;
};

// Slurm's options from the spec's block, then the flags.
std::unique_ptr<ExecutorSetup> SetUpSlurm(const cli::Args& a, const json* block, const std::string& db,
                                          const CampaignRunOptions& o) {
  SlurmSettings settings;
  SlurmOptions& so = settings.options;
  if (block) ParseExecutorBlock(*block, "/executor", so);
  if (a.Has("partition")) so.partition = a.Get("partition", "");
  if (a.Has("account")) so.account = a.Get("account", "");
  if (a.Has("time")) {
    so.time = a.Get("time", "");
    if (!IsSlurmTime(so.time)) {
      throw UsageError("--time: must be a Slurm time such as 30, 4:00:00 or 1-12:00:00 (got \"" + so.time + "\")");
    }
  }
  so.cpus_per_run = a.Integer("cpus-per-run", so.cpus_per_run, 1);
  so.array_max = a.Integer("array-max", so.array_max, 0);
  so.poll_interval = a.Number("poll-interval", so.poll_interval);
  if (!(so.poll_interval > 0))
    throw UsageError("--poll-interval: must be > 0 (got \"" + a.Get("poll-interval", "") + "\")");
  if (a.Has("sbatch-arg")) {
    so.sbatch_args.clear();
    for (const auto& arg : a.All("sbatch-arg")) {
      if (arg.rfind("-", 0) != 0 || arg.find_first_of("\n\r") != std::string::npos) {
        throw UsageError("--sbatch-arg: must be one sbatch option such as --sbatch-arg=--qos=long (got \"" + arg +
                         "\")");
      }
      so.sbatch_args.push_back(arg);
    }
  }
  settings.root = (cli::DbDir(db) / "slurm").string();
  settings.time_limit = o.time_limit;
  return std::make_unique<SlurmSetup>(std::move(settings), a.Has("dry-run"));
}

}  // namespace

ExecutorRow SlurmExecutorRow() {
  return {"slurm",
          "submit the runs as Slurm job arrays and watch them (docs/slurm.md)",
          {{"partition", true},
           {"time", true},
           {"cpus-per-run", true},
           {"array-max", true},
           {"account", true},
           {"sbatch-arg", true},
           {"poll-interval", true},
           {"dry-run", false},
           {"detach", false}},
          "Slurm (docs/slurm.md; defaults from the spec's \"executor\" block):\n"
          "  --partition P, --account A, --time T   sbatch's (T in Slurm's format, e.g. 4:00:00; default\n"
          "                       from --time-limit, which counts from each task's start)\n"
          "  --cpus-per-run C     cores per run: native threads, or LIGGGHTS MPI ranks (srun) (default 1)\n"
          "  --array-max K        at most K tasks of the campaign at once (%K; default: no limit)\n"
          "  --sbatch-arg ARG     one more sbatch option, e.g. --sbatch-arg=--qos=long (repeatable)\n"
          "  --poll-interval S    seconds between squeue calls at first, backing off to 12 S (default 5)\n"
          "  --dry-run            print the manifests and batch scripts; submit nothing\n"
          "  --detach             submit and exit; campaign status, campaign scan and a later campaign run\n"
          "                       --executor slurm follow the jobs\n",
          SetUpSlurm};
}

}  // namespace granary::runner
