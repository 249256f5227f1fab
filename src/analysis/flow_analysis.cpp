// See flow_analysis.h; the numbers come from flow.h (flow_rate, flow_rate_per_outlet) and
// fit.h, and the rules are in docs/analyses.md "Flow rate".
#include "analysis/flow_analysis.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "analysis/campaign_view.h"
#include "analysis/expression.h"
#include "analysis/fit.h"
#include "analysis/options.h"

namespace granary::analysis {
namespace {

// A law in tables: its title for the reader ("2-D Beverloo"), its id beside it (what
// /report/flow/models and scripts name it by), or the id alone for a law without a title.
std::string ModelWords(const std::string& title, const std::string& id) {
  return title.empty() || title == id ? id : title + " (" + id + ")";
}

constexpr char kQUnit[] = "bodies/sqrt(d/g)";
constexpr char kQMassUnit[] = "rho d^2/sqrt(d/g)";

nlohmann::json FlowJson(const FlowRate& f) {
  return {{"ok", f.ok},
          {"note", f.note},
          {"t_start", JsonNumber(f.t_start)},
          {"t_end", JsonNumber(f.t_end)},
          {"n_events", f.n_events},
          {"q_count", JsonNumber(f.q_count)},
          {"q_count_se", JsonNumber(f.q_count_se)},
          {"q_mass", JsonNumber(f.q_mass)},
          {"q_mass_se", JsonNumber(f.q_mass_se)},
          {"q_count_se_ols", JsonNumber(f.q_count_se_ols)},
          {"count_intercept", JsonNumber(f.count_intercept)},
          {"batches", f.batches}};
}

FlowRate FlowOf(const nlohmann::json& j) {
  FlowRate f;
  if (!j.is_object()) return f;
  f.ok = j.value("ok", false);
  f.note = j.value("note", "");
  f.t_start = NumberAt(j, "t_start");
  f.t_end = NumberAt(j, "t_end");
  f.n_events = j.value("n_events", 0);
  f.q_count = NumberAt(j, "q_count");
  f.q_count_se = NumberAt(j, "q_count_se");
  f.q_mass = NumberAt(j, "q_mass");
  f.q_mass_se = NumberAt(j, "q_mass_se");
  f.q_count_se_ols = NumberAt(j, "q_count_se_ols");
  f.count_intercept = NumberAt(j, "count_intercept");
  f.batches = j.value("batches", 0);
  return f;
}

// One run's flow: everything from the exit events, so no frames are asked for.
class FlowAccumulator : public RunAccumulator {
 public:
  explicit FlowAccumulator(const RunView& run) {
    const std::vector<rundir::ExitEvent>& events = run.data->events;
    const FlowInput in{events, run.remove_mode, run.bodies, run.clog_gap, -1, run.t_end, run.on_clog == "stop"};
    const std::vector<FlowRate> per_outlet =
        FlowRatePerOutlet(in, run.options->window, static_cast<int>(run.outlets.size()));
    nlohmann::json outlets = nlohmann::json::array(), rates = nlohmann::json::array();
    for (const OutletGeometry& o : run.outlets) outlets.push_back(o.label);
    for (const FlowRate& f : per_outlet) rates.push_back(FlowJson(f));
    // The cumulative exit count, thinned to <= 201 samples, for the diagnostic figure.
    std::vector<double> t, n;
    const std::size_t count = events.size(), stride = std::max<std::size_t>(1, count / 200);
    for (std::size_t i = 0; i < count; i += stride) {
      t.push_back(events[i].time);
      n.push_back(static_cast<double>(i + 1));
    }
    if (count > 0 && (count - 1) % stride != 0) {
      t.push_back(events.back().time);
      n.push_back(static_cast<double>(count));
    }
    nlohmann::json notes = nlohmann::json::array();
    if (!run.flow.ok) notes.push_back("flow rate: " + run.flow.note);
    // The two records of the discharge must agree; a mismatch means a truncated or foreign file.
    if (run.data->has_summary && run.data->summary.exited != static_cast<int>(count))
      notes.push_back("events.csv has " + std::to_string(count) + " exits but summary.json says " +
                      std::to_string(run.data->summary.exited));
    result_ = {{"total", FlowJson(run.flow)},
               {"per_outlet", rates},
               {"outlets", outlets},
               {"cumulative", {{"t", JsonNumbers(t)}, {"n", JsonNumbers(n)}}},
               {"notes", notes}};
  }
  nlohmann::json Finish() override { return result_; }

 private:
  nlohmann::json result_;
};

std::vector<FlowRate> PerOutletOf(const nlohmann::json& result) {
  std::vector<FlowRate> out;
  if (result.contains("per_outlet"))
    for (const auto& j : result.at("per_outlet")) out.push_back(FlowOf(j));
  return out;
}

std::vector<std::string> LabelsOf(const nlohmann::json& result) {
  std::vector<std::string> out;
  if (result.contains("outlets"))
    for (const auto& j : result.at("outlets")) out.push_back(j.get<std::string>());
  return out;
}

std::string QName(std::size_t k) { return "q_count" + OutletSuffix(k); }

class FlowAnalysis : public Analysis {
 public:
  explicit FlowAnalysis(std::vector<FitModel> models) : models_(std::move(models)) {}
  std::string Key() const override { return "flow"; }
  int Version() const override { return 1; }
  PassUse PassOptionsUsed() const override { return {.window = true, .clog_gap = true, .frames = false}; }
  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    return std::make_unique<FlowAccumulator>(run);
  }

  std::vector<Metric> RunMetrics(const nlohmann::json& result) const override {
    const FlowRate total = FlowOf(result.value("total", nlohmann::json()));
    std::vector<Metric> m;
    m.push_back({"q_count", kQUnit, total.ok ? total.q_count : kNaN, total.ok ? total.q_count_se : kNaN,
                 "Q (bodies/sqrt(d/g))", true});
    m.push_back({"q_mass", kQMassUnit, total.ok ? total.q_mass : kNaN, total.ok ? total.q_mass_se : kNaN,
                 "Q_m (mass/sqrt(d/g))", false});
    const std::vector<FlowRate> per_outlet = PerOutletOf(result);
    const std::vector<std::string> labels = LabelsOf(result);
    if (per_outlet.size() > 1)
      for (std::size_t k = 0; k < per_outlet.size(); ++k) {
        const FlowRate& f = per_outlet[k];
        const std::string where = k < labels.size() ? labels[k] : "outlet " + std::to_string(k);
        m.push_back(
            {QName(k), kQUnit, f.ok ? f.q_count : kNaN, f.ok ? f.q_count_se : kNaN, "Q through " + where, false});
        m.push_back({"q_mass" + OutletSuffix(k), kQMassUnit, f.ok ? f.q_mass : kNaN, f.ok ? f.q_mass_se : kNaN,
                     "Q_m through " + where, false});
      }
    return m;
  }

  std::optional<Section> BuildSection(const SectionInput& in) const override;

 private:
  std::vector<FitModel> models_;  // from /report/flow/models
};

// The Q the figure and the fits use: through the outlet whose width is the x axis when runs
// have several outlets (ch. 7: Q of the small outlet against W1), else all outlets together.
std::string HeadlineQ(const CampaignView& v) {
  if (v.outlets > 1 && v.x_outlet >= 0 && static_cast<std::size_t>(v.x_outlet) < v.outlets)
    return QName(static_cast<std::size_t>(v.x_outlet));
  return "q_count";
}

std::string HeadlineQWhat(const CampaignView& v) {
  if (v.outlets > 1 && v.x_outlet >= 0 && static_cast<std::size_t>(v.x_outlet) < v.outlet_labels.size())
    return "through " + v.outlet_labels[static_cast<std::size_t>(v.x_outlet)];
  return v.outlets > 1 ? "all outlets together" : "";
}

// The steady windows, the rates and the exit streams of every run.
void AddPerRun(const SectionInput& in, Section& s) {
  const CampaignView& v = in.view;
  const bool several = v.outlets > 1;
  Table t{"flow_rate_per_run",
          "Every used run: Q by least squares over its steady window; se by batch means",
          {"run", "point", "replica", "window from", "window to", "exits in window", "Q (bodies/sqrt(d/g))",
           "Q_mass (mass/sqrt(d/g))"},
          {},
          {"run", "point", "replica", "window_start", "window_end", "n_events", "q_count", "q_mass"}};
  if (several)
    for (std::size_t k = 0; k < v.outlets; ++k) {
      t.header.push_back("Q " + (k < v.outlet_labels.size() ? v.outlet_labels[k] : std::to_string(k)));
      t.keys.push_back(QName(k));
    }
  Figure cum{"cumulative_exits",
             "Cumulative exits against time",
             "t (sqrt(d/g))",
             "exits (all outlets)",
             {},
             false,
             false,
             ""};
  int shown = 0;
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    const Point& point = v.points[p];
    bool first = true;
    for (std::size_t i : point.runs) {
      const nlohmann::json& r = in.results.runs[i];
      if (r.is_null()) continue;
      const FlowRate f = FlowOf(r.value("total", nlohmann::json()));
      std::vector<Cell> row{v.used[i].record->run_id,
                            PointName(v, point),
                            Cell::Count(v.used[i].record->replica),
                            Cell::Number(f.ok ? f.t_start : kNaN),
                            Cell::Number(f.ok ? f.t_end : kNaN),
                            Cell::Count(f.n_events),
                            Cell::Estimate(f.q_count, f.q_count_se, -1),
                            Cell::Estimate(f.q_mass, f.q_mass_se, -1)};
      if (several) {
        const std::vector<FlowRate> per_outlet = PerOutletOf(r);
        for (std::size_t k = 0; k < v.outlets; ++k)
          row.push_back(k < per_outlet.size() ? Cell::Estimate(per_outlet[k].q_count, per_outlet[k].q_count_se, -1)
                                              : Cell::Number(kNaN));
      }
      t.rows.push_back(row);
      if (!first || shown >= 8) continue;
      first = false;
      const std::vector<double> ct = NumbersOf(r.at("cumulative").at("t")), cn = NumbersOf(r.at("cumulative").at("n"));
      if (ct.empty()) continue;
      Series data;
      data.label = PointName(v, point);
      data.columns = {"t", "exits"};
      data.style = Series::Style::kLines;
      data.color = shown;
      for (std::size_t k = 0; k < ct.size(); ++k) data.rows.push_back({ct[k], cn[k]});
      cum.series.push_back(data);
      if (f.ok) {
        Series line;
        line.label = "fit, " + data.label;
        line.columns = {"t", "exits_fit"};
        line.style = Series::Style::kLines;
        line.role = Series::Role::kFit;
        line.color = shown;
        for (int k = 0; k <= 10; ++k) {
          const double tv = f.t_start + (f.t_end - f.t_start) * k / 10.0;
          line.rows.push_back({tv, f.count_intercept + f.q_count * tv});
        }
        cum.series.push_back(line);
      }
      ++shown;
    }
  }
  if (t.rows.empty()) return;
  s.blocks.push_back(t);
  if (!cum.series.empty()) {
    const std::size_t with_runs = static_cast<std::size_t>(
        std::count_if(v.points.begin(), v.points.end(), [](const Point& p) { return !p.runs.empty(); }));
    cum.caption =
        "Solid: the exit stream of the first finished replica at " +
        (static_cast<std::size_t>(shown) < with_runs
             ? "each of the first " + std::to_string(shown) + " of the " + std::to_string(with_runs) + " sweep points"
             : std::string("each sweep point")) +
        "; dashed: the straight line fitted over its steady window, whose slope is Q";
    s.blocks.push_back(cum);
  }
  const FlowWindowRule& w = in.pass.window;
  s.blocks.push_back(Text{"Steady window: exits before t = " + FormatNumber(w.start_time) + " and the first " +
                          FormatNumber(100 * w.start_fraction) +
                          "% of the exits are dropped; the window ends at the first clog (a gap of "
                          "clog_window in the exit stream)" +
                          std::string(w.stop_at_first_clog ? "" : " [off]") + " and, in remove mode, when " +
                          FormatNumber(100 * w.shallow_fraction) +
                          "% of the bodies remain. A run that clogs before its " +
                          std::to_string(w.min_exits_before_clog) +
                          "th exit has no steady window (a start-up clog): no Q, and the analyses of steady flow leave "
                          "it out."});
}

std::optional<Section> FlowAnalysis::BuildSection(const SectionInput& in) const {
  const CampaignView& v = in.view;
  bool any = false;
  for (const auto& metrics : in.points)
    if (const PointMetric* q = FindMetric(metrics, "q_count")) any = any || q->n > 0;
  Section s{"flow", "Flow rate", {}};
  if (!any) {
    AddPerRun(in, s);
    if (s.blocks.empty()) return std::nullopt;
    return s;
  }
  const bool several = v.outlets > 1;
  auto metric = [&](std::size_t p, const std::string& name) {
    const PointMetric* m = FindMetric(in.points[p], name);
    return m ? m->Estimate() : MeanSe{};
  };
  Table t{"flow_rate",
          "Flow rate per sweep point: mean ± standard error (replicas)",
          {"point", several ? "Q all outlets (bodies/sqrt(d/g))" : "Q (bodies/sqrt(d/g))",
           several ? "Q_mass all outlets (mass/sqrt(d/g))" : "Q_mass (mass/sqrt(d/g))"},
          {},
          {"point", "q_count", "q_mass"}};
  if (several)
    for (std::size_t k = 0; k < v.outlets; ++k) {
      t.header.push_back("Q " + (k < v.outlet_labels.size() ? v.outlet_labels[k] : std::to_string(k)));
      t.keys.push_back(QName(k));
    }
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    std::vector<Cell> row{PointName(v, v.points[p]), Cell::Estimate(metric(p, "q_count")),
                          Cell::Estimate(metric(p, "q_mass"))};
    if (several)
      for (std::size_t k = 0; k < v.outlets; ++k) row.push_back(Cell::Estimate(metric(p, QName(k))));
    t.rows.push_back(row);
  }
  s.blocks.push_back(t);
  if (HasX(v)) {
    const std::string q_what = HeadlineQWhat(v), headline = HeadlineQ(v);
    Figure f{"flow_rate",
             "Flow rate Q" + (q_what.empty() ? "" : " " + q_what) + " against " + v.x_label,
             v.x_label,
             "Q (bodies/sqrt(d/g))",
             PointSeries(v, in.points, headline, "Q"),
             false,
             false,
             "Error bars: standard error over replicas"};
    Figure per_outlet_figure{"flow_rate_per_outlet",
                             "Flow rate through each outlet against " + v.x_label,
                             v.x_label,
                             "Q (bodies/sqrt(d/g))",
                             OutletSeries(v, in.points, QName, v.outlet_labels, "Q"),
                             false,
                             false,
                             "One curve per outlet (and group); error bars: standard error over replicas"};
    // Fits against W/d per group (>= 3 widths).
    Table fits{"flow_rate_fits",
               "Fits of Q(W/d) per group (95% confidence intervals, Student t). Fit quality: good, poor (weighted, "
               "and the law misses the points by more than their errors), ill-determined (a parameter without a "
               "standard error or whose interval holds 0), failed or not fitted; only converged fits show values",
               {"group", "model", "parameter", "value", "se", "95% CI low", "95% CI high", "chi2/dof", "points",
                "weighted", "fit quality"},
               {},
               {"group", "model", "parameter", "value", "se", "ci_low", "ci_high", "chi2_per_dof", "points", "weighted",
                "fit_quality"}};
    Table residuals{"flow_rate_fit_residuals",
                    "Fit residuals (Q - fit)",
                    {"group", "model", "W/d", "Q", "fit", "residual"},
                    {},
                    {"group", "model", "x", "q", "fit", "residual"}};
    std::vector<FitModel> models;
    if (v.x_is_width) models = {Beverloo2d(), BeverlooFree(), Mankoc()};
    for (const auto& m : models_) models.push_back(m);
    int fitted_groups = 0;
    for (std::size_t k = 0; k < f.series.size(); ++k) f.series[k].color = static_cast<int>(k);
    double x_lo = std::numeric_limits<double>::infinity(), x_hi = -x_lo;
    for (std::size_t p = 0; p < v.points.size(); ++p)
      if (std::isfinite(v.points[p].x) && std::isfinite(metric(p, headline).mean)) {
        x_lo = std::min(x_lo, v.points[p].x);
        x_hi = std::max(x_hi, v.points[p].x);
      }
    constexpr int kCurveSamples = 200;
    const std::vector<Series> data_series = f.series;
    std::map<std::string, Figure> model_figures;
    const std::string other_axis = GroupAxis(v);
    const std::string other_axis_name =
        other_axis.empty() ? "" : AxisText(v, other_axis, v.points.front().spec, NameForm::kLong);
    std::map<std::string, Figure> trends;  // per model: its parameters against other_axis
    std::vector<std::string> not_drawn;    // fits without a curve, and why
    for (const auto& g : GroupsOf(v)) {
      double group_value = kNaN;
      if (!other_axis.empty())
        for (const Point& p : v.points)
          if (p.group == g) {
            const auto gv = AxisValue(other_axis, p.point, p.spec);
            if (gv && gv->is_number()) group_value = gv->get<double>();
            break;
          }
      std::vector<double> x, y, sigma;
      std::set<double> distinct;
      for (std::size_t p = 0; p < v.points.size(); ++p) {
        const MeanSe q = metric(p, headline);
        if (v.points[p].group != g || !std::isfinite(v.points[p].x) || !std::isfinite(q.mean)) continue;
        x.push_back(v.points[p].x);
        y.push_back(q.mean);
        sigma.push_back(q.se);
        distinct.insert(v.points[p].x);
      }
      if (distinct.size() < 3 || models.empty()) continue;
      ++fitted_groups;
      for (const FitModel& model : models) {
        FitResult r;
        try {
          r = MakeFitModel(WithDataGuess(model, x, y), x, y, sigma);
        } catch (const std::exception& e) {
          fits.rows.push_back({g, ModelWords(model.Shown(), model.name), "", Cell::Number(kNaN), Cell::Number(kNaN),
                               Cell::Number(kNaN), Cell::Number(kNaN), Cell::Number(kNaN),
                               Cell::Count(static_cast<long long>(x.size())), "", e.what()});
          continue;
        }
        const std::string weighted = r.sigma.empty() ? "no" : "1/se^2";
        for (const auto& par : r.parameters)
          fits.rows.push_back({g, ModelWords(r.model_title, r.model_name) + ": " + r.expression, par.name,
                               Cell::Number(par.value), Cell::Number(par.se, 2), Cell::Number(par.ci_low),
                               Cell::Number(par.ci_high), Cell::Number(r.Ok() && r.dof > 0 ? r.chi2 / r.dof : kNaN, 3),
                               Cell::Count(static_cast<long long>(x.size())), weighted, r.Verdict()});
        for (std::size_t i = 0; i < r.x.size(); ++i)
          residuals.rows.push_back({g, ModelWords(r.model_title, r.model_name), Cell::Number(r.x[i], 6),
                                    Cell::Number(r.y[i]), Cell::Number(r.fitted[i]), Cell::Number(r.residuals[i], 3)});
        if (!r.Ok()) continue;
        if (std::isfinite(group_value)) {
          Figure& tf = trends[r.model_name];
          if (tf.name.empty()) {
            tf.name = "fit_parameters_" + r.model_name;
            tf.title = "Fitted parameters of " + model.Shown() + " (" + r.expression + ") against " + other_axis_name;
            tf.xlabel = other_axis_name;
            tf.ylabel = "parameter value";
            tf.caption =
                "Error bars: standard errors of the fit. Parameters not determined by the data or whose 95% "
                "interval holds 0 are left out (fit table above)";
          }
          for (const auto& par : r.parameters) {
            if (!par.Determined() || par.CiSpansZero()) continue;
            auto it = std::find_if(tf.series.begin(), tf.series.end(),
                                   [&](const Series& se) { return se.label == par.name; });
            if (it == tf.series.end()) {
              Series se;
              se.label = par.name;
              se.columns = {ShortAxis(other_axis), par.name, par.name + "_se", "ci_low", "ci_high"};
              se.style = Series::Style::kErrorBars;
              se.err = 2;
              tf.series.push_back(se);
              it = tf.series.end() - 1;
            }
            it->rows.push_back({group_value, par.value, par.se, par.ci_low, par.ci_high});
          }
        }
        // A curve only for a fit whose every parameter is determined: an interval holding 0
        // (Mankoc's C in [-83, 84]) makes the curve one of many the data allow.
        if (r.quality != FitQuality::kGood) {
          not_drawn.push_back(r.model_title + (g.empty() ? "" : " (" + g + ")") + ": " + r.Verdict());
          continue;
        }
        Series curve;
        for (std::size_t k = 0; k < data_series.size(); ++k)
          if (data_series[k].label == (g.empty() ? std::string("Q") : g)) curve.color = static_cast<int>(k);
        curve.file_label = r.model_name + (g.empty() ? "" : " (" + g + ")");
        curve.label = r.model_title + (g.empty() ? "" : " (" + g + ")");
        curve.columns = {"W", "Q_fit"};
        curve.style = Series::Style::kLines;
        curve.role = Series::Role::kFit;
        // The fitted function sampled densely over the whole plotted x range (every group's
        // widths), not only through the measured widths.
        for (int i = 0; i <= kCurveSamples; ++i) {
          const double xv = x_lo + (x_hi - x_lo) * i / kCurveSamples;
          const double yv = r.Evaluate(xv);
          if (std::isfinite(yv)) curve.rows.push_back({xv, yv});
        }
        if (curve.rows.empty()) continue;
        // The first model's curves go on the main figure; every other model gets its own
        // figure (data + its curves) so that legends stay readable.
        if (&model == &models.front()) {
          f.series.push_back(std::move(curve));
        } else {
          Figure& mf = model_figures[model.name];
          if (mf.name.empty())
            mf = Figure{"flow_rate_fit_" + model.name,
                        "Flow rate with the " + model.Shown() + " fit (" + r.expression + ")",
                        v.x_label,
                        "Q (bodies/sqrt(d/g))",
                        data_series,
                        false,
                        false,
                        "Error bars: se over replicas"};
          mf.series.push_back(std::move(curve));
        }
      }
    }
    if (!not_drawn.empty()) {
      std::string text =
          "Dashed: fits whose every parameter the data determine. Not drawn (a parameter without a "
          "standard error or with a 95% interval holding 0, so the curve is one of many the data allow): ";
      for (std::size_t i = 0; i < not_drawn.size(); ++i) text += (i ? "; " : "") + not_drawn[i];
      f.caption += ". " + text;
    }
    s.blocks.push_back(f);
    if (several && !per_outlet_figure.series.empty()) s.blocks.push_back(per_outlet_figure);
    for (auto& [name, mf] : model_figures) s.blocks.push_back(mf);
    if (fitted_groups > 0) {
      s.blocks.push_back(
          Text{"Models (shared analyses.md): 2-D Beverloo `Q = C (W/d - k)^(3/2)`, free exponent "
               "`Q = C (W/d - k)^b`, Mankoc `Q = C (1 - exp(-b (W/d - 1))/2) (W/d - 1)^(3/2)`, plus "
               "any model given in the campaign spec `/report/flow/models`. GSL trust-region "
               "Levenberg-Marquardt with a finite-difference Jacobian; weights 1/se^2 when every "
               "point has a replica standard error, covariance scaled by max(1, chi2/dof) (weighted) "
               "or chi2/dof (unweighted)."});
      s.blocks.push_back(fits);
      for (auto& [model, tf] : trends)
        if (std::any_of(tf.series.begin(), tf.series.end(), [](const Series& se) { return se.rows.size() >= 2; }))
          s.blocks.push_back(tf);
      s.blocks.push_back(residuals);
    } else if (v.x_is_width) {
      s.blocks.push_back(
          Text{"Beverloo fits need at least 3 outlet widths in a group; this campaign has fewer so far."});
    }
  }
  AddPerRun(in, s);
  return s;
}

std::vector<FitModel> ReadModels(const nlohmann::json& v, const std::string& path) {
  if (!v.is_array()) throw OptionError(path, v, "must be an array of {name, expression, variable, initial}");
  std::vector<FitModel> models;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const nlohmann::json& m = v[i];
    const std::string mp = path + "/" + std::to_string(i);
    if (!m.is_object() || !m.contains("expression") || !m.at("expression").is_string())
      throw OptionError(mp, m,
                        "must be {\"name\": .., \"expression\": \"C * x^b\", \"variable\": \"x\", \"initial\": {..}}");
    FitModel f;
    f.name =
        m.contains("name") && m.at("name").is_string() ? m.at("name").get<std::string>() : "model_" + std::to_string(i);
    f.expression = m.at("expression").get<std::string>();
    if (m.contains("variable")) {
      if (!m.at("variable").is_string()) throw OptionError(mp + "/variable", m.at("variable"), "must be a name");
      f.variable = m.at("variable").get<std::string>();
    }
    if (m.contains("initial")) {
      if (!m.at("initial").is_object())
        throw OptionError(mp + "/initial", m.at("initial"), "must be {parameter: value}");
      for (const auto& [k, iv] : m.at("initial").items())
        f.initial[k] = OptionNumber(iv, mp + "/initial/" + k, -1e300, 1e300);
    }
    try {
      Expression::Parse(f.expression, {f.variable});
    } catch (const ExpressionError& e) {
      throw std::invalid_argument(mp + "/expression: " + e.what());
    }
    models.push_back(f);
  }
  return models;
}

}  // namespace

std::unique_ptr<Analysis> MakeFlowAnalysis(const nlohmann::json& options, const std::string& path) {
  std::vector<FitModel> models;
  if (!options.is_null()) {
    OptionObject(options, path, {"models"});
    if (options.contains("models")) models = ReadModels(options.at("models"), path + "/models");
  }
  return std::make_unique<FlowAnalysis>(std::move(models));
}

}  // namespace granary::analysis
