// See region_analysis.h; the statistics themselves are region.h.
#include "analysis/region_analysis.h"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <tuple>

#include "analysis/campaign_view.h"
#include "analysis/options.h"
#include "analysis/region.h"
#include "rundir/run_spec.h"
#include "rundir/shape_table.h"

namespace granary::analysis {
namespace {

// Velocity histograms: grid bins of this width (sqrt(g d)), merged over replicas, drawn with
// at most kDrawnBins bins.
constexpr double kVelocityBin = 0.05;
constexpr int kDrawnBins = 40;

nlohmann::json HistogramJson(const GridHistogram& h) {
  return {{"width", h.width}, {"first", h.first}, {"counts", JsonNumbers(h.counts)}};
}

GridHistogram HistogramOf(const nlohmann::json& j) {
  GridHistogram h;
  if (!j.is_object()) return h;
  h.width = j.value("width", kVelocityBin);
  h.first = j.value("first", 0LL);
  h.counts = NumbersOf(j.value("counts", nlohmann::json()));
  return h;
}

std::string Suffix(std::size_t k) { return k == 0 ? "" : OutletSuffix(k); }

// Every outlet's region, each in its outlet's coordinates, over the steady window.
class RegionRunAccumulator : public RunAccumulator {
 public:
  RegionRunAccumulator(const RunView& run, const RegionSize& size) : run_(run) {
    const RegionSize in_d = RegionForRun(size, run.data->spec);
    // In outlet coordinates every outlet is centred at 0 on the line y = 0.
    for (const OutletGeometry& o : run.outlets)
      regions_.emplace_back(RegionAboveOutlet(0.0, o.width, in_d), kVelocityBin);
    pad_ = in_d.pad;
    height_ = in_d.height;
  }
  FrameRequest Frames() const override { return {{run_.steady}, false}; }
  void AddFrame(const FrameView& frame) override {
    // The steady window without a flow window reaches to the first clog, where a run that
    // clogged soon after opening is mostly at rest: no velocities from it.
    const bool flowing = run_.flow.ok && run_.flow.t_start <= frame.frame.time && frame.frame.time <= run_.flow.t_end;
    for (std::size_t k = 0; k < run_.outlets.size(); ++k) {
      discs_ = frame.frame.discs;
      bodies_ = frame.bodies;
      ToOutletFrame(run_.outlets[k], discs_, bodies_);
      regions_[k].Add(discs_, bodies_, flowing);
    }
    ++frames_;
  }
  nlohmann::json Finish() override {
    nlohmann::json result = {{"frames", frames_},
                             {"outlets", nlohmann::json::array()},
                             {"notes", nlohmann::json::array()},
                             {"pad", pad_},
                             {"height", height_}};
    for (const OutletGeometry& o : run_.outlets) result["outlets"].push_back(o.label);
    if (frames_ == 0 || run_.outlets.empty()) {
      if (run_.flow.startup_clog)
        result["notes"].push_back("frames: none (a start-up clog: no steady flow)");
      else if (run_.data->has_frames)
        result["notes"].push_back("frames: none inside the window t = " + std::to_string(run_.steady.start) + " .. " +
                                  std::to_string(run_.steady.end));
      return result;
    }
    if (!run_.flow.ok)
      result["notes"].push_back("velocity distributions: none, the run has no steady flow window (" + run_.flow.note +
                                ")");
    result["regions"] = nlohmann::json::array();
    for (std::size_t k = 0; k < regions_.size(); ++k) {
      const RegionStats s = regions_[k].Result();
      nlohmann::json r = {{"phi", to_json(s.phi)},
                          {"tg_translational", to_json(s.tg_translational)},
                          {"tg_full", to_json(s.tg_full)},
                          {"frames", s.frames}};
      // The distributions of the region next to outlet 0 (the report draws those).
      if (k == 0)
        r["velocity"] = {{"vx", HistogramJson(s.vx)}, {"vy", HistogramJson(s.vy)}, {"frames", s.velocity_frames}};
      result["regions"].push_back(r);
    }
    return result;
  }

 private:
  const RunView& run_;
  std::vector<RegionAccumulator> regions_;
  std::vector<rundir::Disc> discs_;
  std::vector<rundir::Body> bodies_;
  int frames_ = 0;
  double pad_ = 0.0, height_ = 0.0;  // the region's size in d
};

class RegionAnalysis : public Analysis {
 public:
  explicit RegionAnalysis(RegionSize size) : size_(std::move(size)) {}
  std::string Key() const override { return "region"; }
  int Version() const override { return 2; }
  nlohmann::json RunOptions() const override {
    nlohmann::json j = {{"pad", size_.pad}, {"height", size_.height}};
    if (size_.in_d_eq) j["unit"] = "D_eq";  // sizes in d keep the key their cached results have
    return j;
  }
  PassUse PassOptionsUsed() const override { return {.window = true, .clog_gap = true, .frames = true}; }
  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    return std::make_unique<RegionRunAccumulator>(run, size_);
  }
  std::vector<Metric> RunMetrics(const nlohmann::json& result) const override {
    std::vector<Metric> m;
    if (!result.contains("regions")) return m;
    const nlohmann::json& regions = result.at("regions");
    const nlohmann::json labels = result.value("outlets", nlohmann::json::array());
    for (std::size_t k = 0; k < regions.size(); ++k) {
      const std::string s = Suffix(k);
      const std::string where = k == 0 ? "" : " next to " + StringAt(labels, k);
      const MeanSe phi = MeanSeOf(regions[k].at("phi"));
      const MeanSe t3 = MeanSeOf(regions[k].at("tg_translational"));
      const MeanSe t4 = MeanSeOf(regions[k].at("tg_full"));
      m.push_back({"phi" + s, "1", phi.mean, phi.se, "packing fraction" + where, k == 0});
      m.push_back({"tg_translational" + s, "g d", t3.mean, t3.se, "T_g translational (ch. 3)" + where, false});
      m.push_back({"tg_full" + s, "rho g d^3", t4.mean, t4.se, "T_g (ch. 4-5)" + where, k == 0});
    }
    return m;
  }
  std::optional<Section> BuildSection(const SectionInput& in) const override;
  // The velocity components in the region next to outlet 0 (thesis figs. 3.5, 4.6).
  std::vector<DistributionInfo> DistributionNames() const override {
    return {{"vx", "v_x in the region above the outlet", "sqrt(g d)"},
            {"vy", "v_y in the region above the outlet", "sqrt(g d)"}};
  }
  Samples Distribution(const std::string& name, const nlohmann::json& result) const override {
    Samples out;
    if (!result.contains("regions") || result.at("regions").empty()) return out;
    const nlohmann::json velocity = result.at("regions").at(0).value("velocity", nlohmann::json::object());
    const GridHistogram h = HistogramOf(velocity.value(name, nlohmann::json()));
    for (std::size_t i = 0; i < h.counts.size(); ++i) {
      if (h.counts[i] <= 0) continue;
      out.values.push_back(static_cast<double>(h.first + static_cast<long long>(i)) * h.width);
      out.weights.push_back(h.counts[i]);
    }
    return out;
  }

 private:
  RegionSize size_;
};

std::optional<Section> RegionAnalysis::BuildSection(const SectionInput& in) const {
  const CampaignView& v = in.view;
  auto metric = [&](std::size_t p, const std::string& name) {
    const PointMetric* m = FindMetric(in.points[p], name);
    return m ? m->Estimate() : MeanSe{};
  };
  bool any = false;
  for (std::size_t p = 0; p < v.points.size(); ++p) any = any || metric(p, "phi").n > 0;
  if (!any) return std::nullopt;
  Section s{"region", "Region above the outlet", {}};
  const std::string unit = size_.in_d_eq ? " D_eq" : " d";
  s.blocks.push_back(
      Text{"Region " + size_.label + ", centred on " +
           (v.outlets > 1 ? std::string("each outlet (the first table: outlet 0)") : "the outlet") +
           " and reaching from its wall into the silo (above a base outlet, beside a lateral one; pad " +
           FormatNumber(size_.pad) + unit + ", height " + FormatNumber(size_.height) + unit +
           (size_.in_d_eq ? "; D_eq from each run's bodies, the diameter of the disc of a body's area" : "") +
           "). Packing fraction: exact area of every disc inside the region (discs cut by the "
           "edge count with their inside part) over the region area. Temperatures over the bodies "
           "whose centre of mass is inside, per frame, then averaged over frames: ch. 3 "
           "`T_g = 1/2 <(v_x - <v_x>)^2 + (v_y - <v_y>)^2>` and ch. 4-5 "
           "`T_g = 1/3 <m |v - <v>|^2 + I (Omega - <Omega>)^2>`."});
  Table t{"region",
          "Region statistics per point: mean ± se over replicas (n)",
          {"point", "phi", "T_g ch3 (g d)", "T_g ch4 (rho g d^3)"},
          {},
          {"point", "phi", "tg_translational", "tg_full"}};
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    if (metric(p, "phi").n == 0) continue;
    t.rows.push_back({PointName(v, v.points[p]), Cell::Estimate(metric(p, "phi")),
                      Cell::Estimate(metric(p, "tg_translational")), Cell::Estimate(metric(p, "tg_full"))});
  }
  s.blocks.push_back(t);
  // Several outlets: the same statistics next to each of them.
  Table per_outlet{"region_per_outlet",
                   "Region statistics next to every outlet: mean ± se over replicas (n)",
                   {"point", "outlet", "phi", "T_g ch3 (g d)", "T_g ch4 (rho g d^3)"},
                   {},
                   {"point", "outlet", "phi", "tg_translational", "tg_full"}};
  if (v.outlets > 1)
    for (std::size_t p = 0; p < v.points.size(); ++p)
      for (std::size_t k = 0; k < v.outlets; ++k) {
        const std::string sfx = Suffix(k);
        if (metric(p, "phi" + sfx).n == 0) continue;
        per_outlet.rows.push_back({PointName(v, v.points[p]), k < v.outlet_labels.size() ? v.outlet_labels[k] : "",
                                   Cell::Estimate(metric(p, "phi" + sfx)),
                                   Cell::Estimate(metric(p, "tg_translational" + sfx)),
                                   Cell::Estimate(metric(p, "tg_full" + sfx))});
      }
  if (!per_outlet.rows.empty()) s.blocks.push_back(per_outlet);
  if (HasX(v)) {
    const std::string where = v.outlets > 1 ? " next to each outlet" : "";
    auto series = [&](const std::string& base, const std::string& column) {
      return v.outlets > 1 ? OutletSeries(
                                 v, in.points, [&](std::size_t k) { return base + Suffix(k); }, v.outlet_labels, column)
                           : PointSeries(v, in.points, base, column);
    };
    s.blocks.push_back(Figure{"packing_fraction", "Packing fraction phi" + where + " against " + v.x_label, v.x_label,
                              "phi", series("phi", "phi"), false, false, "Error bars: se over replicas"});
    Figure tg{"granular_temperature",
              "Granular temperature" + where + " against " + v.x_label,
              v.x_label,
              "T_g (ch. 3: g d; ch. 4-5: rho g d^3)",
              {},
              false,
              false,
              "Both definitions; error bars: se over replicas"};
    for (auto se : series("tg_translational", "Tg_ch3")) {
      se.label = "ch. 3 " + se.label;
      tg.series.push_back(se);
    }
    for (auto se : series("tg_full", "Tg_ch4")) {
      se.label = "ch. 4-5 " + se.label;
      tg.series.push_back(se);
    }
    s.blocks.push_back(tg);
  }
  // Velocity distributions, pooled over the replicas of each point.
  const std::string pooled = std::string("Pooled over the frames of steady flow (the flow window) and replicas") +
                             (v.outlets > 1 ? "; the region next to outlet 0" : "") +
                             "; in outlet coordinates (x along the outlet, y from its wall into the silo)";
  Figure dx{"velocity_distribution_vx",
            "Distribution of v_x in the region",
            "v_x (sqrt(g d))",
            "probability density",
            {},
            false,
            false,
            pooled};
  Figure dy{"velocity_distribution_vy",
            "Distribution of v_y in the region",
            "v_y (sqrt(g d))",
            "probability density",
            {},
            false,
            false,
            pooled};
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    GridHistogram hx, hy;
    hx.width = hy.width = kVelocityBin;
    for (const nlohmann::json* r : in.results.OfPoint(p)) {
      if (!r->contains("regions") || r->at("regions").empty()) continue;
      const nlohmann::json velocity = r->at("regions").at(0).value("velocity", nlohmann::json::object());
      hx.Merge(HistogramOf(velocity.value("vx", nlohmann::json())));
      hy.Merge(HistogramOf(velocity.value("vy", nlohmann::json())));
    }
    if (hx.Total() < 2) continue;
    for (auto [grid, fig, name] : {std::tuple{&hx, &dx, "vx"}, std::tuple{&hy, &dy, "vy"}}) {
      const Histogram h = grid->Coarse(kDrawnBins);
      Series se;
      se.label = PointName(v, v.points[p]);
      se.columns = {name, "density", "count"};
      se.style = Series::Style::kSteps;
      for (std::size_t i = 0; i < h.counts.size(); ++i) se.rows.push_back({h.Center(i), h.Density(i), h.counts[i]});
      fig->series.push_back(se);
    }
  }
  if (!dx.series.empty()) {
    s.blocks.push_back(dx);
    s.blocks.push_back(dy);
  }
  return s;
}

}  // namespace

RegionSize ReadRegionSize(const nlohmann::json& options, const std::string& path) {
  RegionSize size = Chapter4Region();
  if (options.is_null() || options == "ch4") return size;
  if (options == "ch3") return Chapter3Region();
  if (options == "ch6") return Chapter6Region();
  if (!options.is_object() || !options.contains("pad") || !options.contains("height"))
    throw OptionError(
        path, options,
        "must be \"ch3\", \"ch4\", \"ch6\" or {\"pad\": .., \"height\": .., \"unit\": \"d\" or \"D_eq\"}");
  OptionObject(options, path, {"pad", "height", "unit"});
  size.pad = OptionNumber(options.at("pad"), path + "/pad", -1e300, 1e300);
  size.height = OptionNumber(options.at("height"), path + "/height", 0.0, 1e300);
  std::string unit = "d";
  if (options.contains("unit")) {
    const nlohmann::json& u = options.at("unit");
    if (u != "d" && u != "D_eq") throw OptionError(path + "/unit", u, "must be \"d\" or \"D_eq\"");
    unit = u.get<std::string>();
  }
  size.in_d_eq = unit == "D_eq";
  size.label = "(W + " + FormatNumber(size.pad) + " " + unit + ") x " + FormatNumber(size.height) + " " + unit;
  return size;
}

double EquivalentDiameter(const nlohmann::json& run_spec) {
  RunSpec spec;
  try {
    spec = RunSpec::FromJson(run_spec);
  } catch (const std::exception& e) {
    throw std::invalid_argument(std::string("D_eq: the run's spec does not describe its bodies: ") + e.what());
  }
  double area = 0.0;
  for (const Species& s : spec.bodies.species) area += s.fraction * BodyArea(s);
  return std::sqrt(4.0 * area / std::numbers::pi);
}

RegionSize RegionForRun(const RegionSize& size, const nlohmann::json& run_spec) {
  if (!size.in_d_eq) return size;
  const double d_eq = EquivalentDiameter(run_spec);
  RegionSize out = size;
  out.pad *= d_eq;
  out.height *= d_eq;
  out.in_d_eq = false;
  return out;
}

std::unique_ptr<Analysis> MakeRegionAnalysis(const nlohmann::json& options, const std::string& path) {
  return std::make_unique<RegionAnalysis>(ReadRegionSize(options, path));
}

}  // namespace granary::analysis
