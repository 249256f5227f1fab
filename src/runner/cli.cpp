// See cli.h. Flags and exit codes are documented in docs/cli.md.
#include "runner/cli.h"
#include "rundir/version.h"

#include <signal.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <optional>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <memory>
#include <sstream>
#include <thread>

#include "rundir/progress.h"
#include "runner/calibration.h"
#include "runner/campaign_db.h"
#include "runner/campaign_spec.h"
#include "runner/inspect.h"
#include "runner/run_filter.h"
#include "runner/scan.h"
#include "runner/scheduler.h"
#include "runner/slurm.h"
#include "runner/slurm_executor.h"
#include "runner/util.h"
#ifdef GRANARY_HAVE_ANALYSIS
#include "analysis/cg_run.h"
#include "analysis/export.h"
#include "analysis/fields_analysis.h"
#include "analysis/registry.h"
#include "analysis/report.h"
#include "rundir/contacts.h"
#include "rundir/frames.h"
#endif
#include "rundir/files.h"
#ifdef GRANARY_HAVE_RENDER
#include "render/run_picture.h"
#endif

namespace granary::runner {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parsed flags of one verb: --name value, --name=value, or --name for booleans. A flag given
// twice keeps both values (--only); get() gives the last.
struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::vector<std::string>> flags;
  bool has(const std::string& f) const { return flags.count(f) > 0; }
  std::string get(const std::string& f, const std::string& def) const {
    auto it = flags.find(f);
    return it == flags.end() ? def : it->second.back();
  }
  std::vector<std::string> all(const std::string& f) const {
    auto it = flags.find(f);
    return it == flags.end() ? std::vector<std::string>{} : it->second;
  }
  double number(const std::string& f, double def) const {
    if (!has(f)) return def;
    const std::string& v = flags.at(f).back();
    try {
      std::size_t used = 0;
      const double x = std::stod(v, &used);
      if (used != v.size() || !std::isfinite(x)) throw std::invalid_argument(v);
      return x;
    } catch (const std::exception&) {
      throw UsageError("--" + f + ": must be a number (got \"" + v + "\")");
    }
  }
  int integer(const std::string& f, int def, int min) const {
    const double x = number(f, def);
    if (x != std::floor(x) || x < min || x > 1e6) {
      throw UsageError("--" + f + ": must be an integer >= " + std::to_string(min) + " (got \"" + get(f, "") + "\")");
    }
    return static_cast<int>(x);
  }
};

struct FlagSpec {
  std::string name;
  bool takes_value;
};

Args Parse(const std::vector<std::string>& argv, const std::vector<FlagSpec>& known, const std::string& verb) {
  Args a;
  std::vector<std::string> names;
  for (const auto& k : known) names.push_back(k.name);
  for (std::size_t i = 0; i < argv.size(); ++i) {
    const std::string& s = argv[i];
    if (s.rfind("--", 0) != 0 || s == "--") {
      a.positional.push_back(s);
      continue;
    }
    std::string name = s.substr(2);
    std::string value;
    bool inline_value = false;
    if (auto eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
      inline_value = true;
    }
    auto it = std::find_if(known.begin(), known.end(), [&](const FlagSpec& f) { return f.name == name; });
    if (it == known.end()) {
      const std::string best = nearest(name, names);
      throw UsageError("campaign " + verb + ": unknown flag --" + name +
                       (best.empty() ? "" : "; did you mean --" + best + "?") + " (see campaign " + verb + " --help)");
    }
    if (it->takes_value && !inline_value) {
      if (i + 1 >= argv.size()) throw UsageError("--" + name + ": needs a value");
      value = argv[++i];
    }
    a.flags[name].push_back(value);
  }
  return a;
}

// The flags of a verb, from the verb table at the end of this file.
const std::vector<FlagSpec>& FlagsOf(const std::string& verb);
Args Parse(const std::vector<std::string>& argv, const std::string& verb) { return Parse(argv, FlagsOf(verb), verb); }

std::string DbPath(const Args& a) { return a.get("db", "granary.db"); }

fs::path DbDir(const std::string& db) {
  const fs::path p = fs::absolute(db).parent_path();
  return p;
}

std::string Duration(double s) {
  if (!(s >= 0) || !std::isfinite(s)) return "?";
  const long t = std::lround(s);
  std::ostringstream o;
  if (t >= 3600) o << t / 3600 << "h" << std::setw(2) << std::setfill('0') << (t % 3600) / 60 << "m";
  else if (t >= 60) o << t / 60 << "m" << std::setw(2) << std::setfill('0') << t % 60 << "s";
  else o << t << "s";
  return o.str();
}

std::string CompactPoint(const json& point) {
  std::string out;
  for (const auto& [key, value] : point.items()) {
    if (!out.empty()) out += " ";
    const auto slash = key.rfind('/');
    std::string label = key.substr(slash + 1);
    // "/silo/base_outlets/0/width" -> "base_outlets/0/width" is clearer than "width".
    if (!label.empty() && std::isdigit(static_cast<unsigned char>(label[0]))) label = key;
    else if (slash != std::string::npos && slash > 0) {
      const auto prev = key.rfind('/', slash - 1);
      const std::string parent = key.substr(prev + 1, slash - prev - 1);
      if (!parent.empty() && std::isdigit(static_cast<unsigned char>(parent[0]))) label = key.substr(1);
    }
    out += label + "=" + value.dump();
  }
  return out.empty() ? "-" : out;
}

std::string Bar(double fraction, int width) {
  const int filled = static_cast<int>(std::lround(std::clamp(fraction, 0.0, 1.0) * width));
  std::string bar(static_cast<std::size_t>(width) + 2, '.');
  bar.front() = '[';
  bar.back() = ']';
  for (int i = 0; i < filled; ++i) bar[static_cast<std::size_t>(i) + 1] = '#';
  return bar;
}

// The database of an existing campaign (only `plan` and `compare` create one): a missing file,
// a directory, an empty file or a file that is not a campaign database is said plainly.
std::unique_ptr<Store> OpenCampaignDb(const std::string& db, const std::string& verb) {
  if (!fs::exists(db)) {
    throw UsageError("campaign " + verb + ": no database " + db + " (campaign plan SPEC --db " + db + " makes one)");
  }
  std::error_code ec;
  if (!fs::is_directory(db) && fs::file_size(db, ec) == 0 && !ec) {
    throw StoreError(SQLITE_NOTADB, "database " + db + " is empty (0 bytes): whatever campaign it held is lost (was it "
                                        "truncated, or copied while the disk was full?); plan a campaign into it again "
                                        "with campaign plan SPEC --db " + db);
  }
  try {
    return std::make_unique<Store>(db);
  } catch (const StoreError& e) {
    // Not a campaign database at all (a directory, another file): the user gave the wrong path.
    if (e.code() == SQLITE_NOTADB || fs::is_directory(db)) throw UsageError("campaign " + verb + ": " + e.what());
    throw;
  }
}

// The --only filters of a verb, resolved and checked against the campaign's runs.
RunFilter ResolveOnly(const Args& a, const CampaignRow& campaign, const std::vector<RunRow>& runs) {
  try {
    return resolve_filters(a.all("only"), campaign, runs);
  } catch (const FilterError& e) {
    throw UsageError(e.what());
  }
}

// A run's progress.json as one short line: phase, bar, percent, simulated time, exits, ETA
// (from `elapsed` wall seconds; none when elapsed <= 0).
std::string ProgressText(const json& progress, double elapsed) {
  double f = 0;
  std::string phase = "starting";
  std::ostringstream o;
  if (progress.is_object()) {
    f = std::clamp(progress.value("fraction", 0.0), 0.0, 1.0);
    phase = progress.value("phase", std::string("?"));
  }
  o << std::left << std::setw(9) << phase << " " << Bar(f, 20) << " " << std::right << std::setw(3) << std::lround(f * 100)
    << "%";
  if (progress.is_object() && progress.contains("t") && progress.contains("t_end") && progress.at("t").is_number()) {
    o << "  t " << std::fixed << std::setprecision(1) << progress.at("t").get<double>() << "/"
      << progress.at("t_end").get<double>();
    o.unsetf(std::ios::fixed);
  }
  if (progress.is_object() && progress.contains("exited") && progress.at("exited").is_number())
    o << "  " << progress.at("exited").get<long long>() << " exits";
  if (elapsed > 0) o << "  ETA " << (f > 0.01 ? Duration(elapsed * (1 - f) / f) : std::string("?"));
  return o.str();
}

std::string ExeDir();

// ---------------------------------------------------------------- plan
const char kPlanHelp[] =
    "usage: campaign plan SPEC [--db FILE] [--dry-run] [--json] [--max-runs N] [--jobs N]\n"
    "Expand the campaign spec SPEC into runs and store them in the database (default granary.db).\n"
    "Planning the same spec again changes nothing; runs no longer in an edited spec are retired\n"
    "(their results are kept), new ones are added. A raised /discharge/max_time extends the\n"
    "campaign's runs: each new run takes over its old run's directory and continues from its\n"
    "last checkpoint (the plan lists them).\n"
    "  --db FILE    database (created if missing); run directories go to <db dir>/runs/<run id>/\n"
    "  --dry-run    validate and show what would change, store nothing\n"
    "  --json       print the summary as JSON\n"
    "  --max-runs N refuse a sweep of more than N runs (default 100000), before expanding it\n"
    "  --jobs N     concurrent runs the wall-time estimate assumes (default: number of cores)\n"
    "Prints the estimated core-hours, wall time on --jobs and disk, per point and in total, and\n"
    "how they were estimated (docs/cli.md \"The estimate\"); the first plan on a machine and build\n"
    "measures the engine's speed with granary-engine bench (seconds; cached).\n";

json ReadSpecFile(const std::string& verb, const std::string& spec_path) {
  std::ifstream in(spec_path, std::ios::binary);
  if (!in) throw UsageError("campaign " + verb + ": cannot read " + spec_path);
  std::stringstream text;
  text << in.rdbuf();
  try {
    return parse_spec_text(text.str(), spec_path);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
}

std::uint64_t MaxRuns(const Args& a) {
  if (!a.has("max-runs")) return kDefaultMaxRuns;
  const std::string v = a.get("max-runs", "");
  if (v.empty() || v.size() > 18 || v.find_first_not_of("0123456789") != std::string::npos || std::stoull(v) == 0)
    throw UsageError("--max-runs: must be a positive integer (got \"" + v + "\")");
  return std::stoull(v);
}

// Validates the campaign spec `j` (read from spec_path), expands it and stores the runs.
PlanSummary PlanInto(const json& given, const std::string& spec_path, const std::string& db, bool dry_run,
                     std::uint64_t max_runs, CampaignSpec& spec, std::vector<PlannedRun>* planned = nullptr,
                     std::optional<CampaignEstimate>* estimate = nullptr, int jobs = 1) {
  json j = given;
#ifdef GRANARY_HAVE_ANALYSIS
  // Coarse-grained stress fields need contact frames: the runs write them.
  try {
    j = analysis::with_fields_output(given);
  } catch (const std::invalid_argument& e) {
    throw UsageError(spec_path + ": " + e.what());
  }
  if (j != given && estimate)
    std::cerr << spec_path << ": /report/fields asks for stress maps or force chains: the runs also write contact "
              << "frames (/base/output/contact_forces: true; the disk estimate counts them)\n";
#endif
  try {
    spec = CampaignSpec::from_json(j);
  } catch (const SpecError& e) {
    throw SpecError(e.path(), e.message() + " [" + spec_path + "]");
  }
#ifdef GRANARY_HAVE_ANALYSIS
  try {
    analysis::check_report_spec(j);
  } catch (const std::invalid_argument& e) {
    throw UsageError(spec_path + ": " + e.what());
  }
#endif
  std::vector<PlannedRun> runs;
  try {
    runs = expand(spec, default_cache_dir(), max_runs);
  } catch (const SpecError& e) {
    throw SpecError(e.path(), e.message() + " [" + spec_path + "]");
  }
  // A dry run against a database that does not exist compares with an empty one in memory:
  // it creates no file.
  if (!dry_run) {
    // plan makes the database, and its runs/ beside it, where it is told: like mkdir -p.
    std::error_code ec;
    fs::create_directories(DbDir(db), ec);
    if (ec) throw UsageError("campaign plan: cannot make the directory " + DbDir(db).string() + " for --db " + db + ": " + ec.message());
  }
  Store store(dry_run && !fs::exists(db) ? std::string(":memory:") : db);
  PlanSummary s = plan_campaign(store, spec, runs, (DbDir(db) / "runs").string(), dry_run);
  if (estimate) {
    *estimate = estimate_runs(runs, &store, ExeDir(), jobs, true, [](const std::string& line) {
      std::cerr << line << std::endl;
    });
  }
  if (planned) *planned = std::move(runs);
  return s;
}

// The estimate under the plan: totals, then one line per point.
void PrintEstimate(std::ostream& out, const CampaignEstimate& e) {
  const bool timed = e.calibration.valid();
  out << "estimate: " << (timed ? core_hours_text(e.core_s_low, e.core_s_high) : std::string("core-hours unknown"));
  if (timed) {
    out << ", wall " << Duration(e.wall_s_low);
    if (e.wall_s_high > 1.05 * e.wall_s_low) out << "-" << Duration(e.wall_s_high);
    out << " on " << e.jobs << (e.jobs == 1 ? " job" : " jobs");
  }
  out << ", disk " << bytes_text(e.bytes_low, e.bytes_high) << "\n";
  out << "  how: " << e.method << "\n";
  out << "  " << std::left << std::setw(44) << "point" << std::right << std::setw(6) << "runs" << "  " << std::left
      << std::setw(24) << "core-hours" << "disk\n";
  for (const PointEstimate& p : e.points) {
    std::string label = CompactPoint(p.point);
    if (label.empty()) label = "(base)";
    if (e.points.size() > 1 && p.engine != "native") label += " [" + p.engine + "]";
    out << "  " << std::left << std::setw(44) << label << std::right << std::setw(6) << p.runs << "  " << std::left
        << std::setw(24) << (timed ? core_hours_text(p.core_s_low, p.core_s_high) : std::string("?"))
        << bytes_text(p.bytes_low, p.bytes_high) << (p.open_end ? "  (ends at a clog or discharge: range)" : "") << "\n";
  }
  out << std::right;
}

void PrintPlan(std::ostream& out, const CampaignSpec& spec, const PlanSummary& s, bool dry_run) {
  out << "campaign " << spec.name << (dry_run ? " (dry run: nothing stored)" : "") << "\n";
  out << "  axis                                      values\n";
  for (const auto& axis : s.axes) {
    const auto& vals = s.axis_values.count(axis) ? s.axis_values.at(axis) : std::vector<json>{};
    std::string list;
    for (std::size_t i = 0; i < vals.size() && i < 8; ++i) list += (i ? ", " : "") + vals[i].dump();
    if (vals.size() > 8) list += ", ...";
    out << "  " << std::left << std::setw(40) << axis << "  " << vals.size() << ": " << list << "\n";
  }
  if (spec.engines.size() > 1) {
    std::string names;
    for (const auto& e : spec.engines) names += (names.empty() ? "" : ", ") + e;
    out << "  points " << s.points / static_cast<int>(spec.engines.size()) << " x engines " << spec.engines.size() << " ("
        << names << ") x replicas " << spec.replicas << " = " << s.total << " runs\n";
  } else {
    out << "  points " << s.points << " x replicas " << spec.replicas << " = " << s.total << " runs\n";
  }
  out << "  added " << s.added << ", unchanged " << s.unchanged << ", revived " << s.revived << ", retired "
      << s.retired << "\n";
  if (!s.extended.empty()) {
    out << "  " << (dry_run ? "would extend " : "extended ") << s.extended.size()
        << " run(s): each new run continues the old one from its last checkpoint (old -> new):\n";
    for (const auto& e : s.extended) out << "    " << e.from << " -> " << e.to << "\n";
  }
  for (const auto& [e, why] : s.not_extended)
    out << "  not extended: " << e.to << " runs from the start instead of continuing " << e.from << ": " << why << "\n";
}

json Extensions(const std::vector<PlanSummary::Extension>& list) {
  json out = json::array();
  for (const auto& e : list) out.push_back({{"from", e.from}, {"to", e.to}});
  return out;
}

int Plan(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "plan");
  if (a.positional.size() != 1) throw UsageError("campaign plan: needs exactly one SPEC file (see campaign plan --help)");
  const std::string spec_path = a.positional[0];
  CampaignSpec spec;
  std::optional<CampaignEstimate> estimate;
  const int jobs = a.integer("jobs", static_cast<int>(std::max(1u, std::thread::hardware_concurrency())), 1);
  const PlanSummary s = PlanInto(ReadSpecFile("plan", spec_path), spec_path, DbPath(a), a.has("dry-run"), MaxRuns(a), spec,
                                 nullptr, &estimate, jobs);
  if (a.has("json")) {
    json axes = json::object();
    for (const auto& [axis, values] : s.axis_values) axes[axis] = values;
    out << json{{"campaign", spec.name}, {"runs", s.total},         {"points", s.points},   {"replicas", spec.replicas},
                {"engines", spec.engines}, {"added", s.added},      {"unchanged", s.unchanged}, {"revived", s.revived},
                {"retired", s.retired},  {"axes", axes},            {"dry_run", a.has("dry-run")},
                {"extended", Extensions(s.extended)}, {"estimate", to_json(*estimate)}}
               .dump(2)
        << "\n";
    return 0;
  }
  PrintPlan(out, spec, s, a.has("dry-run"));
  PrintEstimate(out, *estimate);
  return 0;
}

// ---------------------------------------------------------------- run
const char kRunHelp[] =
    "usage: campaign run [--db FILE] [--jobs N] [--engine E] [--only FILTER] [--threads-per-run T]\n"
    "                    [--time-limit S] [--retries K] [--rerun-lost]\n"
    "       campaign run --executor slurm [--partition P] [--time T] [--cpus-per-run C] [--array-max K]\n"
    "                    [--account A] [--sbatch-arg ARG]... [--poll-interval S] [--dry-run] [--detach] ...\n"
    "Run every planned, interrupted or failed run, N at a time, each as an engine subprocess on\n"
    "its run directory. Safe to repeat after a crash or kill: done runs are kept, interrupted ones\n"
    "continue from their checkpoint, and two runners on one database never run the same run.\n"
    "  --jobs N             concurrent runs (default: number of cores)\n"
    "  --engine E           native | liggghts: only runs of that engine; a path: use that executable\n"
    "  --only FILTER        a run-id prefix, or POINTER=VALUE, e.g. /silo/base_outlets/0/width=10\n"
    "                       (a short name that ends one sweep axis will do: width=10); repeat it:\n"
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

// Columns of the terminal on stdout (80 when it cannot be asked).
int TerminalColumns() {
  struct winsize w {};
  if (ioctl(STDOUT_FILENO, TIOCGWINSZ, &w) == 0 && w.ws_col > 0) return w.ws_col;
  return 80;
}

// `line` cut to `columns` - 1 characters (UTF-8 aware), so that a drawn line never wraps: the
// display clears itself by moving up one row per line, which a wrapped line would defeat.
std::string FitColumns(const std::string& line, int columns) {
  const int max = std::max(8, columns - 1);
  int shown = 0;
  for (std::size_t i = 0; i < line.size(); ++i) {
    if ((static_cast<unsigned char>(line[i]) & 0xC0) == 0x80) continue;  // UTF-8 continuation byte
    if (++shown > max) return line.substr(0, i);
  }
  return line;
}

class ConsoleObserver : public RunObserver {
 public:
  ConsoleObserver(std::ostream& out, bool tty) : out_(out), tty_(tty) {}
  void on_begin(int total, int done, int failed) override {
    start_ = std::chrono::steady_clock::now();
    done_at_start_ = done;
    out_ << "campaign run: " << total << " runs, " << done << " done, " << failed << " failed before this run\n";
    out_.flush();
  }
  void on_event(const std::string& run_id, const std::string& state, const std::string& message) override {
    Clear();
    if (state != "running") {
      std::erase_if(active_, [&](const ActiveRun& a) { return a.run_id == run_id; });
      if (state == "done") ++done_;
    }
    std::string first = message.substr(0, message.find('\n'));
    std::string where;
    if (const auto it = points_.find(run_id); it != points_.end()) where = it->second + ": ";
    out_ << std::left << std::setw(12) << state << " " << (run_id.empty() ? "" : run_id + "  ") << where << first << "\n";
    if (state == "failed" || state == "interrupted") {
      const auto nl = message.find('\n');
      if (nl != std::string::npos) {
        std::istringstream tail(message.substr(nl + 1));
        std::string line;
        std::vector<std::string> lines;
        while (std::getline(tail, line)) lines.push_back(line);
        for (std::size_t i = lines.size() > 5 ? lines.size() - 5 : 0; i < lines.size(); ++i) out_ << "    | " << lines[i] << "\n";
      }
    }
    out_.flush();
    Draw();
  }
  void on_tick(const std::vector<ActiveRun>& active, int done, int failed, int total) override {
    active_ = active;
    for (const ActiveRun& a : active_)
      points_[a.run_id] = CompactPoint(json::parse(a.point, nullptr, false)) + " r" + std::to_string(a.replica);
    done_ = done;
    failed_ = failed;
    total_ = total;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    if (tty_) {
      Clear();
      Draw();
    } else if (elapsed - last_plain_ >= 10.0) {
      last_plain_ = elapsed;
      const int queued = Queued(active);
      out_ << "progress " << done << "/" << total << " done, " << failed << " failed, " << active.size() - queued
           << " running" << (queued > 0 ? ", " + std::to_string(queued) + " queued" : "") << ", elapsed "
           << Duration(elapsed) << ", ETA " << Eta(elapsed) << "\n";
      out_.flush();
    }
  }
  void on_end(int done, int failed, int total) override {
    Clear();
    done_ = done;
    failed_ = failed;
    total_ = total;
    out_ << "campaign run: " << done_ << "/" << total_ << " done, " << failed_ << " failed\n";
    out_.flush();
  }

 private:
  std::string Eta(double elapsed) const {
    const int finished_here = done_ - done_at_start_;
    if (finished_here <= 0) return "?";
    return Duration(elapsed / finished_here * std::max(0, total_ - done_ - failed_));
  }
  // Erases what Draw drew: the cursor goes up one row per drawn line (none wraps) and the
  // screen is cleared from there down, so the next text starts on a clean line.
  void Clear() {
    if (!tty_ || lines_ == 0) return;
    out_ << "\r\033[" << lines_ << "A\033[J";
    lines_ = 0;
  }
  void Line(const std::string& text) {
    out_ << FitColumns(text, columns_) << "\n";
    ++lines_;
  }
  static bool IsQueued(const ActiveRun& a) {
    return !a.queue_state.empty() && fate_of(a.queue_state) != TaskFate::kRunning;
  }
  static int Queued(const std::vector<ActiveRun>& active) {
    return static_cast<int>(std::count_if(active.begin(), active.end(), IsQueued));
  }
  void Draw() {
    if (!tty_ || total_ == 0) return;
    columns_ = TerminalColumns();
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    std::ostringstream head;
    head << Bar(static_cast<double>(done_) / total_, 30) << " " << done_ << "/" << total_ << " done, " << failed_
         << " failed, elapsed " << Duration(elapsed) << ", ETA " << Eta(elapsed);
    Line(head.str());
    // Runs waiting in a batch queue get one line for all of them.
    if (const int queued = Queued(active_); queued > 0) Line("  " + std::to_string(queued) + " queued (Slurm)");
    for (const auto& a : active_) {
      if (IsQueued(a)) continue;
      const auto it = points_.find(a.run_id);
      Line("  " + a.run_id.substr(0, 10) + " " + (it == points_.end() ? std::string() : it->second) + "  " +
           ProgressText(a.progress, a.elapsed));
    }
    out_.flush();
  }
  std::ostream& out_;
  bool tty_;
  int columns_ = 80;
  std::chrono::steady_clock::time_point start_;
  int done_at_start_ = 0, done_ = 0, failed_ = 0, total_ = 0, lines_ = 0;
  double last_plain_ = 0;
  std::vector<ActiveRun> active_;
  std::map<std::string, std::string> points_;  // run id -> "W=9 r0", from the ticks
};

std::string ExeDir() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ec ? "." : self.parent_path().string();
}

int RunAll(const std::string& db, const RunOptions& o, std::ostream& out, const SlurmSettings* slurm = nullptr);

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

int DryRun(const std::string& db, const RunOptions& o, ExecutorChoice& c, std::ostream& out);

int Run(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "run");
  if (!a.positional.empty()) throw UsageError("campaign run: unexpected argument \"" + a.positional[0] + "\"");
  RunOptions o = RunOptionsFrom(a);
  o.engine = a.get("engine", "");
  if (!o.engine.empty() && o.engine != "native" && o.engine != "liggghts" && o.engine.find('/') == std::string::npos) {
    throw UsageError("--engine: must be native, liggghts or a path to an engine executable (got \"" + o.engine + "\")");
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
    if (r.state != "planned" && r.state != "interrupted" && r.state != "failed") continue;
    if ((o.engine == "native" || o.engine == "liggghts") && r.engine != o.engine) continue;
    if (!filter.matches(r)) continue;
    Launch l;
    l.run_id = r.run_id;
    l.argv = {o.engine.find('/') != std::string::npos
                  ? o.engine
                  : (fs::path(o.exe_dir) / (r.engine == "liggghts" ? "granary-liggghts" : "granary-engine")).string()};
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
  auto executor = slurm ? make_slurm_executor(*slurm) : make_local_executor(o.jobs);
  ConsoleObserver observer(out, &out == &std::cout && isatty(STDOUT_FILENO));
  ExitCode code;
  try {
    code = run_campaign(store, o, *executor, observer, &g_stop);
  } catch (...) {
    sigaction(SIGINT, &old_int, nullptr);
    sigaction(SIGTERM, &old_term, nullptr);
    throw;
  }
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  return static_cast<int>(code);
}

// ---------------------------------------------------------------- status
const char kStatusHelp[] =
    "usage: campaign status [--db FILE] [--only FILTER]... [--json]\n"
    "Counts by state (they add up to the runs of the campaign; retired runs, no longer in the\n"
    "spec, are counted apart), progress of running runs, failures with the tail of their log,\n"
    "elapsed time and ETA; how many finished runs have their metrics in the database (with\n"
    "--json, every stored metric of every run). Runs in a Slurm queue: pending and running per\n"
    "array, asked from squeue (one call), or as last seen when squeue cannot answer.\n"
    "  --only FILTER  only these runs: a run-id prefix, or POINTER=VALUE (a short name that ends\n"
    "                 one sweep axis will do: width=9); repeat for several (docs/cli.md)\n"
    "  --json         the same as JSON\n";

// The states a campaign's runs are in, in the order status shows them (retired apart).
const char* const kLiveStates[] = {"planned", "running", "done", "failed", "interrupted"};

// Runs in a batch queue, per array job: their queue states, live from squeue when it answers.
struct QueueView {
  bool any = false;
  bool live = false;
  std::string error;
  std::map<std::string, std::string> state_by_run;  // live or last seen; "" = left the queue
  struct Array {
    std::string job_id, name, script;
    std::map<std::string, int> states;
  };
  std::vector<Array> arrays;
};

QueueView ViewQueue(const std::vector<RunRow>& runs) {
  QueueView v;
  std::set<std::string> ids;
  for (const auto& r : runs) {
    if (!r.queued()) continue;
    v.any = true;
    v.state_by_run[r.run_id] = r.job_state;
    if (!r.job_id.empty()) ids.insert(r.job_id);
  }
  if (!v.any) return v;
  if (const auto entries = query_queue(ids, &v.error)) {
    v.live = true;
    std::map<std::pair<std::string, int>, std::string> live;
    for (const auto& e : *entries) live[{e.job_id, e.task}] = e.state;
    for (const auto& r : runs) {
      if (!r.queued()) continue;
      const auto it = live.find({r.job_id, r.job_index});
      v.state_by_run[r.run_id] = it == live.end() ? "" : it->second;
    }
  }
  std::map<std::string, std::size_t> index;  // script -> position in arrays
  for (const auto& r : runs) {
    if (!r.queued()) continue;
    auto [it, fresh] = index.emplace(r.job_script, v.arrays.size());
    if (fresh) v.arrays.push_back({r.job_id, r.job_name, r.job_script, {}});
    const std::string& state = v.state_by_run[r.run_id];
    ++v.arrays[it->second].states[state.empty() ? "left the queue" : state];
  }
  return v;
}

int Status(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "status");
  if (!a.positional.empty()) throw UsageError("campaign status: unexpected argument \"" + a.positional[0] + "\"");
  const std::string db = DbPath(a);
  const auto opened = OpenCampaignDb(db, "status");
  Store& store = *opened;
  const auto campaign = load_campaign(store);
  std::vector<RunRow> all = load_runs(store, true);  // the parameters: for --only and the estimate
  std::vector<std::string> filters;
  if (a.has("only") && campaign) {
    const RunFilter filter = ResolveOnly(a, *campaign, all);
    std::erase_if(all, [&](const RunRow& r) { return !filter.matches(r); });
    filters = filter.texts();
  }
  const std::vector<RunRow>& runs = all;
  const auto metrics = load_metrics(store);
  const QueueView queue = ViewQueue(runs);
  std::map<std::string, int> counts;
  for (const char* state : kLiveStates) counts[state] = 0;
  int retired = 0, total = 0;
  double first_start = 0, last_end = 0, wall_sum = 0, remaining_work = 0;
  int wall_n = 0, active = 0;
  const double now = now_seconds();
  int lost = 0;  // done, but the run directory is gone
  for (const auto& r : runs) {
    if (r.state == "retired") {
      ++retired;
      continue;
    }
    ++total;
    ++counts[r.state];
    if (r.state == "done" && !fs::exists(r.run_dir)) ++lost;
    if (r.started_at > 0 && (first_start == 0 || r.started_at < first_start)) first_start = r.started_at;
    last_end = std::max(last_end, r.ended_at);
    if (r.state == "done" && r.wall_s > 0) {
      wall_sum += r.wall_s;
      ++wall_n;
    }
    if (r.state == "planned" || r.state == "interrupted" || r.state == "failed") remaining_work += 1;
    if (r.state == "running") {
      ++active;
      const double f = r.progress.is_object() ? r.progress.value("fraction", 0.0) : 0.0;
      remaining_work += 1 - std::clamp(f, 0.0, 1.0);
    }
  }
  const double elapsed = first_start > 0 ? (active > 0 ? now : std::max(last_end, first_start)) - first_start : 0;
  double eta = wall_n > 0 ? remaining_work * (wall_sum / wall_n) / std::max(1, active) : -1;
  // The estimate of what remains (estimate.h), its rates scaled by what the done runs took:
  // running runs for the part they have left, the rest after them, on the runs at work now.
  double remaining_core_s = -1;
  {
    std::vector<PlannedRun> left;
    std::vector<double> fraction_left;
    for (const auto& r : runs) {
      if (r.state == "done" || r.state == "retired") continue;
      PlannedRun p;
      p.run_id = r.run_id;
      p.point_id = r.point_id;
      p.point = r.point;
      p.engine = r.engine;
      p.params_json = r.params.dump();
      left.push_back(std::move(p));
      const double f = r.state == "running" && r.progress.is_object() ? r.progress.value("fraction", 0.0) : 0.0;
      fraction_left.push_back(1 - std::clamp(f, 0.0, 1.0));
    }
    const CampaignEstimate e = estimate_runs(left, &store, ExeDir(), std::max(1, active), false, nullptr);
    if (e.calibration.valid() && !left.empty()) {
      std::vector<double> durations;
      remaining_core_s = 0;
      for (std::size_t k = 0; k < left.size(); ++k) {
        durations.push_back(e.runs.at(left[k].run_id).core_s_high * fraction_left[k]);
        remaining_core_s += durations.back();
      }
      if (active > 0) eta = makespan(durations, active);
    } else if (left.empty()) {
      remaining_core_s = 0;
    }
  }
  if (a.has("json")) {
    json list = json::array();
    for (const auto& r : runs) {
      json j = {{"run_id", r.run_id}, {"state", r.state},       {"point", r.point},      {"replica", r.replica},
                {"attempts", r.attempts}, {"engine", r.engine}, {"wall_s", r.wall_s},    {"run_dir", r.run_dir}};
      // Progress belongs to running runs only: a finished run's last progress.json is history.
      if (r.state == "running") {
        if (!r.progress.is_null()) j["progress"] = r.progress;
        j["lease_expired"] = lease_expired(r, this_process_holder().host, now);
      }
      if (!r.failure.empty()) j["failure"] = r.failure;
      if (!r.end_reason.empty()) j["end_reason"] = r.end_reason;
      if (const auto it = metrics.find(r.run_id); it != metrics.end()) {
        json m = json::object();
        for (const RunMetrics& rm : it->second)
          for (const MetricRow& x : rm.metrics)
            m[x.name] = {{"value", std::isfinite(x.value) ? json(x.value) : json(nullptr)},
                         {"se", std::isfinite(x.se) ? json(x.se) : json(nullptr)},
                         {"unit", x.unit},
                         {"analysis", rm.analysis}};
        j["metrics"] = m;
      }
      if (r.state == "done" && !fs::exists(r.run_dir)) j["run_dir_missing"] = true;
      if (r.job_array != 0) j["job"] = r.job_id.empty() ? json(nullptr) : json(r.job_id + "_" + std::to_string(r.job_index));
      if (r.queued()) j["queue_state"] = queue.state_by_run.at(r.run_id);
      list.push_back(j);
    }
    json doc = {{"campaign", campaign ? campaign->name : ""},
                {"total", total},
                {"counts", counts},
                {"retired", retired},
                {"only", filters},
                {"lost", lost},
                {"elapsed_s", elapsed},
                {"eta_s", eta >= 0 ? json(eta) : json(nullptr)},
                {"remaining_core_hours", remaining_core_s >= 0 ? json(remaining_core_s / 3600) : json(nullptr)},
                {"runs", list}};
    if (queue.any) {
      json arrays = json::array();
      for (const auto& q : queue.arrays) {
        arrays.push_back({{"job_id", q.job_id}, {"name", q.name}, {"script", q.script}, {"states", q.states}});
      }
      doc["queue"] = {{"live", queue.live}, {"arrays", arrays}};
      if (!queue.live) doc["queue"]["error"] = queue.error;
    }
    out << doc.dump(2) << "\n";
    return 0;
  }
  std::string only;
  for (const auto& f : filters) only += (only.empty() ? "" : ", ") + f;
  out << "campaign " << (campaign ? campaign->name : "?") << ": " << total << " runs" << (only.empty() ? "" : " with " + only)
      << " (" << db << ")\n ";
  for (const char* state : kLiveStates) out << (std::string(state) == "planned" ? " " : ", ") << state << " " << counts[state];
  if (retired > 0) out << "  (and " << retired << " retired: no longer in the spec, not counted)";
  out << "\n  elapsed " << Duration(elapsed) << ", ETA "
      << (total - counts["done"] == 0 ? std::string("-") : eta >= 0 ? Duration(eta) : "?");
  if (remaining_core_s > 0)
    out << " (" << core_hours_text(remaining_core_s, remaining_core_s) << " left"
        << (active > 0 ? ", on the " + std::to_string(active) + " run(s) at work now" : "") << ")";
  out << "\n";
  if (queue.any) {
    out << "Slurm queue (" << (queue.live ? "live" : "as last seen; squeue: " + queue.error) << "):\n";
    for (const auto& q : queue.arrays) {
      out << "  array " << (q.job_id.empty() ? "?" : q.job_id) << " " << q.name << ":";
      std::string sep = " ";
      for (const auto& [state, n] : q.states) {
        out << sep << n << " " << state;
        sep = ", ";
      }
      out << "\n";
    }
  }
  if (lost > 0) {
    out << "lost: " << lost << " done run(s) have no run directory (deleted after they finished); their results "
        << "are in the database only (campaign run --rerun-lost runs them again):\n";
    for (const auto& r : runs)
      if (r.state == "done" && !fs::exists(r.run_dir)) out << "  " << r.run_id << "  " << r.run_dir << "\n";
  }
  int analysed = 0;
  for (const auto& r : runs) analysed += r.state == "done" && metrics.count(r.run_id) ? 1 : 0;
  if (counts["done"] > 0)
    out << "  metrics in the database for " << analysed << " of " << counts["done"] << " done runs"
        << (analysed < counts["done"] ? " (campaign report or export analyses the others)" : "") << "\n";
  bool header = false;
  for (const auto& r : runs) {
    if (r.state != "running") continue;
    // Queued runs not yet at work are counted per array above, not listed one by one.
    if (r.queued() && fate_of(queue.state_by_run.at(r.run_id)) != TaskFate::kRunning) continue;
    if (!header) out << "running:\n";
    header = true;
    // A task nobody watches (detached) has its progress only in its directory.
    json progress = r.progress;
    if (progress.is_null() && r.queued()) {
      if (const auto p = rundir::ReadProgress(r.run_dir)) progress = p->ToJson();
    }
    out << "  " << r.run_id << " " << ProgressText(progress, 0) << "  " << CompactPoint(r.point) << " r" << r.replica
        << (r.queued() ? "  Slurm " + r.job_id + "_" + std::to_string(r.job_index) +
                             (r.lease_holder.empty() || lease_expired(r, this_process_holder().host, now)
                                  ? " (no runner watching: campaign scan or campaign run --executor slurm)"
                                  : "")
                       : lease_expired(r, this_process_holder().host, now) ? "  (runner gone: resumes on the next campaign run)"
                                                                            : "")
        << "\n";
  }
  header = false;
  for (const auto& r : runs) {
    if (r.state != "failed") continue;
    if (!header) out << "failed:\n";
    header = true;
    out << "  " << r.run_id << "  " << CompactPoint(r.point) << " r" << r.replica << " (attempts " << r.attempts << ")\n";
    std::istringstream lines(r.failure);
    std::string line;
    while (std::getline(lines, line)) out << "    | " << line << "\n";
  }
  return 0;
}

// ---------------------------------------------------------------- scan
const char kScanHelp[] =
    "usage: campaign scan [--db FILE] [--dry-run] [--json]\n"
    "Rebuild every run's state from its run directory (DONE and summary.json: done, ingested), and\n"
    "for runs in a Slurm queue from one squeue call (a task that left the queue ended as its\n"
    "directory says). Safe at any time, also while jobs run; runs a live runner holds are\n"
    "reported, not written. The way to collect a campaign submitted with --detach.\n"
    "  --dry-run    show what would change, write nothing\n"
    "  --json       {\"runs\", \"counts\", \"agrees\", \"changes\": [{\"run_id\", \"from\", \"to\", \"reason\", \"written\"}],\n"
    "               \"lost\": [run ids of done runs whose directory was deleted]}\n"
    "Exit: 0 (also when states changed), 2 usage error, 3 storage error (database unreadable or\n"
    "unwritable).\n";

int Scan(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "scan");
  if (!a.positional.empty()) throw UsageError("campaign scan: unexpected argument \"" + a.positional[0] + "\"");
  const std::string db = DbPath(a);
  const auto opened = OpenCampaignDb(db, "scan");
  Store& store = *opened;
  if (!load_campaign(store)) throw UsageError("campaign scan: " + db + " holds no campaign");
  const ScanReport r = scan_campaign(
      store, [](const std::set<std::string>& ids, std::string* error) { return query_queue(ids, error); }, a.has("dry-run"));
  if (a.has("json")) {
    json changes = json::array();
    for (const auto& c : r.changes) {
      changes.push_back({{"run_id", c.run_id}, {"from", c.from}, {"to", c.to}, {"reason", c.reason}, {"written", c.written}});
    }
    json doc = {{"runs", r.runs}, {"counts", r.counts}, {"agrees", r.changes.empty()}, {"changes", changes}, {"lost", r.lost}};
    if (!r.queue_error.empty()) doc["queue_error"] = r.queue_error;
    out << doc.dump(2) << "\n";
    return 0;
  }
  out << "campaign scan: " << r.runs << " runs;";
  for (const auto& [state, n] : r.counts) out << " " << state << " " << n;
  out << "\n";
  if (!r.queue_error.empty()) out << "  squeue did not answer (" << r.queue_error << "): queued runs left as they were\n";
  if (r.changes.empty()) out << "  the database agrees with the run directories\n";
  if (!r.lost.empty()) {
    out << "  " << r.lost.size() << " done run(s) have no run directory (first " << r.lost.front()
        << "): left done, their results are in the database only (campaign run --rerun-lost runs them again)\n";
  }
  for (const auto& c : r.changes) {
    out << "  " << c.run_id << "  " << c.from << " -> " << c.to << (c.written ? "" : a.has("dry-run") ? " (dry run)" : " (not written)")
        << (c.reason.empty() ? "" : ": " + c.reason.substr(0, c.reason.find('\n'))) << "\n";
  }
  return 0;
}

// ---------------------------------------------------------------- report
const char kReportHelp[] =
    "usage: campaign report [--db FILE] [--out DIR] [--only FILTER]... [--no-figures]\n"
    "Write report.md, report.html, figures and CSVs of the finished runs (default DIR:\n"
    "<db dir>/report).\n"
    "  --only FILTER  report only these runs (as for campaign run; repeat for several)\n";

#ifdef GRANARY_HAVE_ANALYSIS
// A campaign loaded from its database and analysed: what report, export and compare share.
// The analysis points into `info` and `records`, so the whole lives together.
struct AnalysedCampaign {
  analysis::CampaignInfo info;
  std::vector<analysis::RunRecord> records;
  analysis::AnalysisSetup setup;
  std::unique_ptr<analysis::CampaignAnalysis> analysis;
};

// "analysing runs [#####.....] 42/100" on a terminal; nothing otherwise.
std::function<void(int, int)> AnalysisProgress(std::ostream& err) {
  if (&err != &std::cerr || !isatty(STDERR_FILENO)) return nullptr;
  return [&err](int done, int total) {
    err << "\ranalysing runs " << Bar(static_cast<double>(done) / std::max(1, total), 30) << " " << done << "/" << total
        << (done == total ? "\n" : "") << std::flush;
  };
}

// Loads the campaign in `db`, analyses its finished runs (each run's cache first, runs in
// parallel) and stores their per-run metrics in the database (table metrics).
// With `only` (--only filters), the selected runs alone.
std::unique_ptr<AnalysedCampaign> AnalyseCampaignIn(const std::string& db, const std::string& verb, std::ostream& err,
                                                    const std::vector<std::string>& only = {}) {
  const auto opened = OpenCampaignDb(db, verb);
  Store& store = *opened;
  const auto campaign = load_campaign(store);
  if (!campaign) throw UsageError("campaign " + verb + ": " + db + " holds no campaign");
  std::vector<RunRow> runs = load_runs(store, true);
  if (!only.empty()) {
    try {
      const RunFilter filter = resolve_filters(only, *campaign, runs);
      std::erase_if(runs, [&](const RunRow& r) { return !filter.matches(r); });
    } catch (const FilterError& e) {
      throw UsageError(e.what());
    }
  }
  auto c = std::make_unique<AnalysedCampaign>();
  c->info.name = campaign->name;
  c->info.spec_hash = campaign->spec_hash;
  c->info.spec = campaign->spec;
  c->info.axes = campaign->axes;
  c->info.granary_version = campaign->granary_version;
  c->info.git_commit = campaign->git_commit;
  for (const auto& r : runs) {
    if (r.state == "retired") continue;
    analysis::RunRecord rec;
    rec.run_id = r.run_id;
    rec.state = r.state;
    rec.engine = r.engine;
    rec.point_id = r.point_id;
    rec.replica = r.replica;
    rec.point = r.point;
    rec.spec = r.params;
    rec.run_dir = fs::absolute(r.run_dir);
    rec.failure = r.failure;
    c->records.push_back(std::move(rec));
  }
  try {
    c->setup = analysis::setup_analyses(campaign->spec);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("campaign spec: ") + e.what());
  }
  analysis::CampaignAnalysisOptions options;
  options.progress = AnalysisProgress(err);
  c->analysis = analysis::analyse_campaign(c->info, c->records, c->setup, options);
  std::vector<RunMetrics> rows;
  const analysis::CampaignAnalysis& a = *c->analysis;
  for (std::size_t u = 0; u < a.view.used.size(); ++u)
    for (std::size_t k = 0; k < c->setup.analyses.size(); ++k) {
      if (a.results[k].runs[u].is_null()) continue;
      const analysis::Analysis& an = *c->setup.analyses[k];
      RunMetrics rm{a.view.used[u].record->run_id, an.key(), an.version(), an.run_options(), {}};
      for (const analysis::Metric& m : a.run_metrics(k, u)) rm.metrics.push_back({m.name, m.unit, m.value, m.se});
      rows.push_back(std::move(rm));
    }
  store_metrics(store, rows, now_seconds());
  return c;
}

// The report of the campaign in `db`.
analysis::ReportSummary WriteReportOf(const std::string& db, const fs::path& out_dir, bool figures, std::ostream& err,
                                      const std::vector<std::string>& only = {}) {
  const auto c = AnalyseCampaignIn(db, "report", err, only);
  analysis::ReportOptions options;
  options.out_dir = out_dir;
  options.figures = figures;
#ifdef GRANARY_HAVE_RENDER
  options.draw_run = [](const fs::path& run_dir, analysis::ReportOptions::Picture kind, const fs::path& png) {
    render::PictureOptions o;
    o.pick.kind = kind == analysis::ReportOptions::Picture::kBed ? render::FramePick::kFirst : render::FramePick::kLast;
    try {
      render::WritePng(render::RunScene(run_dir, o), 640, png);
      return std::string();
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
  };
  options.draw_clog = [](const fs::path& run_dir, const analysis::ClogPicture& picture, const fs::path& png) {
    render::PictureOptions o;
    o.highlight = picture.highlight;
    try {
      const render::Window window{picture.x_lo, picture.x_hi, picture.y_lo, picture.y_hi};
      render::WritePng(render::ClogScene(run_dir, picture.clog, o, window), 480, png);
      return std::string();
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
  };
#endif
  return analysis::write_report(*c->analysis, options);
}
#endif

int Report(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args a = Parse(argv, "report");
  if (!a.positional.empty()) throw UsageError("campaign report: unexpected argument \"" + a.positional[0] + "\"");
  const std::string db = DbPath(a);
#ifdef GRANARY_HAVE_ANALYSIS
  const auto summary = WriteReportOf(db, a.has("out") ? fs::path(a.get("out", "")) : DbDir(db) / "report",
                                     !a.has("no-figures"), err, a.all("only"));
  out << "report: " << summary.markdown.string() << "\n        " << summary.html.string() << "\n  runs used "
      << summary.runs_used << ", missing " << summary.runs_missing << ", failed " << summary.runs_failed
      << (summary.runs_lost > 0 ? ", lost " + std::to_string(summary.runs_lost) +
                                      " (done, run directory deleted: campaign run --rerun-lost)"
                                : std::string())
      << "\n"
      << "  analysis results: " << summary.results_from_cache << " from the runs' caches, " << summary.results_computed
      << " computed\n";
  return 0;
#else
  (void)out;
  throw UsageError("campaign report: this build has no analysis library (granary_analysis)");
#endif
}

// ---------------------------------------------------------------- export
const char kExportHelp[] =
    "usage: campaign export [--db FILE] [--format csv|json] [--level run|point] [--out FILE] [--only FILTER]...\n"
    "Analyse the finished runs (each run's cached results are reused) and write their metrics as\n"
    "one tidy table: one row per run, or per sweep point; each swept parameter a column named by\n"
    "its short path (base_outlets.0.width), each metric and its se (per point also n) numeric\n"
    "columns. The per-run metrics are stored in the database too (table metrics, view\n"
    "run_metrics; docs/data.md shows both read with pandas).\n"
    "  --db FILE         database (default granary.db)\n"
    "  --format F        csv (default) or json (an array of objects)\n"
    "  --level L         run (default) or point\n"
    "  --out FILE        write there (default: standard output)\n"
    "  --only FILTER     only these runs (as for campaign run; repeat for several)\n";

int Export(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args a = Parse(argv, "export");
  if (!a.positional.empty()) throw UsageError("campaign export: unexpected argument \"" + a.positional[0] + "\"");
  const std::string format = a.get("format", "csv"), level = a.get("level", "run");
  if (format != "csv" && format != "json") throw UsageError("--format: must be csv or json (got \"" + format + "\")");
  if (level != "run" && level != "point") throw UsageError("--level: must be run or point (got \"" + level + "\")");
  const std::string db = DbPath(a);
#ifdef GRANARY_HAVE_ANALYSIS
  const auto c = AnalyseCampaignIn(db, "export", err, a.all("only"));
  const analysis::ExportTable table =
      analysis::export_table(*c->analysis, level == "run" ? analysis::ExportLevel::kRun : analysis::ExportLevel::kPoint);
  const std::string text = format == "csv" ? analysis::to_csv(table) : analysis::to_json(table).dump(2) + "\n";
  if (a.has("out")) {
    WriteAtomically(a.get("out", ""), text);
    err << "export: " << table.rows.size() << " " << level << (table.rows.size() == 1 ? "" : "s") << " to "
        << a.get("out", "") << "\n";
  } else {
    out << text;
  }
  return 0;
#else
  (void)out;
  (void)err;
  throw UsageError("campaign export: this build has no analysis library (granary_analysis)");
#endif
}

// ---------------------------------------------------------------- compare
const char kCompareHelp[] =
    "usage: campaign compare SPEC [--db FILE] [--jobs N] [--no-run] [--out DIR] [--no-figures] [--json]\n"
    "                        [--threads-per-run T] [--time-limit S] [--retries K]\n"
    "Plan the campaign SPEC on both engines (native and liggghts, whatever its \"engine\" says),\n"
    "run what is not done (finished runs are reused: native runs of an earlier single-engine plan\n"
    "of the same spec count), write the report with its engine-comparison section, and print per\n"
    "point and metric both values, their ratio and whether they agree within 2 combined standard\n"
    "errors, plus wall time and disc-steps per second per engine.\n"
    "  --db FILE     database (default granary.db)\n"
    "  --no-run      compare what has finished, run nothing\n"
    "  --out DIR     report folder (default <db dir>/report)\n"
    "  --json        print the comparison as JSON (progress goes to stderr)\n"
    "  --jobs, --threads-per-run, --time-limit, --retries: as for campaign run\n"
    "Exit: 0 compared, 1 some runs failed or no point finished on both engines, 2 usage error,\n"
    "3 storage error, 130 interrupted.\n";

#ifdef GRANARY_HAVE_ANALYSIS
void PrintComparison(std::ostream& out, const json& c) {
  const std::string a = c.at("engine_a"), b = c.at("engine_b");
  out << "engine comparison: ratio " << b << " / " << a << "; agree = " << c.at("agreement").get<std::string>() << "\n";
  const auto cell = [](const json& m) {
    if (!m.at("mean").is_number()) return std::string("-");
    std::ostringstream o;
    o << std::setprecision(4) << m.at("mean").get<double>();
    if (m.at("se").is_number()) o << " ± " << std::setprecision(2) << m.at("se").get<double>();
    return o.str();
  };
  out << "    " << std::left << std::setw(16) << "metric" << std::setw(20) << a << std::setw(20) << b << std::setw(18)
      << "ratio" << "agree\n";
  bool unknown = false;
  for (const json& p : c.at("points")) {
    out << "  " << (p.contains("name") ? p.at("name").get<std::string>() : CompactPoint(p.at("point"))) << "\n";
    if (p.at("metrics").empty()) out << "    (no metric defined on both engines yet)\n";
    for (const json& name : c.at("metric_order")) {
      const std::string metric = name.get<std::string>();
      if (!p.at("metrics").contains(metric)) continue;
      const json& m = p.at("metrics").at(metric);
      if (!m.value("headline", false)) continue;
      unknown = unknown || !m.at("agree").is_boolean();
      json ratio = {{"mean", m.at("ratio")}, {"se", m.at("ratio_se")}};
      out << "    " << std::left << std::setw(16) << metric << std::setw(20) << cell(m.at(a)) << std::setw(20)
          << cell(m.at(b)) << std::setw(18) << cell(ratio)
          << (m.at("agree").is_boolean() ? (m.at("agree").get<bool>() ? "yes" : "no") : "n/a (no se)") << "\n";
    }
  }
  if (unknown)
    out << "  n/a: a value without a standard error (one replica) cannot be judged; plan more replicas\n";
  double rate_a = 0;
  for (const json& e : c.at("costs")) {
    const json& r = e.at("disc_steps_per_s");
    const double rate = r.at("mean").is_number() ? r.at("mean").get<double>() : 0.0;
    if (e.at("engine") == a) rate_a = rate;
    out << "  " << std::left << std::setw(9) << e.at("engine").get<std::string>() << " " << e.at("runs").get<int>()
        << " runs, wall " << Duration(e.at("wall_s").get<double>()) << " (discharge "
        << Duration(e.at("discharge_wall_s").get<double>()) << "), " << std::setprecision(3) << rate / 1e6
        << " M disc-steps/s per run";
    if (e.at("engine") != a && rate > 0) out << "; " << a << " is " << std::setprecision(3) << rate_a / rate << "x faster";
    out << "\n";
  }
}
#endif

int Compare(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args a = Parse(argv, "compare");
  if (a.positional.size() != 1) throw UsageError("campaign compare: needs exactly one SPEC file (see campaign compare --help)");
#ifdef GRANARY_HAVE_ANALYSIS
  const std::string spec_path = a.positional[0];
  json j = ReadSpecFile("compare", spec_path);
  if (j.is_object()) {
    j["engine"] = json::array({"native", "liggghts"});
    if (j.contains("base") && j["base"].is_object()) j["base"].erase("engine");  // both, whatever it says
  }
  const RunOptions o = RunOptionsFrom(a);
  const std::string db = DbPath(a);
  // With --json, stdout carries only the JSON document.
  std::ostream& progress = a.has("json") ? err : out;
  CampaignSpec spec;
  const PlanSummary s = PlanInto(j, spec_path, db, false, MaxRuns(a), spec);
  PrintPlan(progress, spec, s, false);
  int code = 0;
  if (!a.has("no-run")) {
    code = RunAll(db, o, progress);
    if (code == static_cast<int>(ExitCode::kInterrupted)) return code;
  }
  const auto summary = WriteReportOf(db, a.has("out") ? fs::path(a.get("out", "")) : DbDir(db) / "report",
                                     !a.has("no-figures"), err);
  if (a.has("json")) {
    out << json{{"campaign", spec.name},
                {"report", summary.html.string()},
                {"runs_used", summary.runs_used},
                {"runs_missing", summary.runs_missing},
                {"runs_failed", summary.runs_failed},
                {"comparison", summary.comparison}}
               .dump(2)
        << "\n";
  } else if (!summary.comparison.is_null()) {
    PrintComparison(out, summary.comparison);
  }
  progress << "report: " << summary.html.string() << "\n  runs used " << summary.runs_used << ", missing "
           << summary.runs_missing << ", failed " << summary.runs_failed << "\n";
  const bool compared = !summary.comparison.is_null() && !summary.comparison.at("points").empty();
  if (!compared) progress << "campaign compare: no sweep point has finished runs on both engines\n";
  return code != 0 ? code : (compared ? 0 : static_cast<int>(ExitCode::kRunsFailed));
#else
  (void)out;
  (void)err;
  throw UsageError("campaign compare: this build has no analysis library (granary_analysis)");
#endif
}

// ---------------------------------------------------------------- show, clean
const char kShowHelp[] =
    "usage: campaign show RUN [--db FILE] [--log N] [--json]\n"
    "Everything about one run: sweep point and replica, state, attempts, engine, host, start,\n"
    "end and wall time, how it ended (or why it failed), its results, its parameters (the\n"
    "resolved run spec; swept ones marked *), the files of its directory and the tail of its\n"
    "engine log.\n"
    "  RUN        a run id (a unique start of one will do) or a run directory\n"
    "  --log N    lines of engine.log to show (default 20)\n"
    "  --json     the same as JSON\n";

// RUN of `show`: a run id (a unique prefix will do) of the database, or a run directory of it.
RunRow FindRun(const std::string& verb, const std::string& run, Store& store, const std::string& db) {
  std::vector<RunRow> found;
  if (fs::is_directory(run)) {
    const fs::path dir = fs::weakly_canonical(run);
    for (RunRow& r : load_runs(store, true))
      if (fs::weakly_canonical(r.run_dir) == dir) found.push_back(std::move(r));
    if (found.empty()) throw UsageError("campaign " + verb + ": " + run + " is not a run directory of " + db);
    return found.front();
  }
  found = find_runs(store, run);
  if (found.empty()) {
    std::vector<std::string> ids;
    for (const RunRow& r : load_runs(store, false)) ids.push_back(r.run_id);
    const std::string best = nearest(run, ids);
    throw UsageError("campaign " + verb + ": no run id starts with \"" + run + "\" in " + db +
                     (best.empty() ? "" : "; did you mean " + best + "?") + " (campaign status lists them)");
  }
  if (found.size() > 1)
    throw UsageError("campaign " + verb + ": \"" + run + "\" starts " + std::to_string(found.size()) + " run ids (" +
                     found[0].run_id + ", " + found[1].run_id + (found.size() > 2 ? ", ..." : "") + "); give more of it");
  return found.front();
}

std::string LocalTime(double unix_seconds) {
  if (!(unix_seconds > 0)) return "-";
  const std::time_t t = static_cast<std::time_t>(unix_seconds);
  std::tm tm{};
  localtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S", &tm);
  return buf;
}

// Every leaf of a JSON document as (pointer, value), in document order.
void Leaves(const json& j, const std::string& at, std::vector<std::pair<std::string, json>>& out) {
  if (j.is_object() && !j.empty()) {
    for (const auto& [k, v] : j.items()) Leaves(v, at + "/" + escape_pointer_token(k), out);
  } else if (j.is_array() && !j.empty()) {
    for (std::size_t i = 0; i < j.size(); ++i) Leaves(j[i], at + "/" + std::to_string(i), out);
  } else {
    out.emplace_back(at, j);
  }
}

// A result or parameter as text: integers without ".0", others to 6 significant digits.
std::string ValueText(const json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number_float()) {
    const double x = v.get<double>();
    std::ostringstream o;
    if (std::isfinite(x) && x == std::floor(x) && std::fabs(x) < 1e15) o << static_cast<long long>(x);
    else o << std::setprecision(6) << x;
    return o.str();
  }
  return v.dump();
}

int Show(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "show");
  if (a.positional.size() != 1) throw UsageError("campaign show: needs exactly one RUN (see campaign show --help)");
  const std::string db = DbPath(a);
  const auto opened = OpenCampaignDb(db, "show");
  Store& store = *opened;
  const RunRow run = FindRun("show", a.positional[0], store, db);
  const json d = run_details(store, run, a.integer("log", 20, 0));
  if (a.has("json")) {
    out << d.dump(2) << "\n";
    return 0;
  }
  const auto campaign = load_campaign(store);
  std::size_t key_width = 10;
  for (const auto& [key, value] : d["results"].items()) key_width = std::max(key_width, key.size() + 1);
  auto row = [&](const std::string& label, const std::string& value) {
    out << "  " << std::left << std::setw(static_cast<int>(key_width)) << label << " " << value << "\n";
  };
  out << "run " << run.run_id << (campaign ? " of campaign " + campaign->name : std::string()) << " (" << db << ")\n";
  std::string point = CompactPoint(run.point) + ", replica " + std::to_string(run.replica);
  if (run.params.contains("seed")) point += ", seed " + run.params["seed"].dump();
  row("point", point);
  std::string state = run.state;
  if (!run.end_reason.empty()) state += ": " + run.end_reason;
  const json& results = d["results"];
  if (results.contains("exited") && results.contains("bodies"))
    state += ", " + ValueText(results["exited"]) + " exits of " + ValueText(results["bodies"]) + " bodies";
  if (results.contains("t_end")) state += ", t_end " + ValueText(results["t_end"]);
  row("state", state);
  if (run.state == "running") row("progress", ProgressText(run.progress, 0));
  row("attempts", std::to_string(run.attempts));
  row("engine", run.engine + (run.engine_version.empty() ? "" : " " + run.engine_version));
  if (!run.host.empty()) row("host", run.host);
  std::string when = "started " + LocalTime(run.started_at);
  if (run.ended_at > 0) when += ", ended " + LocalTime(run.ended_at);
  if (run.wall_s > 0) when += ", wall " + Duration(run.wall_s);
  if (results.contains("timing/bed_wall_s") && results.contains("timing/discharge_wall_s"))
    when += " (bed " + Duration(results["timing/bed_wall_s"].get<double>()) + ", discharge " +
            Duration(results["timing/discharge_wall_s"].get<double>()) + ")";
  row("time", when);
  if (results.contains("bed/height")) {
    std::string bed;
    if (results.contains("bed/packing_fraction")) bed += "packing fraction " + ValueText(results["bed/packing_fraction"]) + ", ";
    bed += "top " + ValueText(results["bed/height"]);
    if (results.contains("bed/surface")) bed += ", surface " + ValueText(results["bed/surface"]);
    if (results.contains("bed/settle_time")) bed += ", settled in " + ValueText(results["bed/settle_time"]) + " time units";
    if (results.contains("bed/prepared_here"))
      bed += results["bed/prepared_here"].get<double>() != 0 ? " (prepared by this run)" : " (from the bed cache)";
    row("bed", bed);
  }
  row("directory", run.run_dir + (d["run_dir_exists"].get<bool>() ? "" : "  (missing)"));
  if (!run.failure.empty()) {
    out << "failure:\n";
    std::istringstream lines(run.failure);
    for (std::string line; std::getline(lines, line);) out << "  | " << line << "\n";
  }
  if (!results.empty()) {
    out << "results (summary.json):\n";
    for (const auto& [key, value] : results.items()) row(key, ValueText(value));
  }
  out << "parameters (resolved run spec; * swept):\n";
  std::vector<std::pair<std::string, json>> leaves;
  Leaves(run.params, "", leaves);
  std::size_t width = 0;
  for (const auto& [p, v] : leaves) width = std::max(width, p.size());
  for (const auto& [p, v] : leaves) {
    const bool swept = std::any_of(run.point.items().begin(), run.point.items().end(),
                                   [&](const auto& kv) { return p == kv.key() || p.rfind(kv.key() + "/", 0) == 0; });
    out << (swept ? " *" : "  ") << std::left << std::setw(static_cast<int>(width) + 2) << p.substr(1)
        << (v.is_string() ? v.dump() : ValueText(v)) << "\n";
  }
  out << "files:\n";
  if (d["files"].empty()) out << "  (none" << (d["run_dir_exists"].get<bool>() ? "" : ": no directory") << ")\n";
  for (const auto& f : d["files"])
    out << "  " << std::left << std::setw(24) << f["name"].get<std::string>() << std::right << std::setw(10)
        << human_bytes(f["bytes"].get<std::uintmax_t>()) << "\n";
  if (!d["log_tail"].empty()) {
    out << "engine.log (last " << d["log_tail"].size() << " lines):\n";
    for (const auto& line : d["log_tail"]) out << "  | " << line.get<std::string>() << "\n";
  }
  return 0;
}

const char kCleanHelp[] =
    "usage: campaign clean [--retired] [--failed] [--beds] [--locks] [--dry-run] [--db FILE] [--json]\n"
    "Give disk space back: remove the directories of retired runs (no longer in the spec), lock\n"
    "files nobody holds and, when asked, failed runs' directories and cached beds. Says what it\n"
    "removed and how much space that freed. Without a choice: --retired --locks.\n"
    "  --retired  directories of retired runs; if a later plan brings one back, it runs again\n"
    "  --failed   directories of failed runs (they start afresh on the next campaign run)\n"
    "  --beds     cached beds that only this campaign's done or retired runs use (other campaigns'\n"
    "             beds are never touched; a bed needed again is prepared again)\n"
    "  --locks    lock files (bed cache, run directories of runs not running) that nobody holds\n"
    "  --dry-run  say what would be removed and how much it would free; remove nothing\n"
    "Never touches done, planned, running or interrupted runs' directories.\n";

int Clean(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "clean");
  if (!a.positional.empty()) throw UsageError("campaign clean: unexpected argument \"" + a.positional[0] + "\"");
  const std::string db = DbPath(a);
  const auto opened = OpenCampaignDb(db, "clean");
  Store& store = *opened;
  CleanOptions o;
  const bool chosen = a.has("retired") || a.has("failed") || a.has("beds") || a.has("locks");
  o.retired = !chosen || a.has("retired");
  o.locks = !chosen || a.has("locks");
  o.failed = a.has("failed");
  o.beds = a.has("beds");
  o.cache_dir = default_cache_dir();
  // A running runner may be writing into failed runs' directories (retries).
  if (o.failed)
    for (const RunRow& r : load_runs(store, false))
      if (r.state == "running" && !lease_expired(r, this_process_holder().host, now_seconds()))
        throw UsageError("campaign clean --failed: a campaign run is running on " + db +
                         " (it retries failed runs); clean when it has finished");
  const std::vector<CleanItem> items = plan_clean(store, o);
  const bool dry = a.has("dry-run");
  std::map<std::string, std::pair<int, std::uintmax_t>> by_kind;
  std::uintmax_t total = 0;
  for (const CleanItem& it : items) {
    by_kind[it.kind].first += 1;
    by_kind[it.kind].second += it.bytes;
    total += it.bytes;
  }
  const std::uintmax_t freed = dry ? 0 : execute_clean(store, items);
  if (a.has("json")) {
    json list = json::array();
    for (const CleanItem& it : items)
      list.push_back({{"kind", it.kind}, {"path", it.path.string()}, {"run_id", it.run_id}, {"bytes", it.bytes}});
    out << json{{"dry_run", dry}, {"items", list}, {"bytes", total}, {"freed_bytes", freed}}.dump(2) << "\n";
    return 0;
  }
  out << "campaign clean" << (dry ? " (dry run: nothing removed)" : "") << "\n";
  const std::pair<const char*, const char*> kinds[] = {{"retired", "retired runs' directories"},
                                                       {"failed", "failed runs' directories"},
                                                       {"bed", "cached beds"},
                                                       {"lock", "lock files nobody holds"}};
  for (const auto& [kind, label] : kinds) {
    const bool asked = (std::string(kind) == "retired" && o.retired) || (std::string(kind) == "failed" && o.failed) ||
                       (std::string(kind) == "bed" && o.beds) || (std::string(kind) == "lock" && o.locks);
    if (!asked) continue;
    const auto& [n, bytes] = by_kind[kind];
    out << "  " << std::left << std::setw(28) << label << std::right << std::setw(5) << n << "  " << std::setw(10)
        << human_bytes(bytes) << "\n";
  }
  if (dry) {
    out << "would free " << human_bytes(total) << "\n";
  } else {
    out << "freed " << human_bytes(freed) << "\n";
  }
  return 0;
}

// ---------------------------------------------------------------- schema, completion
const char kSchemaHelp[] =
    "usage: campaign schema [--out FILE]\n"
    "Print the JSON Schema of campaign specs: every key, its type, default, range and meaning,\n"
    "generated from the tables the validator reads (docs/campaign-spec.md). An editor that\n"
    "knows it checks a spec as it is typed and completes its keys (VS Code: docs/campaign-spec.md,\n"
    "\"Editing specs\"). The repository keeps a copy in docs/campaign.schema.json.\n"
    "  --out FILE   write it to FILE instead of stdout\n";

int Schema(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "schema");
  if (!a.positional.empty()) throw UsageError("campaign schema: unexpected argument \"" + a.positional[0] + "\"");
  const std::string text = campaign_spec_schema().dump(2) + "\n";
  if (!a.has("out")) {
    out << text;
    return 0;
  }
  const std::string file = a.get("out", "");
  std::ofstream f(file);
  f << text;
  if (!f) throw std::runtime_error("campaign schema: cannot write " + file);
  out << "schema: " << file << "\n";
  return 0;
}

const char kCompletionHelp[] =
    "usage: campaign completion bash\n"
    "Print the bash completion of campaign: verbs, each verb's flags, run ids and --only filters\n"
    "from the database (--db, or granary.db here), engines and colours. To use it now:\n"
    "  source <(campaign completion bash)\n"
    "and for every shell, put that line into ~/.bashrc (or the output into\n"
    "/etc/bash_completion.d/campaign).\n";

// The script: bash asks the binary (`campaign __complete CWORD WORDS...`), so completion knows
// exactly the verbs and flags that the parser accepts and the run ids in the database.
const char kBashCompletion[] = R"(# bash completion for campaign (Granary): source <(campaign completion bash)
_campaign() {
  local IFS=$'\n'
  local words
  words=$("${COMP_WORDS[0]}" __complete "$COMP_CWORD" "${COMP_WORDS[@]}" 2>/dev/null) || return
  if [[ "$words" == "__files__" ]]; then
    COMPREPLY=($(compgen -f -- "${COMP_WORDS[COMP_CWORD]}"))
    compopt -o filenames 2>/dev/null
    return
  fi
  COMPREPLY=($(compgen -W "$words" -- "${COMP_WORDS[COMP_CWORD]}"))
}
complete -F _campaign campaign
)";

int Completion(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "completion");
  if (a.positional.size() != 1 || a.positional[0] != "bash")
    throw UsageError("campaign completion: give the shell: campaign completion bash");
  out << kBashCompletion;
  return 0;
}

// Candidates for the word at `cword` of `words` (words[0] is the program), one per line;
// "__files__" asks the shell for file names. Never fails: completion must stay quiet.
void Complete(int cword, const std::vector<std::string>& words, std::ostream& out);


// ---------------------------------------------------------------- fields
const char kFieldsHelp[] =
    "usage: campaign fields RUN_DIR [--out DIR] [--fields NAMES] [--from T] [--to T] [--stride N]\n"
    "                       [--max-frames N] [--width W] [--cutoff C] [--spacing H]\n"
    "                       [--window X0,X1,Y0,Y1] [--min-phi F] [--threads N] [--json]\n"
    "       campaign fields RUN_DIR --bench [--repeat N] [--threads-list 1,2] [--max-frames N]\n"
    "Coarse-grained fields of one run directory (docs/analyses.md), time-averaged over its frames\n"
    "from T to T: one CSV per field in DIR (default RUN_DIR/fields) with columns x, y, value,\n"
    "n_frames (the frames behind the value). Stress fields need the run's contacts.dump\n"
    "(output.contact_forces).\n"
    "  --fields NAMES    comma-separated (default: all the run's data supports): phi vx vy speed\n"
    "                    omega omega_fl2 tg tg_eq46 sigma_xx sigma_xy sigma_yy pressure shear\n"
    "                    friction kinetic_pressure kinetic_shear total_pressure total_shear\n"
    "                    total_friction\n"
    "  --width W         kernel width w in d (default 1.414); --cutoff C in w (default 3)\n"
    "  --spacing H       grid spacing in d (default 1)\n"
    "  --window ...      the mapped rectangle (default: 1.5 d inside the walls, from 1.5 d above\n"
    "                    the base to min(148.5 d, the bed's height))\n"
    "  --min-phi F       velocity, Omega and T_g of a frame need phi >= F at a node (default 0.05)\n"
    "  --threads N       threads (default: all cores; any count gives the same bits)\n"
    "  --json            print the run's summary as JSON\n"
    "  --bench           frames per second over the run's frames, reading the dumps included:\n"
    "                    reading alone, then the fields at each thread count of --threads-list,\n"
    "                    in --repeat interleaved rounds (best and median); run it under\n"
    "                    `cpu bench` on a shared machine\n"
    "Exit: 0 done, 1 unreadable run directory, 2 usage error.\n";

#ifdef GRANARY_HAVE_ANALYSIS
std::vector<double> NumberList(const std::string& flag, const std::string& text) {
  std::vector<double> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      std::size_t used = 0;
      const double x = std::stod(item, &used);
      if (used != item.size() || !std::isfinite(x)) throw std::invalid_argument(item);
      out.push_back(x);
    } catch (const std::exception&) {
      throw UsageError("--" + flag + ": \"" + item + "\" is not a number (got \"" + text + "\")");
    }
  }
  return out;
}

analysis::CgRunOptions FieldOptions(const Args& a) {
  analysis::CgRunOptions o;
  o.cg.width = a.number("width", o.cg.width);
  o.cg.cutoff = a.number("cutoff", o.cg.cutoff);
  o.cg.spacing = a.number("spacing", o.cg.spacing);
  o.cg.min_phi = a.number("min-phi", o.cg.min_phi);
  o.cg.threads = a.integer("threads", 0, 0);
  if (a.has("window")) {
    const auto w = NumberList("window", a.get("window", ""));
    if (w.size() != 4 || !(w[1] > w[0]) || !(w[3] >= w[2]))
      throw UsageError("--window: needs X0,X1,Y0,Y1 with X0 < X1 and Y0 <= Y1 (got \"" + a.get("window", "") + "\")");
    o.cg.window = {w[0], w[1], w[2], w[3]};
  }
  o.t_start = a.number("from", o.t_start);
  o.t_end = a.number("to", o.t_end);
  o.frame_stride = a.integer("stride", 1, 1);
  o.max_frames = a.integer("max-frames", 0, 0);
  return o;
}

// `campaign fields --bench`: frames per second, reading alone and the fields per thread count.
int FieldsBench(const rundir::RunData& data, const Args& a, std::ostream& out) {
  analysis::CgRunOptions o = FieldOptions(a);
  const int repeat = a.integer("repeat", 3, 1);
  std::vector<int> threads;
  for (double t : NumberList("threads-list", a.get("threads-list", "1,2"))) {
    if (t < 1 || t != std::floor(t)) throw UsageError("--threads-list: thread counts are integers >= 1");
    threads.push_back(static_cast<int>(t));
  }
  const int limit = o.max_frames;
  auto read_only = [&]() {
    rundir::FrameReader frames(data.frames_file());
    std::optional<rundir::ContactReader> contacts;
    if (data.has_contacts) contacts.emplace(data.contacts_file());
    rundir::Frame f;
    rundir::ContactFrame c;
    int n = 0;
    while ((limit == 0 || n < limit) && frames.Next(f)) {
      if (contacts) contacts->Next(c);
      ++n;
    }
    return n;
  };
  std::map<std::string, std::vector<double>> rates;
  std::vector<std::string> order = {"read"};
  for (int t : threads) order.push_back("fields, " + std::to_string(t) + (t == 1 ? " thread" : " threads"));
  int frames = 0;
  std::size_t nodes = 0, contacts_per_frame = 0, discs_per_frame = 0;
  {
    rundir::FrameReader fr(data.frames_file());
    rundir::Frame f;
    if (fr.Next(f)) discs_per_frame = f.discs.size();
    if (data.has_contacts) {
      rundir::ContactReader cr(data.contacts_file());
      rundir::ContactFrame c;
      if (cr.Next(c)) contacts_per_frame = c.contacts.size();
    }
  }
  for (int round = 1; round <= repeat; ++round) {
    for (const std::string& what : order) {
      const auto t0 = std::chrono::steady_clock::now();
      if (what == "read") {
        frames = read_only();
      } else {
        o.cg.threads = threads[static_cast<std::size_t>(&what - &order[1])];
        const analysis::CgRunResult r = analysis::cg_fields_of_run(data, o);
        frames = r.parts.front().frames;
        nodes = r.parts.front().grid.size();
      }
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      rates[what].push_back(frames / s);
      out << "round " << round << "  " << std::left << std::setw(20) << what << std::right << std::fixed
          << std::setprecision(1) << std::setw(8) << frames / s << " frames/s  (" << frames << " frames in "
          << std::setprecision(2) << s << " s)\n"
          << std::defaultfloat;
    }
  }
  out << "run " << data.dir.string() << ": " << discs_per_frame << " discs and " << contacts_per_frame
      << " contacts in its first frame; grid of " << nodes << " nodes\n";
  for (const std::string& what : order) {
    std::vector<double> v = rates[what];
    std::sort(v.begin(), v.end());
    out << std::left << std::setw(20) << what << std::right << std::fixed << std::setprecision(1) << " best "
        << v.back() << "  median " << v[v.size() / 2] << " frames/s\n"
        << std::defaultfloat;
  }
  return 0;
}
#endif

int Fields(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "fields");
  if (a.positional.size() != 1) throw UsageError("campaign fields: needs exactly one RUN_DIR (see campaign fields --help)");
#ifdef GRANARY_HAVE_ANALYSIS
  const fs::path dir = a.positional[0];
  if (!fs::is_directory(dir)) throw UsageError("campaign fields: no run directory " + dir.string());
  const rundir::RunData data = rundir::ReadRun(dir);
  if (!data.has_frames) throw UsageError("campaign fields: " + dir.string() + " has no frames.dump (output.frame_interval = 0)");
  if (a.has("bench")) return FieldsBench(data, a, out);
  const analysis::CgRunOptions o = FieldOptions(a);
  std::vector<analysis::CgField> fields;
  if (a.has("fields")) {
    std::stringstream in(a.get("fields", ""));
    std::string name;
    while (std::getline(in, name, ',')) {
      analysis::CgField f;
      if (!analysis::cg_field_by_name(name, f)) {
        std::vector<std::string> names;
        for (const auto& info : analysis::cg_field_table()) names.push_back(info.name);
        const std::string best = nearest(name, names);
        throw UsageError("--fields: unknown field \"" + name + "\"" + (best.empty() ? "" : "; did you mean \"" + best + "\"?"));
      }
      fields.push_back(f);
    }
  }
  analysis::CgRunResult r;
  try {
    r = analysis::cg_fields_of_run(data, o);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("campaign fields: ") + e.what());
  }
  const analysis::CgMaps maps(r.parts.front());
  if (fields.empty())
    for (const auto& info : analysis::cg_field_table())
      if (maps.has(info.field)) fields.push_back(info.field);
  const fs::path out_dir = a.has("out") ? fs::path(a.get("out", "")) : dir / "fields";
  fs::create_directories(out_dir);
  json files = json::array();
  for (analysis::CgField f : fields) {
    const auto& info = analysis::cg_field_info(f);
    if (!maps.has(f)) throw UsageError(std::string("campaign fields: ") + info.name + " needs contacts.dump, which " +
                                       dir.string() + " does not have (output.contact_forces)");
    const fs::path file = out_dir / (std::string(info.name) + ".csv");
    std::ofstream csv(file);
    csv << analysis::cg_map_csv(maps, f);
    if (!csv) throw std::runtime_error("cannot write " + file.string());
    files.push_back(file.string());
  }
  if (a.has("json")) {
    out << json{{"run_dir", dir.string()},
                {"frames", maps.frames()},
                {"contact_frames", maps.contact_frames()},
                {"first_time", r.first_time},
                {"last_time", r.last_time},
                {"window", {r.window.x0, r.window.x1, r.window.y0, r.window.y1}},
                {"nodes", maps.grid().size()},
                {"files", files}}
               .dump(2)
        << "\n";
  } else {
    out << "fields of " << dir.string() << ": " << maps.frames() << " frames (t = " << r.first_time << " .. "
        << r.last_time << "), " << maps.contact_frames() << " with contacts; window x " << r.window.x0 << " .. "
        << r.window.x1 << ", y " << r.window.y0 << " .. " << r.window.y1 << ", " << maps.grid().nx << " x "
        << maps.grid().ny << " nodes\n  " << files.size() << " CSV files in " << out_dir.string() << "\n";
  }
  return 0;
#else
  (void)out;
  throw UsageError("campaign fields: this build has no analysis library (granary_analysis)");
#endif
}

// ---------------------------------------------------------------- snapshot, movie
const char kSnapshotHelp[] =
    "usage: campaign snapshot RUN [--time T | --clog K | --first | --last] [--color C] [--forces]\n"
    "                         [--highlight ID,ID,...] [--width PX] --out FILE.png|FILE.svg [--db FILE]\n"
    "A picture of one frame of a run: every disc to scale, walls (grey), outlets (red), obstacles,\n"
    "optionally the contact-force network.\n"
    "  RUN          a run directory, or a run id (or the start of one) in the database\n"
    "  --time T     the frame nearest simulated time T (since the outlets opened)\n"
    "  --clog K     the K-th clog (1 = first): the middle of the clogged stretch, or the last frame\n"
    "               if the run ended in it (a clog is a gap of the run's clog_window in the exits)\n"
    "  --first      the first frame (t = 0, the bed before the outlets open)\n"
    "  --last       the last frame (default)\n"
    "  --color C    species (default), speed, rotation (angular velocity) or force (summed contact\n"
    "               force on each body; needs output.contact_forces)\n"
    "  --forces     draw the contact-force network (line width ~ force; needs output.contact_forces)\n"
    "  --highlight  body ids to outline\n"
    "  --width PX   picture width in pixels (default 1000; the height follows the silo)\n"
    "  --out FILE   .png (cairo) or .svg\n"
    "  --db FILE    database to look RUN up in (default granary.db)\n"
    "Exit: 0 written, 1 the run cannot be drawn (no frames, no contact frames, no such clog),\n"
    "2 usage error.\n";

const char kMovieHelp[] =
    "usage: campaign movie RUN --out FILE.mp4 [--fps N] [--color C] [--forces] [--width PX] [--db FILE]\n"
    "Every frame of a run drawn as by campaign snapshot and encoded by ffmpeg (H.264, yuv420p),\n"
    "with a progress bar on stderr.\n"
    "  --fps N      frames per second of the movie (default 20)\n"
    "  --width PX   movie width in pixels (default 800)\n"
    "  RUN, --color, --forces, --db: as for campaign snapshot\n"
    "Exit: 0 written, 1 the run cannot be drawn or ffmpeg failed, 2 usage error.\n";

#ifdef GRANARY_HAVE_RENDER
// RUN: a run directory, or a run id (a unique prefix will do) of the database.
fs::path ResolveRun(const std::string& verb, const std::string& run, const Args& a) {
  if (fs::is_directory(run)) return run;
  const std::string db = DbPath(a);
  if (!fs::exists(db))
    throw UsageError("campaign " + verb + ": '" + run + "' is not a run directory, and there is no database " + db +
                     " to look it up in");
  const auto opened = OpenCampaignDb(db, verb);
  Store& store = *opened;
  std::vector<RunRow> found;
  for (RunRow& r : load_runs(store, false))
    if (r.run_id.rfind(run, 0) == 0) found.push_back(std::move(r));
  if (found.empty()) throw UsageError("campaign " + verb + ": no run directory or run id '" + run + "' in " + db);
  if (found.size() > 1)
    throw UsageError("campaign " + verb + ": '" + run + "' starts " + std::to_string(found.size()) + " run ids in " + db +
                     " (" + found[0].run_id + ", " + found[1].run_id + ", ...); give more of it");
  return found[0].run_dir;
}

render::PictureOptions PictureOptionsFrom(const std::string& verb, const Args& a) {
  render::PictureOptions o;
  int picks = 0;
  for (const char* f : {"time", "clog", "first", "last"}) picks += a.has(f);
  if (picks > 1) throw UsageError("campaign " + verb + ": give one of --time, --clog, --first, --last");
  if (a.has("time")) {
    o.pick.kind = render::FramePick::kTime;
    o.pick.time = a.number("time", 0);
  } else if (a.has("clog")) {
    o.pick.kind = render::FramePick::kClog;
    o.pick.clog = a.integer("clog", 1, 1);
  } else if (a.has("first")) {
    o.pick.kind = render::FramePick::kFirst;
  }
  try {
    o.colour = render::ColourFromName(a.get("color", "species"));
  } catch (const std::invalid_argument& e) {
    throw UsageError("campaign " + verb + ": --color: " + e.what());
  }
  o.forces = a.has("forces");
  if (a.has("highlight")) {
    std::stringstream ids(a.get("highlight", ""));
    for (std::string id; std::getline(ids, id, ',');) {
      std::size_t used = 0;
      long long v = -1;
      try {
        v = std::stoll(id, &used);
      } catch (const std::exception&) {
      }
      if (v < 0 || used != id.size())
        throw UsageError("campaign " + verb + ": --highlight: body ids are integers >= 0 separated by commas (got \"" + id + "\")");
      o.highlight.insert(v);
    }
  }
  return o;
}
#endif

int Snapshot(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "snapshot");
  if (a.positional.size() != 1) throw UsageError("campaign snapshot: needs exactly one RUN (see campaign snapshot --help)");
  if (!a.has("out")) throw UsageError("campaign snapshot: --out FILE.png or FILE.svg is required");
  const fs::path file = a.get("out", "");
  const std::string ext = file.extension().string();
  if (ext != ".png" && ext != ".svg") throw UsageError("campaign snapshot: --out must end in .png or .svg, not '" + ext + "'");
#ifdef GRANARY_HAVE_RENDER
  const render::PictureOptions o = PictureOptionsFrom("snapshot", a);
  const fs::path run = ResolveRun("snapshot", a.positional[0], a);
  const int width = a.integer("width", 1000, 16);
  try {
    const render::Scene scene = render::RunScene(run, o);
    if (ext == ".svg") {
      std::ofstream f(file);
      f << render::Svg(scene, width);
      if (!f) throw std::runtime_error("cannot write " + file.string());
    } else {
      render::WritePng(scene, width, file);
    }
    out << "snapshot: " << file.string() << " (" << scene.caption << ")\n";
    return 0;
  } catch (const rundir::ReadError& e) {
    throw std::runtime_error(e.what());
  }
#else
  (void)out;
  throw UsageError("campaign snapshot: this build has no renderer (granary_render)");
#endif
}

int Movie(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args a = Parse(argv, "movie");
  if (a.positional.size() != 1) throw UsageError("campaign movie: needs exactly one RUN (see campaign movie --help)");
  if (!a.has("out")) throw UsageError("campaign movie: --out FILE.mp4 is required");
  const fs::path file = a.get("out", "");
  if (file.extension() != ".mp4") throw UsageError("campaign movie: --out must end in .mp4");
#ifdef GRANARY_HAVE_RENDER
  const render::PictureOptions o = PictureOptionsFrom("movie", a);
  const fs::path run = ResolveRun("movie", a.positional[0], a);
  const int width = a.integer("width", 800, 16);
  const int fps = a.integer("fps", 20, 1);
  const bool tty = isatty(STDERR_FILENO);
  const int frames = render::WriteMovie(run, o, file, width, fps, [&](int done, int total) {
    if (!tty && done != total) return;
    err << "\rmovie " << Bar(total > 0 ? static_cast<double>(done) / total : 1.0, 30) << " " << done << "/" << total
        << " frames" << (done == total ? "\n" : "") << std::flush;
  });
  out << "movie: " << file.string() << " (" << frames << " frames at " << fps << " fps)\n";
  return 0;
#else
  (void)out;
  (void)err;
  throw UsageError("campaign movie: this build has no renderer (granary_render)");
#endif
}

// ---------------------------------------------------------------- table
struct Verb {
  const char* name;
  const char* summary;
  const char* help;
  std::function<int(const std::vector<std::string>&, std::ostream&, std::ostream&)> run;
  std::vector<FlagSpec> flags;  // what Parse accepts and bash completion offers
};

const std::vector<Verb>& Verbs() {
  static const std::vector<Verb> kVerbs = {
      {"plan", "expand a campaign spec into runs in the database", kPlanHelp, Plan,
       {{"db", true}, {"dry-run", false}, {"json", false}, {"max-runs", true}, {"jobs", true}, {"help", false}}},
      {"run", "run what is not done (resumable, leases, N at a time)", kRunHelp, Run,
       {{"db", true}, {"jobs", true}, {"engine", true}, {"only", true}, {"threads-per-run", true}, {"time-limit", true}, {"retries", true}, {"rerun-lost", false},
        {"executor", true}, {"partition", true}, {"time", true}, {"cpus-per-run", true}, {"array-max", true},
        {"account", true}, {"sbatch-arg", true}, {"poll-interval", true}, {"dry-run", false}, {"detach", false},
        {"help", false}}},
      {"status", "counts, progress, failures, ETA", kStatusHelp, Status,
       {{"db", true}, {"only", true}, {"json", false}, {"help", false}}},
      {"scan", "rebuild run states from the run directories (and the Slurm queue)", kScanHelp, Scan,
       {{"db", true}, {"dry-run", false}, {"json", false}, {"help", false}}},
      {"report", "write the campaign report (markdown, html, figures, CSV)", kReportHelp, Report,
       {{"db", true}, {"out", true}, {"only", true}, {"no-figures", false}, {"help", false}}},
      {"export", "write every run's (or point's) metrics as one CSV or JSON table", kExportHelp, Export,
       {{"db", true}, {"format", true}, {"level", true}, {"out", true}, {"only", true}, {"help", false}}},
      {"compare", "run a campaign on both engines and compare them point by point", kCompareHelp, Compare,
       {{"db", true}, {"jobs", true}, {"no-run", false}, {"out", true}, {"no-figures", false}, {"json", false}, {"threads-per-run", true}, {"time-limit", true}, {"retries", true}, {"max-runs", true}, {"help", false}}},
      {"fields", "coarse-grained fields of one run directory as CSV maps; --bench", kFieldsHelp, Fields,
       {{"out", true}, {"fields", true}, {"from", true}, {"to", true}, {"stride", true}, {"max-frames", true},
        {"width", true}, {"cutoff", true}, {"spacing", true}, {"window", true}, {"min-phi", true}, {"threads", true},
        {"json", false}, {"bench", false}, {"repeat", true}, {"threads-list", true}, {"help", false}}},
      {"show", "everything about one run: state, timings, results, parameters, files, log", kShowHelp, Show,
       {{"db", true}, {"log", true}, {"json", false}, {"help", false}}},
      {"clean", "remove retired (and failed) runs' directories, unused beds, stale locks", kCleanHelp, Clean,
       {{"db", true}, {"retired", false}, {"failed", false}, {"beds", false}, {"locks", false}, {"dry-run", false},
        {"json", false}, {"help", false}}},
      {"schema", "the JSON Schema of campaign specs (for editors)", kSchemaHelp, Schema, {{"out", true}, {"help", false}}},
      {"completion", "bash completion of verbs, flags and run ids", kCompletionHelp, Completion, {{"help", false}}},
      {"snapshot", "a picture of one frame of a run (PNG or SVG)", kSnapshotHelp, Snapshot,
       {{"time", true}, {"clog", true}, {"first", false}, {"last", false}, {"color", true}, {"forces", false}, {"highlight", true}, {"width", true}, {"out", true}, {"db", true}, {"help", false}}},
      {"movie", "a movie of a run's frames (MP4, ffmpeg)", kMovieHelp, Movie,
       {{"out", true}, {"fps", true}, {"color", true}, {"forces", false}, {"width", true}, {"db", true}, {"help", false}}},
  };
  return kVerbs;
}

const std::vector<FlagSpec>& FlagsOf(const std::string& verb) {
  for (const Verb& v : Verbs())
    if (verb == v.name) return v.flags;
  throw std::logic_error("no verb " + verb);
}

void Complete(int cword, const std::vector<std::string>& words, std::ostream& out) {
  auto say = [&](const std::string& w) { out << w << "\n"; };
  if (cword <= 1 || words.size() < 2) {
    for (const Verb& v : Verbs()) say(v.name);
    say("--help");
    say("--version");
    return;
  }
  const Verb* verb = nullptr;
  for (const Verb& v : Verbs())
    if (words[1] == v.name) verb = &v;
  if (!verb) return;
  const std::string cur = static_cast<std::size_t>(cword) < words.size() ? words[static_cast<std::size_t>(cword)] : "";
  const std::string prev = words[static_cast<std::size_t>(cword) - 1];
  // The database the command line names, for run ids and filters.
  std::string db = "granary.db";
  for (std::size_t i = 2; i + 1 < words.size(); ++i)
    if (words[i] == "--db") db = words[i + 1];
  auto runs_of_db = [&](bool with_params) {
    std::vector<RunRow> runs;
    try {
      if (fs::is_regular_file(db)) {
        Store store(db, Store::ReadOnly{});
        runs = load_runs(store, with_params);
      }
    } catch (const std::exception&) {
    }
    return runs;
  };
  const auto flag = std::find_if(verb->flags.begin(), verb->flags.end(),
                                 [&](const FlagSpec& f) { return prev == "--" + f.name; });
  if (flag != verb->flags.end() && flag->takes_value) {
    const std::string name = flag->name;
    if (name == "engine") {
      say("native");
      say("liggghts");
    } else if (name == "color") {
      for (const char* c : {"species", "speed", "rotation", "force"}) say(c);
    } else if (name == "only") {
      std::set<std::string> seen;
      for (const RunRow& r : runs_of_db(false)) {
        seen.insert(r.run_id);
        for (const auto& [axis, value] : r.point.items()) seen.insert(axis + "=" + value.dump());
      }
      for (const auto& w : seen) say(w);
    } else if (name == "db" || name == "out") {
      say("__files__");
    }
    return;
  }
  if (cur.rfind("-", 0) == 0) {
    for (const FlagSpec& f : verb->flags) say("--" + f.name);
    return;
  }
  const std::string v = verb->name;
  if (v == "show" || v == "snapshot" || v == "movie") {
    for (const RunRow& r : runs_of_db(false)) say(r.run_id);
  } else if (v == "plan" || v == "compare") {
    say("__files__");
  } else if (v == "completion") {
    say("bash");
  }
}

std::string MainHelp() {
  std::string h =
      "usage: campaign VERB [flags]   (campaign VERB --help for its flags)\n"
      "Granary campaign manager: plan, run and report sweeps of 2-D silo discharge simulations.\n\nverbs:\n";
  std::size_t width = 0;
  for (const auto& v : Verbs()) width = std::max(width, std::string(v.name).size());
  for (const auto& v : Verbs())
    h += "  " + std::string(v.name) + std::string(width + 2 - std::string(v.name).size(), ' ') + v.summary + "\n";
  h += "\nexit codes: 0 ok, 1 runs failed, 2 usage or spec error, 3 storage (database or run directories),\n"
       "130 interrupted (docs/cli.md)\n";
  return h;
}

}  // namespace

int run_cli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    (args.empty() ? err : out) << MainHelp();
    return args.empty() ? static_cast<int>(ExitCode::kUsage) : 0;
  }
  if (args[0] == "__complete") {  // asked by the bash completion script; not a verb of its own
    const int cword = args.size() > 1 ? std::atoi(args[1].c_str()) : 0;
    Complete(cword, std::vector<std::string>(args.begin() + std::min<std::size_t>(2, args.size()), args.end()), out);
    return 0;
  }
  if (args[0] == "--version") {
    out << "campaign " << GRANARY_VERSION << " (" << granary::GitCommit() << ")\n";
    return 0;
  }
  const Verb* verb = nullptr;
  std::vector<std::string> names;
  for (const auto& v : Verbs()) {
    names.push_back(v.name);
    if (args[0] == v.name) verb = &v;
  }
  if (!verb) {
    const std::string best = nearest(args[0], names);
    err << "campaign: unknown verb \"" << args[0] << "\"" << (best.empty() ? "" : "; did you mean \"" + best + "\"?")
        << "\n" << MainHelp();
    return static_cast<int>(ExitCode::kUsage);
  }
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  if (std::find(rest.begin(), rest.end(), "--help") != rest.end() || std::find(rest.begin(), rest.end(), "-h") != rest.end()) {
    out << verb->help;
    return 0;
  }
  try {
    return verb->run(rest, out, err);
  } catch (const UsageError& e) {
    err << "error: " << e.what() << "\n";
    return static_cast<int>(ExitCode::kUsage);
  } catch (const SpecError& e) {
    err << "error: " << e.what() << "\n";
    return static_cast<int>(ExitCode::kUsage);
  } catch (const StoreError& e) {
    err << "error: " << e.what() << "\n";
    return static_cast<int>(ExitCode::kStorage);
  } catch (const std::invalid_argument& e) {  // e.g. an engine executable that does not exist
    err << "error: " << e.what() << "\n";
    return static_cast<int>(ExitCode::kUsage);
  } catch (const std::exception& e) {
    err << "error: " << e.what() << "\n";
    return static_cast<int>(ExitCode::kRunsFailed);
  }
}

}  // namespace granary::runner
