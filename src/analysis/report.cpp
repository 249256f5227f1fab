// `write_report`: analyses every finished run of a campaign once, aggregates per sweep point
// and renders the sections that the data supports. Each section is one function in the
// kSections table below; adding an analysis to the report means adding one entry.
#include "analysis/report.h"
#include "rundir/version.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <stdexcept>

#include "analysis/engine_comparison.h"
#include "analysis/expression.h"
#include "analysis/metrics.h"
#include "analysis/report_document.h"
#include "analysis/system.h"

namespace granary::analysis {
namespace {

struct AnalysedRun {
  const RunRecord* record = nullptr;
  RunAnalysis analysis;
  std::string engine_version;
  std::string granary_commit;
  std::string tangential_cap;
  std::string reinjection;                  // reinject mode: "random" or "periodic"; "" in remove mode
  RunTiming timing;
};

struct Point {
  std::string id;
  nlohmann::json point;
  double x = kNaN;                          // value on the report's x axis
  std::string group;                        // the other axes' values
  nlohmann::json spec;                      // a run spec of this point (for axis values)
  std::vector<const AnalysedRun*> runs;
  PointMetrics metrics;
  std::string engine;                       // campaigns on several engines: this point's engine
  std::string shared_group;                 // `group` without the engine (points matched across engines)
};

struct Context {
  const CampaignInfo* campaign = nullptr;
  const ReportOptions* options = nullptr;
  std::vector<const RunRecord*> missing, failed, retired;
  std::vector<std::pair<const RunRecord*, std::string>> unreadable;
  std::vector<AnalysedRun> used;
  std::vector<Point> points;
  std::string x_axis;                       // JSON pointer of the x axis ("" = none)
  std::set<std::string> x_axes;             // the sweep axes that make x (left out of the groups)
  std::string x_label;
  std::string x_name;                       // short name of x in CSV headers and point names
  bool x_is_width = false;
  bool x_is_gap = false;                    // x = gap L between base outlets 0 and 1 (ch. 5b, 7)
  int x_outlet = -1;                        // the outlet (event order) whose width is x; -1: none
  std::size_t outlets = 1;                  // most outlets of any used run
  std::vector<std::string> notes;
  std::vector<std::string> engines;         // of the campaign's runs, in first-appearance order
  std::optional<EngineComparison> comparison;  // when runs come from two engines
};

std::string short_axis(const std::string& pointer) {
  std::string s = pointer;
  if (!s.empty() && s.front() == '/') s.erase(0, 1);
  for (const char* prefix : {"silo/", "bodies/", "contact/", "discharge/", "output/", "bed/"})
    if (s.rfind(prefix, 0) == 0) s.erase(0, std::string(prefix).size());
  std::replace(s.begin(), s.end(), '/', '.');
  return s;
}

std::string json_text(const nlohmann::json& v) {
  if (v.is_number()) return format_number(v.get<double>(), 6);
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

// The value of a sweep axis for a run: from the point record, else from the run spec.
std::optional<nlohmann::json> axis_value(const std::string& axis, const nlohmann::json& point,
                                         const nlohmann::json& spec) {
  if (point.is_object() && point.contains(axis)) return point.at(axis);
  try {
    const nlohmann::json::json_pointer ptr(axis);
    if (spec.is_object() && spec.contains(ptr)) return spec.at(ptr);
  } catch (const nlohmann::json::exception&) {
  }
  return std::nullopt;
}

std::string point_label(const Context& c, const nlohmann::json& point, const nlohmann::json& spec,
                        const std::set<std::string>& skip_axes = {}) {
  std::string s;
  for (const auto& axis : c.campaign->axes) {
    if (skip_axes.count(axis)) continue;
    const auto v = axis_value(axis, point, spec);
    s += (s.empty() ? "" : ", ") + short_axis(axis) + "=" + (v ? json_text(*v) : "?");
  }
  return s;
}

// Edge-to-edge gap between base outlets 0 and 1 of a run spec (L of ch. 5b and 7; L = 0 is
// one outlet of twice the width), or nothing if the spec has fewer than two base outlets.
std::optional<double> base_outlet_gap(const nlohmann::json& spec) {
  std::vector<OutletGeometry> base;
  for (const OutletGeometry& o : outlets_of(spec))
    if (o.base) base.push_back(o);
  if (base.size() < 2) return std::nullopt;
  return std::abs(base[1].center - base[0].center) - 0.5 * (base[0].width + base[1].width);
}

std::string tangential_cap_of(const nlohmann::json& spec) {
  if (spec.is_object() && spec.contains("contact") && spec.at("contact").is_object())
    return spec.at("contact").value("tangential_cap", std::string("lammps")) + "";
  return "lammps (default)";
}

std::string state_reason(const RunRecord& r) {
  std::string f = r.failure;
  if (f.size() > 300) f = f.substr(0, 300) + "...";
  for (char& ch : f)
    if (ch == '\n' || ch == '\r') ch = ' ';
  return f;
}

// ---- context ----------------------------------------------------------------------------

Context build_context(const CampaignInfo& campaign, const std::vector<RunRecord>& runs, const ReportOptions& options) {
  Context c;
  c.campaign = &campaign;
  c.options = &options;
  for (const RunRecord& r : runs) {
    if (r.state == "failed") {
      c.failed.push_back(&r);
    } else if (r.state == "retired") {
      c.retired.push_back(&r);
    } else if (r.state != "done") {
      c.missing.push_back(&r);
    } else {
      try {
        AnalysedRun a;
        a.record = &r;
        const rundir::RunData data = rundir::ReadRun(r.run_dir);
        if (!data.has_summary) throw rundir::ReadError((r.run_dir / rundir::kSummaryFile).string() + ": missing");
        a.analysis = analyse_events(data, options.analysis);
        analyse_frames(data, options.analysis, a.analysis);
        a.engine_version = data.summary.engine_version;
        a.granary_commit = data.summary.granary_commit;
        // LIGGGHTS says which cap it applied (its own, whatever the spec asks).
        a.tangential_cap = data.summary.raw.value("tangential_cap", tangential_cap_of(data.spec.is_null() ? r.spec : data.spec));
        {
          // LIGGGHTS says how it reinjected (periodic, whatever the spec asks).
          const nlohmann::json& spec = data.spec.is_null() ? r.spec : data.spec;
          const nlohmann::json discharge = spec.is_object() ? spec.value("discharge", nlohmann::json::object())
                                                            : nlohmann::json::object();
          if (discharge.value("mode", std::string()) == "reinject")
            a.reinjection = data.summary.raw.value("reinject_position", discharge.value("reinject_position", std::string("random")));
        }
        if (data.summary.raw.contains("timing") && data.summary.raw.at("timing").is_object()) {
          const nlohmann::json& t = data.summary.raw.at("timing");
          a.timing.wall_s = t.value("wall_s", kNaN);
          a.timing.discharge_wall_s = t.value("discharge_wall_s", kNaN);
          a.timing.disc_steps_per_s = t.value("disc_steps_per_s", kNaN);
          a.timing.threads = t.value("threads", 0);
        }
        if (a.analysis.engine.empty()) a.analysis.engine = r.engine;
        c.used.push_back(std::move(a));
      } catch (const std::exception& e) {
        c.unreadable.emplace_back(&r, e.what());
      }
    }
  }
  for (const AnalysedRun& a : c.used) c.outlets = std::max(c.outlets, a.analysis.outlets.size());
  // The x axis: the gap between two base outlets if a base outlet's centre is swept (the
  // thesis plots ch. 5b and 7 against L), else an outlet width if swept, else the first
  // numeric axis.
  const std::regex centre_axis(R"(/silo/base_outlets/\d+/center)");
  const std::regex width_axis(R"(/silo/(base|side)_outlets/(\d+)/width)");
  bool two_base_outlets = !runs.empty();
  for (const RunRecord& r : runs) two_base_outlets = two_base_outlets && base_outlet_gap(r.spec).has_value();
  for (const auto& axis : campaign.axes)
    if (two_base_outlets && std::regex_match(axis, centre_axis)) c.x_axes.insert(axis);
  if (!c.x_axes.empty()) {
    c.x_is_gap = true;
    c.x_axis = *c.x_axes.begin();
    c.x_name = "L";
    c.x_label = "L/d (gap between base outlets 0 and 1, edge to edge)";
  }
  for (const auto& axis : campaign.axes) {
    std::smatch m;
    if (c.x_is_gap || !std::regex_match(axis, m, width_axis)) continue;
    c.x_axis = axis;
    c.x_axes = {axis};
    c.x_is_width = true;
    c.x_name = short_axis(axis);
    c.x_label = "W/d (outlet width " + c.x_name + ")";
    // Outlets are numbered in event order: base outlets first, then side outlets.
    c.x_outlet = std::stoi(m[2].str());
    if (m[1].str() == "side" && !runs.empty()) {
      int base = 0;
      for (const OutletGeometry& o : outlets_of(runs.front().spec)) base += o.base ? 1 : 0;
      c.x_outlet += base;
    }
    break;
  }
  // Points in first-appearance order.
  std::map<std::string, std::size_t> index;
  for (const RunRecord& r : runs) {
    if (index.count(r.point_id)) continue;
    index[r.point_id] = c.points.size();
    Point p;
    p.id = r.point_id;
    p.point = r.point;
    c.points.push_back(p);
  }
  if (c.x_axis.empty()) {
    for (const auto& axis : campaign.axes) {
      bool numeric = true;
      for (const RunRecord& r : runs) {
        const auto v = axis_value(axis, r.point, r.spec);
        if (!v || !v->is_number()) numeric = false;
      }
      if (numeric && !runs.empty()) {
        c.x_axis = axis;
        c.x_axes = {axis};
        c.x_name = c.x_label = short_axis(axis);
        break;
      }
    }
  }
  for (const AnalysedRun& a : c.used) c.points[index[a.record->point_id]].runs.push_back(&a);
  for (Point& p : c.points) {
    const nlohmann::json spec = p.runs.empty() ? nlohmann::json() : p.runs.front()->record->spec;
    nlohmann::json any_spec = spec;
    if (any_spec.is_null())
      for (const RunRecord& r : runs)
        if (r.point_id == p.id) {
          any_spec = r.spec;
          break;
        }
    if (c.x_is_gap) {
      p.x = base_outlet_gap(any_spec).value_or(kNaN);
    } else if (!c.x_axis.empty()) {
      const auto v = axis_value(c.x_axis, p.point, any_spec);
      if (v && v->is_number()) p.x = v->get<double>();
    }
    p.group = point_label(c, p.point, any_spec, c.x_axes);
    p.spec = any_spec;
    const auto engine = axis_value("/engine", p.point, any_spec);
    p.engine = engine && engine->is_string() ? engine->get<std::string>() : "";
    std::set<std::string> skip = c.x_axes;
    skip.insert("/engine");
    p.shared_group = point_label(c, p.point, any_spec, skip);
  }
  // N_u for points where every run clogged: the freely discharging runs of the same group
  // (same silo and mixture, other widths), else of the whole campaign.
  std::map<std::string, std::vector<const RunAnalysis*>> by_group;
  std::vector<const RunAnalysis*> all;
  for (const Point& p : c.points)
    for (const AnalysedRun* a : p.runs) {
      by_group[p.group].push_back(&a->analysis);
      all.push_back(&a->analysis);
    }
  const double campaign_stagnant = stagnant_count(all);
  for (Point& p : c.points) {
    PointRuns pr{p.id, p.point, {}};
    for (const AnalysedRun* a : p.runs) pr.runs.push_back(&a->analysis);
    const double group_stagnant = stagnant_count(by_group[p.group]);
    p.metrics = group_stagnant >= 0.0
                    ? point_metrics(pr, options.analysis, group_stagnant,
                                    "every run clogged: N_u from the freely discharging runs of " +
                                        (p.group.empty() ? std::string("the campaign") : p.group))
                    : point_metrics(pr, options.analysis, campaign_stagnant,
                                    "every run clogged: N_u from the campaign's freely discharging runs");
  }
  std::stable_sort(c.points.begin(), c.points.end(), [](const Point& a, const Point& b) {
    if (a.group != b.group) return a.group < b.group;
    return a.x < b.x;
  });
  return c;
}

std::string point_name(const Context& c, const Point& p) {
  std::string s = p.group;
  if (!c.x_axis.empty()) s = c.x_name + "=" + format_number(p.x, 6) + (s.empty() ? "" : ", " + s);
  return s.empty() ? p.id : s;
}

std::vector<std::string> groups_of(const Context& c) {
  std::vector<std::string> g;
  for (const Point& p : c.points)
    if (std::find(g.begin(), g.end(), p.group) == g.end()) g.push_back(p.group);
  return g;
}

// One series per group of (x, mean, se, n) for points where `get` is defined.
std::vector<Series> point_series(const Context& c, const std::function<MeanSe(const Point&)>& get,
                                 const std::string& name) {
  std::vector<Series> out;
  for (const auto& g : groups_of(c)) {
    Series s;
    s.label = g.empty() ? name : g;
    s.columns = {c.x_label.empty() ? "x" : c.x_name, name, name + "_se", "n"};
    s.style = Series::Style::kErrorBars;
    s.err = 2;
    for (const Point& p : c.points) {
      if (p.group != g || !std::isfinite(p.x)) continue;
      const MeanSe m = get(p);
      if (!std::isfinite(m.mean)) continue;
      s.rows.push_back({p.x, m.mean, m.se, static_cast<double>(m.n)});
    }
    if (!s.rows.empty()) out.push_back(std::move(s));
  }
  return out;
}

// One series per (outlet, group) of a per-outlet metric, for runs with several outlets.
std::vector<Series> outlet_series(const Context& c, const std::function<MeanSe(const OutletMetrics&)>& get,
                                  const std::string& name) {
  std::vector<Series> out;
  for (std::size_t o = 0; o < c.outlets; ++o) {
    for (const auto& g : groups_of(c)) {
      Series s;
      s.columns = {c.x_label.empty() ? "x" : c.x_name, name, name + "_se", "n"};
      s.style = Series::Style::kErrorBars;
      s.err = 2;
      for (const Point& p : c.points) {
        if (p.group != g || !std::isfinite(p.x) || o >= p.metrics.per_outlet.size()) continue;
        const OutletMetrics& om = p.metrics.per_outlet[o];
        s.label = om.label + (g.empty() ? "" : ", " + g);
        const MeanSe m = get(om);
        if (!std::isfinite(m.mean)) continue;
        s.rows.push_back({p.x, m.mean, m.se, static_cast<double>(m.n)});
      }
      if (!s.rows.empty()) out.push_back(std::move(s));
    }
  }
  return out;
}

// Point series of a metric: per (outlet, group) when runs have several outlets, else per group.
std::vector<Series> metric_series(const Context& c, MeanSe PointMetrics::*total, MeanSe OutletMetrics::*outlet,
                                  const std::string& name) {
  if (c.outlets > 1) return outlet_series(c, [outlet](const OutletMetrics& m) { return m.*outlet; }, name);
  return point_series(c, [total](const Point& p) { return p.metrics.*total; }, name);
}

// The flow rate the headline figure and the fits use: through the outlet whose width is the
// x axis when runs have several outlets (ch. 7: Q of the small outlet against W1), else
// through all outlets together.
MeanSe headline_q(const Context& c, const Point& p) {
  if (c.outlets > 1 && c.x_outlet >= 0 && static_cast<std::size_t>(c.x_outlet) < p.metrics.per_outlet.size())
    return p.metrics.per_outlet[static_cast<std::size_t>(c.x_outlet)].q_count;
  return p.metrics.q_count;
}

std::string headline_q_what(const Context& c) {
  if (c.outlets > 1 && c.x_outlet >= 0) {
    for (const Point& p : c.points)
      if (static_cast<std::size_t>(c.x_outlet) < p.metrics.per_outlet.size())
        return "through " + p.metrics.per_outlet[static_cast<std::size_t>(c.x_outlet)].label;
  }
  return c.outlets > 1 ? "all outlets together" : "";
}

bool has_x(const Context& c) {
  int n = 0;
  for (const Point& p : c.points) n += std::isfinite(p.x) ? 1 : 0;
  return n >= 2;
}

// ---- sections ---------------------------------------------------------------------------

std::optional<Section> runs_section(const Context& c) {
  Section s{"runs", "Runs", {}};
  const int total = static_cast<int>(c.used.size() + c.missing.size() + c.failed.size() + c.unreadable.size() +
                                     c.retired.size());
  s.blocks.push_back(Text{std::to_string(total) + " runs in the campaign: **" + std::to_string(c.used.size()) +
                          " used**, " + std::to_string(c.missing.size()) + " missing (not finished), " +
                          std::to_string(c.failed.size()) + " failed, " + std::to_string(c.unreadable.size()) +
                          " finished but unreadable, " + std::to_string(c.retired.size()) + " retired. " +
                          "Every number below is computed from the used runs only; a point with fewer replicas "
                          "than planned says so in its `n`."});
  Table t{"runs_not_used", "Runs not used, with the reason", {"run", "point", "replica", "state", "reason"}, {}};
  for (const RunRecord* r : c.missing)
    t.rows.push_back({r->run_id, point_label(c, r->point, r->spec), std::to_string(r->replica), r->state,
                      r->failure.empty() ? "not finished" : "not finished: " + state_reason(*r)});
  for (const RunRecord* r : c.failed) t.rows.push_back({r->run_id, point_label(c, r->point, r->spec), std::to_string(r->replica), r->state, state_reason(*r)});
  for (const auto& [r, why] : c.unreadable) t.rows.push_back({r->run_id, point_label(c, r->point, r->spec), std::to_string(r->replica), r->state, "unreadable: " + why});
  for (const RunRecord* r : c.retired) t.rows.push_back({r->run_id, point_label(c, r->point, r->spec), std::to_string(r->replica), r->state, "retired (superseded)"});
  if (!t.rows.empty()) s.blocks.push_back(t);
  return s;
}

std::optional<Section> provenance_section(const Context& c) {
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
  text += ". Sweep axes: ";
  for (std::size_t i = 0; i < k.axes.size(); ++i) text += (i ? ", " : "") + std::string("`") + k.axes[i] + "`";
  if (k.axes.empty()) text += "none";
  text += ".";
  s.blocks.push_back(Text{text});
  // engine, version, commit, tangential cap -> runs
  std::map<std::vector<std::string>, int> rows;
  for (const AnalysedRun& a : c.used)
    ++rows[{a.analysis.engine, a.engine_version, a.granary_commit, a.tangential_cap}];
  Table t{"provenance", "Engines that produced the used runs",
          {"engine", "engine version", "granary commit", "tangential cap (/contact/tangential_cap)", "runs"}, {}};
  for (const auto& [key, n] : rows) t.rows.push_back({key[0], key[1], key[2], key[3], std::to_string(n)});
  s.blocks.push_back(t);
  s.blocks.push_back(Text{"Tangential cap: `lammps` caps spring plus damping at mu|F_n| (LAMMPS convention, "
                          "physics.md); `liggghts` caps only the spring part (LIGGGHTS 3.8). Runs with different "
                          "caps are not the same model."});
  return s;
}

std::optional<Section> per_run_section(const Context& c) {
  if (c.used.empty()) return std::nullopt;
  Section s{"per-run", "Per-run results", {}};
  Table t{"per_run",
          "Every used run (Q by least squares over the steady window; se by batch means)",
          {"run", "point", "replica", "engine", "end", "bodies", "exited", "t_end", "clogs (engine/stream)", "window t",
           "Q (bodies/t)", "Q se", "Q_mass (mass/t)", "phi", "T_g ch3", "T_g ch4", "notes"},
          {}};
  if (c.outlets > 1) t.header.insert(t.header.begin() + 13, "Q per outlet");
  for (const Point& p : c.points) {
    for (const AnalysedRun* a : p.runs) {
      const RunAnalysis& r = a->analysis;
      std::string notes;
      for (const auto& n : r.notes) notes += (notes.empty() ? "" : "; ") + n;
      t.rows.push_back({a->record->run_id, point_name(c, p), std::to_string(a->record->replica), r.engine,
                        r.end_reason, std::to_string(r.bodies), std::to_string(r.exited), format_number(r.t_end),
                        (r.engine_clogs >= 0 ? std::to_string(r.engine_clogs) : std::string("?")) + " / " +
                            std::to_string(r.series.clogged.size()),
                        r.flow.ok ? format_number(r.flow.t_start, 3) + "-" + format_number(r.flow.t_end, 3) : "",
                        format_number(r.flow.q_count), format_number(r.flow.q_count_se, 2),
                        format_number(r.flow.q_mass), r.has_region ? format_number(r.region.phi.mean) : "",
                        r.has_region ? format_number(r.region.tg_translational.mean) : "",
                        r.has_region ? format_number(r.region.tg_full.mean) : "", notes});
      if (c.outlets > 1) {
        std::string per_outlet;
        for (const FlowRate& f : r.flow_per_outlet) per_outlet += (per_outlet.empty() ? "" : " / ") + format_number(f.q_count);
        t.rows.back().insert(t.rows.back().begin() + 13, per_outlet);
      }
    }
  }
  s.blocks.push_back(t);
  // Diagnostic: the exit streams and the fitted lines over their windows (first replica of
  // up to 8 points), so that a reader can judge the window rule.
  Figure cum{"cumulative_exits", "Cumulative exits against time", "t (sqrt(d/g))", "exits (all outlets)", {}, false,
             false, "Curves: the exit streams; dots: the least-squares line over each run's steady window. First replica of up to "
             "8 points"};
  int shown = 0;
  for (const Point& p : c.points) {
    if (p.runs.empty() || shown >= 8) continue;
    const RunAnalysis& r = p.runs.front()->analysis;
    if (r.cumulative_t.empty()) continue;
    Series data;
    data.label = point_name(c, p);
    data.columns = {"t", "exits"};
    data.style = Series::Style::kLines;
    data.color = shown;
    for (std::size_t i = 0; i < r.cumulative_t.size(); ++i) data.rows.push_back({r.cumulative_t[i], r.cumulative_n[i]});
    cum.series.push_back(data);
    if (r.flow.ok) {
      Series line;
      line.label = "fit, " + data.label;
      line.columns = {"t", "exits_fit"};
      line.style = Series::Style::kPoints;
      line.color = shown;
      for (int i = 0; i <= 10; ++i) {
        const double tv = r.flow.t_start + (r.flow.t_end - r.flow.t_start) * i / 10.0;
        line.rows.push_back({tv, r.flow.count_intercept + r.flow.q_count * tv});
      }
      cum.series.push_back(line);
    }
    ++shown;
  }
  if (!cum.series.empty()) s.blocks.push_back(cum);
  const FlowWindowRule& w = c.options->analysis.window;
  s.blocks.push_back(Text{
      "Steady window: exits before t = " + format_number(w.start_time) + " and the first " +
      format_number(100 * w.start_fraction) + "% of the exits are dropped; the window ends at the first clog (a gap of "
      "clog_window in the exit stream)" + std::string(w.stop_at_first_clog ? "" : " [off]") +
      " and, in remove mode, when " + format_number(100 * w.shallow_fraction) + "% of the bodies remain."});
  return s;
}

// The sweep axis that names the groups (the axes other than x) with one number per group,
// different in every group, against which fitted parameters are drawn; "" if none. Zipped
// axes move together (ch. 4: both species fractions), so the first of them serves.
std::string group_axis(const Context& c) {
  const std::vector<std::string> groups = groups_of(c);
  if (groups.size() < 2) return "";
  for (const auto& axis : c.campaign->axes) {
    if (c.x_axes.count(axis)) continue;
    std::map<std::string, double> value_of_group;
    bool ok = true;
    for (const Point& p : c.points) {
      const auto v = axis_value(axis, p.point, p.spec);
      if (!v || !v->is_number()) {
        ok = false;
        break;
      }
      const auto [it, added] = value_of_group.emplace(p.group, v->get<double>());
      if (!added && it->second != v->get<double>()) ok = false;
    }
    std::set<double> distinct;
    for (const auto& [g, v] : value_of_group) distinct.insert(v);
    if (ok && distinct.size() == value_of_group.size()) return axis;
  }
  return "";
}

std::optional<Section> flow_section(const Context& c) {
  bool any = false;
  for (const Point& p : c.points) any = any || p.metrics.q_count.n > 0;
  if (!any) return std::nullopt;
  Section s{"flow", "Flow rate", {}};
  const bool several = c.outlets > 1;
  Table t{"flow_rate", "Flow rate per sweep point: mean ± standard error (replicas)",
          {"point", several ? "Q all outlets (bodies/sqrt(d/g))" : "Q (bodies/sqrt(d/g))",
           several ? "Q_mass all outlets (mass/sqrt(d/g))" : "Q_mass (mass/sqrt(d/g))"},
          {}};
  // Several outlets (ch. 5, 7): Q and V_max of every outlet in its own columns.
  std::vector<std::string> labels;
  for (const Point& p : c.points)
    for (std::size_t o = labels.size(); o < p.metrics.per_outlet.size(); ++o) labels.push_back(p.metrics.per_outlet[o].label);
  if (several)
    for (const auto& l : labels) t.header.push_back("Q " + l);
  t.header.push_back(several ? "V_max " + (labels.empty() ? std::string("base 0") : labels.front()) : "V_max");
  if (several)
    for (std::size_t o = 1; o < labels.size(); ++o) t.header.push_back("V_max " + labels[o]);
  for (const Point& p : c.points) {
    const PointMetrics& m = p.metrics;
    std::vector<std::string> row{point_name(c, p), format_mean_se(m.q_count.mean, m.q_count.se, m.q_count.n),
                                 format_mean_se(m.q_mass.mean, m.q_mass.se, m.q_mass.n)};
    auto per_outlet = [&](MeanSe OutletMetrics::*field, std::size_t o) {
      if (o >= m.per_outlet.size()) return std::string();
      const MeanSe v = m.per_outlet[o].*field;
      return format_mean_se(v.mean, v.se, v.n);
    };
    if (several) {
      for (std::size_t o = 0; o < labels.size(); ++o) row.push_back(per_outlet(&OutletMetrics::q_count, o));
      for (std::size_t o = 0; o < labels.size(); ++o) row.push_back(per_outlet(&OutletMetrics::v_max, o));
    } else {
      row.push_back(format_mean_se(m.v_max.mean, m.v_max.se, m.v_max.n));
    }
    t.rows.push_back(row);
  }
  s.blocks.push_back(t);
  if (!has_x(c)) return s;
  const std::string q_what = headline_q_what(c);
  Figure f{"flow_rate", "Flow rate Q" + (q_what.empty() ? "" : " " + q_what) + " against " + c.x_label, c.x_label,
           "Q (bodies per sqrt(d/g))", point_series(c, [&c](const Point& p) { return headline_q(c, p); }, "Q"), false,
           false, "Error bars: standard error over replicas"};
  Figure per_outlet_figure{"flow_rate_per_outlet", "Flow rate through each outlet against " + c.x_label, c.x_label,
                           "Q (bodies per sqrt(d/g))", outlet_series(c, [](const OutletMetrics& m) { return m.q_count; }, "Q"),
                           false, false,
                           "One curve per outlet (and group); error bars: standard error over replicas"};
  // Fits against W/d per group (>= 3 widths).
  Table fits{"flow_rate_fits",
             "Fits of Q(W/d) per group (95% confidence intervals, Student t). Fit quality: good, ill-determined (a "
             "parameter without a standard error or whose interval holds 0), failed or not fitted; only converged "
             "fits show values",
             {"group", "model", "parameter", "value", "se", "95% CI", "chi2/dof", "points", "weighted", "fit quality"}, {}};
  Table residuals{"flow_rate_fit_residuals", "Fit residuals (Q - fit)",
                  {"group", "model", "W/d", "Q", "fit", "residual"}, {}};
  std::vector<FitModel> models;
  if (c.x_is_width) models = {beverloo_2d(), beverloo_free(), mankoc()};
  for (const auto& m : c.options->models) models.push_back(m);
  int fitted_groups = 0;
  for (std::size_t k = 0; k < f.series.size(); ++k) f.series[k].color = static_cast<int>(k);
  double x_lo = std::numeric_limits<double>::infinity(), x_hi = -x_lo;
  for (const Point& p : c.points)
    if (std::isfinite(p.x) && std::isfinite(headline_q(c, p).mean)) {
      x_lo = std::min(x_lo, p.x);
      x_hi = std::max(x_hi, p.x);
    }
  constexpr int kCurveSamples = 200;
  const std::vector<Series> data_series = f.series;
  std::map<std::string, Figure> model_figures;
  const std::string other_axis = group_axis(c);
  std::map<std::string, Figure> trends;  // per model: its parameters against other_axis
  for (const auto& g : groups_of(c)) {
    double group_value = kNaN;
    if (!other_axis.empty())
      for (const Point& p : c.points)
        if (p.group == g) {
          const auto v = axis_value(other_axis, p.point, p.spec);
          if (v && v->is_number()) group_value = v->get<double>();
          break;
        }
    std::vector<double> x, y, sigma;
    std::set<double> distinct;
    for (const Point& p : c.points) {
      const MeanSe q = headline_q(c, p);
      if (p.group != g || !std::isfinite(p.x) || !std::isfinite(q.mean)) continue;
      x.push_back(p.x);
      y.push_back(q.mean);
      sigma.push_back(q.se);
      distinct.insert(p.x);
    }
    if (distinct.size() < 3 || models.empty()) continue;
    ++fitted_groups;
    for (const FitModel& model : models) {
      FitResult r;
      try {
        r = fit_model(with_data_guess(model, x, y), x, y, sigma);
      } catch (const std::exception& e) {
        fits.rows.push_back({g, model.name, "", "", "", "", "", std::to_string(x.size()), "", e.what()});
        continue;
      }
      const std::string weighted = r.sigma.empty() ? "no" : "1/se^2";
      for (const auto& par : r.parameters)
        fits.rows.push_back({g, r.model_name + ": " + r.expression, par.name, format_number(par.value),
                             format_number(par.se, 2),
                             std::isfinite(par.ci_low) ? std::string("[") + format_number(par.ci_low) + ", " +
                                                             format_number(par.ci_high) + "]"
                                                       : std::string(),
                             r.ok() && r.dof > 0 ? format_number(r.chi2 / r.dof, 3) : "", std::to_string(x.size()),
                             weighted, r.verdict()});
      for (std::size_t i = 0; i < r.x.size(); ++i)
        residuals.rows.push_back({g, r.model_name, format_number(r.x[i], 6), format_number(r.y[i]),
                                  format_number(r.fitted[i]), format_number(r.residuals[i], 3)});
      if (!r.ok()) continue;
      if (std::isfinite(group_value)) {
        Figure& tf = trends[r.model_name];
        if (tf.name.empty()) {
          tf.name = "fit_parameters_" + r.model_name;
          tf.title = "Fitted parameters of " + r.model_name + " (" + r.expression + ") against " + short_axis(other_axis);
          tf.xlabel = short_axis(other_axis);
          tf.ylabel = "parameter value";
          tf.caption = "Error bars: standard errors of the fit. Parameters not determined by the data or whose 95% "
                       "interval holds 0 are left out (fit table above)";
        }
        for (const auto& par : r.parameters) {
          if (!par.determined() || par.ci_spans_zero()) continue;
          auto it = std::find_if(tf.series.begin(), tf.series.end(), [&](const Series& se) { return se.label == par.name; });
          if (it == tf.series.end()) {
            Series se;
            se.label = par.name;
            se.columns = {short_axis(other_axis), par.name, par.name + "_se", "ci_low", "ci_high"};
            se.style = Series::Style::kErrorBars;
            se.err = 2;
            tf.series.push_back(se);
            it = tf.series.end() - 1;
          }
          it->rows.push_back({group_value, par.value, par.se, par.ci_low, par.ci_high});
        }
      }
      Series curve;
      for (std::size_t k = 0; k < data_series.size(); ++k)
        if (data_series[k].label == (g.empty() ? std::string("Q") : g)) curve.color = static_cast<int>(k);
      curve.label = r.model_name + (g.empty() ? "" : " (" + g + ")") +
                    (r.quality == FitQuality::kGood ? "" : ", " + to_string(r.quality));
      curve.columns = {"W", "Q_fit"};
      curve.style = Series::Style::kLines;
      // The fitted function sampled densely over the whole plotted x range (every group's
      // widths), not only through the measured widths.
      for (int i = 0; i <= kCurveSamples; ++i) {
        const double xv = x_lo + (x_hi - x_lo) * i / kCurveSamples;
        const double yv = r.evaluate(xv);
        if (std::isfinite(yv)) curve.rows.push_back({xv, yv});
      }
      if (curve.rows.empty()) continue;
      // The first model's curves go on the main figure; every other model gets its own
      // figure (data + its curves) so that legends stay readable.
      if (&model == &models.front()) {
        f.series.push_back(std::move(curve));
      } else {
        Figure& mf = model_figures[model.name];
        if (mf.name.empty()) {
          mf = Figure{"flow_rate_fit_" + model.name, "Flow rate with the " + model.name + " fit (" + r.expression + ")",
                      c.x_label, "Q (bodies per sqrt(d/g))", data_series, false, false, "Error bars: se over replicas"};
        }
        mf.series.push_back(std::move(curve));
      }
    }
  }
  s.blocks.push_back(f);
  if (several && !per_outlet_figure.series.empty()) s.blocks.push_back(per_outlet_figure);
  for (auto& [name, mf] : model_figures) s.blocks.push_back(mf);
  if (fitted_groups > 0) {
    s.blocks.push_back(Text{"Models (shared analyses.md): 2-D Beverloo `Q = C (W/d - k)^(3/2)`, free exponent "
                            "`Q = C (W/d - k)^b`, Mankoc `Q = C (1 - exp(-b (W/d - 1))/2) (W/d - 1)^(3/2)`, plus "
                            "any model given in the campaign spec `/report/models`. GSL trust-region "
                            "Levenberg-Marquardt with a finite-difference Jacobian; weights 1/se^2 when every "
                            "point has a replica standard error, covariance scaled by max(1, chi2/dof) (weighted) "
                            "or chi2/dof (unweighted)."});
    s.blocks.push_back(fits);
    for (auto& [model, tf] : trends)
      if (std::any_of(tf.series.begin(), tf.series.end(), [](const Series& se) { return se.rows.size() >= 2; }))
        s.blocks.push_back(tf);
    s.blocks.push_back(residuals);
  } else if (c.x_is_width) {
    s.blocks.push_back(Text{"Beverloo fits need at least 3 outlet widths in a group; this campaign has fewer so far."});
  }
  return s;
}

std::optional<Section> profile_section(const Context& c) {
  const bool lateral = !c.used.empty() && !c.used.front().analysis.outlets.empty() &&
                       !c.used.front().analysis.outlets.front().base;
  const std::string along = lateral ? "y/W (height along the lateral outlet, from its centre)" : "x/W";
  Figure fy{"velocity_profile_vy",
            lateral ? "Normalised horizontal (outflow) velocity across the lateral outlet (ch. 5a)"
                    : "Normalised vertical velocity across the outlet",
            along, lateral ? "v_n / max|v_n| (v_n: velocity away from the wall)" : "v_y / max|v_y|", {}, false, false,
            "Bodies with centre within " + format_number(c.options->analysis.profile.band_low) + ".." +
                format_number(c.options->analysis.profile.band_high) + " d of " +
                (c.outlets > 1 ? std::string("each outlet's") : std::string("the outlet's")) +
                " wall (x along the outlet, v_y normal to it), averaged over the steady-window frames and replicas; "
                "error bars: standard error over replicas (none with one replica)"};
  Figure fx{"velocity_profile_vx",
            lateral ? "Normalised vertical velocity across the lateral outlet"
                    : "Normalised horizontal velocity across the outlet",
            along, lateral ? "v_y / max|v_y|" : "v_x / max|v_x|", {}, false, false,
            std::string(lateral ? "Sign: positive upwards. " : "") + "Error bars: standard error over replicas"};
  for (const Point& p : c.points)
  for (std::size_t o = 0; o < c.outlets; ++o) {
    std::vector<const VelocityProfile*> prof;
    std::string outlet_label;
    for (const AnalysedRun* a : p.runs)
      if (a->analysis.has_profile && o < a->analysis.profile_per_outlet.size()) {
        prof.push_back(&a->analysis.profile_per_outlet[o]);
        outlet_label = a->analysis.outlets[o].label;
      }
    if (prof.empty()) continue;
    Series sy, sx;
    sy.label = sx.label = point_name(c, p) + (c.outlets > 1 ? ", " + outlet_label : "");
    sy.columns = {"x_over_W", "vy_norm", "vy_norm_se", "n"};
    sx.columns = {"x_over_W", "vx_norm", "vx_norm_se", "n"};
    sy.style = sx.style = Series::Style::kLinesPoints;
    sy.err = sx.err = 2;  // standard error over replicas
    for (std::size_t i = 0; i < prof.front()->x_over_w.size(); ++i) {
      std::vector<double> vy, vx;
      for (const auto* q : prof) {
        if (i >= q->vy_norm.size()) continue;
        vy.push_back(q->vy_norm[i]);
        vx.push_back(q->vx_norm[i]);
      }
      const MeanSe my = mean_se_finite(vy), mx = mean_se_finite(vx);
      sy.rows.push_back({prof.front()->x_over_w[i], my.mean, my.se, static_cast<double>(my.n)});
      sx.rows.push_back({prof.front()->x_over_w[i], mx.mean, mx.se, static_cast<double>(mx.n)});
    }
    auto finite = [](const Series& se) {
      return std::any_of(se.rows.begin(), se.rows.end(), [](const auto& row) { return std::isfinite(row[1]); });
    };
    if (finite(sy)) fy.series.push_back(sy);
    if (finite(sx)) fx.series.push_back(sx);
  }
  if (fy.series.empty() && fx.series.empty()) return std::nullopt;
  Section s{"profiles", "Velocity profiles across the outlet", {}};
  if (!fy.series.empty()) s.blocks.push_back(fy);
  if (!fx.series.empty()) s.blocks.push_back(fx);
  if (has_x(c))
    s.blocks.push_back(Figure{"v_max", "V_max against " + c.x_label, c.x_label, "V_max (sqrt(g d))",
                              metric_series(c, &PointMetrics::v_max, &OutletMetrics::v_max, "V_max"), false, false,
                              std::string("max |v_y| of the profile") + (c.outlets > 1 ? ", per outlet" : "")});
  return s;
}

std::optional<Section> region_section(const Context& c) {
  bool any = false;
  for (const Point& p : c.points) any = any || p.metrics.phi.n > 0;
  if (!any) return std::nullopt;
  const RegionSize& size = c.options->analysis.region;
  Section s{"region", "Region above the outlet", {}};
  s.blocks.push_back(Text{"Region " + size.label + ", centred on " +
                          (c.outlets > 1 ? std::string("each outlet (the first table: outlet 0)") : "the outlet") +
                          " and reaching from its wall into the "
                          "silo (above a base outlet, beside a lateral one; pad " +
                          format_number(size.pad) + " d, height " + format_number(size.height) +
                          " d). Packing fraction: exact area of every disc inside the region (discs cut by the "
                          "edge count with their inside part) over the region area. Temperatures over the bodies "
                          "whose centre of mass is inside, per frame, then averaged over frames: ch. 3 "
                          "`T_g = 1/2 <(v_x - <v_x>)^2 + (v_y - <v_y>)^2>` and ch. 4-5 "
                          "`T_g = 1/3 <m |v - <v>|^2 + I (Omega - <Omega>)^2>`."});
  Table t{"region", "Region statistics per point: mean ± se over replicas (n)",
          {"point", "phi", "T_g ch3 (g d)", "T_g ch4 (m g d)"}, {}};
  for (const Point& p : c.points) {
    const PointMetrics& m = p.metrics;
    if (m.phi.n == 0) continue;
    t.rows.push_back({point_name(c, p), format_mean_se(m.phi.mean, m.phi.se, m.phi.n),
                      format_mean_se(m.tg_translational.mean, m.tg_translational.se, m.tg_translational.n),
                      format_mean_se(m.tg_full.mean, m.tg_full.se, m.tg_full.n)});
  }
  s.blocks.push_back(t);
  // Several outlets: the same statistics next to each of them.
  Table per_outlet{"region_per_outlet", "Region statistics next to every outlet: mean ± se over replicas (n)",
                   {"point", "outlet", "phi", "T_g ch3 (g d)", "T_g ch4 (m g d)"}, {}};
  for (const Point& p : c.points) {
    if (c.outlets < 2) continue;
    for (const OutletMetrics& m : p.metrics.per_outlet) {
      if (m.phi.n == 0) continue;
      per_outlet.rows.push_back({point_name(c, p), m.label, format_mean_se(m.phi.mean, m.phi.se, m.phi.n),
                                 format_mean_se(m.tg_translational.mean, m.tg_translational.se, m.tg_translational.n),
                                 format_mean_se(m.tg_full.mean, m.tg_full.se, m.tg_full.n)});
    }
  }
  if (!per_outlet.rows.empty()) s.blocks.push_back(per_outlet);
  if (has_x(c)) {
    const std::string where = c.outlets > 1 ? " next to each outlet" : "";
    s.blocks.push_back(Figure{"packing_fraction", "Packing fraction phi" + where + " against " + c.x_label, c.x_label,
                              "phi", metric_series(c, &PointMetrics::phi, &OutletMetrics::phi, "phi"), false, false,
                              "Error bars: se over replicas"});
    Figure tg{"granular_temperature", "Granular temperature" + where + " against " + c.x_label, c.x_label,
              "T_g (ch. 3: g d; ch. 4-5: m g d)", {}, false, false, "Both definitions; error bars: se over replicas"};
    for (auto se : metric_series(c, &PointMetrics::tg_translational, &OutletMetrics::tg_translational, "Tg_ch3")) {
      se.label = "ch. 3 " + se.label;
      tg.series.push_back(se);
    }
    for (auto se : metric_series(c, &PointMetrics::tg_full, &OutletMetrics::tg_full, "Tg_ch4")) {
      se.label = "ch. 4-5 " + se.label;
      tg.series.push_back(se);
    }
    s.blocks.push_back(tg);
  }
  // Velocity distributions, pooled over the replicas of each point.
  const std::string pooled = std::string("Pooled over frames and replicas") +
                             (c.outlets > 1 ? "; the region next to outlet 0" : "") +
                             "; in outlet coordinates (x along the outlet, y from its wall into the silo)";
  Figure dx{"velocity_distribution_vx", "Distribution of v_x in the region", "v_x (sqrt(g d))", "probability density",
            {}, false, false, pooled};
  Figure dy{"velocity_distribution_vy", "Distribution of v_y in the region", "v_y (sqrt(g d))", "probability density",
            {}, false, false, pooled};
  for (const Point& p : c.points) {
    std::vector<double> vx, vy;
    for (const AnalysedRun* a : p.runs) {
      if (!a->analysis.has_region) continue;
      vx.insert(vx.end(), a->analysis.region.vx.begin(), a->analysis.region.vx.end());
      vy.insert(vy.end(), a->analysis.region.vy.begin(), a->analysis.region.vy.end());
    }
    if (vx.size() < 2) continue;
    for (auto [values, fig, name] : {std::tuple{&vx, &dx, "vx"}, std::tuple{&vy, &dy, "vy"}}) {
      const Histogram h = make_histogram(*values, 30);
      Series se;
      se.label = point_name(c, p);
      se.columns = {name, "density", "count"};
      se.style = Series::Style::kSteps;
      for (std::size_t i = 0; i < h.counts.size(); ++i) se.rows.push_back({h.center(i), h.density(i), h.counts[i]});
      fig->series.push_back(se);
    }
  }
  if (!dx.series.empty()) {
    s.blocks.push_back(dx);
    s.blocks.push_back(dy);
  }
  return s;
}

std::optional<Section> clogging_index_section(const Context& c) {
  bool any = false;
  for (const Point& p : c.points) any = any || p.metrics.clogging.clogged > 0;
  if (!any) return std::nullopt;
  Section s{"clogging-index", "Clogging index Psi (ch. 3, eq. 3.1)", {}};
  s.blocks.push_back(Text{"Psi = (1/n) sum_i (N_undis,i - N_u) / (N_total - N_u), N_u the mean number left in the "
                          "point's runs that did not clog (stagnant zones). Runs that clogged before " +
                          std::to_string(c.options->analysis.min_exits_before_clog) + " bodies left are discarded."});
  Table t{"clogging_index", "Clogging index per point",
          {"point", "Psi", "clogged runs", "discarded", "N_u", "note"}, {}};
  for (const Point& p : c.points) {
    const ClogIndex& ci = p.metrics.clogging;
    if (ci.psi.n == 0 && ci.discarded == 0) continue;
    t.rows.push_back({point_name(c, p), format_mean_se(ci.psi.mean, ci.psi.se, ci.psi.n), std::to_string(ci.clogged),
                      std::to_string(ci.discarded), format_number(ci.n_stagnant), ci.note});
  }
  s.blocks.push_back(t);
  if (has_x(c))
    s.blocks.push_back(Figure{"clogging_index", "Clogging index Psi against " + c.x_label, c.x_label, "Psi",
                              point_series(c, [](const Point& p) { return p.metrics.clogging.psi; }, "Psi"), false,
                              false, "Error bars: se over replicas"});
  return s;
}

// Ch. 4 and 6 average <s> over at least this many avalanches per point.
constexpr int kThesisAvalanches = 100;

std::optional<Section> avalanche_section(const Context& c) {
  bool any = false, any_per_outlet = false;
  for (const Point& p : c.points) {
    any = any || p.metrics.avalanche_size.n > 0;
    for (const OutletMetrics& m : p.metrics.per_outlet) any_per_outlet = any_per_outlet || m.avalanche_size.n > 0;
  }
  if (!any && !(c.outlets > 1 && any_per_outlet)) return std::nullopt;
  Section s{"avalanches", "Avalanche sizes (ch. 4, 6)", {}};
  s.blocks.push_back(Text{"An avalanche is the number of bodies that leave between the opening (or an unclog) and a "
                          "clog; a clog is a gap of at least the run's clog_window in the exit stream of all outlets "
                          "together, or the engine's own stop on a clog. A stretch still flowing when a run ended is "
                          "not an avalanche. The tail fit is the maximum-likelihood geometric law P(s) ~ "
                          "exp(-s/s_decay) for s above the median."});
  Table t{"avalanches", "Avalanche statistics per point (pooled over replicas)",
          {"point", "<s> ± se (avalanches)", "tail from s", "s_decay", "s_decay se", "tail n", "note"}, {}};
  Figure dist{"avalanche_distribution", "Avalanche size distribution", "s (bodies)", "probability density", {}, false,
              true, "Pooled over replicas; at most 6 points drawn (all in the table and CSVs)"};
  int colour = 0;
  // The distribution figure shows at most 6 points, spread over the list, to stay legible;
  // the table and the CSVs have them all.
  std::vector<const Point*> with_avalanches;
  for (const Point& p : c.points)
    if (p.metrics.avalanche_size.n > 0) with_avalanches.push_back(&p);
  std::set<const Point*> drawn;
  constexpr std::size_t kMaxDrawn = 6;
  for (std::size_t k = 0; k < std::min(kMaxDrawn, with_avalanches.size()); ++k)
    drawn.insert(with_avalanches[k * with_avalanches.size() / std::min(kMaxDrawn, with_avalanches.size())]);
  for (const Point& p : c.points) {
    std::vector<double> sizes;
    for (const AnalysedRun* a : p.runs)
      for (double v : a->analysis.series.avalanche_sizes()) sizes.push_back(v);
    if (sizes.empty()) continue;
    const AvalancheStats st = avalanche_stats(sizes);
    t.rows.push_back({point_name(c, p), format_mean_se(st.size.mean, st.size.se, st.size.n),
                      format_number(st.tail.s_min), format_number(st.tail.s_decay), format_number(st.tail.s_decay_se, 2),
                      std::to_string(st.tail.n_tail),
                      st.size.n < kThesisAvalanches ? "fewer than " + std::to_string(kThesisAvalanches) +
                                                          " avalanches (the thesis averages >= 100)"
                                                    : ""});
    Series se;
    se.label = point_name(c, p);
    se.columns = {"s", "density", "count"};
    se.style = Series::Style::kPoints;
    for (std::size_t i = 0; i < st.histogram.counts.size(); ++i)
      if (st.histogram.counts[i] > 0) se.rows.push_back({st.histogram.center(i), st.histogram.density(i), st.histogram.counts[i]});
    if (!drawn.count(&p)) continue;
    se.color = colour;
    dist.series.push_back(se);
    // The fitted tail drawn on the same density scale: (n_tail / n) (1 - q) q^(s - s_min).
    if (std::isfinite(st.tail.q) && st.size.n > 0) {
      Series tail;
      tail.label = "tail fit, " + point_name(c, p);
      tail.columns = {"s", "density_fit"};
      tail.style = Series::Style::kLines;
      tail.color = colour;
      const double norm = static_cast<double>(st.tail.n_tail) / st.size.n * (1.0 - st.tail.q);
      for (std::size_t i = 0; i < st.histogram.counts.size(); ++i) {
        const double sv = st.histogram.center(i);
        if (sv >= st.tail.s_min) tail.rows.push_back({sv, norm * std::pow(st.tail.q, sv - st.tail.s_min)});
      }
      if (!tail.rows.empty()) dist.series.push_back(tail);
    }
    ++colour;
  }
  if (!t.rows.empty()) s.blocks.push_back(t);
  if (has_x(c) && any)
    s.blocks.push_back(Figure{"avalanche_mean", "Mean avalanche size against " + c.x_label, c.x_label, "<s> (bodies)",
                              point_series(c, [](const Point& p) { return p.metrics.avalanche_size; }, "s_mean"), false,
                              false, "Error bars: standard error over avalanches"});
  if (!dist.series.empty()) s.blocks.push_back(dist);
  if (c.outlets > 1 && any_per_outlet) {
    // Several outlets: the exit stream of each outlet on its own (ch. 7: the small outlet
    // clogs and unclogs while the large one keeps the silo flowing).
    s.blocks.push_back(Text{"Per outlet: the same rule applied to each outlet's own exit stream (gaps counted from "
                            "the first exit through any outlet), so an outlet that clogs while another keeps flowing "
                            "has avalanches too."});
    Table po{"avalanches_per_outlet", "Avalanche sizes per point and outlet (pooled over replicas)",
             {"point", "outlet", "<s> ± se (avalanches)"}, {}};
    for (const Point& p : c.points)
      for (const OutletMetrics& m : p.metrics.per_outlet)
        po.rows.push_back({point_name(c, p), m.label,
                           m.avalanche_size.n > 0
                               ? format_mean_se(m.avalanche_size.mean, m.avalanche_size.se, m.avalanche_size.n)
                               : "no avalanche"});
    s.blocks.push_back(po);
    if (has_x(c))
      s.blocks.push_back(Figure{"avalanche_mean_per_outlet", "Mean avalanche size per outlet against " + c.x_label,
                                c.x_label, "<s> (bodies)",
                                outlet_series(c, [](const OutletMetrics& m) { return m.avalanche_size; }, "s_mean"),
                                false, false, "Error bars: standard error over avalanches"});
  }
  return s;
}

std::optional<Section> intermittency_section(const Context& c) {
  bool any = false;
  for (const AnalysedRun& a : c.used)
    for (const auto& series : a.analysis.series_per_outlet) any = any || series.unclogs() > 0;
  if (!any) return std::nullopt;
  Section s{"intermittency", "Flowing and clogged times per outlet (ch. 7)", {}};
  s.blocks.push_back(Text{"From the exit stream of each outlet: a gap of at least clog_window is a clog (t_c from the "
                          "last exit before it to the first after it); a flowing stretch runs from the opening or an "
                          "unclog to the last exit before a clog (t_f). Censored stretches (the run ended) are left "
                          "out of the means. N_u = unclogging events per unit time, over the replicas' total time."});
  Table t{"intermittency", "t_f, t_c and N_u per point and outlet (pooled over replicas)",
          {"point", "outlet", "<t_f> ± se (n)", "<t_c> ± se (n)", "N_u (1/sqrt(d/g))", "unclogs", "time"}, {}};
  // Figures against the x axis: one series per (group, outlet).
  Figure times{"intermittency_times", "Mean flowing and clogged times against " + c.x_label, c.x_label,
               "<t_f>, <t_c> (sqrt(d/g))", {}, false, false, "Error bars: se over stretches pooled over replicas"};
  Figure rate{"unclogging_rate", "Unclogging rate N_u against " + c.x_label, c.x_label, "N_u (1/sqrt(d/g))", {}, false,
              false, "Unclogging events per unit time over the replicas' total time"};
  std::map<std::string, std::size_t> tf_index, tc_index, nu_index;
  auto series_for = [](Figure& f, std::map<std::string, std::size_t>& index, const std::string& label,
                       const std::vector<std::string>& columns, Series::Style style) -> Series& {
    auto it = index.find(label);
    if (it == index.end()) {
      Series se;
      se.label = label;
      se.columns = columns;
      se.style = style;
      se.err = style == Series::Style::kErrorBars ? 2 : -1;
      f.series.push_back(se);
      it = index.emplace(label, f.series.size() - 1).first;
    }
    return f.series[it->second];
  };
  for (const Point& p : c.points) {
    std::size_t outlets = 0;
    for (const AnalysedRun* a : p.runs) outlets = std::max(outlets, a->analysis.series_per_outlet.size());
    for (std::size_t o = 0; o < outlets; ++o) {
      std::vector<ClogSeries> series;
      std::string label = "outlet " + std::to_string(o);
      for (const AnalysedRun* a : p.runs)
        if (o < a->analysis.series_per_outlet.size()) {
          series.push_back(a->analysis.series_per_outlet[o]);
          label = a->analysis.outlets[o].label;
        }
      const IntermittencyStats st = intermittency(series);
      t.rows.push_back({point_name(c, p), label, format_mean_se(st.t_flowing.mean, st.t_flowing.se, st.t_flowing.n),
                        format_mean_se(st.t_clogged.mean, st.t_clogged.se, st.t_clogged.n),
                        format_number(st.unclog_rate), std::to_string(st.unclogs), format_number(st.observed_time)});
      if (!std::isfinite(p.x)) continue;
      const std::string key = label + (p.group.empty() ? "" : ", " + p.group);
      const std::string xname = c.x_name;
      if (std::isfinite(st.t_flowing.mean))
        series_for(times, tf_index, "t_f " + key, {xname, "t_f", "t_f_se", "n"}, Series::Style::kErrorBars)
            .rows.push_back({p.x, st.t_flowing.mean, st.t_flowing.se, static_cast<double>(st.t_flowing.n)});
      if (std::isfinite(st.t_clogged.mean))
        series_for(times, tc_index, "t_c " + key, {xname, "t_c", "t_c_se", "n"}, Series::Style::kErrorBars)
            .rows.push_back({p.x, st.t_clogged.mean, st.t_clogged.se, static_cast<double>(st.t_clogged.n)});
      if (std::isfinite(st.unclog_rate))
        series_for(rate, nu_index, key, {xname, "N_u", "unclogs", "time"}, Series::Style::kLinesPoints)
            .rows.push_back({p.x, st.unclog_rate, static_cast<double>(st.unclogs), st.observed_time});
    }
  }
  s.blocks.push_back(t);
  if (has_x(c)) {
    if (!times.series.empty()) s.blocks.push_back(times);
    if (!rate.series.empty()) s.blocks.push_back(rate);
  }
  return s;
}

// ---- engine comparison (campaign compare) ------------------------------------------------

constexpr double kInf = std::numeric_limits<double>::infinity();

const char* metric_title(const std::string& name) {
  static const std::map<std::string, const char*> titles = {
      {"q_count", "Q (bodies / sqrt(d/g))"}, {"q_mass", "Q_m (mass / sqrt(d/g))"},
      {"phi", "packing fraction"},           {"tg_translational", "T_g translational (ch. 3)"},
      {"tg_full", "T_g (ch. 4-5)"},          {"v_max", "V_max / sqrt(g d)"},
      {"avalanche_size", "mean avalanche size"}, {"psi", "clogging index Psi"}};
  const auto it = titles.find(name);
  return it == titles.end() ? name.c_str() : it->second;
}

// The comparison of the first two engines of the campaign: native is `a` when present.
std::optional<EngineComparison> engine_comparison_of(const Context& c) {
  if (c.engines.size() < 2) return std::nullopt;
  const bool has_native = std::find(c.engines.begin(), c.engines.end(), "native") != c.engines.end();
  const std::string a = has_native ? "native" : c.engines[0];
  std::string b;
  for (const auto& e : c.engines)
    if (e != a && b.empty()) b = e;
  std::vector<PointMetrics> ma, mb;
  for (const Point& p : c.points) {
    if (p.engine == a) ma.push_back(p.metrics);
    if (p.engine == b) mb.push_back(p.metrics);
  }
  std::vector<RunTiming> ta, tb;
  for (const AnalysedRun& r : c.used) {
    if (r.record->engine == a) ta.push_back(r.timing);
    if (r.record->engine == b) tb.push_back(r.timing);
  }
  return compare_engines(a, ma, ta, b, mb, tb);
}

// The point of `engine` with these sweep values, or nullptr.
const Point* engine_point(const Context& c, const nlohmann::json& point, const std::string& engine) {
  for (const Point& p : c.points)
    if (p.engine == engine && p.point == point) return &p;
  return nullptr;
}

// The report's name of a compared point: the x value and the groups without the engine.
std::string shared_point_name(const Context& c, const nlohmann::json& point, const std::string& engine) {
  const Point* p = engine_point(c, point, engine);
  if (!p) return point.dump();
  std::string s = p->shared_group;
  if (!c.x_axis.empty()) s = c.x_name + "=" + format_number(p->x, 6) + (s.empty() ? "" : ", " + s);
  return s;
}

std::optional<Section> engine_comparison_section(const Context& c) {
  if (!c.comparison) return std::nullopt;
  const EngineComparison& k = *c.comparison;
  const std::string& a = k.engine_a;
  const std::string& b = k.engine_b;
  Section s{"engine-comparison", "Engine comparison: " + a + " and " + b, {}};
  std::map<std::string, std::set<std::string>> caps, reinjections;
  for (const AnalysedRun& r : c.used) {
    caps[r.record->engine].insert(r.tangential_cap);
    if (!r.reinjection.empty()) reinjections[r.record->engine].insert(r.reinjection);
  }
  auto list_text = [](const std::set<std::string>& values) {
    std::string t;
    for (const auto& x : values) t += (t.empty() ? "" : ", ") + x;
    return t.empty() ? std::string("?") : t;
  };
  auto cap_text = [&](const std::string& e) { return list_text(caps[e]); };
  const std::string reinjection_text =
      reinjections.empty() ? std::string()
                           : " Reinjection: " + a + " `" + list_text(reinjections[a]) + "`, " + b + " `" +
                                 list_text(reinjections[b]) +
                                 "` (`random`: a random place on top of the bed, the thesis; `periodic`: "
                                 "through the bottom of a y-periodic box, same x and velocity, LIGGGHTS' way).";
  s.blocks.push_back(Text{
      "The same sweep points and replica seeds on both engines (beds are prepared by each engine, so replicas are "
      "statistically, not bodily, the same). Ratio = " + b + " / " + a + ", with the standard error of both "
      "means propagated. **agree**: the difference is within " + format_number(kAgreementSigmas) +
      " combined standard errors. Coulomb cap of the tangential force: " + a + " `" + cap_text(a) + "`, " + b + " `" +
      cap_text(b) + "` (`lammps` caps spring + damping, `liggghts` the spring part only; docs/liggghts.md)." +
      reinjection_text});
  // One line per metric: how many points agree and the spread of the ratio.
  std::map<std::string, std::vector<const MetricAgreement*>> by_metric;
  std::vector<std::string> metric_order;
  for (const PointAgreement& p : k.points)
    for (const MetricAgreement& m : p.metrics) {
      if (!by_metric.count(m.difference.name)) metric_order.push_back(m.difference.name);
      by_metric[m.difference.name].push_back(&m);
    }
  Table overview{"engine_agreement",
                 "Agreement per metric over all compared points (n/a: no standard error on one side, e.g. one "
                 "replica, so agreement cannot be judged)",
                 {"metric", "points", "agree", "disagree", "n/a", "ratio min", "ratio mean", "ratio max"}, {}};
  for (const auto& name : metric_order) {
    int agree = 0, disagree = 0, unknown = 0;
    double lo = kInf, hi = -kInf, sum = 0;
    int n = 0;
    for (const MetricAgreement* m : by_metric[name]) {
      (m->agree ? (*m->agree ? agree : disagree) : unknown) += 1;
      if (!std::isfinite(m->ratio)) continue;
      lo = std::min(lo, m->ratio);
      hi = std::max(hi, m->ratio);
      sum += m->ratio;
      ++n;
    }
    overview.rows.push_back({metric_title(name), std::to_string(by_metric[name].size()), std::to_string(agree),
                             std::to_string(disagree), std::to_string(unknown), n ? format_number(lo) : "", n ? format_number(sum / n) : "", n ? format_number(hi) : ""});
  }
  if (k.points.empty()) {
    s.blocks.push_back(Text{"No sweep point has finished runs on both engines yet."});
  } else {
    s.blocks.push_back(overview);
    Table t{"engine_comparison", "Every metric of every point on both engines (mean ± se (n) over replicas)",
            {"point", "metric", a, b, "ratio " + b + "/" + a, "z", "agree"}, {}};
    for (const PointAgreement& p : k.points) {
      const std::string name = shared_point_name(c, p.point, a);
      for (const MetricAgreement& m : p.metrics) {
        const MetricDifference& d = m.difference;
        t.rows.push_back({name, metric_title(d.name), format_mean_se(d.a.mean, d.a.se, d.a.n),
                          format_mean_se(d.b.mean, d.b.se, d.b.n), format_mean_se(m.ratio, m.ratio_se, -1),
                          format_number(d.z, 3), agreement_text(m.agree)});
      }
    }
    s.blocks.push_back(t);
  }
  // Ratio against x, one series per (metric, group), with the 10 % band.
  if (has_x(c) && !k.points.empty()) {
    Figure f{"engine_ratio", "Ratio " + b + " / " + a + " against " + c.x_label, c.x_label, b + " / " + a, {}, false,
             false, "Error bars: propagated se of both means. Black lines: equal, and the ±10 % band."};
    double xlo = kInf, xhi = -kInf;
    for (const char* metric : {"q_count", "phi", "tg_full", "psi", "avalanche_size"}) {
      std::map<std::string, Series> by_group;
      std::vector<std::string> order;
      for (const PointAgreement& p : k.points) {
        const Point* pa = engine_point(c, p.point, a);
        if (!pa || !std::isfinite(pa->x)) continue;
        for (const MetricAgreement& m : p.metrics) {
          if (m.difference.name != metric || !std::isfinite(m.ratio)) continue;
          if (!by_group.count(pa->shared_group)) {
            order.push_back(pa->shared_group);
            Series ser;
            ser.label = std::string(metric_title(metric)) + (pa->shared_group.empty() ? "" : ", " + pa->shared_group);
            ser.columns = {c.x_name, "ratio", "ratio_se"};
            ser.style = Series::Style::kErrorBars;
            ser.err = 2;
            by_group[pa->shared_group] = ser;
          }
          by_group[pa->shared_group].rows.push_back({pa->x, m.ratio, m.ratio_se});
          xlo = std::min(xlo, pa->x);
          xhi = std::max(xhi, pa->x);
        }
      }
      for (const auto& g : order) {
        Series& ser = by_group[g];
        std::sort(ser.rows.begin(), ser.rows.end());
        f.series.push_back(std::move(ser));
      }
    }
    if (!f.series.empty()) {
      for (const double level : {0.9, 1.0, 1.1}) {
        Series line;
        line.label = level == 1.0 ? "equal" : (level < 1 ? "-10 %" : "+10 %");
        line.columns = {c.x_name, "ratio"};
        line.style = Series::Style::kLines;
        line.color = 7;
        line.rows = {{xlo, level}, {xhi, level}};
        f.series.push_back(std::move(line));
      }
      s.blocks.push_back(f);
    }
  }
  Table cost{"engine_cost", "What each engine cost on this campaign (discharge throughput: disc-steps per second "
                            "per run; one disc = one sphere of a LIGGGHTS multisphere body)",
             {"engine", "runs", "wall time (bed + discharge)", "discharge wall time", "disc-steps/s per run",
              "threads per run", "throughput / " + a}, {}};
  const double base_rate = k.costs.empty() ? kNaN : k.costs.front().disc_steps_per_s.mean;
  for (const EngineCost& e : k.costs) {
    cost.rows.push_back({e.engine, std::to_string(e.runs), format_number(e.wall_s, 4) + " s",
                         format_number(e.discharge_wall_s, 4) + " s",
                         format_mean_se(e.disc_steps_per_s.mean, e.disc_steps_per_s.se, e.disc_steps_per_s.n),
                         std::to_string(e.threads), format_number(e.disc_steps_per_s.mean / base_rate, 3)});
  }
  s.blocks.push_back(cost);
  return s;
}

// ---- the system: what was simulated -------------------------------------------------------

std::optional<Section> system_section(const Context& c) {
  Section s{"system", "The system", {}};
  const nlohmann::json& cs = c.campaign->spec;
  std::string intro = cs.is_object() && cs.contains("description") && cs.at("description").is_string()
                          ? cs.at("description").get<std::string>()
                          : "(The campaign spec has no \"description\".)";
  s.blocks.push_back(Text{intro});
  // A resolved run spec of the campaign: of a point's run, else of any run it has.
  nlohmann::json spec;
  if (!c.points.empty()) spec = c.points.front().spec;
  for (const auto* list : {&c.missing, &c.failed, &c.retired})
    if (spec.is_null() && !list->empty()) spec = list->front()->spec;
  if (spec.is_null()) return s;
  s.blocks.push_back(fixed_parameters(spec, c.campaign->axes));
  if (!c.campaign->axes.empty()) {
    Table t;
    t.name = "system-axes";
    t.caption = "Swept parameters";
    t.header = {"parameter", "in the run spec", "values"};
    for (const auto& axis : c.campaign->axes) {
      std::vector<std::string> values;
      for (const auto& p : c.points) {
        const auto v = axis_value(axis, p.point, p.spec);
        const std::string text = v ? json_text(*v) : "?";
        if (std::find(values.begin(), values.end(), text) == values.end()) values.push_back(text);
      }
      std::string joined;
      for (const auto& v : values) joined += (joined.empty() ? "" : ", ") + v;
      t.rows.push_back({axis_name(axis, spec), axis, joined.empty() ? "(no finished run yet)" : joined});
    }
    s.blocks.push_back(t);
  }
  // Each point: the bed before the outlets open and the last state of its first replica.
  if (!c.options->draw_run) {
    s.blocks.push_back(Text{"(No pictures: this report was written without the renderer.)"});
    return s;
  }
  std::vector<std::string> problems;
  for (std::size_t k = 0; k < c.points.size(); ++k) {
    const Point& p = c.points[k];
    const AnalysedRun* run = nullptr;
    for (const AnalysedRun* r : p.runs)
      if (!run || r->record->replica < run->record->replica) run = r;
    if (!run) continue;
    const std::string stem = "pictures/point-" + std::to_string(k + 1);
    std::filesystem::create_directories(c.options->out_dir / "pictures");
    Pictures pics;
    std::string label;
    for (const auto& axis : c.campaign->axes) {
      const auto v = axis_value(axis, p.point, p.spec);
      label += (label.empty() ? "" : ", ") + axis_name(axis, p.spec) + " = " + (v ? json_text(*v) : "?");
    }
    pics.caption = (label.empty() ? std::string("The silo") : label) + " (replica " + std::to_string(run->record->replica) +
                   ", run `" + run->record->run_id.substr(0, 10) + "`)";
    const std::string end = run->analysis.end_reason;
    const std::pair<ReportOptions::Picture, std::string> kinds[] = {
        {ReportOptions::Picture::kBed, "the bed before the outlets open (t = 0)"},
        {ReportOptions::Picture::kEnd, (end == "clogged" ? "clogged" : end == "discharged" ? "discharged" : "the last frame") +
                                           std::string(" (t = ") + format_number(run->analysis.t_end, 4) + ")"}};
    for (const auto& [kind, caption] : kinds) {
      const std::string file = stem + (kind == ReportOptions::Picture::kBed ? "-bed.png" : "-end.png");
      const std::string problem = c.options->draw_run(run->record->run_dir, kind, c.options->out_dir / file);
      if (problem.empty()) {
        pics.pictures.push_back({file, caption});
      } else if (problems.size() < 5) {
        problems.push_back(problem);
      }
    }
    if (!pics.pictures.empty()) s.blocks.push_back(pics);
  }
  if (!problems.empty()) {
    std::string text = "Not drawn:";
    for (const auto& pr : problems) text += "\n\n" + pr;
    s.blocks.push_back(Text{text});
  }
  return s;
}

using SectionBuilder = std::optional<Section> (*)(const Context&);
// The report's sections in order. A new analysis adds one function and one line here.
constexpr SectionBuilder kSections[] = {system_section,    runs_section,      provenance_section,     per_run_section,
                                        flow_section,      profile_section,        region_section,
                                        clogging_index_section, avalanche_section, intermittency_section,
                                        engine_comparison_section};

[[noreturn]] void bad_report_key(const std::string& path, const nlohmann::json& value, const std::string& allowed) {
  throw std::invalid_argument(path + ": " + allowed + " (got " + value.dump() + ")");
}

double number_at(const nlohmann::json& j, const std::string& path, double lo, double hi) {
  if (!j.is_number()) bad_report_key(path, j, "must be a number");
  const double v = j.get<double>();
  if (v < lo || v > hi)
    bad_report_key(path, j, "must be in [" + format_number(lo) + ", " + format_number(hi) + "]");
  return v;
}

}  // namespace

void apply_report_spec(const nlohmann::json& campaign_spec, ReportOptions& options) {
  if (!campaign_spec.is_object() || !campaign_spec.contains("report")) return;
  const nlohmann::json& r = campaign_spec.at("report");
  if (!r.is_object()) bad_report_key("/report", r, "must be an object");
  AnalysisOptions& a = options.analysis;
  constexpr double kBig = 1e300;
  for (const auto& [key, v] : r.items()) {
    const std::string path = "/report/" + key;
    if (key == "models") {
      if (!v.is_array()) bad_report_key(path, v, "must be an array of {name, expression, variable, initial}");
      for (std::size_t i = 0; i < v.size(); ++i) {
        const nlohmann::json& m = v[i];
        const std::string mp = path + "/" + std::to_string(i);
        if (!m.is_object() || !m.contains("expression") || !m.at("expression").is_string())
          bad_report_key(mp, m, "must be {\"name\": .., \"expression\": \"C * x^b\", \"variable\": \"x\", \"initial\": {..}}");
        FitModel f;
        f.name = m.contains("name") && m.at("name").is_string() ? m.at("name").get<std::string>()
                                                                : "model_" + std::to_string(i);
        f.expression = m.at("expression").get<std::string>();
        if (m.contains("variable")) {
          if (!m.at("variable").is_string()) bad_report_key(mp + "/variable", m.at("variable"), "must be a name");
          f.variable = m.at("variable").get<std::string>();
        }
        if (m.contains("initial")) {
          if (!m.at("initial").is_object()) bad_report_key(mp + "/initial", m.at("initial"), "must be {parameter: value}");
          for (const auto& [k, iv] : m.at("initial").items()) f.initial[k] = number_at(iv, mp + "/initial/" + k, -kBig, kBig);
        }
        try {
          Expression::parse(f.expression, {f.variable});
        } catch (const ExpressionError& e) {
          throw std::invalid_argument(mp + "/expression: " + e.what());
        }
        // Idempotent: a caller may apply the spec before write_report applies it again.
        const bool known = std::any_of(options.models.begin(), options.models.end(), [&](const FitModel& x) {
          return x.name == f.name && x.expression == f.expression && x.variable == f.variable;
        });
        if (!known) options.models.push_back(f);
      }
    } else if (key == "region") {
      if (v == "ch3") {
        a.region = chapter3_region();
      } else if (v == "ch4") {
        a.region = chapter4_region();
      } else if (v.is_object() && v.contains("pad") && v.contains("height")) {
        a.region.pad = number_at(v.at("pad"), path + "/pad", -kBig, kBig);
        a.region.height = number_at(v.at("height"), path + "/height", 0.0, kBig);
        a.region.label = "(W + " + format_number(a.region.pad) + " d) x " + format_number(a.region.height) + " d";
      } else {
        bad_report_key(path, v, "must be \"ch3\", \"ch4\" or {\"pad\": .., \"height\": ..}");
      }
    } else if (key == "clog_gap") {
      a.clog_gap = number_at(v, path, 0.0, kBig);
    } else if (key == "min_exits_before_clog") {
      a.min_exits_before_clog = static_cast<int>(number_at(v, path, 0.0, 1e9));
    } else if (key == "frame_stride") {
      a.frame_stride = static_cast<int>(number_at(v, path, 1.0, 1e9));
    } else if (key == "max_frames") {
      a.max_frames = static_cast<int>(number_at(v, path, 0.0, 1e9));
    } else if (key == "window" && v.is_object()) {
      for (const auto& [k, w] : v.items()) {
        const std::string p = path + "/" + k;
        if (k == "start_time") {
          a.window.start_time = number_at(w, p, 0.0, kBig);
        } else if (k == "start_fraction") {
          a.window.start_fraction = number_at(w, p, 0.0, 1.0);
        } else if (k == "shallow_fraction") {
          a.window.shallow_fraction = number_at(w, p, 0.0, 1.0);
        } else if (k == "min_events") {
          a.window.min_events = static_cast<int>(number_at(w, p, 2.0, 1e9));
        } else if (k == "stop_at_first_clog") {
          if (!w.is_boolean()) bad_report_key(p, w, "must be true or false");
          a.window.stop_at_first_clog = w.get<bool>();
        } else {
          bad_report_key(p, w, "unknown key (known: start_time, start_fraction, shallow_fraction, min_events, "
                               "stop_at_first_clog)");
        }
      }
    } else if (key == "profile" && v.is_object()) {
      for (const auto& [k, w] : v.items()) {
        const std::string p = path + "/" + k;
        if (k == "bins") {
          a.profile.bins = static_cast<int>(number_at(w, p, 1.0, 1e6));
        } else if (k == "band_low") {
          a.profile.band_low = number_at(w, p, -kBig, kBig);
        } else if (k == "band_high") {
          a.profile.band_high = number_at(w, p, -kBig, kBig);
        } else {
          bad_report_key(p, w, "unknown key (known: bins, band_low, band_high)");
        }
      }
    } else {
      bad_report_key(path, v,
                     "unknown key or wrong type (known: models, region, clog_gap, min_exits_before_clog, "
                     "frame_stride, max_frames, window {..}, profile {..})");
    }
  }
}

ReportSummary write_report(const CampaignInfo& campaign, const std::vector<RunRecord>& runs,
                           const ReportOptions& options) {
  if (options.out_dir.empty()) throw std::invalid_argument("write_report: ReportOptions::out_dir is empty");
  ReportOptions effective = options;
  apply_report_spec(campaign.spec, effective);
  // A campaign on several engines: the engine is one more axis, so every table, figure and fit
  // keeps the engines apart, and the engines are compared point by point.
  CampaignInfo with_engines = campaign;
  std::vector<std::string> engines;
  for (const RunRecord& r : runs)
    if (r.state != "retired" && std::find(engines.begin(), engines.end(), r.engine) == engines.end())
      engines.push_back(r.engine);
  if (engines.size() > 1 && std::find(campaign.axes.begin(), campaign.axes.end(), "/engine") == campaign.axes.end())
    with_engines.axes.push_back("/engine");
  Context c = build_context(with_engines, runs, effective);
  c.engines = engines;
  c.comparison = engine_comparison_of(c);
  std::vector<Section> sections;
  for (SectionBuilder build : kSections)
    if (auto s = build(c)) sections.push_back(std::move(*s));
  RenderOptions render;
  render.figures = options.figures;
  render.gnuplot = options.gnuplot;
  const RenderResult r = render_report("Granary report: " + campaign.name, sections, options.out_dir, render);
  ReportSummary summary;
  summary.runs_used = static_cast<int>(c.used.size());
  summary.runs_missing = static_cast<int>(c.missing.size());
  summary.runs_failed = static_cast<int>(c.failed.size() + c.unreadable.size());
  summary.markdown = r.markdown;
  summary.html = r.html;
  if (c.comparison) summary.comparison = to_json(*c.comparison);
  return summary;
}

}  // namespace granary::analysis
