// See campaign_view.h.
#include "analysis/campaign_view.h"

#include <algorithm>
#include <cmath>
#include <regex>

#include "analysis/analysis.h"
#include "analysis/outlets.h"
#include "analysis/system.h"
#include "rundir/layout.h"

namespace granary::analysis {
namespace {

std::string TangentialCapOf(const nlohmann::json& spec) {
  if (spec.is_object() && spec.contains("contact") && spec.at("contact").is_object())
    return spec.at("contact").value("tangential_cap", std::string("lammps")) + "";
  return "lammps (default)";
}

// The used run of a done record, or the reason it cannot be used.
std::optional<UsedRun> ToUsedRun(const RunRecord& r, std::string& why) {
  UsedRun u;
  u.record = &r;
  try {
    const std::filesystem::path file = r.run_dir / rundir::kSummaryFile;
    if (!std::filesystem::exists(file)) throw rundir::ReadError(file.string() + ": missing");
    u.summary = rundir::ReadSummary(file);
    u.spec = std::filesystem::exists(r.run_dir / rundir::kRunSpecFile) ? rundir::ReadRunSpecJson(r.run_dir) : r.spec;
  } catch (const std::exception& e) {
    why = e.what();
    return std::nullopt;
  }
  if (u.spec.is_null()) u.spec = u.summary.spec;
  // LIGGGHTS says which cap and which reinjection it applied, whatever the spec asks.
  u.tangential_cap = !u.summary.tangential_cap.empty() ? u.summary.tangential_cap : TangentialCapOf(u.spec);
  const nlohmann::json discharge =
      u.spec.is_object() ? u.spec.value("discharge", nlohmann::json::object()) : nlohmann::json::object();
  if (discharge.value("mode", std::string()) == "reinject")
    u.reinjection = !u.summary.reinject_position.empty() ? u.summary.reinject_position
                                                         : discharge.value("reinject_position", std::string("random"));
  if (u.summary.timing) {
    u.timing.wall_s = u.summary.timing->wall_s;
    u.timing.discharge_wall_s = u.summary.timing->discharge_wall_s;
    u.timing.disc_steps_per_s = u.summary.timing->disc_steps_per_s;
    u.timing.threads = u.summary.timing->threads;
  }
  if (u.summary.engine.empty()) u.summary.engine = r.engine;
  u.outlets = OutletsOf(u.spec).size();
  return u;
}

}  // namespace

std::string ValueText(const nlohmann::json& v) {
  if (v.is_number()) return FormatNumber(v.get<double>(), 6);
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

std::string ShortAxis(const std::string& pointer) {
  std::string s = pointer;
  if (!s.empty() && s.front() == '/') s.erase(0, 1);
  for (const char* prefix : {"silo/", "bodies/", "contact/", "discharge/", "output/", "bed/"})
    if (s.rfind(prefix, 0) == 0) s.erase(0, std::string(prefix).size());
  std::replace(s.begin(), s.end(), '/', '.');
  return s;
}

std::optional<nlohmann::json> AxisValue(const std::string& axis, const nlohmann::json& point,
                                        const nlohmann::json& spec) {
  if (point.is_object() && point.contains(axis)) return point.at(axis);
  try {
    const nlohmann::json::json_pointer ptr(axis);
    if (spec.is_object() && spec.contains(ptr)) return spec.at(ptr);
  } catch (const nlohmann::json::exception&) {
  }
  return std::nullopt;
}

std::string AxisText(const CampaignView& view, const std::string& axis, const nlohmann::json& spec, NameForm form) {
  if (form == NameForm::kShort)
    if (const auto it = view.axis_symbols.find(axis); it != view.axis_symbols.end()) return it->second;
  return AxisName(axis, spec);
}

std::string PointLabel(const CampaignView& view, const nlohmann::json& point, const nlohmann::json& spec, NameForm form,
                       const std::set<std::string>& skip_axes) {
  std::string s;
  for (const auto& axis : view.axes) {
    if (skip_axes.count(axis)) continue;
    const auto v = AxisValue(axis, point, spec);
    s += (s.empty() ? "" : ", ") + AxisText(view, axis, spec, form) + " = " + (v ? ValueText(*v) : "?");
  }
  return s;
}

std::string PointLabelWithUnits(const CampaignView& view, const nlohmann::json& point, const nlohmann::json& spec) {
  std::string s;
  for (const auto& axis : view.axes) {
    const auto v = AxisValue(axis, point, spec);
    const std::string unit = v && v->is_number() ? AxisUnit(axis) : "";
    s += (s.empty() ? "" : ", ") + AxisText(view, axis, spec, NameForm::kShort) + " = " + (v ? ValueText(*v) : "?") +
         (unit.empty() ? "" : " " + unit);
  }
  return s;
}

std::string XText(const CampaignView& view, double x, NameForm form) {
  if (view.x_axis.empty()) return "";
  return (form == NameForm::kShort ? view.x_symbol : view.x_title) + " = " + FormatNumber(x, 6);
}

std::string PointName(const CampaignView& view, const Point& p) {
  std::string s = p.group;
  if (!view.x_axis.empty()) s = XText(view, p.x, NameForm::kShort) + (s.empty() ? "" : ", " + s);
  return s.empty() ? p.id : s;
}

std::string PointTitle(const CampaignView& view, const Point& p) {
  std::string s = p.group_title;
  if (!view.x_axis.empty()) s = XText(view, p.x, NameForm::kLong) + (s.empty() ? "" : ", " + s);
  return s.empty() ? p.id : s;
}

std::vector<std::string> GroupsOf(const CampaignView& view) {
  std::vector<std::string> g;
  for (const Point& p : view.points)
    if (std::find(g.begin(), g.end(), p.group) == g.end()) g.push_back(p.group);
  return g;
}

bool HasX(const CampaignView& view) {
  int n = 0;
  for (const Point& p : view.points) n += std::isfinite(p.x) ? 1 : 0;
  return n >= 2;
}

std::string GroupAxis(const CampaignView& view) {
  const std::vector<std::string> groups = GroupsOf(view);
  if (groups.size() < 2) return "";
  for (const auto& axis : view.axes) {
    if (view.x_axes.count(axis)) continue;
    std::map<std::string, double> value_of_group;
    bool ok = true;
    for (const Point& p : view.points) {
      const auto v = AxisValue(axis, p.point, p.spec);
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

CampaignView MakeCampaignView(const CampaignInfo& campaign, const std::vector<RunRecord>& runs,
                              const std::map<std::string, std::string>& unreadable, const RunChecks& checks) {
  CampaignView c;
  c.campaign = &campaign;
  c.axes = campaign.axes;
  for (const RunRecord& r : runs)
    if (r.state != "retired" && std::find(c.engines.begin(), c.engines.end(), r.engine) == c.engines.end())
      c.engines.push_back(r.engine);
  // A campaign on several engines: the engine is one more axis, so every table, figure and fit
  // keeps the engines apart.
  if (c.engines.size() > 1 && std::find(c.axes.begin(), c.axes.end(), "/engine") == c.axes.end())
    c.axes.push_back("/engine");
  for (const RunRecord& r : runs) {
    if (r.state == "failed") {
      c.failed.push_back(&r);
    } else if (r.state == "retired") {
      c.retired.push_back(&r);
    } else if (r.state != "done") {
      c.missing.push_back(&r);
    } else if (!std::filesystem::exists(r.run_dir)) {
      c.lost.push_back(&r);
    } else if (const auto check = checks.find(r.run_id);
               check != checks.end() && check->second.integrity == rundir::Integrity::kDamaged) {
      c.damaged.emplace_back(&r, check->second.problems);
    } else if (const auto it = unreadable.find(r.run_id); it != unreadable.end()) {
      c.unreadable.emplace_back(&r, it->second);
    } else {
      std::string why;
      if (auto u = ToUsedRun(r, why)) {
        if (check != checks.end() && check->second.integrity == rundir::Integrity::kNotVerifiable)
          c.unverifiable.push_back(&r);
        c.used.push_back(std::move(*u));
      } else {
        c.unreadable.emplace_back(&r, why);
      }
    }
  }
  const UsedRun* most = nullptr;
  for (const UsedRun& u : c.used)
    if (!most || u.outlets > most->outlets) most = &u;
  if (most) {
    c.outlets = std::max<std::size_t>(1, most->outlets);
    for (const OutletGeometry& o : OutletsOf(most->spec)) c.outlet_labels.push_back(o.label);
  }
  // Each axis' one short name (its symbol; two axes with one symbol, such as two species' "d",
  // their short paths), and the derived axes of the campaign spec's /axes.
  {
    const nlohmann::json& spec = runs.empty() ? nlohmann::json() : runs.front().spec;
    const nlohmann::json& cs = campaign.spec;
    c.named = CampaignAxes(c.axes, spec, cs.is_object() && cs.contains("axes") ? cs.at("axes") : nlohmann::json());
    for (const auto& axis : c.axes) c.axis_symbols[axis] = c.named.ShortName(axis);
  }
  // The x axis: the gap between two base outlets if a base outlet's centre is swept (the
  // thesis plots ch. 5b and 7 against L), else an outlet width if swept, else the first
  // numeric axis.
  const std::regex centre_axis(R"(/silo/base_outlets/\d+/center)");
  const std::regex width_axis(R"(/silo/(base|side)_outlets/(\d+)/width)");
  bool two_base_outlets = !runs.empty();
  for (const RunRecord& r : runs) two_base_outlets = two_base_outlets && BaseOutletGap(r.spec).has_value();
  for (const auto& axis : c.axes)
    if (two_base_outlets && std::regex_match(axis, centre_axis)) c.x_axes.insert(axis);
  if (!c.x_axes.empty()) {
    c.x_is_gap = true;
    c.x_axis = *c.x_axes.begin();
    c.x_name = c.x_symbol = "L";
    c.x_title = "gap L";
    c.x_label = "L/d (gap between base outlets 0 and 1, edge to edge)";
  }
  for (const auto& axis : c.axes) {
    std::smatch m;
    if (c.x_is_gap || !std::regex_match(axis, m, width_axis)) continue;
    c.x_axis = axis;
    c.x_axes = {axis};
    c.x_is_width = true;
    c.x_name = c.axis_symbols[axis];
    c.x_title = AxisName(axis, runs.empty() ? nlohmann::json() : runs.front().spec);
    c.x_symbol = c.axis_symbols[axis];
    c.x_label = "W/d (" + c.x_title + ")";
    // Outlets are numbered in event order: base outlets first, then side outlets.
    c.x_outlet = std::stoi(m[2].str());
    if (m[1].str() == "side" && !runs.empty()) {
      int base = 0;
      for (const OutletGeometry& o : OutletsOf(runs.front().spec)) base += o.base ? 1 : 0;
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
    for (const auto& axis : c.axes) {
      bool numeric = true;
      for (const RunRecord& r : runs) {
        const auto v = AxisValue(axis, r.point, r.spec);
        if (!v || !v->is_number()) numeric = false;
      }
      if (numeric && !runs.empty()) {
        c.x_axis = axis;
        c.x_axes = {axis};
        c.x_name = c.axis_symbols[axis];
        c.x_label = c.x_title = AxisName(axis, runs.front().spec);
        c.x_symbol = c.axis_symbols[axis];
        break;
      }
    }
  }
  for (std::size_t i = 0; i < c.used.size(); ++i) c.points[index[c.used[i].record->point_id]].runs.push_back(i);
  for (Point& p : c.points) {
    nlohmann::json spec = p.runs.empty() ? nlohmann::json() : c.used[p.runs.front()].record->spec;
    if (spec.is_null())
      for (const RunRecord& r : runs)
        if (r.point_id == p.id) {
          spec = r.spec;
          break;
        }
    if (c.x_is_gap) {
      p.x = BaseOutletGap(spec).value_or(kNaN);
    } else if (!c.x_axis.empty()) {
      const auto v = AxisValue(c.x_axis, p.point, spec);
      if (v && v->is_number()) p.x = v->get<double>();
    }
    p.group = PointLabel(c, p.point, spec, NameForm::kShort, c.x_axes);
    p.group_title = PointLabel(c, p.point, spec, NameForm::kLong, c.x_axes);
    p.spec = spec;
    const auto engine = AxisValue("/engine", p.point, spec);
    p.engine = engine && engine->is_string() ? engine->get<std::string>() : "";
    std::set<std::string> skip = c.x_axes;
    skip.insert("/engine");
    p.shared_group = PointLabel(c, p.point, spec, NameForm::kShort, skip);
  }
  std::stable_sort(c.points.begin(), c.points.end(), [](const Point& a, const Point& b) {
    if (a.group != b.group) return a.group < b.group;
    return a.x < b.x;
  });
  return c;
}

namespace {

// The curve of metric `name` over the points of `group`: rows (x, mean, se, n) where defined.
Series MetricCurve(const CampaignView& view, const PointMetricTable& metrics, const std::string& name,
                   const std::string& group, const std::string& label, const std::string& column) {
  Series s;
  s.label = label;
  s.columns = {view.x_label.empty() ? "x" : view.x_name, column, column + "_se", "n"};
  s.style = Series::Style::kErrorBars;
  s.err = 2;
  for (std::size_t i = 0; i < view.points.size() && i < metrics.size(); ++i) {
    const Point& p = view.points[i];
    if (p.group != group || !std::isfinite(p.x)) continue;
    const PointMetric* m = FindMetric(metrics[i], name);
    if (!m || !std::isfinite(m->mean)) continue;
    s.rows.push_back({p.x, m->mean, m->se, static_cast<double>(m->n)});
  }
  return s;
}

}  // namespace

std::vector<Series> PointSeries(const CampaignView& view, const PointMetricTable& metrics, const std::string& name,
                                const std::string& column) {
  std::vector<Series> out;
  for (const auto& g : GroupsOf(view)) {
    Series s = MetricCurve(view, metrics, name, g, g.empty() ? column : g, column);
    if (!s.rows.empty()) out.push_back(std::move(s));
  }
  return out;
}

std::vector<std::size_t> SpreadPoints(const CampaignView& view, const std::function<bool(std::size_t)>& has,
                                      std::size_t most) {
  std::vector<std::size_t> with;
  for (std::size_t k = 0; k < view.points.size(); ++k)
    if (has(k)) with.push_back(k);
  if (with.size() <= most) return with;
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < most; ++k) out.push_back(with[k * with.size() / most]);
  return out;
}

std::vector<Series> OutletSeries(const CampaignView& view, const PointMetricTable& metrics,
                                 const std::function<std::string(std::size_t)>& name_of,
                                 const std::vector<std::string>& outlet_labels, const std::string& column) {
  std::vector<Series> out;
  for (std::size_t o = 0; o < view.outlets; ++o) {
    const std::string label = o < outlet_labels.size() ? outlet_labels[o] : "outlet " + std::to_string(o);
    for (const auto& g : GroupsOf(view)) {
      Series s = MetricCurve(view, metrics, name_of(o), g, label + (g.empty() ? "" : ", " + g), column);
      if (!s.rows.empty()) out.push_back(std::move(s));
    }
  }
  return out;
}

}  // namespace granary::analysis
