// `write_report`: key results and the spec's figures, each analysis' section (registry order),
// the engine comparison, then the campaign view's sections and the gallery; rendered by
// report_document.h.
#include "analysis/report.h"

#include <array>
#include <algorithm>
#include <cmath>
#include <ctime>
#include <map>
#include <optional>
#include <unistd.h>

#include "analysis/arches_analysis.h"
#include "analysis/engine_comparison.h"
#include "analysis/expectations.h"
#include "analysis/figures.h"
#include "analysis/stats.h"
#include "analysis/report_document.h"
#include "analysis/system.h"
#include "rundir/replica_rule.h"
#include "rundir/version.h"

namespace granary::analysis {
namespace {

std::string StateReason(const RunRecord& r) {
  std::string f = r.failure;
  if (f.size() > 300) f = f.substr(0, 300) + "...";
  for (char& ch : f)
    if (ch == '\n' || ch == '\r') ch = ' ';
  return f;
}

std::optional<Section> RunsSection(const CampaignView& c) {
  Section s{"runs", "Runs", {}};
  const int total = static_cast<int>(c.used.size() + c.missing.size() + c.failed.size() + c.unreadable.size() +
                                     c.damaged.size() + c.lost.size() + c.retired.size());
  s.blocks.push_back(
      Text{std::to_string(total) + " runs in the campaign: **" + std::to_string(c.used.size()) + " used**, " +
           std::to_string(c.missing.size()) + " missing (not finished), " + std::to_string(c.failed.size()) +
           " failed, " + std::to_string(c.unreadable.size()) + " finished but unreadable, " +
           (c.damaged.empty() ? std::string()
                              : "**" + std::to_string(c.damaged.size()) +
                                    " finished but damaged** (a file differs from what the engine "
                                    "recorded; below), ") +
           (c.lost.empty() ? std::string()
                           : std::to_string(c.lost.size()) + " finished but their run directory was deleted, ") +
           std::to_string(c.retired.size()) + " retired. " +
           "Every number below is computed from the used runs only; a point with fewer replicas "
           "than planned says so in its `n`."});
  Table t{"runs_not_used", "Runs not used, with the reason", {"run", "point", "replica", "state", "reason"}, {}, {}};
  auto row = [&](const RunRecord* r, const std::string& reason) {
    t.rows.push_back(
        {r->run_id, PointLabel(c, r->point, r->spec, NameForm::kShort), Cell::Count(r->replica), r->state, reason});
  };
  for (const RunRecord* r : c.missing) row(r, r->failure.empty() ? "not finished" : "not finished: " + StateReason(*r));
  for (const RunRecord* r : c.failed) row(r, StateReason(*r));
  for (const auto& [r, why] : c.unreadable) row(r, "unreadable: " + why);
  for (const auto& [r, problems] : c.damaged)
    row(r, "damaged: " + rundir::Verification{rundir::Integrity::kDamaged, problems, 0}.Text());
  for (const RunRecord* r : c.lost)
    row(r, "run directory deleted after it finished (campaign run --rerun-lost runs it again)");
  for (const RunRecord* r : c.retired) row(r, "retired (superseded)");
  if (!t.rows.empty()) s.blocks.push_back(t);
  if (!c.damaged.empty()) {
    s.blocks.push_back(
        Text{"**Damaged runs.** These runs finished, but their files no longer are what the engine "
             "recorded when it finished (`manifest.json`: sizes, checksums, counts of frames, events "
             "and clogs): cut short, changed or missing. They are kept out of every number of this "
             "report, of `campaign export` and of `campaign status`. Restore the files, or delete a "
             "run's directory and `campaign run --rerun-lost` runs it again."});
    Table d{"damaged_runs",
            "Damaged runs: each file that differs and how",
            {"run", "point", "replica", "file", "what differs"},
            {},
            {}};
    for (const auto& [r, problems] : c.damaged)
      for (const rundir::FileProblem& p : problems)
        d.rows.push_back(
            {r->run_id, PointLabel(c, r->point, r->spec, NameForm::kShort), Cell::Count(r->replica), p.file, p.what});
    s.blocks.push_back(d);
  }
  if (!c.unverifiable.empty())
    s.blocks.push_back(Text{std::to_string(c.unverifiable.size()) +
                            " of the used runs are **not verifiable**: they were "
                            "written before engines recorded a manifest of their files, so a file cut or changed "
                            "since cannot be told from a whole one (only `events.csv` against `summary.json` is "
                            "checked). First of them: `" +
                            c.unverifiable.front()->run_id + "`."});
  return s;
}

// Adaptive replicas (rundir/replica_rule.h): the stopping rule, and per point its targets as
// the used runs reach them; a point that got `max` replicas without reaching one is marked.
std::optional<Section> ReplicasSection(const CampaignAnalysis& ca) {
  const CampaignView& c = ca.view;
  const nlohmann::json& spec = c.campaign->spec;
  if (!spec.is_object() || !spec.contains("replicas") || !spec["replicas"].is_object()) return std::nullopt;
  ReplicaRule rule;
  try {
    rule = ReplicaRule::FromJson(spec["replicas"]);
  } catch (const std::exception&) {
    return std::nullopt;  // the runner validated it when it was planned
  }
  Section s{"replicas", "Replicas: the stopping rule", {}};
  s.blocks.push_back(Text{
      "Replicas were added adaptively: " + rule.Text() +
      ". After every finished run the runner judges each point whose runs have all ended and plans more where a "
      "target is not met (as many as se ~ 1/sqrt(n) says it needs, at most doubling). The number of runs per point "
      "is therefore itself random, and stopping when the standard error looks small favours stretches of runs that "
      "happened to agree: the se of a point that stopped at its target is slightly optimistic, and a mean whose "
      "spread grows with its size (avalanche sizes) is biased low by a term of order 1/n. The `min` pilot runs keep "
      "n from stopping on one or two lucky runs; the bias is small against the se at the targets used here "
      "(docs/analyses.md \"Sequential stopping\"). Points marked **max reached** stopped at `max` without reaching "
      "their target: their se is larger than asked for."});
  std::map<std::string, int> planned;
  for (const UsedRun& u : c.used) ++planned[u.record->point_id];
  for (const RunRecord* r : c.missing) ++planned[r->point_id];
  for (const RunRecord* r : c.failed) ++planned[r->point_id];
  std::vector<std::string> header = {"point", "runs used", "runs planned"};
  for (const ReplicaTarget& t : rule.until)
    header.insert(header.end(), {t.metric, (t.relative ? "se/|" + t.metric + "|" : "se(" + t.metric + ")") +
                                               " (target " + Cell::Number(t.value, 3).Shown() + ")"});
  header.push_back("verdict");
  Table t{"replicas", "Adaptive replicas per point: each target and how far the point got", header, {}, {}};
  for (std::size_t p = 0; p < c.points.size(); ++p) {
    std::map<std::string, MetricEstimate> metrics;
    for (const PointMetric& m : ca.AllPointMetrics(p)) metrics[m.name] = {m.mean, m.se, m.n};
    const std::vector<TargetStatus> targets = JudgeTargets(rule, metrics);
    const int n_planned = planned[c.points[p].id];
    std::vector<Cell> row = {PointLabel(c, c.points[p].point, c.points[p].spec, NameForm::kShort),
                             Cell::Count(static_cast<long long>(c.points[p].runs.size())), Cell::Count(n_planned)};
    bool met = true;
    for (const TargetStatus& x : targets) {
      row.push_back(Cell::Estimate(x.estimate.value, x.estimate.se, x.estimate.n));
      row.push_back(Cell::Number(x.achieved, 3));
      met = met && x.met;
    }
    row.push_back(met                     ? "met"
                  : n_planned >= rule.max ? "**max reached, target not met**"
                                          : "not yet (more runs planned or to plan)");
    t.rows.push_back(std::move(row));
  }
  s.blocks.push_back(t);
  return s;
}

std::optional<Section> ProvenanceSection(const CampaignView& c) {
  Section s{"provenance", "Provenance", {}};
  const CampaignInfo& k = *c.campaign;
  auto or_unknown = [](const std::string& v) { return v.empty() ? std::string("unknown") : v; };
  std::string text = "Campaign `" + or_unknown(k.name) + "`, spec hash `" + or_unknown(k.spec_hash) +
                     "`; report written by Granary " + or_unknown(k.granary_version) + " (commit `" +
                     or_unknown(k.git_commit) + "`)";
  text += std::string(", analysis library built from commit `") + granary::GitCommit() + "`";
  {
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    gmtime_r(&now, &utc);
    char stamp[32];
    std::strftime(stamp, sizeof stamp, "%Y-%m-%d %H:%M UTC", &utc);
    text += ", on " + std::string(stamp);
  }
  {
    char host[256] = {};
    if (gethostname(host, sizeof host - 1) == 0 && host[0] != '\0') text += " on host `" + std::string(host) + "`";
  }
  text += ". Sweep axes: ";
  for (std::size_t i = 0; i < k.axes.size(); ++i) text += (i ? ", " : "") + std::string("`") + k.axes[i] + "`";
  if (k.axes.empty()) text += "none";
  text += ".";
  s.blocks.push_back(Text{text});
  // engine, version, commit, tangential cap -> runs
  std::map<std::vector<std::string>, int> rows;
  for (const UsedRun& a : c.used)
    ++rows[{a.summary.engine, a.summary.engine_version, a.summary.granary_commit, a.tangential_cap}];
  Table t{"provenance",
          "Engines that produced the used runs",
          {"engine", "engine version", "granary commit", "tangential cap (/contact/tangential_cap)", "runs"},
          {},
          {"engine", "engine_version", "granary_commit", "tangential_cap", "runs"}};
  for (const auto& [key, n] : rows) t.rows.push_back({key[0], key[1], key[2], key[3], Cell::Count(n)});
  s.blocks.push_back(t);
  // What the runs cost, per engine: wall time and core-hours (wall time x threads).
  std::map<std::string, std::array<double, 3>> cost;  // engine -> runs, wall s, core s
  for (const UsedRun& a : c.used) {
    auto& e = cost[a.summary.engine];
    e[0] += 1;
    if (std::isfinite(a.timing.wall_s)) {
      e[1] += a.timing.wall_s;
      e[2] += a.timing.wall_s * std::max(1, a.timing.threads);
    }
  }
  Table ct{"provenance_cost",
           "What the used runs cost (summary.json timing; core-hours = wall time x threads)",
           {"engine", "runs", "wall time (h)", "core-hours"},
           {},
           {"engine", "runs", "wall_h", "core_hours"}};
  for (const auto& [engine, e] : cost)
    ct.rows.push_back({engine, Cell::Count(static_cast<long long>(e[0])), Cell::Number(e[1] / 3600.0, 3),
                       Cell::Number(e[2] / 3600.0, 3)});
  if (!ct.rows.empty()) s.blocks.push_back(ct);
  s.blocks.push_back(
      Text{"Tangential cap: `lammps` caps spring plus damping at mu|F_n| (LAMMPS convention, "
           "docs/model.md); `liggghts` caps only the spring part (LIGGGHTS 3.8). Runs with different "
           "caps are not the same model."});
  if (k.spec.is_object()) {
    s.blocks.push_back(Text{"The campaign spec as planned:"});
    s.blocks.push_back(Code{k.spec.dump(2)});
  }
  return s;
}

// What was simulated: the campaign's description, the units, its fixed parameters, the swept
// ones by their human names and the derived axes (the pictures are in the gallery).
std::optional<Section> SystemSection(const CampaignView& c) {
  Section s{"system", "The system", {}};
  const nlohmann::json& cs = c.campaign->spec;
  s.blocks.push_back(Text{cs.is_object() && cs.contains("description") && cs.at("description").is_string()
                              ? cs.at("description").get<std::string>()
                              : "(The campaign spec has no \"description\".)"});
  // A resolved run spec of the campaign: of a point's run, else of any run it has.
  nlohmann::json spec;
  if (!c.points.empty()) spec = c.points.front().spec;
  for (const auto* list : {&c.missing, &c.failed, &c.retired})
    if (spec.is_null() && !list->empty()) spec = list->front()->spec;
  if (spec.is_null()) return s;
  s.blocks.push_back(Text{std::string("Units (every table, figure and export): ") + kUnitsText + "."});
  s.blocks.push_back(FixedParameters(spec, c.axes));
  if (!c.named.Derived().empty()) {
    Table d{"system-derived-axes",
            "Derived axes (campaign spec /axes): usable in --only, the export and figures",
            {"name", "expression"},
            {},
            {}};
    for (const DerivedAxis& a : c.named.Derived()) d.rows.push_back({a.name, a.expression.Text()});
    s.blocks.push_back(d);
  }
  if (!c.axes.empty()) {
    Table t{"system-axes",
            "Swept parameters (short: as tables and figure keys name them)",
            {"parameter", "short", "in the run spec", "values"},
            {},
            {}};
    for (const auto& axis : c.axes) {
      std::vector<std::string> values;
      for (const Point& p : c.points) {
        const auto v = AxisValue(axis, p.point, p.spec);
        const std::string text = v ? ValueText(*v) : "?";
        if (std::find(values.begin(), values.end(), text) == values.end()) values.push_back(text);
      }
      std::string joined;
      for (const auto& v : values) joined += (joined.empty() ? "" : ", ") + v;
      t.rows.push_back({AxisName(axis, spec), AxisText(c, axis, spec, NameForm::kShort), axis,
                        joined.empty() ? "(no finished run yet)" : joined});
    }
    s.blocks.push_back(t);
  }
  // The beds the runs started from, as the engine measured them (summary.json "bed").
  {
    Table t{"system-beds",
            "The prepared beds, as the engine measured them before the outlets opened: packing fraction phi of the "
            "full-width band from 5 d above the base to 5 d below the surface, the highest disc's top, the surface "
            "(mean top of 1 d columns) and the simulated settling time; mean +- se over the point's runs (runs "
            "written before engines measured phi have none)",
            {"point", "runs", "phi", "top", "surface", "settle time"},
            {},
            {"point", "runs", "phi", "top", "surface", "settle_time"}};
    bool any = false;
    for (const Point& p : c.points) {
      std::vector<double> phi, top, surface, settle;
      for (const std::size_t i : p.runs) {
        const rundir::BedInfo& b = c.used[i].summary.bed;
        phi.push_back(b.packing_fraction.value_or(kNaN));
        surface.push_back(b.surface.value_or(kNaN));
        top.push_back(b.height > 0 ? b.height : kNaN);
        settle.push_back(b.settle_time > 0 ? b.settle_time : kNaN);
        any = any || b.packing_fraction.has_value();
      }
      t.rows.push_back({PointName(c, p), Cell::Count(static_cast<long long>(p.runs.size())),
                        Cell::Estimate(MeanSeFinite(phi), 3), Cell::Estimate(MeanSeFinite(top), 4),
                        Cell::Estimate(MeanSeFinite(surface), 4), Cell::Estimate(MeanSeFinite(settle), 3)});
    }
    if (!t.rows.empty() && any) s.blocks.push_back(t);
  }
  s.blocks.push_back(Text{"Pictures of every point (its bed and its end) are in the [gallery](#gallery) at the end."});
  return s;
}

// Each point: the bed before the outlets open and the last state of its first replica; last in
// the report, so that the results come first.
// The used run of point k with the lowest replica, or nullptr.
const UsedRun* LowestReplica(const CampaignView& c, std::size_t k) {
  const UsedRun* run = nullptr;
  for (std::size_t u : c.points[k].runs)
    if (!run || c.used[u].record->replica < run->record->replica) run = &c.used[u];
  return run;
}

// A figure's marks on `run` (none without a figure); what the run has no geometry for goes to
// not_drawn.
std::vector<PictureMark> MarksOn(const CampaignView& c, const UsedRun& run, const FigureSpec* figure,
                                 NotDrawn& not_drawn) {
  if (!figure || figure->annotate.empty()) return {};
  std::vector<std::string> problems;
  std::vector<PictureMark> marks = PictureMarksOf(*figure, c.campaign ? c.campaign->spec : nlohmann::json(), run.spec,
                                                  run.summary.bed.height, problems);
  for (const std::string& p : problems) not_drawn.Add("run " + run.record->run_id.substr(0, 10) + ": " + p);
  return marks;
}

// The outline of a figure's zoom window on the whole picture.
PictureMark ZoomMark(const std::array<double, 4>& w) {
  return {PictureMark::Kind::kRect, w[0], w[2], w[1], w[3], "zoom", false};
}

// Pictures of point k's lowest replica (`kinds`: its bed, its end, or both) as `stem`-bed.png and
// `stem`-end.png; with a figure, its marks drawn, its colouring, and its zoom as `stem`-bed-zoom.png
// besides; empty when it has no used run or nothing could be drawn (why: not_drawn).
Pictures PointPictures(const CampaignView& c, std::size_t k, const ReportOptions& options, bool bed, bool end_picture,
                       const std::string& stem, NotDrawn& not_drawn, const FigureSpec* figure = nullptr) {
  Pictures pics;
  const Point& p = c.points[k];
  const UsedRun* run = LowestReplica(c, k);
  if (!run) return pics;
  std::filesystem::create_directories(options.out_dir / "pictures");
  // In words, engine included (a campaign on two engines shows each point twice).
  const std::string label = c.axes.empty() ? std::string() : PointTitle(c, p);
  pics.caption = (label.empty() ? std::string("The silo") : label) + " (replica " +
                 std::to_string(run->record->replica) + ", run `" + run->record->run_id.substr(0, 10) + "`)";
  const std::string& end = run->summary.end_reason;
  const std::pair<ReportOptions::Picture, std::string> kinds[] = {
      {ReportOptions::Picture::kBed, "the bed before the outlets open (t = 0)"},
      {ReportOptions::Picture::kEnd, (end == "clogged"      ? "clogged"
                                      : end == "discharged" ? "discharged"
                                                            : "the last frame") +
                                         std::string(" (t = ") + FormatNumber(run->summary.t_end, 4) + ")"}};
  const std::vector<PictureMark> marks = MarksOn(c, *run, figure, not_drawn);
  for (const auto& [kind, caption] : kinds) {
    const bool is_bed = kind == ReportOptions::Picture::kBed;
    if ((is_bed && !bed) || (!is_bed && !end_picture)) continue;
    ReportOptions::RunPicture picture{kind, marks, figure && figure->colour_by_disc, std::nullopt};
    if (figure && figure->window) picture.marks.push_back(ZoomMark(*figure->window));
    const std::string file = stem + (is_bed ? "-bed.png" : "-end.png");
    const std::string problem = options.draw_run(run->record->run_dir, picture, options.out_dir / file);
    if (!problem.empty()) {
      not_drawn.Add(problem);
      continue;
    }
    pics.pictures.push_back({file, caption});
    if (!figure || !figure->window) continue;
    picture.marks = marks;
    picture.window = figure->window;
    const std::string zoom = stem + (is_bed ? "-bed-zoom.png" : "-end-zoom.png");
    const std::string zoom_problem = options.draw_run(run->record->run_dir, picture, options.out_dir / zoom);
    if (zoom_problem.empty())
      pics.pictures.push_back({zoom, caption + ", near the outlet"});
    else
      not_drawn.Add(zoom_problem);
  }
  return pics;
}

// A figure's "clog" picture of point k: the kept clog of its lowest replica with clogs whose
// arch's N_t is nearest the point's median N_t (as the arches section chooses), the arch's
// bodies outlined, in a window around the arch or the figure's own.
Pictures ClogPictureOf(const CampaignView& c, std::size_t k, const AnalysisResults& arches,
                       const ReportOptions& options, const FigureSpec& figure, NotDrawn& not_drawn) {
  Pictures pics;
  std::vector<std::size_t> runs = c.points[k].runs;
  std::sort(runs.begin(), runs.end(),
            [&](std::size_t a, std::size_t b) { return c.used[a].record->replica < c.used[b].record->replica; });
  std::vector<double> n_values;
  for (std::size_t u : runs)
    if (u < arches.runs.size() && !arches.runs[u].is_null())
      for (const ClogArches& clog : ClogsOf(arches.runs[u]))
        for (const Arch& a : clog.arches) n_values.push_back(a.n);
  const std::string title = c.axes.empty() ? std::string("The silo") : PointTitle(c, c.points[k]);
  if (n_values.empty()) {
    not_drawn.Add(title + ": no kept clog with an arch");
    return pics;
  }
  const double median_n = Median(n_values);
  for (std::size_t u : runs) {
    if (u >= arches.runs.size() || arches.runs[u].is_null()) continue;
    const std::vector<ClogArches> clogs = ClogsOf(arches.runs[u]);
    int best_clog = 0;
    const Arch* best = nullptr;
    for (std::size_t i = 0; i < clogs.size(); ++i)
      for (const Arch& a : clogs[i].arches)
        if (!best || std::fabs(a.n - median_n) < std::fabs(best->n - median_n)) {
          best = &a;
          best_clog = static_cast<int>(i) + 1;
        }
    if (!best) continue;
    const UsedRun& run = c.used[u];
    ClogPicture picture = ArchPicture(best_clog, *best);
    picture.marks = MarksOn(c, run, &figure, not_drawn);
    picture.colour_by_disc = figure.colour_by_disc;
    if (figure.window) {
      const auto& w = *figure.window;
      picture.x_lo = w[0], picture.x_hi = w[1], picture.y_lo = w[2], picture.y_hi = w[3];
    }
    std::filesystem::create_directories(options.out_dir / "pictures");
    const std::string file = "pictures/figure-" + figure.name + "-" + std::to_string(k + 1) + "-clog.png";
    const std::string problem = options.draw_clog(run.record->run_dir, picture, options.out_dir / file);
    if (!problem.empty()) {
      not_drawn.Add(problem);
      return pics;
    }
    pics.caption = title + " (replica " + std::to_string(run.record->replica) + ", run `" +
                   run.record->run_id.substr(0, 10) + "`)";
    pics.pictures.push_back({file, "clog " + std::to_string(best_clog) + ": N_t = " + std::to_string(best->n) +
                                       " (the point's median N_t = " + FormatNumber(median_n, 3) +
                                       "), arch bodies outlined"});
    return pics;
  }
  return pics;
}

std::optional<Section> GallerySection(const CampaignView& c, const ReportOptions& options) {
  Section s{"gallery", "Gallery: every point", {}};
  if (!options.draw_run) {
    s.blocks.push_back(Text{"(No pictures: this report was written without the renderer.)"});
    return s;
  }
  NotDrawn not_drawn;
  for (std::size_t k = 0; k < c.points.size(); ++k) {
    Pictures pics = PointPictures(c, k, options, true, true, "pictures/point-" + std::to_string(k + 1), not_drawn);
    if (!pics.pictures.empty()) s.blocks.push_back(pics);
  }
  not_drawn.AppendTo(s);
  return s;
}

// A figure of kind "pictures": the chosen points' pictures, side by side, under its caption.
void AddFigurePictures(const CampaignAnalysis& ca, FigureOutcome& f, const ReportOptions& options) {
  const CampaignView& c = ca.view;
  const FigureSpec& spec = *f.spec;
  const bool clog = spec.picture == "clog";
  if (clog ? !options.draw_clog : !options.draw_run) {
    f.blocks.push_back(Text{"(Figure " + spec.name + ": no pictures, this report was written without the renderer.)"});
    return;
  }
  const AnalysisResults* arches = nullptr;
  for (std::size_t a = 0; a < ca.setup->analyses.size(); ++a)
    if (ca.setup->analyses[a]->Key() == "arches") arches = &ca.results[a];
  Pictures all;
  all.caption = (spec.title.empty() ? spec.name : spec.title) + (spec.caption.empty() ? "" : ". " + spec.caption) +
                (spec.reference.empty() ? "" : ". Reference: " + spec.reference);
  NotDrawn not_drawn;
  if (clog && !arches) not_drawn.Add("\"picture\": \"clog\" needs the arches analysis, which this report has not run");
  for (const FigureDatum& d : f.data)
    for (std::size_t k : d.points) {
      if (clog && !arches) break;
      const Pictures one =
          clog ? ClogPictureOf(c, k, *arches, options, spec, not_drawn)
               : PointPictures(c, k, options, spec.picture == "bed", spec.picture == "end",
                               "pictures/figure-" + spec.name + "-" + std::to_string(k + 1), not_drawn, &spec);
      for (const Picture& p : one.pictures) all.pictures.push_back({p.file, one.caption + ": " + p.caption});
    }
  if (!all.pictures.empty()) f.blocks.push_back(all);
  Section notes{"", "", {}};
  not_drawn.AppendTo(notes);
  for (Block& b : notes.blocks) f.blocks.push_back(std::move(b));
}

// Every used run with its headline metrics (every analysis' metrics are in the export).
std::optional<Section> PerRunSection(const CampaignAnalysis& ca) {
  const CampaignView& c = ca.view;
  if (c.used.empty()) return std::nullopt;
  Section s{"per-run", "Per-run results", {}};
  // The headline metric columns, in analysis order, then first appearance.
  std::vector<std::pair<std::string, std::string>> columns;  // name, title
  std::vector<std::vector<std::map<std::string, Metric>>> by_run(c.used.size());
  for (std::size_t u = 0; u < c.used.size(); ++u) {
    by_run[u].resize(ca.results.size());
    for (std::size_t a = 0; a < ca.results.size(); ++a)
      for (const Metric& m : ca.RunMetrics(a, u)) {
        if (!m.headline) continue;
        by_run[u][a][m.name] = m;
        if (std::none_of(columns.begin(), columns.end(), [&](const auto& col) { return col.first == m.name; }))
          columns.emplace_back(m.name, m.title.empty() ? m.name : m.title);
      }
  }
  Table t{"per_run",
          "Every used run: its headline metrics (value ± se where the analysis gives one)",
          {"run", "point", "replica", "engine", "end", "bodies", "exited", "t_end", "clogs (engine)"},
          {},
          {"run", "point", "replica", "engine", "end_reason", "bodies", "exited", "t_end", "engine_clogs"}};
  for (const auto& [name, title] : columns) {
    t.header.push_back(title);
    t.keys.push_back(name);
  }
  t.header.push_back("notes");
  t.keys.push_back("notes");
  for (const Point& p : c.points) {
    for (std::size_t u : p.runs) {
      const UsedRun& r = c.used[u];
      const rundir::Summary& sm = r.summary;
      std::vector<Cell> row{r.record->run_id,
                            PointName(c, p),
                            Cell::Count(r.record->replica),
                            sm.engine,
                            sm.end_reason,
                            Cell::Count(sm.bodies),
                            Cell::Count(sm.exited),
                            Cell::Number(sm.t_end),
                            sm.clogs ? Cell::Count(*sm.clogs) : Cell::Number(kNaN)};
      for (const auto& [name, title] : columns) {
        const Metric* m = nullptr;
        for (const auto& metrics : by_run[u])
          if (const auto it = metrics.find(name); it != metrics.end()) m = &it->second;
        if (!m) {
          row.push_back(Cell::Number(kNaN));
        } else if (std::isfinite(m->se)) {
          row.push_back(Cell::Estimate(m->value, m->se, -1));
        } else {
          row.push_back(Cell::Number(m->value));
        }
      }
      std::vector<std::string> notes;
      for (const AnalysisResults& res : ca.results) {
        const nlohmann::json& result = res.runs[u];
        if (!result.is_object() || !result.contains("notes")) continue;
        for (const auto& n : result.at("notes")) {
          const std::string text = n.get<std::string>();
          if (std::find(notes.begin(), notes.end(), text) == notes.end()) notes.push_back(text);
        }
      }
      std::string joined;
      for (const auto& n : notes) joined += (joined.empty() ? "" : "; ") + n;
      row.push_back(joined);
      t.rows.push_back(row);
    }
  }
  s.blocks.push_back(t);
  return s;
}

}  // namespace

void CheckReportSpec(const nlohmann::json& campaign_spec) {
  CampaignAxes::OfCampaignSpec(campaign_spec);
  SetupAnalyses(campaign_spec);
  ReadExpectations(campaign_spec, ReadFigureSpecs(campaign_spec));
}

ReportSummary WriteReport(const CampaignInfo& campaign, const std::vector<RunRecord>& runs,
                          const ReportOptions& options) {
  if (options.out_dir.empty()) throw std::invalid_argument("write_report: ReportOptions::out_dir is empty");
  const AnalysisSetup setup = SetupAnalyses(campaign.spec);
  const std::unique_ptr<CampaignAnalysis> analysis = AnalyseCampaign(campaign, runs, setup, options.analysis);
  return WriteReport(*analysis, options);
}

ReportSummary WriteReport(const CampaignAnalysis& ca, const ReportOptions& options) {
  if (options.out_dir.empty()) throw std::invalid_argument("write_report: ReportOptions::out_dir is empty");
  const CampaignView& c = ca.view;
  // Key results (the reproduction table), the spec's figures, each analysis' section, the
  // engine comparison; then what was simulated, the runs, provenance, per-run tables and the
  // gallery of every point.
  const std::unique_ptr<Reproduction> reproduction = Reproduce(ca);
  for (FigureOutcome& f : reproduction->figures)
    if (f.spec->kind == "pictures") AddFigurePictures(ca, f, options);
  std::vector<Section> sections;
  if (auto s = KeyResultsSection(reproduction->results)) sections.push_back(std::move(*s));
  if (auto s = FiguresSection(reproduction->figures)) sections.push_back(std::move(*s));
  for (std::size_t a = 0; a < ca.setup->analyses.size(); ++a) {
    const SectionInput input{c, ca.results[a], ca.point_metrics[a], ca.setup->pass, options.out_dir, options.draw_clog};
    if (auto s = ca.setup->analyses[a]->BuildSection(input)) sections.push_back(std::move(*s));
  }
  std::vector<std::vector<PointMetric>> all;
  for (std::size_t p = 0; p < c.points.size(); ++p) all.push_back(ca.AllPointMetrics(p));
  const std::optional<EngineComparison> comparison = EngineComparisonOf(c, all);
  if (comparison)
    if (auto s = EngineComparisonSection(c, *comparison)) sections.push_back(std::move(*s));
  if (auto s = SystemSection(c)) sections.push_back(std::move(*s));
  if (auto s = ReplicasSection(ca)) sections.push_back(std::move(*s));
  if (auto s = RunsSection(c)) sections.push_back(std::move(*s));
  if (auto s = ProvenanceSection(c)) sections.push_back(std::move(*s));
  if (auto s = PerRunSection(ca)) sections.push_back(std::move(*s));
  if (auto s = GallerySection(c, options)) sections.push_back(std::move(*s));
  RenderOptions render;
  render.figures = options.figures;
  render.gnuplot = options.gnuplot;
  const RenderResult r = RenderReport("Granary report: " + c.campaign->name, sections, options.out_dir, render);
  ReportSummary summary;
  summary.runs_used = static_cast<int>(c.used.size());
  summary.runs_missing = static_cast<int>(c.missing.size());
  summary.runs_failed = static_cast<int>(c.failed.size() + c.unreadable.size());
  summary.results_from_cache = ca.results_from_cache;
  summary.results_computed = ca.results_computed;
  summary.runs_lost = static_cast<int>(c.lost.size());
  summary.runs_damaged = static_cast<int>(c.damaged.size());
  summary.runs_unverifiable = static_cast<int>(c.unverifiable.size());
  summary.markdown = r.markdown;
  summary.html = r.html;
  if (comparison) summary.comparison = to_json(*comparison);
  if (!reproduction->results.empty()) summary.expectations = ToString(Count(reproduction->results));
  return summary;
}

}  // namespace granary::analysis
