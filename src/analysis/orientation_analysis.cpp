// See orientation_analysis.h; the geometry of axes is orientation.h, the arches arches.h.
#include "analysis/orientation_analysis.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

#include "analysis/arches.h"
#include "analysis/campaign_view.h"
#include "analysis/expression.h"
#include "analysis/json_numbers.h"
#include "analysis/options.h"
#include "rundir/clogs.h"

namespace granary::analysis {
namespace {

constexpr double kPi = std::numbers::pi;
double Degrees(double radians) { return radians * 180 / kPi; }
double Radians(double degrees) { return degrees * kPi / 180; }

std::vector<double> Numbers(const nlohmann::json& v, const std::string& path, double lo, double hi) {
  if (!v.is_array() || v.empty()) throw OptionError(path, v, "must be a non-empty array of numbers");
  std::vector<double> out;
  for (std::size_t k = 0; k < v.size(); ++k) out.push_back(OptionNumber(v[k], path + "/" + std::to_string(k), lo, hi));
  return out;
}

std::vector<std::vector<double>> Matrix(const nlohmann::json& j) {
  std::vector<std::vector<double>> m;
  if (!j.is_array()) return m;
  for (const auto& row : j) {
    m.emplace_back();
    for (const auto& v : row) m.back().push_back(v.is_number() ? v.get<double>() : kNaN);
  }
  return m;
}
std::vector<double> Vector(const nlohmann::json& j) {
  std::vector<double> v;
  if (!j.is_array()) return v;
  for (const auto& x : j) v.push_back(x.is_number() ? x.get<double>() : kNaN);
  return v;
}

bool AnyElongated(const std::vector<rundir::Disc>& discs) {
  for (const BodyAxis& a : BodyAxes(discs))
    if (a.elongated) return true;
  return false;
}

// The bed before the opening (the frames at t <= 0, the first of them), steady flow (the
// steady window's frames), then the arch bodies of the kept clogs in the window.
class OrientationAccumulator : public RunAccumulator {
 public:
  // `notes`: what the analysis found of its options at this run (an empty region).
  OrientationAccumulator(const RunView& run, const OrientationAnalysisOptions& o, std::vector<std::string> notes)
      : data_(run.data), steady_(run.steady), o_(o), notes_(std::move(notes)) {
    try {
      silo_ = SiloOf(data_->spec, 1e3);
      if (o.outlet >= static_cast<int>(silo_.outlets.size())) {
        notes_.push_back("orientation: the run has no outlet " + std::to_string(o.outlet));
      } else {
        outlet_ = &silo_.outlets[static_cast<std::size_t>(o.outlet)];
      }
    } catch (const std::exception& e) {
      notes_.push_back(std::string("orientation: ") + e.what());
    }
  }
  FrameRequest Frames() const override {
    if (!outlet_) return {};
    return {{TimeWindow{-std::numeric_limits<double>::infinity(), 0.0}, steady_}, false};
  }
  // Why region i has no flow direction (FlowDirection gave NaN).
  std::string NoFlowNote(const std::string& name, std::size_t i) const {
    const std::string what = "orientation: region \"" + name + "\" ";
    const double n = i < flow_.flow_count.size() ? flow_.flow_count[i] : 0.0;
    if (!(n > 0)) return what + "held no body during steady flow: no flow direction, S undefined";
    const double speed = std::hypot(flow_.vx_sum[i], flow_.vy_sum[i]) / n;
    return what + "has no flow direction: its mean velocity, " + FormatNumber(speed, 3) + " sqrt(g d) over " +
           FormatNumber(n, 6) + " body-frames of steady flow, is within 3 standard errors of zero; S undefined";
  }
  void AddFrame(const FrameView& f) override {
    const std::vector<rundir::Disc>& discs = f.frame.discs;
    if (!elongated_) elongated_ = AnyElongated(discs);
    if (f.frame.time <= 0.0 && bed_.frames == 0) AddOrientationFrame(discs, *outlet_, silo_.half_width, o_.where, bed_);
    if (steady_.Contains(f.frame.time)) AddOrientationFrame(discs, *outlet_, silo_.half_width, o_.where, flow_);
  }
  nlohmann::json Finish() override {
    nlohmann::json result = {{"elongated", false}};
    std::vector<double> arch_window(static_cast<std::size_t>(std::max(1, o_.where.axis_bins)), 0.0);
    if (outlet_) {
      try {
        rundir::ClogReader reader(data_->dir);
        rundir::ClogState clog;
        while (reader.Next(clog)) {
          if (!elongated_) elongated_ = AnyElongated(clog.frame.discs);
          for (const Arch& a : AnalyseClog(clog, silo_).arches) {
            if (a.outlet != o_.outlet) continue;
            for (const ArchBody& b : a.bodies) {
              if (!std::isfinite(b.axis) || std::fabs(b.theta - o_.where.window_theta) > o_.where.window_dtheta / 2)
                continue;
              const int bins = static_cast<int>(arch_window.size());
              arch_window[static_cast<std::size_t>(std::clamp(static_cast<int>(b.axis / kPi * bins), 0, bins - 1))] +=
                  1;
            }
          }
        }
      } catch (const std::exception& e) {
        notes_.push_back(std::string("orientation (arches): ") + e.what());
      }
      std::vector<std::string> names;
      nlohmann::json bounds = nlohmann::json::array();
      const std::vector<OrientationOptions::Region> regions = OrientationRegions(o_.where, *outlet_);
      for (const auto& r : regions) {
        names.push_back(r.name);
        bounds.push_back(JsonNumbers(std::vector<double>{r.x0, r.x1, r.y0, r.y1}));
      }
      result["regions"] = names;
      result["region_bounds"] = bounds;  // x0, x1, y0, y1 at this run's point
      // The director S was measured against in each region, in degrees: the fixed one, or for
      // "flow" the direction the mean velocity pointed (null, with a note, where it had none).
      const std::vector<double> directors = RegionDirectors(flow_, regions);
      std::vector<double> degrees;
      for (std::size_t i = 0; i < regions.size(); ++i) {
        degrees.push_back(Degrees(directors[i]));
        if (regions[i].flow_director && !std::isfinite(directors[i])) notes_.push_back(NoFlowNote(regions[i].name, i));
      }
      result["directors"] = JsonNumbers(degrees);
    }
    result["elongated"] = elongated_;
    result["bed"] = to_json(bed_);
    result["flow"] = to_json(flow_);
    result["arch_window"] = arch_window;
    if (!notes_.empty()) result["notes"] = notes_;
    return result;
  }

 private:
  const rundir::RunData* data_;
  TimeWindow steady_;
  OrientationAnalysisOptions o_;
  silo::SiloGeometry silo_;
  const silo::OutletFrame* outlet_ = nullptr;
  OrientationSums bed_, flow_;
  bool elongated_ = false;
  std::vector<std::string> notes_;
};

class OrientationAnalysis : public Analysis {
 public:
  OrientationAnalysis(OrientationAnalysisOptions o, nlohmann::json raw) : o_(std::move(o)), raw_(std::move(raw)) {}
  std::string Key() const override { return "orientation"; }
  int Version() const override { return 2; }
  // With bounds over axes, the derived axes they may name are part of what a result depends on.
  nlohmann::json RunOptions() const override {
    if (o_.bounds.empty()) return raw_;
    nlohmann::json derived = nlohmann::json::object();
    for (const DerivedAxis& d : axes_.Derived()) derived[d.name] = d.expression.Text();
    return {{"options", raw_}, {"axes", derived}};
  }
  PassUse PassOptionsUsed() const override { return {.window = true, .clog_gap = true, .frames = true}; }
  void UseAxes(const CampaignAxes& axes) override {
    axes_ = axes;
    const std::vector<std::string> names = axes.ExpressionNames();
    for (const auto& b : o_.bounds) {
      std::vector<std::string> unknown;
      try {
        unknown = Expression::Parse(b.text, names).Parameters();
      } catch (const ExpressionError& e) {
        throw OptionError(b.path, b.text, e.what());
      }
      if (!unknown.empty()) {
        std::string list, known;
        for (const auto& u : unknown) list += (list.empty() ? "" : ", ") + u;
        for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
        throw OptionError(b.path, b.text,
                          "names no axis: " + list + " (a bound is a number or an expression over the axes: " +
                              (known.empty() ? std::string("none") : known) + ")");
      }
    }
  }
  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    if (o_.bounds.empty()) return std::make_unique<OrientationAccumulator>(run, o_, std::vector<std::string>{});
    // The bounds at this run's point: its axes read from its spec.
    OrientationAnalysisOptions o = o_;
    std::vector<std::string> notes;
    const std::map<std::string, double> values =
        axes_.Values(nlohmann::json::object(), run.data ? run.data->spec : nlohmann::json::object());
    const std::vector<std::string> names = axes_.ExpressionNames();
    for (const auto& b : o_.bounds) {
      const Expression e = Expression::Parse(b.text, names);
      std::vector<double> vars;
      for (const auto& n : e.Variables()) vars.push_back(values.count(n) ? values.at(n) : kNaN);
      OrientationOptions::Region& r = o.where.regions[b.region];
      double* side[4] = {&r.x0, &r.x1, &r.y0, &r.y1};
      *side[b.side] = e.Evaluate(vars, {});
    }
    for (OrientationOptions::Region& r : o.where.regions)
      if (!(r.x0 < r.x1) || !(r.y0 < r.y1)) {
        notes.push_back("orientation: region \"" + r.name + "\" is empty at this point (x " + FormatNumber(r.x0) +
                        " .. " + FormatNumber(r.x1) + ", y " + FormatNumber(r.y0) + " .. " + FormatNumber(r.y1) + ")");
        // A box that holds no body (a NaN bound would hold every body: the test is "outside").
        r.x0 = r.y0 = std::numeric_limits<double>::infinity();
        r.x1 = r.y1 = -std::numeric_limits<double>::infinity();
      }
    return std::make_unique<OrientationAccumulator>(run, o, notes);
  }
  // flow_frames, order_parameter_<k> for each region k over the run's steady frames.
  std::vector<Metric> RunMetrics(const nlohmann::json& result) const override {
    std::vector<Metric> m;
    if (!result.value("elongated", false)) return m;
    const OrientationSums flow = OrientationSumsFromJson(result.value("flow", nlohmann::json::object()));
    m.push_back({"flow_frames", "frames", static_cast<double>(flow.frames), kNaN, "frames of steady flow", false});
    std::vector<double> directors;
    for (const auto& d : result.value("directors", nlohmann::json::array())) directors.push_back(Radians(NumberOf(d)));
    const std::vector<double> s = OrderParameters(flow, directors);
    const std::vector<std::string> names = result.value("regions", std::vector<std::string>{});
    for (std::size_t k = 0; k < s.size(); ++k)
      m.push_back({"order_parameter_" + std::to_string(k), "1", s[k], kNaN,
                   "order parameter S" + (k < names.size() ? " in " + names[k] : std::string()), false});
    return m;
  }
  std::optional<Section> BuildSection(const SectionInput& in) const override;
  // The axis angles psi in the window (fig. 6.5): in the bed before the opening, during steady
  // flow, and of the arch bodies; each run keeps them on its grid of axis_bins over [0, 180).
  std::vector<DistributionInfo> DistributionNames() const override {
    return {{"axis_bed", "axis angle psi in the window, in the bed before the opening", "degrees"},
            {"axis_flow", "axis angle psi in the window, during steady flow", "degrees"},
            {"axis_arches", "axis angle psi in the window, of arch bodies", "degrees"}};
  }
  Samples Distribution(const std::string& name, const nlohmann::json& result) const override {
    if (!result.value("elongated", false)) return {};
    std::vector<double> counts;
    if (name == "axis_bed" || name == "axis_flow")
      counts = OrientationSumsFromJson(result.value(name.substr(5), nlohmann::json::object())).window_axes;
    else if (name == "axis_arches")
      counts = Vector(result.value("arch_window", nlohmann::json::array()));
    Samples out;
    for (std::size_t b = 0; b < counts.size(); ++b)
      if (counts[b] > 0) {
        out.values.push_back(Degrees((static_cast<double>(b) + 0.5) * kPi / static_cast<double>(counts.size())));
        out.weights.push_back(counts[b]);
      }
    return out;
  }

 private:
  OrientationAnalysisOptions o_;
  nlohmann::json raw_;
  CampaignAxes axes_;
};

std::optional<Section> OrientationAnalysis::BuildSection(const SectionInput& in) const {
  const OrientationAnalysisOptions& o = o_;
  const CampaignView& v = in.view;
  // Per point: the runs' sums added up; S per region as mean +- se over runs.
  struct PointSums {
    bool elongated = false;
    OrientationSums bed, flow;
    std::vector<double> arch_window;
    std::vector<std::string> regions;
  };
  std::vector<PointSums> ps(v.points.size());
  bool any = false;
  for (std::size_t k = 0; k < v.points.size(); ++k) {
    for (const nlohmann::json* r : in.results.OfPoint(k)) {
      if (!r->value("elongated", false)) continue;
      PointSums& p = ps[k];
      p.elongated = true;
      p.bed.Add(OrientationSumsFromJson(r->value("bed", nlohmann::json::object())));
      const OrientationSums flow = OrientationSumsFromJson(r->value("flow", nlohmann::json::object()));
      p.flow.Add(flow);
      const std::vector<double> aw = Vector(r->value("arch_window", nlohmann::json::array()));
      if (p.arch_window.empty()) p.arch_window.assign(aw.size(), 0.0);
      for (std::size_t i = 0; i < aw.size() && i < p.arch_window.size(); ++i) p.arch_window[i] += aw[i];
      if (p.regions.empty()) p.regions = r->value("regions", std::vector<std::string>{});
    }
    any = any || ps[k].elongated;
  }
  if (!any) return std::nullopt;
  Section s{"orientation", "Orientation of elongated bodies (ch. 4, 5, 6)", {}};
  s.blocks.push_back(Text{
      "The long axis of a body is the line through the centres of its two discs furthest apart; psi is its angle with "
      "the horizontal in [0, 180) degrees. Positions are taken from outlet " +
      std::to_string(o.outlet) +
      ": s along it from its centre, h into the silo, theta = atan2(h, s) (90 = above its centre). The mean "
      "orientation averages the acute angle with the horizontal (90 = vertical, whichever way a body leans; fig. 4.3) "
      "over the frames of steady flow; S = 2 <cos^2(psi - director)> - 1 (fig. 5.5) is 1 along the director, -1 across "
      "it, 0 for no order; a \"flow\" director is the direction of the region's mean body velocity (all bodies) over "
      "the run's frames of steady flow (0 = +x, 90 = up, -90 = down). Distributions of psi in the window at theta = " +
      FormatNumber(Degrees(o.where.window_theta), 3) + " ± " + FormatNumber(Degrees(o.where.window_dtheta / 2), 3) +
      " degrees and r = " + FormatNumber(o.where.window_radius, 3) + " ± " + FormatNumber(o.where.window_dr / 2, 3) +
      " d: in the bed before the opening (t = 0), during flow, and of the "
      "arch bodies at that angular position (any radius; fig. 6.5)."});
  const std::vector<std::size_t> drawn = SpreadPoints(v, [&](std::size_t k) { return ps[k].elongated; });
  // Fig. 4.3a and b: a figure per height and per radius.
  for (std::size_t h = 0; h < o.where.heights.size(); ++h) {
    Figure f{"orientation_s_" + std::to_string(h + 1),
             "Mean orientation against s at h = " + FormatNumber(o.where.heights[h], 3) + " d",
             "s (d)",
             "mean acute angle with the horizontal (degrees)",
             {},
             false,
             false,
             "Fig. 4.3a: steady flow, band h ± " + FormatNumber(o.where.band / 2, 3) + " d"};
    for (std::size_t k : drawn) {
      const OrientationProfile prof = OrientationAgainstS(ps[k].flow, o.where);
      if (h >= prof.mean.size()) continue;
      Series se{PointName(v, v.points[k]), {"s", "angle_deg", "count"}, {}, Series::Style::kLinesPoints};
      for (std::size_t b = 0; b < prof.centre.size(); ++b)
        if (std::isfinite(prof.mean[h][b]))
          se.rows.push_back({prof.centre[b], Degrees(prof.mean[h][b]), prof.count[h][b]});
      if (!se.rows.empty()) f.series.push_back(se);
    }
    if (!f.series.empty()) s.blocks.push_back(f);
  }
  for (std::size_t r = 0; r < o.where.radii.size(); ++r) {
    Figure f{"orientation_theta_" + std::to_string(r + 1),
             "Mean orientation against the angular position at r = " + FormatNumber(o.where.radii[r], 3) + " d",
             "theta (degrees)",
             "mean acute angle with the horizontal (degrees)",
             {},
             false,
             false,
             "Fig. 4.3b: steady flow, ring r ± " + FormatNumber(o.where.ring / 2, 3) + " d"};
    for (std::size_t k : drawn) {
      const OrientationProfile prof = OrientationAgainstTheta(ps[k].flow, o.where);
      if (r >= prof.mean.size()) continue;
      Series se{PointName(v, v.points[k]), {"theta_deg", "angle_deg", "count"}, {}, Series::Style::kLinesPoints};
      for (std::size_t b = 0; b < prof.centre.size(); ++b)
        if (std::isfinite(prof.mean[r][b]))
          se.rows.push_back({Degrees(prof.centre[b]), Degrees(prof.mean[r][b]), prof.count[r][b]});
      if (!se.rows.empty()) f.series.push_back(se);
    }
    if (!f.series.empty()) s.blocks.push_back(f);
  }
  // Fig. 5.5: S per region.
  std::vector<std::string> regions;
  for (const PointSums& p : ps)
    if (regions.size() < p.regions.size()) regions = p.regions;
  Table t{"orientation_order",
          "Order parameter S during steady flow (mean ± se over runs)",
          {"point", "frames"},
          {},
          {"point", "flow_frames"}};
  // A "flow" region also shows which way the flow pointed at the point: the direction of its
  // mean velocity over all its runs' steady frames (each run's S is against its own).
  auto flows = [&](std::size_t r) { return r < o.where.regions.size() && o.where.regions[r].flow_director; };
  for (std::size_t r = 0; r < regions.size(); ++r) {
    t.header.push_back("S, " + regions[r]);
    t.keys.push_back("order_parameter_" + std::to_string(r));
    if (!flows(r)) continue;
    t.header.push_back("flow direction, " + regions[r] + " (degrees)");
    t.keys.push_back("flow_direction_" + std::to_string(r));
  }
  for (std::size_t k = 0; k < v.points.size(); ++k) {
    if (!ps[k].elongated) continue;
    std::vector<Cell> row = {PointName(v, v.points[k]), Cell::Count(ps[k].flow.frames)};
    for (std::size_t r = 0; r < regions.size(); ++r) {
      const PointMetric* m = FindMetric(in.points[k], "order_parameter_" + std::to_string(r));
      row.push_back(m ? Cell::Estimate(m->Estimate()) : Cell());
      if (!flows(r)) continue;
      const double d = FlowDirection(ps[k].flow, r);
      row.push_back(std::isfinite(d) ? Cell::Number(Degrees(d), 3) : Cell("no flow"));
    }
    t.rows.push_back(row);
  }
  s.blocks.push_back(t);
  if (HasX(v) && !regions.empty()) {
    Figure f{"orientation_order",
             "Order parameter against " + v.x_label,
             v.x_label,
             "S",
             {},
             false,
             false,
             "Fig. 5.5: error bars, standard error over runs"};
    for (std::size_t r = 0; r < regions.size(); ++r)
      for (Series se : PointSeries(v, in.points, "order_parameter_" + std::to_string(r), "S")) {
        se.label = regions[r] + (se.label == "S" ? "" : ", " + se.label);
        f.series.push_back(se);
      }
    if (!f.series.empty()) s.blocks.push_back(f);
  }
  // Fig. 6.5: the window's distributions.
  const std::pair<std::string, std::function<std::vector<double>(std::size_t)>> scenes[] = {
      {"bed", [&](std::size_t k) { return ps[k].bed.window_axes; }},
      {"flow", [&](std::size_t k) { return ps[k].flow.window_axes; }},
      {"arches", [&](std::size_t k) { return ps[k].arch_window; }}};
  const char* titles[] = {"in the bed before the opening", "during steady flow", "of arch bodies"};
  for (std::size_t sc = 0; sc < std::size(scenes); ++sc) {
    Figure f{"orientation_window_" + scenes[sc].first,
             "Axis angles " + std::string(titles[sc]) + " in the window",
             "psi (degrees)",
             "probability density (1/rad)",
             {},
             false,
             false,
             "Fig. 6.5"};
    for (std::size_t k : drawn) {
      const std::vector<double> counts = scenes[sc].second(k);
      const std::vector<double> d = AxisDensity(counts);
      double total = 0;
      for (double c : counts) total += c;
      if (total <= 0) continue;
      Series se{PointName(v, v.points[k]) + " (" + FormatNumber(total, 6) + " axes)",
                {"psi_deg", "density", "count"},
                {},
                Series::Style::kSteps};
      se.file_label = PointName(v, v.points[k]);
      for (std::size_t b = 0; b < d.size(); ++b)
        se.rows.push_back(
            {Degrees((static_cast<double>(b) + 0.5) * kPi / static_cast<double>(d.size())), d[b], counts[b]});
      f.series.push_back(se);
    }
    if (!f.series.empty()) s.blocks.push_back(f);
  }
  return s;
}

}  // namespace

nlohmann::json to_json(const OrientationSums& s) {
  return {{"frames", s.frames},           {"s_sum", s.s_sum},
          {"s_count", s.s_count},         {"theta_sum", s.theta_sum},
          {"theta_count", s.theta_count}, {"region_count", s.region_count},
          {"cos2psi_sum", s.cos2psi_sum}, {"sin2psi_sum", s.sin2psi_sum},
          {"flow_count", s.flow_count},   {"vx_sum", s.vx_sum},
          {"vy_sum", s.vy_sum},           {"v2_sum", s.v2_sum},
          {"window_axes", s.window_axes}, {"s_range", s.s_range}};
}

OrientationSums OrientationSumsFromJson(const nlohmann::json& j) {
  OrientationSums s;
  if (!j.is_object()) return s;
  s.frames = j.value("frames", 0);
  s.s_sum = Matrix(j.value("s_sum", nlohmann::json::array()));
  s.s_count = Matrix(j.value("s_count", nlohmann::json::array()));
  s.theta_sum = Matrix(j.value("theta_sum", nlohmann::json::array()));
  s.theta_count = Matrix(j.value("theta_count", nlohmann::json::array()));
  s.region_count = Vector(j.value("region_count", nlohmann::json::array()));
  s.cos2psi_sum = Vector(j.value("cos2psi_sum", nlohmann::json::array()));
  s.sin2psi_sum = Vector(j.value("sin2psi_sum", nlohmann::json::array()));
  s.flow_count = Vector(j.value("flow_count", nlohmann::json::array()));
  s.vx_sum = Vector(j.value("vx_sum", nlohmann::json::array()));
  s.vy_sum = Vector(j.value("vy_sum", nlohmann::json::array()));
  s.v2_sum = Vector(j.value("v2_sum", nlohmann::json::array()));
  s.window_axes = Vector(j.value("window_axes", nlohmann::json::array()));
  s.s_range = j.value("s_range", 0.0);
  return s;
}

OrientationAnalysisOptions ReadOrientationOptions(const nlohmann::json& options, const std::string& path) {
  OrientationAnalysisOptions o;
  o.where.heights = {5, 10};
  o.where.radii = {5, 10};
  if (options.is_null()) return o;
  OptionObject(options, path,
               {"outlet", "heights", "band", "s_range", "s_bins", "radii", "ring", "theta_bins", "regions", "window",
                "axis_bins"});
  constexpr double kBig = 1e6;
  OrientationOptions& w = o.where;
  for (const auto& [k, v] : options.items()) {
    const std::string p = path + "/" + k;
    if (k == "outlet") o.outlet = OptionInteger(v, p, 0, 1000);
    if (k == "heights") w.heights = Numbers(v, p, -kBig, kBig);
    if (k == "band") w.band = OptionNumber(v, p, 1e-6, kBig);
    if (k == "s_range") w.s_range = OptionNumber(v, p, 0.0, kBig);
    if (k == "s_bins") w.s_bins = OptionInteger(v, p, 1, 1000);
    if (k == "radii") w.radii = Numbers(v, p, 0.0, kBig);
    if (k == "ring") w.ring = OptionNumber(v, p, 1e-6, kBig);
    if (k == "theta_bins") w.theta_bins = OptionInteger(v, p, 1, 360);
    if (k == "axis_bins") w.axis_bins = OptionInteger(v, p, 1, 360);
    if (k == "window") {
      OptionObject(v, p, {"theta", "dtheta", "radius", "dr"});
      for (const auto& [wk, wv] : v.items()) {
        const std::string wp = p + "/" + wk;
        if (wk == "theta") w.window_theta = Radians(OptionNumber(wv, wp, 0.0, 180.0));
        if (wk == "dtheta") w.window_dtheta = Radians(OptionNumber(wv, wp, 1e-6, 180.0));
        if (wk == "radius") w.window_radius = OptionNumber(wv, wp, 0.0, kBig);
        if (wk == "dr") w.window_dr = OptionNumber(wv, wp, 1e-6, kBig);
      }
    }
    if (k == "regions") {
      if (!v.is_array()) throw OptionError(p, v, "must be an array of {name, x: [lo, hi], y: [lo, hi], director}");
      w.regions.clear();
      for (std::size_t i = 0; i < v.size(); ++i) {
        const std::string rp = p + "/" + std::to_string(i);
        OptionObject(v[i], rp, {"name", "x", "y", "director"});
        OrientationOptions::Region r;
        r.name = "region " + std::to_string(i + 1);
        if (v[i].contains("name")) {
          if (!v[i].at("name").is_string()) throw OptionError(rp + "/name", v[i].at("name"), "must be a string");
          r.name = v[i].at("name").get<std::string>();
        }
        for (const char* axis : {"x", "y"}) {
          if (!v[i].contains(axis)) throw OptionError(rp, v[i], std::string("must have \"") + axis + "\": [lo, hi]");
          const nlohmann::json& range = v[i].at(axis);
          const std::string ap = rp + "/" + axis;
          if (!range.is_array() || range.size() != 2)
            throw OptionError(ap, range,
                              "must be [lo, hi]: numbers (d), or expressions over the campaign's axes (\"W_s - 5\")");
          double* ends[2] = {axis[0] == 'x' ? &r.x0 : &r.y0, axis[0] == 'x' ? &r.x1 : &r.y1};
          for (std::size_t e = 0; e < 2; ++e) {
            const std::string ep = ap + "/" + std::to_string(e);
            if (range[e].is_string()) {
              try {
                Expression::Parse(range[e].get<std::string>(), {});  // the grammar; the names at UseAxes
              } catch (const ExpressionError& err) {
                throw OptionError(ep, range[e], err.what());
              }
              o.bounds.push_back(
                  {w.regions.size(), (axis[0] == 'x' ? 0 : 2) + static_cast<int>(e), range[e].get<std::string>(), ep});
              *ends[e] = kNaN;
            } else {
              *ends[e] = OptionNumber(range[e], ep, -kBig, kBig);
            }
          }
          if (std::isfinite(*ends[0]) && std::isfinite(*ends[1]) && !(*ends[0] < *ends[1]))
            throw OptionError(ap, range, "must be [lo, hi] with lo < hi");
        }
        if (v[i].contains("director")) {
          const nlohmann::json& d = v[i].at("director");
          const std::string dp = rp + "/director";
          if (d.is_string() && d.get<std::string>() == "flow")
            r.flow_director = true;
          else if (d.is_number())
            r.director = Radians(OptionNumber(d, dp, -360.0, 360.0));
          else
            throw OptionError(dp, d,
                              "must be an angle in degrees in [-360, 360] (0 = horizontal, 90 = vertical) or \"flow\" "
                              "(the direction of the region's mean velocity)");
        }
        w.regions.push_back(r);
      }
    }
  }
  return o;
}

std::unique_ptr<Analysis> MakeOrientationAnalysis(const nlohmann::json& options, const std::string& path) {
  return std::make_unique<OrientationAnalysis>(ReadOrientationOptions(options, path), options);
}

}  // namespace granary::analysis
