// `campaign run`: see run.h; flags in docs/cli.md, the executors in executors.h.
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
#include "runner/executors.h"

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char kRunHelpHead[] =
    "usage: campaign run [--db FILE] [--jobs N] [--engine E] [--only FILTER] [--threads-per-run T]\n"
    "                    [--time-limit S] [--retries K] [--rerun-lost] [--executor E] [E's flags]\n"
    "Run every planned, interrupted or failed run, N at a time (--jobs), each as an engine subprocess on\n"
    "its run directory. Safe to repeat after a crash or kill: done runs are kept, interrupted ones\n"
    "continue from their checkpoint, and two runners on one database never run the same run.\n"
    "  --engine E           native | liggghts | lammps: only runs of that engine; a path: use that executable\n"
    "  --only FILTER        a run-id prefix, or POINTER=VALUE, e.g. /silo/base_outlets/0/width=10\n"
    "                       (an axis' short name as the report prints it will do: W=10, D_b=1.5;\n"
    "                       so will a derived axis of the spec's /axes, or a short name that ends\n"
    "                       one sweep axis: width=10); repeat it:\n"
    "                       values of one parameter are alternatives, different parameters all hold\n"
    "  --time-limit S       wall seconds per run; a run over it is stopped and marked failed\n"
    "  --retries K          extra attempts per run in this invocation (default 1)\n"
    "  --rerun-lost         run again the done runs whose run directory was deleted\n"
    "  --executor E         where the runs go (default: the spec's \"executor\" block, else the first):\n";

const char kRunHelpTail[] =
    "Exit: 0 all ran (or submitted, with --detach), 1 some runs failed, 2 usage error, 3 storage\n"
    "error (database or run directories: full disk, unwritable), 130 interrupted (Ctrl-C / SIGTERM;\n"
    "jobs in a batch queue keep running).\n";

// The help of `campaign run`: the executors and their flags from the executor table.
const char* RunHelp() {
  static const std::string kHelp = [] {
    std::string h = kRunHelpHead;
    for (const ExecutorRow& row : ExecutorRows()) {
      std::string name = "    " + std::string(row.name);
      name.resize(std::max<std::size_t>(name.size() + 1, 23), ' ');
      h += name + row.summary + "\n";
    }
    for (const ExecutorRow& row : ExecutorRows()) h += row.flags_help;
    return h + kRunHelpTail;
  }();
  return kHelp.c_str();
}

volatile std::sig_atomic_t g_stop = 0;
extern "C" void RunnerOnStopSignal(int) { g_stop = 1; }

}  // namespace

std::string ExeDir() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ec ? "." : self.parent_path().string();
}

// The flags `run` and `compare` share: --jobs, --threads-per-run, --time-limit, --retries.
CampaignRunOptions RunOptionsFrom(const Args& a) {
  CampaignRunOptions o;
  o.jobs = a.Integer("jobs", static_cast<int>(std::max(1u, std::thread::hardware_concurrency())), 1);
  o.threads_per_run = a.Integer("threads-per-run", 1, 1);
  o.time_limit = a.Number("time-limit", 0);
  if (o.time_limit < 0) throw UsageError("--time-limit: must be >= 0 (got \"" + a.Get("time-limit", "") + "\")");
  o.retries = a.Integer("retries", 1, 0);
  o.exe_dir = ExeDir();
  o.heartbeat_interval = std::min(o.heartbeat_interval, LeaseStaleSeconds() / 5);
  return o;
}

namespace {

// The executor `campaign run` uses: --executor, else the spec's "executor" block, else the
// table's first; a flag of another executor is refused.
std::unique_ptr<ExecutorSetup> ChooseExecutor(const Args& a, const json& spec, const std::string& db,
                                              const CampaignRunOptions& o) {
  const json* block = spec.is_object() && spec.contains("executor") ? &spec["executor"] : nullptr;
  const ExecutorRow* row = block ? &ExecutorOfBlock(*block, "/executor") : &ExecutorRows().front();
  if (a.Has("executor")) {
    row = FindExecutor(a.Get("executor", ""));
    if (!row)
      throw UsageError("--executor: must be " + ExecutorNames(false) + " (got \"" + a.Get("executor", "") + "\")");
  }
  for (const ExecutorRow& other : ExecutorRows()) {
    if (&other == row) continue;
    for (const auto& other_flag : other.flags) {
      const std::string& flag = other_flag.first;
      const bool own =
          std::any_of(row->flags.begin(), row->flags.end(), [&](const auto& f) { return f.first == flag; });
      if (!own && a.Has(flag)) {
        throw UsageError("--" + flag + ": only with --executor " + other.name + " (or a spec whose executor is " +
                         other.name + ")");
      }
    }
  }
  return row->setup(a, block, db, o);
}

int Run(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "run");
  if (!a.positional.empty()) throw UsageError("campaign run: unexpected argument \"" + a.positional[0] + "\"");
  CampaignRunOptions o = RunOptionsFrom(a);
  o.engine = a.Get("engine", "");
  if (!o.engine.empty() && o.engine != "native" && o.engine != "liggghts" && o.engine != "lammps" &&
      o.engine.find('/') == std::string::npos) {
    throw UsageError("--engine: must be native, liggghts, lammps or a path to an engine executable (got \"" + o.engine +
                     "\")");
  }
  o.only = a.All("only");
  const std::string db = DbPath(a);
  json spec;
  std::string name;
  {
    const auto opened = OpenCampaignDb(db, "run");
    const auto campaign = LoadCampaign(*opened);
    if (!campaign) throw UsageError("campaign run: " + db + " holds no campaign (run campaign plan first)");
    spec = campaign->spec;
    name = campaign->name;
    // The bed cache is part of each planned run (bed/cache_file in run.json): a
    // GRANARY_CACHE_DIR set now that differs is not used, and saying so beats beds appearing
    // elsewhere without a word.
    if (const char* env = std::getenv("GRANARY_CACHE_DIR"); env && *env) {
      for (const RunRow& r : LoadRuns(*opened, true)) {
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
  const std::unique_ptr<ExecutorSetup> setup = ChooseExecutor(a, spec, db, o);
  o.detach = a.Has("detach");
  o.rerun_lost = a.Has("rerun-lost");
  {
    const auto opened = OpenCampaignDb(db, "run");
    setup->Prepare(*opened, o, out);
    if (const std::optional<int> code = setup->DryRun(*opened, o, out)) return *code;
  }
  return RunAll(db, o, out, setup.get());
}

}  // namespace

int RunAll(const std::string& db, const CampaignRunOptions& options, std::ostream& out, const ExecutorSetup* setup) {
  const auto opened = OpenCampaignDb(db, "run");
  Store& store = *opened;
  const auto campaign = LoadCampaign(store);
  if (!campaign) throw UsageError("campaign run: " + db + " holds no campaign (run campaign plan first)");
  CampaignRunOptions o = options;
  if (!o.only.empty()) {
    try {
      o.only = ResolveFilters(o.only, *campaign, LoadRuns(store, true)).Texts();
    } catch (const FilterError& e) {
      throw UsageError(e.what());
    }
  }

  struct sigaction sa {};
  sa.sa_handler = RunnerOnStopSignal;
  sigemptyset(&sa.sa_mask);
  struct sigaction old_int {
  }, old_term{};
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);
  g_stop = 0;
  std::set<std::string> reported;  // adaptive replicas: points whose verdict was said
  if (CampaignSpec::FromJson(campaign->spec).replica_rule.Adaptive())
    o.add_runs = [&store, &reported](RunObserver& observer) { return AddReplicas(store, observer, reported); };
  auto executor = setup ? setup->Make(o) : MakeLocalExecutor(o.jobs);
  const auto observer =
      MakeConsoleObserver(out, &out == &std::cout && isatty(STDOUT_FILENO), ShortAxisNames(campaign->spec));
  ExitCode code;
  try {
    code = RunCampaign(store, o, *executor, *observer, &g_stop);
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
  std::vector<FlagSpec> flags = {{"db", true},      {"engine", true},      {"only", true},     {"time-limit", true},
                                 {"retries", true}, {"rerun-lost", false}, {"executor", true}, {"help", false}};
  for (const ExecutorRow& row : ExecutorRows())
    for (const auto& row_flag : row.flags)
      if (std::none_of(flags.begin(), flags.end(), [&](const FlagSpec& f) { return f.name == row_flag.first; }))
        flags.push_back({row_flag.first, row_flag.second});
  return {"run", "run what is not done (resumable, leases, N at a time)", RunHelp(), Run, flags};
}

}  // namespace granary::runner::cli
