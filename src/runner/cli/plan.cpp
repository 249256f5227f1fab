// `campaign plan`: see plan.h; flags in docs/cli.md.
#include "runner/cli/plan.h"

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
#include <thread>
#include <vector>

#include "runner/calibration.h"
#include "runner/cli/run.h"
#include "runner/store.h"
#ifdef GRANARY_HAVE_ANALYSIS
#include "analysis/expectations.h"
#include "analysis/fields_analysis.h"
#include "analysis/report.h"
#endif

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

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
    "measures the engine's speed with granary-engine bench (seconds; cached).\n"
    "Exit: 0 planned (or the dry run shown), 2 spec or usage error (the message names the JSON\n"
    "path, or FILE:LINE:COLUMN), 3 storage error.\n";

}  // namespace

json ReadSpecFile(const std::string& verb, const std::string& spec_path) {
  std::ifstream in(spec_path, std::ios::binary);
  if (!in) throw UsageError("campaign " + verb + ": cannot read " + spec_path);
  std::stringstream text;
  text << in.rdbuf();
  try {
    json spec = ParseSpecText(text.str(), spec_path);
    ResolveSpecPaths(spec, spec_path);
    return spec;
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
}

std::uint64_t MaxRuns(const Args& a) {
  if (!a.Has("max-runs")) return kDefaultMaxRuns;
  const std::string v = a.Get("max-runs", "");
  if (v.empty() || v.size() > 18 || v.find_first_not_of("0123456789") != std::string::npos || std::stoull(v) == 0)
    throw UsageError("--max-runs: must be a positive integer (got \"" + v + "\")");
  return std::stoull(v);
}
PlanSummary PlanInto(const json& given, const std::string& spec_path, const std::string& db, bool dry_run,
                     std::uint64_t max_runs, CampaignSpec& spec, std::optional<CampaignEstimate>* estimate, int jobs) {
  json j = given;
#ifdef GRANARY_HAVE_ANALYSIS
  // Coarse-grained stress fields need contact frames: the runs write them.
  try {
    j = analysis::WithFieldsOutput(given);
  } catch (const std::invalid_argument& e) {
    throw UsageError(spec_path + ": " + e.what());
  }
  if (j != given && estimate)
    std::cerr << spec_path << ": /report/fields asks for stress maps or force chains: the runs also write contact "
              << "frames (/base/output/contact_forces: true; the disk estimate counts them)\n";
#endif
  try {
    spec = CampaignSpec::FromJson(j);
  } catch (const SpecError& e) {
    throw SpecError(e.Path(), e.Message() + " [" + spec_path + "]");
  }
#ifdef GRANARY_HAVE_ANALYSIS
  try {
    analysis::CheckReportSpec(j);
    analysis::CheckMetricReferences(j);
  } catch (const std::invalid_argument& e) {
    throw UsageError(spec_path + ": " + e.what());
  }
#endif
  std::vector<PlannedRun> runs;
  try {
    runs = Expand(spec, DefaultCacheDir(), max_runs, spec.replica_rule.max);
  } catch (const SpecError& e) {
    throw SpecError(e.Path(), e.Message() + " [" + spec_path + "]");
  }
  // A dry run against a database that does not exist compares with an empty one in memory:
  // it creates no file.
  if (!dry_run) {
    // plan makes the database, and its runs/ beside it, where it is told: like mkdir -p.
    std::error_code ec;
    fs::create_directories(DbDir(db), ec);
    if (ec)
      throw UsageError("campaign plan: cannot make the directory " + DbDir(db).string() + " for --db " + db + ": " +
                       ec.message());
  }
  Store store(dry_run && !fs::exists(db) ? std::string(":memory:") : db);
  // Adaptive replicas: the first `min` per point, and those a runner added keep their place.
  runs = WithAddedReplicas(store, spec, std::move(runs));
  PlanSummary s = PlanCampaign(store, spec, runs, (DbDir(db) / "runs").string(), dry_run);
  if (estimate) {
    *estimate = EstimateRuns(runs, &store, ExeDir(), jobs, true,
                             [](const std::string& line) { std::cerr << line << std::endl; });
  }
  return s;
}

namespace {

// The estimate under the plan: totals, then one line per point.
void PrintEstimate(std::ostream& out, const CampaignEstimate& e,
                   const std::map<std::string, std::string>& short_names) {
  const bool timed = e.calibration.Valid();
  out << "estimate: " << (timed ? CoreHoursText(e.core_s_low, e.core_s_high) : std::string("core-hours unknown"));
  if (timed) {
    out << ", wall " << Duration(e.wall_s_low);
    if (e.wall_s_high > 1.05 * e.wall_s_low) out << "-" << Duration(e.wall_s_high);
    out << " on " << e.jobs << (e.jobs == 1 ? " job" : " jobs");
  }
  out << ", disk " << BytesText(e.bytes_low, e.bytes_high) << "\n";
  out << "  how: " << e.method << "\n";
  // Columns as wide as their widest cell, so a long label or range never runs into the next.
  struct Row {
    std::string label, runs, cost, disk, note;
  };
  std::vector<Row> rows;
  std::size_t label_w = 5, cost_w = 10;  // "point", "core-hours"
  for (const PointEstimate& p : e.points) {
    Row r;
    r.label = CompactPoint(p.point, short_names);
    if (r.label.empty()) r.label = "(base)";
    if (e.points.size() > 1 && p.engine != "native") r.label += " [" + p.engine + "]";
    r.runs = std::to_string(p.runs);
    r.cost = timed ? CoreHoursText(p.core_s_low, p.core_s_high) : std::string("?");
    r.disk = BytesText(p.bytes_low, p.bytes_high);
    r.note = p.open_end ? "  (ends at a clog or discharge: range)" : "";
    label_w = std::max(label_w, r.label.size());
    cost_w = std::max(cost_w, r.cost.size());
    rows.push_back(std::move(r));
  }
  const auto line = [&](const std::string& label, const std::string& runs, const std::string& cost,
                        const std::string& disk, const std::string& note) {
    out << "  " << std::left << std::setw(static_cast<int>(label_w)) << label << std::right << std::setw(6) << runs
        << "  " << std::left << std::setw(static_cast<int>(cost_w)) << cost << "  " << disk << note << "\n";
  };
  line("point", "runs", "core-hours", "disk", "");
  for (const Row& r : rows) line(r.label, r.runs, r.cost, r.disk, r.note);
  out << std::right;
}

json Extensions(const std::vector<PlanSummary::Extension>& list) {
  json out = json::array();
  for (const auto& e : list) out.push_back({{"from", e.from}, {"to", e.to}});
  return out;
}

}  // namespace

void PrintPlan(std::ostream& out, const CampaignSpec& spec, const PlanSummary& s, bool dry_run) {
  out << "campaign " << spec.name << (dry_run ? " (dry run: nothing stored)" : "") << "\n";
  const std::map<std::string, std::string> short_names = ShortAxisNames(spec.raw);
  out << "  axis                                      values\n";
  for (const auto& axis : s.axes) {
    const auto named = short_names.find(axis);
    const std::string label = named != short_names.end() && named->second != axis ? named->second + "  " + axis : axis;
    const auto& vals = s.axis_values.count(axis) ? s.axis_values.at(axis) : std::vector<json>{};
    std::string list;
    for (std::size_t i = 0; i < vals.size() && i < 8; ++i) list += (i ? ", " : "") + vals[i].dump();
    if (vals.size() > 8) list += ", ...";
    out << "  " << std::left << std::setw(40) << label << "  " << vals.size() << ": " << list << "\n";
  }
  if (spec.engines.size() > 1) {
    std::string names;
    for (const auto& e : spec.engines) names += (names.empty() ? "" : ", ") + e;
    out << "  points " << s.points / static_cast<int>(spec.engines.size()) << " x engines " << spec.engines.size()
        << " (" << names << ") x replicas " << spec.replicas << " = " << s.total << " runs\n";
  } else {
    out << "  points " << s.points << " x replicas " << spec.replicas << " = " << s.total << " runs\n";
  }
  if (spec.replica_rule.Adaptive())
    out << "  adaptive replicas: " << spec.replica_rule.Text() << " (campaign run adds them; " << s.total
        << " runs planned now, counting those a runner added)\n";
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

namespace {

int Plan(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "plan");
  if (a.positional.size() != 1)
    throw UsageError("campaign plan: needs exactly one SPEC file (see campaign plan --help)");
  const std::string spec_path = a.positional[0];
  CampaignSpec spec;
  std::optional<CampaignEstimate> estimate;
  const int jobs = a.Integer("jobs", static_cast<int>(std::max(1u, std::thread::hardware_concurrency())), 1);
  const PlanSummary s = PlanInto(ReadSpecFile("plan", spec_path), spec_path, DbPath(a), a.Has("dry-run"), MaxRuns(a),
                                 spec, &estimate, jobs);
  if (a.Has("json")) {
    json axes = json::object();
    for (const auto& [axis, values] : s.axis_values) axes[axis] = values;
    out << json{{"campaign", spec.name},
                {"runs", s.total},
                {"points", s.points},
                {"replicas", spec.replicas},
                {"engines", spec.engines},
                {"added", s.added},
                {"unchanged", s.unchanged},
                {"revived", s.revived},
                {"retired", s.retired},
                {"axes", axes},
                {"dry_run", a.Has("dry-run")},
                {"extended", Extensions(s.extended)},
                {"estimate", to_json(*estimate)},
                {"replica_rule", spec.replica_rule.Adaptive() ? json(spec.replica_rule.Text()) : json(nullptr)}}
               .dump(2)
        << "\n";
    return 0;
  }
  PrintPlan(out, spec, s, a.Has("dry-run"));
  PrintEstimate(out, *estimate, ShortAxisNames(spec.raw));
  return 0;
}

}  // namespace

Verb PlanVerb() {
  return {"plan",
          "expand a campaign spec into runs in the database",
          kPlanHelp,
          Plan,
          {{"db", true}, {"dry-run", false}, {"json", false}, {"max-runs", true}, {"jobs", true}, {"help", false}},
          Operand::kFile};
}

}  // namespace granary::runner::cli
