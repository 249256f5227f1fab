// `campaign status` and `campaign show`: a campaign's runs, and one run. Flags in docs/cli.md.

#include <ctime>
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

#include "rundir/json_pointer.h"
#include "rundir/progress.h"
#include "runner/calibration.h"
#include "runner/campaign_db.h"
#include "runner/cli/common.h"
#include "runner/cli/run.h"
#include "runner/cli/report.h"
#include "runner/cli/replicas.h"
#include "runner/campaign_spec.h"
#include "runner/inspect.h"
#include "runner/scan.h"
#include "runner/executor.h"
#include "runner/util.h"

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char kStatusHelp[] =
    "usage: campaign status [--db FILE] [--only FILTER]... [--json]\n"
    "Counts by state (they add up to the runs of the campaign; retired runs, no longer in the\n"
    "spec, are counted apart), progress of running runs, failures with the tail of their log,\n"
    "elapsed time and ETA; how many finished runs have their metrics in the database (with\n"
    "--json, every stored metric of every run); when the spec states expected values (/expect),\n"
    "how many agree, disagree and are not yet judged (the finished runs analysed, caches first). Runs in a Slurm queue: pending and running per\n"
    "array, asked from squeue (one call), or as last seen when squeue cannot answer.\n"
    "  --only FILTER  only these runs: a run-id prefix, or POINTER=VALUE (an axis' short name as\n"
    "                 the report prints it, D_b=1.5, or a derived axis of /axes, or a short name\n"
    "                 that ends one sweep axis: width=9); repeat for several (docs/cli.md)\n"
    "  --json         the same as JSON\n"
    "Done runs whose files differ from their engine's manifest (a stat per file) are listed as\n"
    "damaged; their stored metrics are not shown.\n"
    "Exit: 0, 2 usage error (no database, --only that selects nothing), 3 storage error.\n";

// Runs in a batch queue, per array job: their queue states, live from the queue when it answers.
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
    if (!r.Queued()) continue;
    v.any = true;
    v.state_by_run[r.run_id] = r.job_state;
    if (!r.job_id.empty()) ids.insert(r.job_id);
  }
  if (!v.any) return v;
  if (const auto entries = DefaultBatchQueue().Query(ids, &v.error)) {
    v.live = true;
    std::map<std::pair<std::string, int>, std::string> live;
    for (const auto& e : *entries) live[{e.job_id, e.task}] = e.state;
    for (const auto& r : runs) {
      if (!r.Queued()) continue;
      const auto it = live.find({r.job_id, r.job_index});
      v.state_by_run[r.run_id] = it == live.end() ? "" : it->second;
    }
  }
  std::map<std::string, std::size_t> index;  // script -> position in arrays
  for (const auto& r : runs) {
    if (!r.Queued()) continue;
    auto [it, fresh] = index.emplace(r.job_script, v.arrays.size());
    if (fresh) v.arrays.push_back({r.job_id, r.job_name, r.job_script, {}});
    const std::string& state = v.state_by_run[r.run_id];
    ++v.arrays[it->second].states[state.empty() ? "left the queue" : state];
  }
  return v;
}

int Status(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args a = Parse(argv, "status");
  if (!a.positional.empty()) throw UsageError("campaign status: unexpected argument \"" + a.positional[0] + "\"");
  const std::string db = DbPath(a);
  const auto opened = OpenCampaignDb(db, "status", true);
  Store& store = *opened;
  const auto campaign = LoadCampaign(store);
  std::vector<RunRow> all = LoadRuns(store, true);  // the parameters: for --only and the estimate
  std::vector<std::string> filters;
  if (a.Has("only") && campaign) {
    const RunFilter filter = ResolveOnly(a, *campaign, all);
    std::erase_if(all, [&](const RunRow& r) { return !filter.Matches(r); });
    filters = filter.Texts();
  }
  const std::vector<RunRow>& runs = all;
  // Sizes against the manifests (a stat per file): a damaged run's stored metrics are not shown.
  const auto checks = CheckDoneRuns(runs, rundir::VerifyLevel::kSizes);
  const auto damaged = [&](const std::string& id) {
    const auto it = checks.find(id);
    return it != checks.end() && it->second.integrity == rundir::Integrity::kDamaged;
  };
  auto metrics = LoadMetrics(store);
  std::erase_if(metrics, [&](const auto& m) { return damaged(m.first); });
  const QueueView queue = ViewQueue(runs);
  std::map<std::string, int> counts;
  for (const RunState state : kLiveRunStates) counts[ToString(state)] = 0;
  int retired = 0, total = 0;
  double first_start = 0, last_end = 0, wall_sum = 0, remaining_work = 0;
  int wall_n = 0, active = 0;
  const double now = NowSeconds();
  int lost = 0;  // done, but the run directory is gone
  for (const auto& r : runs) {
    if (r.state == RunState::kRetired) {
      ++retired;
      continue;
    }
    ++total;
    ++counts[ToString(r.state)];
    if (r.state == RunState::kDone && !fs::exists(r.run_dir)) ++lost;
    if (r.started_at > 0 && (first_start == 0 || r.started_at < first_start)) first_start = r.started_at;
    last_end = std::max(last_end, r.ended_at);
    if (r.state == RunState::kDone && r.wall_s > 0) {
      wall_sum += r.wall_s;
      ++wall_n;
    }
    if (Runnable(r.state)) remaining_work += 1;
    if (r.state == RunState::kRunning) {
      // A run whose runner is gone is not progressing: no ETA counts on it (a task in a batch
      // queue is at work with or without a runner watching).
      const bool in_queue = r.Queued() && !queue.state_by_run.at(r.run_id).empty();
      if (in_queue || !LeaseExpired(r, ThisProcessHolder().host, now)) ++active;
      const double f = r.progress.is_object() ? r.progress.value("fraction", 0.0) : 0.0;
      remaining_work += 1 - std::clamp(f, 0.0, 1.0);
    }
  }
  const double elapsed = first_start > 0 ? (active > 0 ? now : std::max(last_end, first_start)) - first_start : 0;
  // An ETA only while something runs: with no live runner nothing will finish by itself.
  double eta = wall_n > 0 && active > 0 ? remaining_work * (wall_sum / wall_n) / active : -1;
  // The estimate of what remains (estimate.h), its rates scaled by what the done runs took:
  // running runs for the part they have left, the rest after them, on the runs at work now.
  double remaining_core_s = -1;
  {
    std::vector<PlannedRun> left;
    std::vector<double> fraction_left;
    for (const auto& r : runs) {
      if (r.state == RunState::kDone || r.state == RunState::kRetired) continue;
      left.push_back(ToPlannedRun(r));
      const double f =
          r.state == RunState::kRunning && r.progress.is_object() ? r.progress.value("fraction", 0.0) : 0.0;
      fraction_left.push_back(1 - std::clamp(f, 0.0, 1.0));
    }
    const CampaignEstimate e = EstimateRuns(left, &store, ExeDir(), std::max(1, active), false, nullptr);
    if (e.calibration.Valid() && !left.empty()) {
      std::vector<double> durations;
      remaining_core_s = 0;
      for (std::size_t k = 0; k < left.size(); ++k) {
        durations.push_back(e.runs.at(left[k].run_id).core_s_high * fraction_left[k]);
        remaining_core_s += durations.back();
      }
      if (active > 0) eta = Makespan(durations, active);
    } else if (left.empty()) {
      remaining_core_s = 0;
    }
  }
  if (a.Has("json")) {
    json list = json::array();
    for (const auto& r : runs) {
      json j = {{"run_id", r.run_id},     {"state", ToString(r.state)}, {"point", r.point},   {"replica", r.replica},
                {"attempts", r.attempts}, {"engine", r.engine},         {"wall_s", r.wall_s}, {"run_dir", r.run_dir}};
      // Progress belongs to running runs only: a finished run's last progress.json is history.
      if (r.state == RunState::kRunning) {
        if (!r.progress.is_null()) j["progress"] = r.progress;
        j["lease_expired"] = LeaseExpired(r, ThisProcessHolder().host, now);
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
      if (r.state == RunState::kDone && !fs::exists(r.run_dir)) j["run_dir_missing"] = true;
      if (const auto it = checks.find(r.run_id); it != checks.end()) {
        j["integrity"] = rundir::IntegrityName(it->second.integrity);
        if (!it->second.problems.empty()) {
          json problems = json::array();
          for (const auto& p : it->second.problems) problems.push_back({{"file", p.file}, {"what", p.what}});
          j["problems"] = problems;
        }
      }
      if (r.job_array != 0)
        j["job"] = r.job_id.empty() ? json(nullptr) : json(r.job_id + "_" + std::to_string(r.job_index));
      if (r.Queued()) j["queue_state"] = queue.state_by_run.at(r.run_id);
      list.push_back(j);
    }
    json doc = {{"campaign", campaign ? campaign->name : ""},
                {"total", total},
                {"counts", counts},
                {"retired", retired},
                {"only", filters},
                {"lost", lost},
                {"damaged", CountIntegrity(checks).damaged},
                {"elapsed_s", elapsed},
                {"eta_s", eta >= 0 ? json(eta) : json(nullptr)},
                {"remaining_core_hours", remaining_core_s >= 0 ? json(remaining_core_s / 3600) : json(nullptr)},
                {"runs", list}};
#ifdef GRANARY_HAVE_ANALYSIS
    if (const auto e = ExpectationCounts(db, err, a.All("only"))) doc["expectations"] = *e;
#endif
    if (campaign) {
      const CampaignSpec cs = CampaignSpec::FromJson(campaign->spec);
      if (cs.replica_rule.Adaptive())
        doc["replicas"] = ReplicaProgressJson(ReplicaStates(store, nullptr, false), cs.replica_rule);
    }
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
  out << "campaign " << (campaign ? campaign->name : "?") << ": " << total << " runs"
      << (only.empty() ? "" : " with " + only) << " (" << db << ")\n ";
  for (const RunState state : kLiveRunStates)
    out << (state == RunState::kPlanned ? " " : ", ") << state << " " << counts[ToString(state)];
  if (retired > 0) out << "  (and " << retired << " retired: no longer in the spec, not counted)";
  out << "\n  elapsed " << Duration(elapsed) << ", ETA "
      << (total - counts[ToString(RunState::kDone)] == 0 ? std::string("-")
          : active == 0                                  ? std::string("- (no runner at work: campaign run continues)")
          : eta >= 0                                     ? Duration(eta)
                                                         : "?");
  if (remaining_core_s > 0)
    out << " (" << CoreHoursText(remaining_core_s, remaining_core_s) << " left"
        << (active > 0 ? ", on the " + std::to_string(active) + " run(s) at work now" : "") << ")";
  out << "\n";
  if (queue.any) {
    const BatchQueue& batch = DefaultBatchQueue();
    out << batch.Name() << " queue ("
        << (queue.live ? std::string("live") : "as last seen; " + std::string(batch.QueryTool()) + ": " + queue.error)
        << "):\n";
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
      if (r.state == RunState::kDone && !fs::exists(r.run_dir)) out << "  " << r.run_id << "  " << r.run_dir << "\n";
  }
  if (const int n = CountIntegrity(checks).damaged; n > 0) {
    out << "damaged: " << n << " done run(s) whose files differ from what the engine recorded; left out of every "
        << "number (campaign scan --verify checks every byte; delete the run directory and campaign run --rerun-lost to "
        << "run one again):\n";
    for (const auto& [id, v] : checks) {
      if (v.integrity != rundir::Integrity::kDamaged) continue;
      out << "  " << id << "\n";
      for (const auto& p : v.problems) out << "    " << p.file << ": " << p.what << "\n";
    }
  }
  int analysed = 0;
  for (const auto& r : runs) analysed += r.state == RunState::kDone && metrics.count(r.run_id) ? 1 : 0;
  if (counts[ToString(RunState::kDone)] > 0)
    out << "  metrics in the database for " << analysed << " of " << counts[ToString(RunState::kDone)] << " done runs"
        << (analysed < counts[ToString(RunState::kDone)] ? " (campaign report or export analyses the others)" : "")
        << "\n";
  if (campaign) {
    const CampaignSpec cs = CampaignSpec::FromJson(campaign->spec);
    if (cs.replica_rule.Adaptive()) PrintReplicaProgress(out, ReplicaStates(store, nullptr, false), cs.replica_rule);
  }
#ifdef GRANARY_HAVE_ANALYSIS
  if (const auto e = ExpectationCounts(db, err, a.All("only")))
    out << "  expectations: " << *e << " (campaign export --expectations, or the report's Key results)\n";
#endif
  bool header = false;
  for (const auto& r : runs) {
    if (r.state != RunState::kRunning) continue;
    // Queued runs not yet at work are counted per array above, not listed one by one.
    if (r.Queued() && DefaultBatchQueue().FateOf(queue.state_by_run.at(r.run_id)) != TaskFate::kRunning) continue;
    if (!header) out << "running:\n";
    header = true;
    // A task nobody watches (detached) has its progress only in its directory.
    json progress = r.progress;
    if (progress.is_null() && r.Queued()) {
      if (const auto p = rundir::ReadProgress(r.run_dir)) progress = p->ToJson();
    }
    out << "  " << r.run_id << " " << ProgressText(progress, false) << "  " << CompactPoint(r.point) << " r"
        << r.replica
        << (r.Queued()
                ? "  " + std::string(DefaultBatchQueue().Name()) + " " + r.job_id + "_" + std::to_string(r.job_index) +
                      (r.lease_holder.empty() || LeaseExpired(r, ThisProcessHolder().host, now)
                           ? " (no runner watching: campaign scan or campaign run --executor slurm)"
                           : "")
            : LeaseExpired(r, ThisProcessHolder().host, now) ? "  (runner gone: resumes on the next campaign run)"
                                                             : "")
        << "\n";
  }
  header = false;
  for (const auto& r : runs) {
    if (r.state != RunState::kFailed) continue;
    if (!header) out << "failed:\n";
    header = true;
    out << "  " << r.run_id << "  " << CompactPoint(r.point) << " r" << r.replica << " (attempts " << r.attempts
        << ")\n";
    std::istringstream lines(r.failure);
    std::string line;
    while (std::getline(lines, line)) out << "    | " << line << "\n";
  }
  return 0;
}

const char kShowHelp[] =
    "usage: campaign show RUN [--db FILE] [--log N] [--json]\n"
    "Everything about one run: sweep point and replica, state, attempts, engine, host, start,\n"
    "end and wall time, how it ended (or why it failed), its results, its parameters (the\n"
    "resolved run spec; swept ones marked *), the files of its directory and the tail of its\n"
    "engine log.\n"
    "  RUN        a run id (a unique start of one will do) or a run directory\n"
    "  --log N    lines of engine.log to show (default 20)\n"
    "  --json     the same as JSON\n"
    "A done run's files are checked against its manifest (\"files\": whole, damaged with what\n"
    "differs, or not verifiable).\n"
    "Exit: 0, 2 usage error (no such run, no database), 3 storage error.\n";

// RUN of `show`: a run id (a unique prefix will do) of the database, or a run directory of it.
RunRow FindRun(const std::string& verb, const std::string& run, Store& store, const std::string& db) {
  std::vector<RunRow> found;
  if (fs::is_directory(run)) {
    const fs::path dir = fs::weakly_canonical(run);
    for (RunRow& r : LoadRuns(store, true))
      if (fs::weakly_canonical(r.run_dir) == dir) found.push_back(std::move(r));
    if (found.empty()) throw UsageError("campaign " + verb + ": " + run + " is not a run directory of " + db);
    return found.front();
  }
  found = FindRuns(store, run);
  if (found.empty()) {
    std::vector<std::string> ids;
    for (const RunRow& r : LoadRuns(store, false)) ids.push_back(r.run_id);
    const std::string best = Nearest(run, ids);
    throw UsageError("campaign " + verb + ": no run id starts with \"" + run + "\" in " + db +
                     (best.empty() ? "" : "; did you mean " + best + "?") + " (campaign status lists them)");
  }
  if (found.size() > 1)
    throw UsageError("campaign " + verb + ": \"" + run + "\" starts " + std::to_string(found.size()) + " run ids (" +
                     found[0].run_id + ", " + found[1].run_id + (found.size() > 2 ? ", ..." : "") +
                     "); give more of it");
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
    for (const auto& [k, v] : j.items()) Leaves(v, at + "/" + EscapePointerToken(k), out);
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
    if (std::isfinite(x) && x == std::floor(x) && std::fabs(x) < 1e15)
      o << static_cast<long long>(x);
    else
      o << std::setprecision(6) << x;
    return o.str();
  }
  return v.dump();
}

int Show(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "show");
  if (a.positional.size() != 1) throw UsageError("campaign show: needs exactly one RUN (see campaign show --help)");
  const std::string db = DbPath(a);
  const auto opened = OpenCampaignDb(db, "show", true);
  Store& store = *opened;
  const RunRow run = FindRun("show", a.positional[0], store, db);
  const json d = RunDetails(store, run, a.Integer("log", 20, 0));
  if (a.Has("json")) {
    out << d.dump(2) << "\n";
    return 0;
  }
  const auto campaign = LoadCampaign(store);
  std::size_t key_width = 10;
  for (const auto& [key, value] : d["results"].items()) key_width = std::max(key_width, key.size() + 1);
  auto row = [&](const std::string& label, const std::string& value) {
    out << "  " << std::left << std::setw(static_cast<int>(key_width)) << label << " " << value << "\n";
  };
  out << "run " << run.run_id << (campaign ? " of campaign " + campaign->name : std::string()) << " (" << db << ")\n";
  std::string point = CompactPoint(run.point) + ", replica " + std::to_string(run.replica);
  if (run.params.contains("seed")) point += ", seed " + run.params["seed"].dump();
  row("point", point);
  std::string state = ToString(run.state);
  if (!run.end_reason.empty()) state += ": " + run.end_reason;
  const json& results = d["results"];
  if (results.contains("exited") && results.contains("bodies"))
    state += ", " + ValueText(results["exited"]) + " exits of " + ValueText(results["bodies"]) + " bodies";
  if (results.contains("t_end")) state += ", t_end " + ValueText(results["t_end"]);
  row("state", state);
  if (run.state == RunState::kRunning) row("progress", ProgressText(run.progress, false));
  row("attempts", std::to_string(run.attempts));
  row("engine", run.engine + (run.engine_version.empty() ? "" : " " + run.engine_version));
  if (!run.host.empty()) row("host", run.host);
  std::string when = "started " + LocalTime(run.started_at);
  if (run.ended_at > 0) when += ", ended " + LocalTime(run.ended_at);
  // The engine's own wall time covers every attempt (a resumed run's bed and discharge); the
  // runner's figure is its last attempt's alone.
  const bool engine_wall = results.contains("timing/wall_s") && results["timing/wall_s"].is_number();
  if (engine_wall) {
    when += ", wall " + Duration(results["timing/wall_s"].get<double>());
  } else if (run.wall_s > 0) {
    when += ", wall " + Duration(run.wall_s);
  }
  if (results.contains("timing/bed_wall_s") && results.contains("timing/discharge_wall_s"))
    when += " (bed " + Duration(results["timing/bed_wall_s"].get<double>()) + ", discharge " +
            Duration(results["timing/discharge_wall_s"].get<double>()) + ")";
  if (engine_wall && run.attempts > 1 && run.wall_s >= 0) when += "; last attempt " + Duration(run.wall_s);
  row("time", when);
  if (results.contains("bed/height")) {
    std::string bed;
    if (results.contains("bed/packing_fraction"))
      bed += "packing fraction " + ValueText(results["bed/packing_fraction"]) + ", ";
    bed += "top " + ValueText(results["bed/height"]);
    if (results.contains("bed/surface")) bed += ", surface " + ValueText(results["bed/surface"]);
    if (results.contains("bed/settle_time"))
      bed += ", settled in " + ValueText(results["bed/settle_time"]) + " time units";
    if (results.contains("bed/prepared_here"))
      bed += results["bed/prepared_here"].get<double>() != 0 ? " (prepared by this run)" : " (from the bed cache)";
    row("bed", bed);
  }
  row("directory", run.run_dir + (d["run_dir_exists"].get<bool>() ? "" : "  (missing)"));
  if (d.contains("integrity")) {
    std::string text = d["integrity"].get<std::string>();
    for (const auto& p : d.value("problems", json::array()))
      text += "\n    " + p.value("file", std::string()) + ": " + p.value("what", std::string());
    if (text == "damaged") text += " (campaign scan --verify)";
    row("files", text);
  }
  if (!run.failure.empty()) {
    out << "failure:\n";
    std::istringstream lines(run.failure);
    for (std::string line; std::getline(lines, line);) out << "  | " << line << "\n";
  }
  for (const auto& f : d["analysis_failures"]) {
    out << "analysis " << f["analysis"].get<std::string>() << " failed (campaign report: Python analysis):\n";
    std::istringstream lines(f["error"].get<std::string>());
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
  for (const auto& leaf : leaves) {
    const std::string& p = leaf.first;
    const nlohmann::json& v = leaf.second;
    const bool swept = std::any_of(run.point.items().begin(), run.point.items().end(),
                                   [&](const auto& kv) { return p == kv.key() || p.rfind(kv.key() + "/", 0) == 0; });
    out << (swept ? " *" : "  ") << std::left << std::setw(static_cast<int>(width) + 2) << p.substr(1)
        << (v.is_string() ? v.dump() : ValueText(v)) << "\n";
  }
  out << "files:\n";
  if (d["files"].empty()) out << "  (none" << (d["run_dir_exists"].get<bool>() ? "" : ": no directory") << ")\n";
  for (const auto& f : d["files"])
    out << "  " << std::left << std::setw(24) << f["name"].get<std::string>() << std::right << std::setw(10)
        << HumanBytes(f["bytes"].get<std::uintmax_t>()) << "\n";
  if (!d["log_tail"].empty()) {
    out << "engine.log (last " << d["log_tail"].size() << " lines):\n";
    for (const auto& line : d["log_tail"]) out << "  | " << line.get<std::string>() << "\n";
  }
  return 0;
}

}  // namespace

Verb StatusVerb() {
  return {"status",
          "counts, progress, failures, ETA",
          kStatusHelp,
          Status,
          {{"db", true}, {"only", true}, {"json", false}, {"help", false}}};
}

Verb ShowVerb() {
  return {"show",
          "everything about one run: state, timings, results, parameters, files, log",
          kShowHelp,
          Show,
          {{"db", true}, {"log", true}, {"json", false}, {"help", false}},
          Operand::kRun};
}

}  // namespace granary::runner::cli
