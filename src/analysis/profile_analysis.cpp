// See profile_analysis.h; the profile itself is VelocityProfileAccumulator (flow.h).
#include "analysis/profile_analysis.h"

#include <algorithm>
#include <cmath>

#include "analysis/campaign_view.h"
#include "analysis/options.h"

namespace granary::analysis {
namespace {

constexpr char kVelocityUnit[] = "sqrt(g d)";

nlohmann::json ProfileJson(const VelocityProfile& p) {
  return {{"x_over_w", JsonNumbers(p.x_over_w)},
          {"vx", JsonNumbers(p.vx)},
          {"vy", JsonNumbers(p.vy)},
          {"vx_norm", JsonNumbers(p.vx_norm)},
          {"vy_norm", JsonNumbers(p.vy_norm)},
          {"samples", JsonNumbers(p.samples)},
          {"v_max", JsonNumber(p.v_max)},
          {"frames", p.frames}};
}

VelocityProfile ProfileOf(const nlohmann::json& j) {
  VelocityProfile p;
  p.x_over_w = NumbersOf(j.value("x_over_w", nlohmann::json()));
  p.vx = NumbersOf(j.value("vx", nlohmann::json()));
  p.vy = NumbersOf(j.value("vy", nlohmann::json()));
  p.vx_norm = NumbersOf(j.value("vx_norm", nlohmann::json()));
  p.vy_norm = NumbersOf(j.value("vy_norm", nlohmann::json()));
  p.samples = NumbersOf(j.value("samples", nlohmann::json()));
  p.v_max = NumberAt(j, "v_max");
  p.frames = j.value("frames", 0);
  return p;
}

std::vector<VelocityProfile> ProfilesOf(const nlohmann::json& result) {
  std::vector<VelocityProfile> out;
  if (result.contains("profiles"))
    for (const auto& j : result.at("profiles")) out.push_back(ProfileOf(j));
  return out;
}

std::string VMaxName(std::size_t k) { return k == 0 ? "v_max" : "v_max" + OutletSuffix(k); }

// Profiles of every outlet, each in its outlet's coordinates, over the steady window.
class ProfileAccumulator : public RunAccumulator {
 public:
  ProfileAccumulator(const RunView& run, const ProfileOptions& options) : run_(run) {
    for (const OutletGeometry& o : run.outlets) profiles_.emplace_back(0.0, o.width, options);
  }
  FrameRequest Frames() const override { return {{run_.steady}, false}; }
  void AddFrame(const FrameView& frame) override {
    std::vector<rundir::Disc> no_discs;
    for (std::size_t k = 0; k < run_.outlets.size(); ++k) {
      bodies_ = frame.bodies;
      ToOutletFrame(run_.outlets[k], no_discs, bodies_);
      profiles_[k].Add(bodies_);
    }
    ++frames_;
  }
  nlohmann::json Finish() override {
    nlohmann::json result = {
        {"frames", frames_}, {"outlets", nlohmann::json::array()}, {"base", nlohmann::json::array()}};
    for (const OutletGeometry& o : run_.outlets) {
      result["outlets"].push_back(o.label);
      result["base"].push_back(o.base);
    }
    if (frames_ == 0 || run_.outlets.empty()) return result;
    result["profiles"] = nlohmann::json::array();
    for (const VelocityProfileAccumulator& p : profiles_) result["profiles"].push_back(ProfileJson(p.Result()));
    return result;
  }

 private:
  const RunView& run_;
  std::vector<VelocityProfileAccumulator> profiles_;
  std::vector<rundir::Body> bodies_;
  int frames_ = 0;
};

class ProfileAnalysis : public Analysis {
 public:
  explicit ProfileAnalysis(ProfileOptions options) : options_(options) {}
  std::string Key() const override { return "profile"; }
  int Version() const override { return 1; }
  nlohmann::json RunOptions() const override {
    return {{"bins", options_.bins}, {"band_low", options_.band_low}, {"band_high", options_.band_high}};
  }
  PassUse PassOptionsUsed() const override { return {.window = true, .clog_gap = true, .frames = true}; }
  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    return std::make_unique<ProfileAccumulator>(run, options_);
  }
  std::vector<Metric> RunMetrics(const nlohmann::json& result) const override {
    std::vector<Metric> m;
    const std::vector<VelocityProfile> profiles = ProfilesOf(result);
    const nlohmann::json labels = result.value("outlets", nlohmann::json::array());
    for (std::size_t k = 0; k < profiles.size(); ++k)
      m.push_back({VMaxName(k), kVelocityUnit, profiles[k].v_max, kNaN,
                   "V_max / sqrt(g d)" + (k == 0 ? std::string() : " at " + StringAt(labels, k)), false});
    return m;
  }
  std::optional<Section> BuildSection(const SectionInput& in) const override;

 private:
  ProfileOptions options_;
};

std::optional<Section> ProfileAnalysis::BuildSection(const SectionInput& in) const {
  const CampaignView& v = in.view;
  bool lateral = false;
  for (const nlohmann::json& r : in.results.runs)
    if (!r.is_null()) {
      const nlohmann::json base = r.value("base", nlohmann::json::array());
      lateral = !base.empty() && !base.front().get<bool>();
      break;
    }
  const std::string along = lateral ? "y/W (height along the lateral outlet, from its centre)" : "x/W";
  Figure fy{"velocity_profile_vy",
            lateral ? "Normalised horizontal (outflow) velocity across the lateral outlet (ch. 5a)"
                    : "Normalised vertical velocity across the outlet",
            along,
            lateral ? "v_n / max|v_n| (v_n: velocity away from the wall)" : "v_y / max|v_y|",
            {},
            false,
            false,
            "Bodies with centre within " + FormatNumber(options_.band_low) + ".." + FormatNumber(options_.band_high) +
                " d of " + (v.outlets > 1 ? std::string("each outlet's") : std::string("the outlet's")) +
                " wall (x along the outlet, v_y normal to it), averaged over the steady-window frames and replicas; "
                "error bars: standard error over replicas (none with one replica)"};
  Figure fx{"velocity_profile_vx",
            lateral ? "Normalised vertical velocity across the lateral outlet"
                    : "Normalised horizontal velocity across the outlet",
            along,
            lateral ? "v_y / max|v_y|" : "v_x / max|v_x|",
            {},
            false,
            false,
            std::string(lateral ? "Sign: positive upwards. " : "") + "Error bars: standard error over replicas"};
  for (std::size_t pi = 0; pi < v.points.size(); ++pi) {
    const std::vector<const nlohmann::json*> runs = in.results.OfPoint(pi);
    for (std::size_t o = 0; o < v.outlets; ++o) {
      std::vector<VelocityProfile> prof;
      std::string outlet_label;
      for (const nlohmann::json* r : runs) {
        const std::vector<VelocityProfile> all = ProfilesOf(*r);
        if (o >= all.size()) continue;
        prof.push_back(all[o]);
        outlet_label = r->at("outlets").at(o).get<std::string>();
      }
      if (prof.empty()) continue;
      Series sy, sx;
      sy.label = sx.label = PointName(v, v.points[pi]) + (v.outlets > 1 ? ", " + outlet_label : "");
      sy.columns = {"x_over_W", "vy_norm", "vy_norm_se", "n"};
      sx.columns = {"x_over_W", "vx_norm", "vx_norm_se", "n"};
      sy.style = sx.style = Series::Style::kLinesPoints;
      sy.err = sx.err = 2;  // standard error over replicas
      for (std::size_t i = 0; i < prof.front().x_over_w.size(); ++i) {
        std::vector<double> vy, vx;
        for (const VelocityProfile& q : prof) {
          if (i >= q.vy_norm.size()) continue;
          vy.push_back(q.vy_norm[i]);
          vx.push_back(q.vx_norm[i]);
        }
        const MeanSe my = MeanSeFinite(vy), mx = MeanSeFinite(vx);
        sy.rows.push_back({prof.front().x_over_w[i], my.mean, my.se, static_cast<double>(my.n)});
        sx.rows.push_back({prof.front().x_over_w[i], mx.mean, mx.se, static_cast<double>(mx.n)});
      }
      auto finite = [](const Series& se) {
        return std::any_of(se.rows.begin(), se.rows.end(), [](const auto& row) { return std::isfinite(row[1]); });
      };
      if (finite(sy)) fy.series.push_back(sy);
      if (finite(sx)) fx.series.push_back(sx);
    }
  }
  if (fy.series.empty() && fx.series.empty()) return std::nullopt;
  Section s{"profiles", "Velocity profiles across the outlet", {}};
  if (!fy.series.empty()) s.blocks.push_back(fy);
  if (!fx.series.empty()) s.blocks.push_back(fx);
  Table t{"v_max_per_point", "V_max per point: mean ± se over replicas (n)", {"point"}, {}, {"point"}};
  for (std::size_t k = 0; k < v.outlets; ++k) {
    t.header.push_back("V_max" +
                       (v.outlets > 1 && k < v.outlet_labels.size() ? " " + v.outlet_labels[k] : std::string()) +
                       " (sqrt(g d))");
    t.keys.push_back(VMaxName(k));
  }
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    std::vector<Cell> row{PointName(v, v.points[p])};
    for (std::size_t k = 0; k < v.outlets; ++k) {
      const PointMetric* m = FindMetric(in.points[p], VMaxName(k));
      row.push_back(Cell::Estimate(m ? m->Estimate() : MeanSe{}));
    }
    t.rows.push_back(row);
  }
  s.blocks.push_back(t);
  if (HasX(v))
    s.blocks.push_back(Figure{"v_max", "V_max against " + v.x_label, v.x_label, "V_max (sqrt(g d))",
                              v.outlets > 1 ? OutletSeries(v, in.points, VMaxName, v.outlet_labels, "V_max")
                                            : PointSeries(v, in.points, "v_max", "V_max"),
                              false, false,
                              std::string("max |v_y| of the profile") + (v.outlets > 1 ? ", per outlet" : "")});
  return s;
}

}  // namespace

std::unique_ptr<Analysis> MakeProfileAnalysis(const nlohmann::json& options, const std::string& path) {
  ProfileOptions o;
  if (!options.is_null()) {
    OptionObject(options, path, {"bins", "band_low", "band_high"});
    if (options.contains("bins")) o.bins = OptionInteger(options.at("bins"), path + "/bins", 1, 1000000);
    if (options.contains("band_low"))
      o.band_low = OptionNumber(options.at("band_low"), path + "/band_low", -1e300, 1e300);
    if (options.contains("band_high"))
      o.band_high = OptionNumber(options.at("band_high"), path + "/band_high", -1e300, 1e300);
  }
  return std::make_unique<ProfileAnalysis>(o);
}

}  // namespace granary::analysis
