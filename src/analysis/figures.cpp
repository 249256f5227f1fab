// See figures.h.
#include "analysis/figures.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "analysis/options.h"

namespace granary::analysis {
namespace {

constexpr const char* kFigureKeys[] = {"name", "kind", "picture", "y", "ylabel", "x", "group", "pool", "only", "fit",
                                       "title", "caption", "reference", "logx", "logy"};
constexpr const char* kFitKeys[] = {"model", "over", "initial", "collapse"};

std::string joined(const std::vector<std::string>& items) {
  std::string s;
  for (const auto& i : items) s += (s.empty() ? "" : ", ") + i;
  return s.empty() ? "none" : s;
}

void check_keys(const nlohmann::json& j, const std::string& path, const char* const* begin, const char* const* end) {
  for (const auto& [key, v] : j.items())
    if (std::find_if(begin, end, [&](const char* k) { return key == k; }) == end) {
      std::vector<std::string> names(begin, end);
      throw OptionError(path + "/" + key, v, "unknown key (known: " + joined(names) + ")");
    }
}

std::string text_at(const nlohmann::json& j, const std::string& key, const std::string& path) {
  if (!j.contains(key)) return "";
  if (!j.at(key).is_string()) throw OptionError(path + "/" + key, j.at(key), "must be a string");
  return j.at(key).get<std::string>();
}

// An axis name that the campaign has (a sweep axis by short name or pointer, a derived axis,
// or "L" where the view's x is the gap: it is checked again against the view).
std::string axis_name_at(const nlohmann::json& v, const std::string& path, const CampaignAxes& axes) {
  const std::vector<std::string> names = axes.names();
  if (!v.is_string()) throw OptionError(path, v, "must be an axis name (axes: " + joined(names) + ")");
  const std::string name = v.get<std::string>();
  if (axes.find_derived(name)) return name;
  if (const auto pointer = axes.pointer_of(name)) return axes.short_name(*pointer);
  if (name == "L") return name;  // the gap between two outlets, when the campaign has two
  throw OptionError(path, v, "names no axis (axes: " + joined(names) + ")");
}

std::vector<std::string> axis_list_at(const nlohmann::json& v, const std::string& path, const CampaignAxes& axes) {
  std::vector<std::string> out;
  if (v.is_string()) return {axis_name_at(v, path, axes)};
  if (!v.is_array()) throw OptionError(path, v, "must be an axis name or a list of them (axes: " + joined(axes.names()) + ")");
  for (std::size_t i = 0; i < v.size(); ++i) out.push_back(axis_name_at(v[i], path + "/" + std::to_string(i), axes));
  return out;
}

std::vector<std::pair<std::string, std::vector<nlohmann::json>>> read_only(const nlohmann::json& o, const std::string& path,
                                                                          const CampaignAxes& axes) {
  if (!o.is_object()) throw OptionError(path + "/only", o, "must be an object {axis: value or [values]}, e.g. {\"W\": [15, 25]}");
  std::vector<std::pair<std::string, std::vector<nlohmann::json>>> out;
  for (const auto& [k, v] : o.items()) {
    const std::string name = axis_name_at(nlohmann::json(k), path + "/only/" + k, axes);
    std::vector<nlohmann::json> values;
    for (const auto& one : v.is_array() ? v : nlohmann::json::array({v})) {
      if (!one.is_number() && !one.is_string())
        throw OptionError(path + "/only/" + k, v, "must be a number, a string or a list of them");
      values.push_back(one);
    }
    if (values.empty()) throw OptionError(path + "/only/" + k, v, "must list at least one value");
    out.emplace_back(name, values);
  }
  return out;
}

FigureSpec read_one(const nlohmann::json& f, const std::string& path, const CampaignAxes& axes,
                    const std::set<std::string>& names_before) {
  if (!f.is_object())
    throw OptionError(path, f, "must be an object {\"name\", \"y\", \"x\", \"group\", \"only\", \"pool\", \"fit\", ...}");
  check_keys(f, path, std::begin(kFigureKeys), std::end(kFigureKeys));
  FigureSpec s;
  s.path = path;
  s.name = text_at(f, "name", path);
  if (s.name.empty()) throw OptionError(path + "/name", f.value("name", nlohmann::json()), "must be a non-empty name (the figure's file stem)");
  for (char c : s.name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.'))
      throw OptionError(path + "/name", f.at("name"), "letters, digits, '-', '_' and '.' only (it names files)");
  if (names_before.count(s.name)) throw OptionError(path + "/name", f.at("name"), "another figure has this name");
  if (f.contains("kind")) {
    s.kind = text_at(f, "kind", path);
    if (s.kind != "points" && s.kind != "pictures")
      throw OptionError(path + "/kind", f.at("kind"),
                        "must be \"points\" (points with error bars) or \"pictures\" (of the points `only` chooses)");
  }
  if (s.kind == "pictures") {
    for (const char* key : {"y", "x", "group", "pool", "fit", "ylabel", "logx", "logy"})
      if (f.contains(key))
        throw OptionError(path + "/" + key, f.at(key),
                          "a figure of pictures takes name, only, picture, title, caption and reference");
    s.picture = f.contains("picture") ? text_at(f, "picture", path) : "end";
    if (s.picture != "end" && s.picture != "bed")
      throw OptionError(path + "/picture", f.at("picture"), "must be \"end\" (the last frame) or \"bed\" (t = 0)");
  } else if (f.contains("picture")) {
    throw OptionError(path + "/picture", f.at("picture"), "only a figure of kind \"pictures\" takes it");
  }
  s.title = text_at(f, "title", path);
  s.caption = text_at(f, "caption", path);
  s.reference = text_at(f, "reference", path);
  if (s.kind == "pictures") {
    if (f.contains("only")) s.only = read_only(f.at("only"), path, axes);
    return s;
  }
  s.y = text_at(f, "y", path);
  if (s.y.empty()) throw OptionError(path + "/y", f.value("y", nlohmann::json()), "must be a metric name or an expression over metrics and axes");
  try {
    Expression::parse(s.y, {});  // the grammar; names are checked against the metrics when drawn
  } catch (const ExpressionError& e) {
    throw OptionError(path + "/y", f.at("y"), e.what());
  }
  s.ylabel = text_at(f, "ylabel", path);
  if (f.contains("x")) s.x = axis_name_at(f.at("x"), path + "/x", axes);
  if (f.contains("group")) {
    s.group = axis_list_at(f.at("group"), path + "/group", axes);
    s.group_given = true;
  }
  if (f.contains("pool")) s.pool = axis_list_at(f.at("pool"), path + "/pool", axes);
  if (f.contains("only")) s.only = read_only(f.at("only"), path, axes);
  if (f.contains("fit")) {
    const nlohmann::json& fj = f.at("fit");
    const std::string fp = path + "/fit";
    if (!fj.is_object()) throw OptionError(fp, fj, "must be {\"model\": \"C * W^b\", \"over\": [axes], \"initial\": {..}, \"collapse\": bool}");
    check_keys(fj, fp, std::begin(kFitKeys), std::end(kFitKeys));
    FigureFitSpec fit;
    fit.model = text_at(fj, "model", fp);
    if (fit.model.empty()) throw OptionError(fp + "/model", fj.value("model", nlohmann::json()), "must be an expression, e.g. \"C * W^b\"");
    std::vector<std::string> usable = axes.expression_names();
    if (std::find(usable.begin(), usable.end(), "L") == usable.end()) usable.push_back("L");
    if (fj.contains("over")) {
      fit.over = axis_list_at(fj.at("over"), fp + "/over", axes);
      for (const auto& v : fit.over)
        if (!is_identifier(v)) throw OptionError(fp + "/over", fj.at("over"), "\"" + v + "\" cannot stand in an expression; declare it under /axes with a name of letters, digits and '_'");
    }
    Expression e;
    try {
      e = Expression::parse(fit.model, fj.contains("over") ? fit.over : usable);
    } catch (const ExpressionError& err) {
      throw OptionError(fp + "/model", fj.at("model"), err.what());
    }
    if (!fj.contains("over")) {
      // The axes the model names (without variables, every name it uses is a "parameter").
      const std::vector<std::string> named = Expression::parse(fit.model, {}).parameters();
      for (const auto& v : named)  // in the order the model names them
        if (std::find(usable.begin(), usable.end(), v) != usable.end()) fit.over.push_back(v);
      if (fit.over.empty())
        throw OptionError(fp + "/model", fj.at("model"), "uses no axis; its variables must be axes (" + joined(usable) + ")");
    }
    if (e.parameters().empty()) throw OptionError(fp + "/model", fj.at("model"), "has no parameter to fit");
    if (fj.contains("initial")) {
      if (!fj.at("initial").is_object()) throw OptionError(fp + "/initial", fj.at("initial"), "must be {parameter: value}");
      for (const auto& [k, v] : fj.at("initial").items()) fit.initial[k] = option_number(v, fp + "/initial/" + k, -1e300, 1e300);
    }
    if (fj.contains("collapse")) fit.collapse = option_bool(fj.at("collapse"), fp + "/collapse");
    s.fit = fit;
  }
  if (f.contains("logx")) s.logx = option_bool(f.at("logx"), path + "/logx");
  if (f.contains("logy")) s.logy = option_bool(f.at("logy"), path + "/logy");
  return s;
}

}  // namespace

MeanSe y_value(const std::string& y, const std::map<std::string, MeanSe>& metrics, const std::map<std::string, double>& axes,
               std::string& problem) {
  if (const auto it = metrics.find(y); it != metrics.end()) return it->second;
  std::vector<std::string> variables;
  for (const auto& [name, e] : metrics)
    if (is_identifier(name)) variables.push_back(name);
  for (const auto& [name, v] : axes)
    if (is_identifier(name) && !metrics.count(name)) variables.push_back(name);
  Expression e;
  try {
    e = Expression::parse(y, variables);
  } catch (const ExpressionError& err) {
    problem = err.what();
    return {};
  }
  if (!e.parameters().empty()) {
    problem = "y \"" + y + "\" names no metric or axis: " + joined(e.parameters());
    return {};
  }
  std::vector<double> values;
  std::vector<double> ses;
  MeanSe out;
  out.n = -1;
  for (const auto& name : e.variables()) {
    if (const auto it = metrics.find(name); it != metrics.end()) {
      values.push_back(it->second.mean);
      ses.push_back(it->second.se);
      if (y.find(name) != std::string::npos) out.n = out.n < 0 ? it->second.n : std::min(out.n, it->second.n);
    } else {
      values.push_back(axes.at(name));
      ses.push_back(0.0);
    }
  }
  out.mean = e.evaluate(values, {});
  double var = 0.0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (ses[i] == 0.0) continue;
    // Only the metrics the expression reads matter; a derivative of 0 drops the rest.
    const double h = 1e-6 * std::max(1.0, std::abs(values[i]));
    std::vector<double> up = values, down = values;
    up[i] += h;
    down[i] -= h;
    const double d = (e.evaluate(up, {}) - e.evaluate(down, {})) / (2 * h);
    if (d == 0.0) continue;
    if (!std::isfinite(ses[i])) {
      var = kNaN;
      break;
    }
    var += d * d * ses[i] * ses[i];
  }
  out.se = std::isfinite(var) ? std::sqrt(var) : kNaN;
  if (out.n < 0) out.n = 0;
  return out;
}

std::map<std::string, MeanSe> pooled_metrics(const CampaignAnalysis& ca, const std::vector<std::size_t>& points) {
  std::map<std::string, std::vector<PointMetric>> by_name;
  for (std::size_t p : points)
    for (const PointMetric& m : ca.all_point_metrics(p)) by_name[m.name].push_back(m);
  std::map<std::string, MeanSe> out;
  for (const auto& [name, list] : by_name) {
    if (list.size() == 1) {
      out[name] = list.front().estimate();
      continue;
    }
    double sum = 0, weight = 0, var = 0;
    int n = 0;
    for (const PointMetric& m : list) {
      if (!std::isfinite(m.mean) || m.n <= 0) continue;
      sum += m.n * m.mean;
      weight += m.n;
      var += std::isfinite(m.se) ? static_cast<double>(m.n) * m.n * m.se * m.se : kNaN;
      n += m.n;
    }
    out[name] = weight > 0 ? MeanSe{sum / weight, std::sqrt(var) / weight, n} : MeanSe{};
  }
  return out;
}

namespace {

std::string value_words(double v) { return format_number(v, 6); }

}  // namespace

std::vector<FigureSpec> read_figure_specs(const nlohmann::json& campaign_spec) {
  if (!campaign_spec.is_object() || !campaign_spec.contains("report") || !campaign_spec.at("report").is_object() ||
      !campaign_spec.at("report").contains("figures"))
    return {};
  const nlohmann::json& list = campaign_spec.at("report").at("figures");
  if (!list.is_array()) throw OptionError("/report/figures", list, "must be an array of figures ({\"name\", \"y\", ...})");
  const CampaignAxes axes = CampaignAxes::of_campaign_spec(campaign_spec);
  std::vector<FigureSpec> out;
  std::set<std::string> names;
  for (std::size_t i = 0; i < list.size(); ++i) {
    out.push_back(read_one(list[i], "/report/figures/" + std::to_string(i), axes, names));
    names.insert(out.back().name);
  }
  return out;
}

std::map<std::string, double> point_axes(const CampaignView& view, const Point& point) {
  std::map<std::string, double> axes = view.named.values(point.point, point.spec);
  if (!view.x_symbol.empty() && !axes.count(view.x_symbol)) axes[view.x_symbol] = point.x;
  return axes;
}

bool axis_value_matches(const CampaignView& view, const Point& point, const std::string& name, const nlohmann::json& want) {
  if (const auto pointer = view.named.pointer_of(name)) {
    const auto v = axis_value(*pointer, point.point, point.spec);
    if (v && v->is_string()) return want.is_string() && want.get<std::string>() == v->get<std::string>();
  }
  const std::map<std::string, double> axes = point_axes(view, point);
  const auto it = axes.find(name);
  if (it == axes.end() || !std::isfinite(it->second) || !want.is_number()) return false;
  const double a = it->second, b = want.get<double>();
  return a == b || std::abs(a - b) <= 1e-9 * std::max(std::abs(a), std::abs(b)) || value_words(a) == value_words(b);
}

FigureOutcome make_figure(const CampaignAnalysis& ca, const FigureSpec& spec) {
  const CampaignView& v = ca.view;
  FigureOutcome out;
  out.spec = &spec;
  const std::string x_name = spec.x.empty() ? v.x_symbol : spec.x;
  // The group axes: as given, or every sweep axis that is not x and not pooled.
  std::vector<std::string> group = spec.group;
  if (!spec.group_given)
    for (const auto& axis : v.axes) {
      const std::string n = v.named.short_name(axis);
      const bool is_x = n == x_name || v.x_axes.count(axis);
      if (!is_x && std::find(spec.pool.begin(), spec.pool.end(), n) == spec.pool.end()) group.push_back(n);
    }
  std::vector<std::string> notes;
  // The points the figure shows, merged when they differ only in pooled axes.
  std::map<std::string, std::size_t> datum_of;  // key of the non-pooled axes -> index in out.data
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    const Point& point = v.points[p];
    if (point.runs.empty()) continue;
    bool keep = true;
    for (const auto& [name, values] : spec.only)
      keep = keep && std::any_of(values.begin(), values.end(),
                                 [&](const nlohmann::json& w) { return axis_value_matches(v, point, name, w); });
    if (!keep) continue;
    const std::map<std::string, double> axes = point_axes(v, point);
    std::string key;
    for (const auto& axis : v.axes) {
      const std::string n = v.named.short_name(axis);
      if (std::find(spec.pool.begin(), spec.pool.end(), n) != spec.pool.end()) continue;
      const auto value = axis_value(axis, point.point, point.spec);
      key += n + "=" + (value ? value_text(*value) : "?") + ";";
    }
    if (std::find(spec.pool.begin(), spec.pool.end(), x_name) == spec.pool.end() && axes.count(x_name))
      key += "x=" + value_words(axes.at(x_name));
    const auto [it, added] = datum_of.emplace(key, out.data.size());
    if (added) {
      FigureDatum d;
      d.axes = axes;
      for (const auto& g : group) {
        const auto pointer = v.named.pointer_of(g);
        const auto value = pointer ? axis_value(*pointer, point.point, point.spec) : std::nullopt;
        const std::string text = value ? value_text(*value) : axes.count(g) ? value_words(axes.at(g)) : "?";
        d.group += (d.group.empty() ? "" : ", ") + g + " = " + text;
      }
      out.data.push_back(d);
    }
    out.data[it->second].points.push_back(p);
  }
  // Pictures: the chosen points are the figure; the report draws them (it has the renderer).
  if (spec.kind == "pictures") {
    if (out.data.empty())
      out.blocks.push_back(Text{"**Not drawn:** " + spec.path + " (\"" + spec.name + "\"): no finished run passes its `only`."});
    return out;
  }
  std::string problem;
  for (FigureDatum& d : out.data) {
    const std::map<std::string, MeanSe> metrics = pooled_metrics(ca, d.points);
    // Pooled axes vary inside a datum: they are not its axes.
    for (const auto& name : spec.pool) d.axes.erase(name);
    const auto xi = d.axes.find(x_name);
    d.x = xi == d.axes.end() ? kNaN : xi->second;
    const MeanSe y = y_value(spec.y, metrics, d.axes, problem);
    d.y = y.mean;
    d.se = y.se;
    d.n = y.n;
  }
  const std::string where = spec.path + " (\"" + spec.name + "\")";
  if (!problem.empty()) notes.push_back("**Not drawn:** " + where + ": " + problem);
  if (out.data.empty()) notes.push_back("**Not drawn:** " + where + ": no finished run passes its `only`.");

  Figure f;
  f.name = "figure-" + spec.name;
  f.title = spec.title.empty() ? spec.y + " against " + x_name : spec.title;
  f.xlabel = x_name;
  f.ylabel = spec.ylabel.empty() ? spec.y : spec.ylabel;
  f.logx = spec.logx;
  f.logy = spec.logy;
  std::vector<std::string> groups;
  for (const FigureDatum& d : out.data)
    if (std::find(groups.begin(), groups.end(), d.group) == groups.end()) groups.push_back(d.group);
  std::vector<std::pair<std::string, Series>> curves;
  for (std::size_t gi = 0; gi < groups.size(); ++gi) {
    Series se;
    se.label = groups[gi].empty() ? spec.y : groups[gi];
    se.columns = {x_name, "y", "y_se", "n"};
    se.style = Series::Style::kErrorBars;
    se.err = 2;
    se.color = static_cast<int>(gi);
    std::vector<const FigureDatum*> in;
    for (const FigureDatum& d : out.data)
      if (d.group == groups[gi] && std::isfinite(d.x) && std::isfinite(d.y)) in.push_back(&d);
    std::sort(in.begin(), in.end(), [](const FigureDatum* a, const FigureDatum* b) { return a->x < b->x; });
    for (const FigureDatum* d : in) se.rows.push_back({d->x, d->y, d->se, static_cast<double>(d->n)});
    if (!se.rows.empty()) f.series.push_back(se);
  }
  if (problem.empty() && !out.data.empty() && f.series.empty())
    notes.push_back("**Not drawn:** " + where + ": no point has both " + x_name + " and " + spec.y + ".");

  // The fit across every point of the figure.
  Table fit_table;
  Figure collapse;
  if (spec.fit && problem.empty()) {
    const FigureFitSpec& fs = *spec.fit;
    std::vector<std::vector<double>> xs;
    std::vector<double> ys, sigma;
    std::vector<const FigureDatum*> used;
    for (const FigureDatum& d : out.data) {
      if (!std::isfinite(d.y)) continue;
      std::vector<double> row;
      bool ok = true;
      for (const auto& name : fs.over) {
        const auto it = d.axes.find(name);
        ok = ok && it != d.axes.end() && std::isfinite(it->second);
        row.push_back(ok ? it->second : kNaN);
      }
      if (!ok) continue;
      xs.push_back(row);
      ys.push_back(d.y);
      sigma.push_back(d.se);
      used.push_back(&d);
    }
    FitResult r = fit_model_multi(spec.name, fs.model, fs.over, xs, ys, sigma, fs.initial);
    out.fit = r;
    fit_table = Table{"figure-" + spec.name + "-fit",
                      "Fit of " + fs.model + " over " + joined(fs.over) + " across the figure's " +
                          std::to_string(xs.size()) + " points (95% confidence intervals, Student t; " +
                          (r.sigma.empty() ? "unweighted" : "weights 1/se^2") + "): " + r.verdict(),
                      {"parameter", "value", "se", "95% CI low", "95% CI high", "chi2/dof", "points", "fit quality"},
                      {},
                      {"parameter", "value", "se", "ci_low", "ci_high", "chi2_per_dof", "points", "fit_quality"}};
    for (const FitParameter& par : r.parameters)
      fit_table.rows.push_back({par.name, Cell::number(par.value, 5), Cell::number(par.se, 2), Cell::number(par.ci_low, 5),
                                Cell::number(par.ci_high, 5), Cell::number(r.ok() && r.dof > 0 ? r.chi2 / r.dof : kNaN, 3),
                                Cell::count(static_cast<long long>(xs.size())), to_string(r.quality)});
    if (r.quality != FitQuality::kGood) {
      notes.push_back("The fit is not drawn: " + r.verdict() +
                      " (a curve is drawn only when every parameter is determined and no 95% interval holds 0).");
    } else {
      // One curve per group: x sampled across the figure's range, the other variables at the
      // group's values (a derived variable recomputed from the sampled sweep value).
      const auto x_pointer = v.named.pointer_of(x_name);
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (const FigureDatum* d : used)
        if (std::isfinite(d->x)) {
          lo = std::min(lo, d->x);
          hi = std::max(hi, d->x);
        }
      for (std::size_t gi = 0; gi < groups.size() && std::isfinite(lo); ++gi) {
        const FigureDatum* first = nullptr;
        for (const FigureDatum* d : used)
          if (d->group == groups[gi]) first = d;
        if (!first) continue;
        Series curve;
        curve.label = "fit" + (groups[gi].empty() ? std::string() : " (" + groups[gi] + ")");
        curve.columns = {x_name, "fit"};
        curve.style = Series::Style::kLines;
        curve.role = Series::Role::kFit;
        curve.color = static_cast<int>(gi);
        constexpr int kSamples = 120;
        const Point& rep = v.points[first->points.front()];
        for (int i = 0; i <= kSamples; ++i) {
          const double xv = lo + (hi - lo) * i / kSamples;
          std::map<std::string, double> axes = first->axes;
          if (x_pointer) {
            nlohmann::json point = rep.point;
            point[*x_pointer] = xv;
            axes = point_axes(v, Point{rep.id, point, xv, "", "", "", "", rep.spec, {}});
          } else if (std::find(fs.over.begin(), fs.over.end(), x_name) != fs.over.end()) {
            axes[x_name] = xv;
          } else {
            break;  // x is derived and not a fit variable: the curve is drawn through the points below
          }
          std::vector<double> at;
          for (const auto& name : fs.over) at.push_back(axes.count(name) ? axes.at(name) : kNaN);
          const double yv = r.evaluate_at(at);
          if (std::isfinite(yv)) curve.rows.push_back({xv, yv});
        }
        if (curve.rows.empty())  // through the fitted values at the data points
          for (std::size_t i = 0; i < used.size(); ++i)
            if (used[i]->group == groups[gi]) curve.rows.push_back({used[i]->x, r.fitted[i]});
        std::sort(curve.rows.begin(), curve.rows.end());
        if (!curve.rows.empty()) f.series.push_back(curve);
      }
      if (fs.collapse) {
        collapse.name = "figure-" + spec.name + "-collapse";
        collapse.title = (spec.title.empty() ? spec.y : spec.title) + ", divided by the fitted law";
        collapse.xlabel = x_name;
        collapse.ylabel = "(" + spec.y + ") / (" + fs.model + ")";
        collapse.logx = spec.logx;
        collapse.caption = "The data divided by the law fitted across every point (parameters in the table): a law "
                           "that holds puts every point on 1";
        for (std::size_t gi = 0; gi < groups.size(); ++gi) {
          Series se;
          se.label = groups[gi].empty() ? spec.y : groups[gi];
          se.columns = {x_name, "y_over_law", "y_over_law_se"};
          se.style = Series::Style::kErrorBars;
          se.err = 2;
          se.color = static_cast<int>(gi);
          for (std::size_t i = 0; i < used.size(); ++i)
            if (used[i]->group == groups[gi] && std::isfinite(used[i]->x) && r.fitted[i] != 0.0)
              se.rows.push_back({used[i]->x, used[i]->y / r.fitted[i], used[i]->se / std::abs(r.fitted[i])});
          std::sort(se.rows.begin(), se.rows.end());
          if (!se.rows.empty()) collapse.series.push_back(se);
        }
        if (!collapse.series.empty()) {
          Series one;
          one.label = "1 (the law)";
          one.columns = {x_name, "one"};
          one.style = Series::Style::kLines;
          one.role = Series::Role::kReference;
          one.rows = {{lo, 1.0}, {hi, 1.0}};
          collapse.series.push_back(one);
        }
      }
    }
  }
  std::string caption = spec.caption;
  caption += std::string(caption.empty() ? "" : ". ") + "Error bars: standard errors" +
             (spec.pool.empty() ? "" : "; pooled over " + joined(spec.pool) + " (means weighted by n)");
  if (!spec.only.empty()) {
    std::string only;
    for (const auto& [name, values] : spec.only) {
      std::string vs;
      for (const auto& w : values) vs += (vs.empty() ? "" : ", ") + (w.is_string() ? w.get<std::string>() : value_words(w.get<double>()));
      only += (only.empty() ? "" : "; ") + name + " in {" + vs + "}";
    }
    caption += "; only " + only;
  }
  if (spec.fit && out.fit && out.fit->quality == FitQuality::kGood) caption += "; dashed: " + spec.fit->model + " fitted across every point";
  if (!spec.reference.empty()) caption += ". Reference: " + spec.reference;
  f.caption = caption;
  if (!f.series.empty()) out.blocks.push_back(f);
  if (!fit_table.name.empty()) out.blocks.push_back(fit_table);
  if (!collapse.series.empty()) {
    if (!spec.reference.empty()) collapse.caption += ". Reference: " + spec.reference;
    out.blocks.push_back(collapse);
  }
  for (const auto& n : notes) out.blocks.push_back(Text{n});
  return out;
}

std::optional<Section> figures_section(const std::vector<FigureOutcome>& figures) {
  if (figures.empty()) return std::nullopt;
  Section s{"figures", "Figures", {}};
  s.blocks.push_back(Text{"The figures the campaign spec asks for (`/report/figures`); every analysis' own figures "
                          "follow in its section."});
  for (const FigureOutcome& f : figures)
    for (const Block& b : f.blocks) s.blocks.push_back(b);
  return s;
}

}  // namespace granary::analysis
