// `campaign report`, `export` and `compare`: the analysed campaign. Flags in docs/cli.md.

#include <unistd.h>

#include <functional>
#include <memory>
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

#include "runner/campaign_db.h"
#include "runner/cli/common.h"
#include "runner/cli/plan.h"
#include "runner/cli/report.h"
#include "runner/cli/run.h"
#include "runner/store.h"
#include "runner/scheduler.h"
#include "rundir/files.h"
#include "rundir/manifest.h"
#ifdef GRANARY_HAVE_ANALYSIS
#include "analysis/expectations.h"
#include "analysis/export.h"
#include "analysis/registry.h"
#include "analysis/report.h"
#endif
#ifdef GRANARY_HAVE_RENDER
#include "render/run_picture.h"
#endif

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char kReportHelp[] =
    "usage: campaign report [--db FILE] [--out DIR] [--only FILTER]... [--no-figures]\n"
    "Write report.md, report.html, figures and CSVs of the finished runs (default DIR:\n"
    "<db dir>/report). Each run is first checked against the manifest its engine wrote; a\n"
    "damaged run (a file cut, changed or missing) is left out of every number and listed on\n"
    "stderr and in the report.\n"
    "  --out DIR      the report's folder\n"
    "  --only FILTER  report only these runs (as for campaign run; repeat for several)\n"
    "  --no-figures   no gnuplot figures (faster)\n"
    "Exit: 0 written, 4 written but some finished runs are damaged (left out), 5 no finished\n"
    "run to analyse (an empty report), 2 usage error, 3 storage error.\n";

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

// The finished runs an analysis left out, on stderr: every damaged run with each file and
// what differs, every unreadable one, and how many used runs could not be verified.
void SayRunsKeptOut(const analysis::CampaignView& v, const std::string& verb, std::ostream& err) {
  for (const auto& [r, problems] : v.damaged) {
    err << verb << ": run " << r->run_id << " (" << CompactPoint(r->point) << " r" << r->replica
        << ") is damaged and left out:\n";
    for (const rundir::FileProblem& p : problems) err << "    " << p.file << ": " << p.what << "\n";
  }
  for (const auto& [r, why] : v.unreadable)
    err << verb << ": run " << r->run_id << " (" << CompactPoint(r->point) << " r" << r->replica
        << ") is unreadable and left out: " << why << "\n";
  if (!v.unverifiable.empty())
    err << verb << ": " << v.unverifiable.size() << " of " << v.used.size()
        << " used runs are not verifiable (written before engines recorded manifest.json; first: "
        << v.unverifiable.front()->run_id << ")\n";
}

// Loads the campaign in `db`, analyses its finished runs (each run's cache first, runs in
// parallel) and stores their per-run metrics in the database (table metrics).
// With `only` (--only filters), the selected runs alone.
// `store_results` false: read the database only (status).
std::unique_ptr<AnalysedCampaign> AnalyseCampaignIn(const std::string& db, const std::string& verb, std::ostream& err,
                                                    const std::vector<std::string>& only = {},
                                                    bool store_results = true) {
  const auto opened = OpenCampaignDb(db, verb, verb == "report" || verb == "export" || !store_results);
  Store& store = *opened;
  const auto campaign = LoadCampaign(store);
  if (!campaign) throw UsageError("campaign " + verb + ": " + db + " holds no campaign");
  std::vector<RunRow> runs = LoadRuns(store, true);
  if (!only.empty()) {
    try {
      const RunFilter filter = ResolveFilters(only, *campaign, runs);
      std::erase_if(runs, [&](const RunRow& r) { return !filter.Matches(r); });
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
    if (r.state == RunState::kRetired) continue;
    analysis::RunRecord rec;
    rec.run_id = r.run_id;
    rec.state = ToString(r.state);
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
    c->setup = analysis::SetupAnalyses(campaign->spec);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("campaign spec: ") + e.what());
  }
  analysis::CampaignAnalysisOptions options;
  options.progress = AnalysisProgress(err);
  c->analysis = analysis::AnalyseCampaign(c->info, c->records, c->setup, options);
  if (!store_results) return c;
  std::vector<RunMetrics> rows;
  const analysis::CampaignAnalysis& a = *c->analysis;
  for (std::size_t u = 0; u < a.view.used.size(); ++u)
    for (std::size_t k = 0; k < c->setup.analyses.size(); ++k) {
      if (a.results[k].runs[u].is_null()) continue;
      const analysis::Analysis& an = *c->setup.analyses[k];
      RunMetrics rm{a.view.used[u].record->run_id, an.Key(), an.Version(), an.RunOptions(), {}};
      for (const analysis::Metric& m : a.RunMetrics(k, u)) rm.metrics.push_back({m.name, m.unit, m.value, m.se});
      rows.push_back(std::move(rm));
    }
  if (store.IsReadOnly()) {
    err << verb << ": the database " << db << " cannot be written here (read-only): the metrics are not stored in it\n";
  } else {
    StoreMetrics(store, rows, NowSeconds());
    // A damaged run's metrics stored by an earlier report are no longer numbers of the campaign.
    std::vector<std::string> damaged;
    for (const auto& [r, problems] : a.view.damaged) damaged.push_back(r->run_id);
    ForgetMetrics(store, damaged);
  }
  SayRunsKeptOut(a.view, verb, err);
  return c;
}

}  // namespace

std::optional<std::string> ExpectationCounts(const std::string& db, std::ostream& err,
                                             const std::vector<std::string>& only) {
  {
    const auto opened = OpenCampaignDb(db, "status", true);
    const auto campaign = LoadCampaign(*opened);
    if (!campaign || !campaign->spec.is_object() || !campaign->spec.contains("expect")) return std::nullopt;
  }
  const auto c = AnalyseCampaignIn(db, "status", err, only, false);
  try {
    return analysis::ToString(analysis::Count(analysis::Reproduce(*c->analysis)->results));
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("campaign spec: ") + e.what());
  }
}

namespace {

#ifdef GRANARY_HAVE_RENDER
// A figure's marks as the renderer draws them.
std::vector<render::Mark> MarksOf(const std::vector<analysis::PictureMark>& marks) {
  std::vector<render::Mark> out;
  for (const analysis::PictureMark& m : marks) {
    using K = analysis::PictureMark::Kind;
    const render::Mark::Kind kind = m.kind == K::kRect        ? render::Mark::Kind::kRect
                                    : m.kind == K::kDimension ? render::Mark::Kind::kDimension
                                    : m.kind == K::kDiscs     ? render::Mark::Kind::kDiscs
                                                              : render::Mark::Kind::kOrigin;
    out.push_back({kind, m.x0, m.y0, m.x1, m.y1, m.label, m.shade, m.labels});
  }
  return out;
}
#endif

// The report of the campaign in `db`.
analysis::ReportSummary WriteReportOf(const std::string& db, const fs::path& out_dir, bool figures, std::ostream& err,
                                      const std::vector<std::string>& only = {}) {
  const auto c = AnalyseCampaignIn(db, "report", err, only);
  analysis::ReportOptions options;
  options.out_dir = out_dir;
  options.figures = figures;
#ifdef GRANARY_HAVE_RENDER
  options.draw_run = [](const fs::path& run_dir, const analysis::ReportOptions::RunPicture& picture,
                        const fs::path& png) {
    render::PictureOptions o;
    o.pick.kind =
        picture.kind == analysis::ReportOptions::Picture::kBed ? render::FramePick::kFirst : render::FramePick::kLast;
    o.marks = MarksOf(picture.marks);
    if (picture.colour_by_disc) o.colour = render::Colour::kDisc;
    if (picture.window)
      o.window = render::Window{(*picture.window)[0], (*picture.window)[1], (*picture.window)[2], (*picture.window)[3]};
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
    o.marks = MarksOf(picture.marks);
    if (picture.colour_by_disc) o.colour = render::Colour::kDisc;
    try {
      const render::Window window{picture.x_lo, picture.x_hi, picture.y_lo, picture.y_hi};
      render::WritePng(render::ClogScene(run_dir, picture.clog, o, window), 480, png);
      return std::string();
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
  };
#endif
  // One report at a time into one folder: a second waits, and says so (two writing at once
  // left report.md without some figure links).
  fs::create_directories(out_dir);
  const FileLock lock(out_dir / ".report.lock", [&] {
    err << "report: another campaign report is writing " << out_dir.string() << "; waiting for it to finish\n"
        << std::flush;
  });
  return analysis::WriteReport(*c->analysis, options);
}
#endif

int Report(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args a = Parse(argv, "report");
  if (!a.positional.empty()) throw UsageError("campaign report: unexpected argument \"" + a.positional[0] + "\"");
  const std::string db = DbPath(a);
#ifdef GRANARY_HAVE_ANALYSIS
  const auto summary = WriteReportOf(db, a.Has("out") ? fs::path(a.Get("out", "")) : DbDir(db) / "report",
                                     !a.Has("no-figures"), err, a.All("only"));
  out << "report: " << summary.markdown.string() << "\n        " << summary.html.string() << "\n  runs used "
      << summary.runs_used << ", missing " << summary.runs_missing << ", failed " << summary.runs_failed
      << (summary.runs_damaged > 0
              ? ", damaged " + std::to_string(summary.runs_damaged) + " (left out; listed above and in the report)"
              : std::string())
      << (summary.runs_lost > 0 ? ", lost " + std::to_string(summary.runs_lost) +
                                      " (done, run directory deleted: campaign run --rerun-lost)"
                                : std::string())
      << (summary.runs_unverifiable > 0 ? ", not verifiable " + std::to_string(summary.runs_unverifiable)
                                        : std::string())
      << "\n"
      << "  analysis results: " << summary.results_from_cache << " from the runs' caches, " << summary.results_computed
      << " computed\n";
  if (!summary.expectations.empty()) out << "  expectations: " << summary.expectations << " (Key results)\n";
  if (summary.runs_used == 0) {
    err << "report: no finished run to analyse: the report has no numbers (campaign status says where the runs are)\n";
    return kExitNothingToAnalyse;
  }
  return summary.runs_damaged > 0 ? kExitDamagedRuns : 0;
#else
  (void)out;
  (void)err;
  throw UsageError("campaign report: this build has no analysis library (granary_analysis)");
#endif
}

// ---------------------------------------------------------------- export
const char kExportHelp[] =
    "usage: campaign export [--db FILE] [--format csv|json] [--level run|point] [--expectations] [--out FILE]\n"
    "                       [--only FILTER]...\n"
    "Analyse the finished runs (each run's cached results are reused) and write their metrics as\n"
    "one tidy table: one row per run, or per sweep point; each swept parameter a column named by\n"
    "its short name (W, X_db, D_b), each derived axis of the spec's /axes, each metric and its se\n"
    "(per point also n) numeric columns. The per-run metrics are stored in the database too (table\n"
    "metrics, view run_metrics; docs/data.md shows both read with pandas).\n"
    "  --db FILE         database (default granary.db)\n"
    "  --format F        csv (default) or json (an array of objects)\n"
    "  --level L         run (default) or point\n"
    "  --expectations    the reproduction table instead: each expected value of the spec's /expect\n"
    "                    with the measured value, se, n, runs and the verdict (agrees, disagrees,\n"
    "                    not enough runs), as in the report's Key results\n"
    "  --out FILE        write there (default: standard output)\n"
    "  --only FILTER     only these runs (as for campaign run; repeat for several)\n"
    "Damaged runs (a file differs from the engine's manifest) and unreadable ones are left out\n"
    "and named on stderr.\n"
    "Exit: 0 written, 4 written but some finished runs are damaged (left out), 5 no finished\n"
    "run to analyse (no rows), 2 usage error, 3 storage error.\n";

int Export(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args a = Parse(argv, "export");
  if (!a.positional.empty()) throw UsageError("campaign export: unexpected argument \"" + a.positional[0] + "\"");
  const std::string format = a.Get("format", "csv"), level = a.Get("level", "run");
  if (format != "csv" && format != "json") throw UsageError("--format: must be csv or json (got \"" + format + "\")");
  if (level != "run" && level != "point") throw UsageError("--level: must be run or point (got \"" + level + "\")");
  const std::string db = DbPath(a);
#ifdef GRANARY_HAVE_ANALYSIS
  if (a.Has("expectations") && a.Has("level")) throw UsageError("--expectations: a table of its own; drop --level");
  const auto c = AnalyseCampaignIn(db, "export", err, a.All("only"));
  analysis::ExportTable table;
  if (a.Has("expectations")) {
    std::unique_ptr<analysis::Reproduction> r;
    try {
      r = analysis::Reproduce(*c->analysis);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("campaign spec: ") + e.what());
    }
    if (r->expectations.empty())
      throw UsageError("--expectations: the campaign spec has no \"expect\" (docs/analyses.md)");
    table = analysis::ExpectationsTable(r->results);
  } else {
    table = analysis::MakeExportTable(*c->analysis,
                                      level == "run" ? analysis::ExportLevel::kRun : analysis::ExportLevel::kPoint);
  }
  const std::string text = format == "csv" ? analysis::ToCsv(table) : analysis::to_json(table).dump(2) + "\n";
  if (a.Has("out")) {
    WriteAtomically(a.Get("out", ""), text);
    const std::string what = a.Has("expectations") ? "expectation" : level;
    err << "export: " << table.rows.size() << " " << what << (table.rows.size() == 1 ? "" : "s") << " to "
        << a.Get("out", "") << "\n";
  } else {
    out << text;
  }
  const analysis::CampaignView& view = c->analysis->view;
  if (view.used.empty()) {
    err << "export: no finished run to analyse: the table has no rows (campaign status says where the runs are)\n";
    return kExitNothingToAnalyse;
  }
  return view.damaged.empty() ? 0 : kExitDamagedRuns;
#else
  (void)out;
  (void)err;
  throw UsageError("campaign export: this build has no analysis library (granary_analysis)");
#endif
}

// ---------------------------------------------------------------- compare
const char kCompareHelp[] =
    "usage: campaign compare SPEC [--db FILE] [--jobs N] [--no-run] [--out DIR] [--no-figures] [--json]\n"
    "                        [--threads-per-run T] [--time-limit S] [--retries K] [--max-runs N]\n"
    "Plan the campaign SPEC on two or three engines: those its \"engine\" lists when it lists two or\n"
    "three (e.g. [\"native\", \"lammps\"]), otherwise native and liggghts; the comparison is of\n"
    "native (or the first engine) with the next one,\n"
    "run what is not done (finished runs are reused: native runs of an earlier single-engine plan\n"
    "of the same spec count), write the report with its engine-comparison section, and print per\n"
    "point and metric both values, their ratio and whether they agree within 2 combined standard\n"
    "errors, plus wall time and disc-steps per second per engine.\n"
    "  --db FILE     database (default granary.db)\n"
    "  --no-run      compare what has finished, run nothing\n"
    "  --out DIR     report folder (default <db dir>/report)\n"
    "  --json        print the comparison as JSON (progress goes to stderr)\n"
    "  --jobs, --threads-per-run, --time-limit, --retries: as for campaign run\n"
    "  --max-runs N  as for campaign plan\n"
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
      << "ratio"
      << "agree\n";
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
  if (unknown) out << "  n/a: a value without a standard error (one replica) cannot be judged; plan more replicas\n";
  double rate_a = 0;
  for (const json& e : c.at("costs")) {
    const json& r = e.at("disc_steps_per_s");
    const double rate = r.at("mean").is_number() ? r.at("mean").get<double>() : 0.0;
    if (e.at("engine") == a) rate_a = rate;
    out << "  " << std::left << std::setw(9) << e.at("engine").get<std::string>() << " " << e.at("runs").get<int>()
        << " runs, wall " << Duration(e.at("wall_s").get<double>()) << " (discharge "
        << Duration(e.at("discharge_wall_s").get<double>()) << "), " << std::setprecision(3) << rate / 1e6
        << " M disc-steps/s per run";
    if (e.at("engine") != a && rate > 0)
      out << "; " << a << " is " << std::setprecision(3) << rate_a / rate << "x faster";
    out << "\n";
  }
}
#endif

int Compare(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args a = Parse(argv, "compare");
  if (a.positional.size() != 1)
    throw UsageError("campaign compare: needs exactly one SPEC file (see campaign compare --help)");
#ifdef GRANARY_HAVE_ANALYSIS
  const std::string spec_path = a.positional[0];
  json j = ReadSpecFile("compare", spec_path);
  if (j.is_object() && !(j.contains("engine") && j["engine"].is_array() && j["engine"].size() >= 2)) {
    j["engine"] = json::array({"native", "liggghts"});
    if (j.contains("base") && j["base"].is_object()) j["base"].erase("engine");  // both, whatever it says
  }
  const CampaignRunOptions o = RunOptionsFrom(a);
  const std::string db = DbPath(a);
  // With --json, stdout carries only the JSON document.
  std::ostream& progress = a.Has("json") ? err : out;
  CampaignSpec spec;
  const PlanSummary s = PlanInto(j, spec_path, db, false, MaxRuns(a), spec);
  PrintPlan(progress, spec, s, false);
  int code = 0;
  if (!a.Has("no-run")) {
    code = RunAll(db, o, progress);
    if (code == static_cast<int>(ExitCode::kInterrupted)) return code;
  }
  const auto summary =
      WriteReportOf(db, a.Has("out") ? fs::path(a.Get("out", "")) : DbDir(db) / "report", !a.Has("no-figures"), err);
  if (a.Has("json")) {
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

}  // namespace

Verb ReportVerb() {
  return {"report",
          "write the campaign report (markdown, html, figures, CSV)",
          kReportHelp,
          Report,
          {{"db", true}, {"out", true}, {"only", true}, {"no-figures", false}, {"help", false}}};
}

Verb ExportVerb() {
  return {"export",
          "write every run's (or point's) metrics as one CSV or JSON table",
          kExportHelp,
          Export,
          {{"db", true},
           {"format", true},
           {"level", true},
           {"expectations", false},
           {"out", true},
           {"only", true},
           {"help", false}}};
}

Verb CompareVerb() {
  return {"compare",
          "run a campaign on both engines and compare them point by point",
          kCompareHelp,
          Compare,
          {{"db", true},
           {"jobs", true},
           {"no-run", false},
           {"out", true},
           {"no-figures", false},
           {"json", false},
           {"threads-per-run", true},
           {"time-limit", true},
           {"retries", true},
           {"max-runs", true},
           {"help", false}},
          Operand::kFile};
}

}  // namespace granary::runner::cli
