// `campaign run`: see run.h; flags in docs/cli.md, Slurm in docs/slurm.md.
#include "runner/cli/run.h"

#include "runner/calibration.h"

#include <signal.h>
#include <unistd.h>

#include <csignal>
#include <thread>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "runner/campaign_spec.h"
#include "runner/campaign_db.h"
#include <cstdlib>
#include "runner/cli/console_observer.h"
#include "runner/cli/replicas.h"
#include "runner/slurm.h"

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char kRunHelp[] =
    "usage: campaign run [--db FILE] [--jobs N] [--engine E] [--only FILTER] [--threads-per-run T]\n"
    "                    [--time-limit S] [--retries K] [--rerun-lost]\n"
    "       campaign run --executor slurm [--partition P] [--time T] [--cpus-per-run C] [--array-max K]\n"
    "                    [--account A] [--sbatch-arg ARG]... [--poll-interval S] [--dry-run] [--detach] ...\n"
    "Run every planned, interrupted or failed run, N at a time, each as an engine subprocess on\n"
    "its run directory. Safe to repeat after a crash or kill: done runs are kept, interrupted ones\n"
    "continue from their checkpoint, and two runners on one database never run the same run.\n"
    "  --jobs N             concurrent runs (default: number of cores)\n"
    "  --engine E           native | liggghts | lammps: only runs of that engine; a path: use that executable\n"
    "  --only FILTER        a run-id prefix, or POINTER=VALUE, e.g. /silo/base_outlets/0/width=10\n"
    "                       (an axis' short name as the report prints it will do: W=10, D_b=1.5;\n"
    "                       so will a derived axis of the spec's /axes, or a short name that ends\n"
    "                       one sweep axis: width=10); repeat it:\n"
    "                       values of one parameter are alternatives, different parameters all hold\n"
    "  --threads-per-run T  passed to the engine as --threads (default 1)\n"
    "  --time-limit S       wall seconds per run; a run over it is stopped and marked failed\n"
    "  --retries K          extra attempts per run in this invocation (default 1)\n"
    "  --rerun-lost         run again the done runs whose run directory was deleted\n"
    "Slurm (docs/slurm.md; defaults from the spec's \"executor\" block):\n"
    "  --executor E         local (default) or slurm: submit the runs as job arrays and watch them\n"
    "  --partition P, --account A, --time T   sbatch's (T in Slurm's format, e.g. 4:00:00; default\n"
    "                       from --time-limit, which counts from each task's start)\n"
    "  --cpus-per-run C     cores per run: native threads, or LIGGGHTS MPI ranks (srun) (default 1)\n"
    "  --array-max K        at most K tasks of the campaign at once (%K; default: no limit)\n"
    "  --sbatch-arg ARG     one more sbatch option, e.g. --sbatch-arg=--qos=long (repeatable)\n"
    "  --poll-interval S    seconds between squeue calls at first, backing off to 12 S (default 5)\n"
    "  --dry-run            print the manifests and batch scripts; submit nothing\n"
    "  --detach             submit and exit; campaign status, campaign scan and a later campaign run\n"
    "                       --executor slurm follow the jobs\n"
    "Exit: 0 all ran (or submitted, with --detach), 1 some runs failed, 2 usage error, 3 storage\n"
    "error (database or run directories: full disk, unwritable), 130 interrupted (Ctrl-C / SIGTERM;\n"
    "Slurm jobs keep running).\n";

volatile std::sig_atomic_t g_stop = 0;
extern "C" void RunnerOnStopSignal(int) { g_stop = 1; }

}  // namespace

std::string ExeDir() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ec ? "." : self.parent_path().string();
}

// The flags `run` and `compare` share: --jobs, --threads-per-run, --time-limit, --retries.
RunOptions RunOptionsFrom(const Args& a) {
  RunOptions o;
  o.jobs = a.integer("jobs", static_cast<int>(std::max(1u, std::thread::hardware_concurrency())), 1);
  o.threads_per_run = a.integer("threads-per-run", 1, 1);
  o.time_limit = a.number("time-limit", 0);
  if (o.time_limit < 0) throw UsageError("--time-limit: must be >= 0 (got \"" + a.get("time-limit", "") + "\")");
  o.retries = a.integer("retries", 1, 0);
  o.exe_dir = ExeDir();
  o.heartbeat_interval = std::min(o.heartbeat_interval, lease_stale_seconds() / 5);
  return o;
}

namespace {

// The executor `campaign run` uses: --executor, else the spec's "executor" block, else local;
// Slurm's options from the block, then the flags.
struct ExecutorChoice {
  bool slurm = false;
  SlurmSettings settings;
};

ExecutorChoice ChooseExecutor(const Args& a, const json& spec, const std::string& db, const RunOptions& o) {
  ExecutorChoice c;
  std::string type = "local";
  if (spec.is_object() && spec.contains("executor")) type = parse_executor_block(spec["executor"], "/executor", c.settings.options);
  if (a.has("executor")) {
    type = a.get("executor", "");
    if (type != "local" && type != "slurm") throw UsageError("--executor: must be local or slurm (got \"" + type + "\")");
  }
  c.slurm = type == "slurm";
  const std::vector<std::string> slurm_only = {"partition", "time", "cpus-per-run", "array-max", "account", "sbatch-arg",
                                               "poll-interval", "dry-run", "detach"};
  if (!c.slurm) {
    for (const auto& f : slurm_only) {
      if (a.has(f)) throw UsageError("--" + f + ": only with --executor slurm (or a spec whose executor is slurm)");
    }
    return c;
  }
  if (a.has("jobs")) throw UsageError("--jobs: not with --executor slurm (the queue runs them; --array-max K throttles)");
  if (a.has("threads-per-run")) throw UsageError("--threads-per-run: not with --executor slurm (use --cpus-per-run)");
  SlurmOptions& so = c.settings.options;
  if (a.has("partition")) so.partition = a.get("partition", "");
  if (a.has("account")) so.account = a.get("account", "");
  if (a.has("time")) {
    so.time = a.get("time", "");
    if (!is_slurm_time(so.time)) {
      throw UsageError("--time: must be a Slurm time such as 30, 4:00:00 or 1-12:00:00 (got \"" + so.time + "\")");
    }
  }
  so.cpus_per_run = a.integer("cpus-per-run", so.cpus_per_run, 1);
  so.array_max = a.integer("array-max", so.array_max, 0);
  so.poll_interval = a.number("poll-interval", so.poll_interval);
  if (!(so.poll_interval > 0)) throw UsageError("--poll-interval: must be > 0 (got \"" + a.get("poll-interval", "") + "\")");
  if (a.has("sbatch-arg")) {
    so.sbatch_args.clear();
    for (const auto& arg : a.all("sbatch-arg")) {
      if (arg.rfind("-", 0) != 0 || arg.find_first_of("\n\r") != std::string::npos) {
        throw UsageError("--sbatch-arg: must be one sbatch option such as --sbatch-arg=--qos=long (got \"" + arg + "\")");
      }
      so.sbatch_args.push_back(arg);
    }
  }
  c.settings.root = (DbDir(db) / "slurm").string();
  c.settings.time_limit = o.time_limit;
  return c;
}

// The arrays and scripts `campaign run --executor slurm` would submit; nothing is written.
int DryRun(const std::string& db, const RunOptions& o, ExecutorChoice& c, std::ostream& out) {
  const auto opened = OpenCampaignDb(db, "run");
  Store& store = *opened;
  RunFilter filter;
  if (const auto campaign = load_campaign(store); campaign && !o.only.empty()) {
    try {
      filter = resolve_filters(o.only, *campaign, load_runs(store, true));
    } catch (const FilterError& e) {
      throw UsageError(e.what());
    }
  }
  std::string size_note;
  try {
    c.settings.max_array_size = query_max_array_size();
  } catch (const std::exception& e) {
    c.settings.max_array_size = 1001;
    size_note = " (Slurm's default; " + std::string(e.what()) + ")";
  }
  std::vector<Launch> launches;
  for (const auto& r : load_runs(store, true)) {
    if (!runnable(r.state)) continue;
    if ((o.engine == "native" || o.engine == "liggghts" || o.engine == "lammps") && r.engine != o.engine) continue;
    if (!filter.matches(r)) continue;
    Launch l;
    l.run_id = r.run_id;
    l.argv = {o.engine.find('/') != std::string::npos
                  ? o.engine
                  : (fs::path(o.exe_dir) / engine_program(r.engine)).string()};
    l.engine = r.engine;
    l.run_dir = r.run_dir;
    l.place = QueuePlace{r.job_dir, r.job_script, r.job_name, r.job_index, r.job_id, r.job_state};
    launches.push_back(l);
  }
  const auto arrays = plan_slurm_arrays(launches, c.settings);
  out << "campaign run --executor slurm --dry-run: " << launches.size() << " runs in " << arrays.size()
      << " array(s); MaxArraySize " << c.settings.max_array_size << size_note << "; nothing is submitted\n";
  for (const auto& p : arrays) {
    out << "\n== " << p.sbatch << "\n";
    if (p.manifest.empty()) {
      out << "-- resubmits indices " << p.array.array << " of " << (fs::path(p.array.dir) / "manifest.tsv").string() << "\n";
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

int Run(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "run");
  if (!a.positional.empty()) throw UsageError("campaign run: unexpected argument \"" + a.positional[0] + "\"");
  RunOptions o = RunOptionsFrom(a);
  o.engine = a.get("engine", "");
  if (!o.engine.empty() && o.engine != "native" && o.engine != "liggghts" && o.engine != "lammps" &&
      o.engine.find('/') == std::string::npos) {
    throw UsageError("--engine: must be native, liggghts, lammps or a path to an engine executable (got \"" + o.engine +
                     "\")");
  }
  o.only = a.all("only");
  const std::string db = DbPath(a);
  json spec;
  std::string name;
  {
    const auto opened = OpenCampaignDb(db, "run");
    const auto campaign = load_campaign(*opened);
    if (!campaign) throw UsageError("campaign run: " + db + " holds no campaign (run campaign plan first)");
    spec = campaign->spec;
    name = campaign->name;
    // The bed cache is part of each planned run (bed/cache_file in run.json): a
    // GRANARY_CACHE_DIR set now that differs is not used, and saying so beats beds appearing
    // elsewhere without a word.
    if (const char* env = std::getenv("GRANARY_CACHE_DIR"); env && *env) {
      for (const RunRow& r : load_runs(*opened, true)) {
        if (r.state == RunState::kDone || r.state == RunState::kRetired) continue;
        const json* file = r.params.contains("bed") ? &r.params["bed"] : nullptr;
        if (!file || !file->contains("cache_file") || !(*file)["cache_file"].is_string()) continue;
        const fs::path planned = fs::path((*file)["cache_file"].get<std::string>()).parent_path();
        if (fs::weakly_canonical(planned) != fs::weakly_canonical(env))
          out << "note: GRANARY_CACHE_DIR=" << env << " is not used: the plan fixed the prepared beds' directory at "
              << planned.string() << " (bed/cache_file of each planned run; campaign plan stores it)\n";
        break;
      }
    }
  }
  ExecutorChoice c = ChooseExecutor(a, spec, db, o);
  c.settings.campaign = name;
  if (c.slurm) o.threads_per_run = c.settings.options.cpus_per_run;
  if (c.slurm && c.settings.options.time.empty() && c.settings.time_limit <= 0) {
    // Each array's --time from the estimate of its longest run, with a margin.
    const auto opened = OpenCampaignDb(db, "run");
    const CampaignEstimate e = estimate_runs(runs_left(*opened), opened.get(), ExeDir(), 1, true,
                                             [&](const std::string& line) { out << line << std::endl; });
    if (e.calibration.valid())
      for (const auto& [id, run] : e.runs) c.settings.estimate_s[id] = run.core_s_high;
  }
  o.detach = a.has("detach");
  o.rerun_lost = a.has("rerun-lost");
  if (a.has("dry-run")) return DryRun(db, o, c, out);
  return RunAll(db, o, out, c.slurm ? &c.settings : nullptr);
}

}  // namespace

// Runs the campaign in `db` with a console display; Ctrl-C / SIGTERM stop it cleanly. With
// `slurm`, the runs go to Slurm.
int RunAll(const std::string& db, const RunOptions& options, std::ostream& out, const SlurmSettings* slurm) {
  const auto opened = OpenCampaignDb(db, "run");
  Store& store = *opened;
  const auto campaign = load_campaign(store);
  if (!campaign) throw UsageError("campaign run: " + db + " holds no campaign (run campaign plan first)");
  RunOptions o = options;
  if (!o.only.empty()) {
    try {
      o.only = resolve_filters(o.only, *campaign, load_runs(store, true)).texts();
    } catch (const FilterError& e) {
      throw UsageError(e.what());
    }
  }

  struct sigaction sa {};
  sa.sa_handler = RunnerOnStopSignal;
  sigemptyset(&sa.sa_mask);
  struct sigaction old_int {}, old_term {};
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);
  g_stop = 0;
  std::set<std::string> reported;  // adaptive replicas: points whose verdict was said
  if (CampaignSpec::from_json(campaign->spec).replica_rule.adaptive())
    o.add_runs = [&store, &reported](RunObserver& observer) { return AddReplicas(store, observer, reported); };
  auto executor = slurm ? make_slurm_executor(*slurm) : make_local_executor(o.jobs);
  const auto observer = MakeConsoleObserver(out, &out == &std::cout && isatty(STDOUT_FILENO));
  ExitCode code;
  try {
    code = run_campaign(store, o, *executor, *observer, &g_stop);
  } catch (...) {
    sigaction(SIGINT, &old_int, nullptr);
    sigaction(SIGTERM, &old_term, nullptr);
    throw;
  }
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  return static_cast<int>(code);
}

Verb RunVerb() {
  return {"run", "run what is not done (resumable, leases, N at a time)", kRunHelp, Run,
          {{"db", true}, {"jobs", true}, {"engine", true}, {"only", true}, {"threads-per-run", true}, {"time-limit", true}, {"retries", true}, {"rerun-lost", false},
           {"executor", true}, {"partition", true}, {"time", true}, {"cpus-per-run", true}, {"array-max", true},
           {"account", true}, {"sbatch-arg", true}, {"poll-interval", true}, {"dry-run", false}, {"detach", false},
           {"help", false}}};
}

}  // namespace granary::runner::cli
