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
#include <vector>

#include "runner/store.h"
#ifdef GRANARY_HAVE_ANALYSIS
#include "analysis/fields_analysis.h"
#include "analysis/report.h"
#endif

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char kPlanHelp[] =
    "usage: campaign plan SPEC [--db FILE] [--dry-run] [--json] [--max-runs N]\n"
    "Expand the campaign spec SPEC into runs and store them in the database (default granary.db).\n"
    "Planning the same spec again changes nothing; runs no longer in an edited spec are retired\n"
    "(their results are kept), new ones are added.\n"
    "  --db FILE    database (created if missing); run directories go to <db dir>/runs/<run id>/\n"
    "  --dry-run    validate and show what would change, store nothing\n"
    "  --json       print the summary as JSON\n"
    "  --max-runs N refuse a sweep of more than N runs (default 100000), before expanding it\n"
    "Exit: 0 planned (or the dry run shown), 2 spec or usage error (the message names the JSON\n"
    "path, or FILE:LINE:COLUMN), 3 storage error.\n";

}  // namespace

json ReadSpecFile(const std::string& verb, const std::string& spec_path) {
  std::ifstream in(spec_path, std::ios::binary);
  if (!in) throw UsageError("campaign " + verb + ": cannot read " + spec_path);
  std::stringstream text;
  text << in.rdbuf();
  try {
    json spec = parse_spec_text(text.str(), spec_path);
    resolve_spec_paths(spec, spec_path);
    return spec;
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
PlanSummary PlanInto(const json& given, const std::string& spec_path, const std::string& db, bool dry_run,
                     std::uint64_t max_runs, CampaignSpec& spec) {
  json j = given;
#ifdef GRANARY_HAVE_ANALYSIS
  // Coarse-grained stress fields need contact frames: the runs write them.
  try {
    j = analysis::with_fields_output(given);
  } catch (const std::invalid_argument& e) {
    throw UsageError(spec_path + ": " + e.what());
  }
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
  return plan_campaign(store, spec, runs, (DbDir(db) / "runs").string(), dry_run);
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
}

namespace {

int Plan(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "plan");
  if (a.positional.size() != 1) throw UsageError("campaign plan: needs exactly one SPEC file (see campaign plan --help)");
  const std::string spec_path = a.positional[0];
  CampaignSpec spec;
  const PlanSummary s =
      PlanInto(ReadSpecFile("plan", spec_path), spec_path, DbPath(a), a.has("dry-run"), MaxRuns(a), spec);
  if (a.has("json")) {
    json axes = json::object();
    for (const auto& [axis, values] : s.axis_values) axes[axis] = values;
    out << json{{"campaign", spec.name}, {"runs", s.total},         {"points", s.points},   {"replicas", spec.replicas},
                {"engines", spec.engines}, {"added", s.added},      {"unchanged", s.unchanged}, {"revived", s.revived},
                {"retired", s.retired},  {"axes", axes},            {"dry_run", a.has("dry-run")}}
               .dump(2)
        << "\n";
    return 0;
  }
  PrintPlan(out, spec, s, a.has("dry-run"));
  return 0;
}

}  // namespace

Verb PlanVerb() {
  return {"plan", "expand a campaign spec into runs in the database", kPlanHelp, Plan,
          {{"db", true}, {"dry-run", false}, {"json", false}, {"max-runs", true}, {"help", false}},
          Operand::kFile};
}

}  // namespace granary::runner::cli
