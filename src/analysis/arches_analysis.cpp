// See arches_analysis.h; the arches themselves are arches.h.
#include "analysis/arches_analysis.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "analysis/campaign_view.h"
#include "analysis/options.h"
#include "rundir/clogs.h"

namespace granary::analysis {
namespace {

constexpr double kPi = std::numbers::pi;
// Ch. 4 and 6 average over at least this many clogged states per point.
constexpr int kThesisClogs = 100;

double Degrees(double radians) { return radians * 180 / kPi; }

// The arches of every clog of these runs, pooled.
ArchSummary RunsSummary(const std::vector<const nlohmann::json*>& runs, const ArchSummaryOptions& options) {
  std::vector<ClogArches> clogs;
  for (const nlohmann::json* r : runs)
    for (ClogArches& c : ClogsOf(*r)) clogs.push_back(std::move(c));
  std::vector<const ClogArches*> list;
  for (const ClogArches& c : clogs) list.push_back(&c);
  return SummarizeArches(list, options);
}

// The arches of every clog of every replica of point p, pooled.
ArchSummary PointSummary(const AnalysisResults& results, std::size_t p, const ArchSummaryOptions& options) {
  return RunsSummary(results.OfPoint(p), options);
}

class ArchesAccumulator : public RunAccumulator {
 public:
  explicit ArchesAccumulator(const RunView& run) : run_(run.data) {}
  nlohmann::json Finish() override { return ArchesRunResult(*run_); }

 private:
  const rundir::RunData* run_;
};

class ArchesAnalysis : public Analysis {
 public:
  explicit ArchesAnalysis(ArchesOptions options) : o_(options) {}
  std::string Key() const override { return "arches"; }
  int Version() const override { return 1; }
  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    return std::make_unique<ArchesAccumulator>(run);
  }

  // Means over the run's arches, se over them.
  std::vector<Metric> RunMetrics(const nlohmann::json& result) const override {
    if (!result.value("present", false)) return {};
    const std::vector<ClogArches> clogs = ClogsOf(result);
    std::vector<const ClogArches*> list;
    for (const ClogArches& c : clogs) list.push_back(&c);
    const ArchSummary s = SummarizeArches(list, o_.summary);
    std::vector<Metric> m = {
        {"arches", "arches", static_cast<double>(s.arches), kNaN, "arches in the kept clogs", false},
        {"obstacle_arches", "arches", static_cast<double>(s.obstacle_arches), kNaN, "arches through an obstacle",
         false}};
    for (const auto& [name, unit, estimate, title, headline] : Means(s))
      m.push_back({name, unit, estimate.mean, estimate.se, title, headline});
    return m;
  }

  // Pooled over the arches of every replica (the thesis averages over clogged states): n = arches.
  std::vector<PointMetric> PointMetrics(const AnalysisResults& results, std::size_t point) const override {
    bool present = false;
    for (const nlohmann::json* r : results.OfPoint(point)) present = present || r->value("present", false);
    if (!present) return {};
    const ArchSummary s = PointSummary(results, point, o_.summary);
    const std::string note = s.arches < kThesisClogs
                                 ? "fewer than " + std::to_string(kThesisClogs) + " arches (the thesis averages >= 100)"
                                 : "";
    std::vector<PointMetric> m = {{"arches", "arches", static_cast<double>(s.arches), kNaN, s.clogs,
                                   "arches in the kept clogs (n = clogs)", false, "", false},
                                  {"obstacle_arches", "arches", static_cast<double>(s.obstacle_arches), kNaN, s.clogs,
                                   "arches through an obstacle", false, "", false}};
    for (const auto& [name, unit, estimate, title, headline] : Means(s))
      m.push_back({name, unit, estimate.mean, estimate.se, estimate.n, title, headline, note});
    m.push_back(
        {"arch_width_sd", "d", s.width_sd, kNaN, s.width.n, "standard deviation of w (table 3.1)", false, note});
    m.push_back(
        {"arch_height_sd", "d", s.height_sd, kNaN, s.height.n, "standard deviation of h (table 3.1)", false, note});
    return m;
  }

  std::optional<Section> BuildSection(const SectionInput& in) const override;

  // The arch sizes N_t, one per arch of the kept clogs (the inset of thesis fig. 6.9).
  std::vector<DistributionInfo> DistributionNames() const override {
    return {{"arch_sizes", "bodies in an arch N_t", "bodies"}};
  }
  Samples Distribution(const std::string& name, const nlohmann::json& result) const override {
    if (name != "arch_sizes") return {};
    return {RunsSummary({&result}, o_.summary).n_values, {}};
  }
  // Per angular position of the arch bodies (figs. 6.6, 6.7) and per arch size (fig. 6.9), from
  // the arches of the runs given pooled, as the section draws them for the points it picks.
  std::vector<CurveInfo> CurveNames() const override {
    return {{"arch_pressure_theta", "Pressure of arch bodies against their angular position", "theta (degrees)",
             "P (rho g d)", false},
            {"arch_axis_mode_theta", "Most frequent axis angle of arch bodies against their angular position",
             "theta (degrees)", "mode of the axis angle psi (degrees)", true},
            {"arch_pressure_n", "Mean arch pressure against the arch's size", "N_t (bodies)", "<P> (rho g d)", false}};
  }
  std::vector<CurvePoint> Curve(const std::string& name,
                                const std::vector<const nlohmann::json*>& results) const override {
    const ArchSummary a = RunsSummary(results, o_.summary);
    std::vector<CurvePoint> out;
    if (name == "arch_pressure_theta" || name == "arch_axis_mode_theta")
      for (const ThetaBin& b : a.theta) {
        if (name == "arch_pressure_theta" && b.pressure.n > 0)
          out.push_back({Degrees(b.theta), b.pressure.mean, b.pressure.se, static_cast<double>(b.pressure.n)});
        if (name == "arch_axis_mode_theta" && b.elongated > 0)
          out.push_back({Degrees(b.theta), Degrees(b.axis_mode), kNaN, static_cast<double>(b.elongated)});
      }
    if (name == "arch_pressure_n")
      for (const auto& b : a.pressure_by_n)
        out.push_back({static_cast<double>(b.n), b.pressure.mean, b.pressure.se, static_cast<double>(b.pressure.n)});
    return out;
  }

 private:
  struct Mean {
    const char* name;
    const char* unit;
    MeanSe estimate;
    const char* title;
    bool headline;
  };
  static std::vector<Mean> Means(const ArchSummary& s) {
    return {{"arch_n", "bodies", s.n, "bodies in an arch N_t", true},
            {"arch_width", "d", s.width, "arch width w", false},
            {"arch_height", "d", s.height, "arch height h", false},
            {"arch_perimeter", "d", s.perimeter, "arch perimeter p", false},
            {"arch_c_over_p", "1", s.c_over_p, "arc over perimeter c/p", false},
            {"arch_elongated_fraction", "1", s.elongated_fraction, "elongated bodies in an arch X^arch", false},
            {"arch_pressure", "rho g d", s.mean_pressure, "mean pressure of an arch <P>", false}};
  }
  void AddPictures(const SectionInput& in, const std::vector<ArchSummary>& sums, Section& s) const;

  ArchesOptions o_;
};

std::optional<Section> ArchesAnalysis::BuildSection(const SectionInput& in) const {
  const CampaignView& v = in.view;
  std::vector<ArchSummary> sums;
  bool any_files = false, any = false;
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    sums.push_back(PointSummary(in.results, p, o_.summary));
    any = any || sums.back().arches > 0;
    for (const nlohmann::json* r : in.results.OfPoint(p)) any_files = any_files || r->value("present", false);
  }
  if (!any_files) return std::nullopt;
  Section s{"arches", "Arches (ch. 3, 4, 6)", {}};
  s.blocks.push_back(Text{
      "Every clog an engine judged is kept with its configuration and contact forces (`clog_frames.dump`, "
      "`clog_contacts.dump`). The arch of an outlet is the chain of mutually touching bodies that spans it and holds "
      "the bed, the one nearest the outlet (To, Lai & Pak 2001; Garcimartin et al. 2010): read off the edge of the "
      "free space under it (the clog judgement's flood fill), dead-end branches cut off as defects, bodies that do not "
      "touch joined through the contact network (docs/analyses.md \"Arches\"). w is the distance between the end "
      "bodies' centres along the outlet, h the highest centre above the end bodies' mean, p the centre-to-centre "
      "length of the chain, c the arc through the end bodies and the highest one, P the pressure of eq. 6.1 over pair "
      "contacts (compression positive, rho g d). Means are over arches, pooled over the point's replicas (the thesis "
      "averages over clogged states); sigma is the standard deviation (table 3.1)."});
  if (!any) {
    s.blocks.push_back(Text{"No run of this campaign kept a clog, so there is no arch."});
    return s;
  }
  const bool obstacles =
      std::any_of(sums.begin(), sums.end(), [](const ArchSummary& a) { return a.obstacle_arches > 0; });
  Table t{"arches", "Arches per point (pooled over replicas)", {}, {}, {}};
  t.header = {"point",         "clogs",
              "arches",        "particle / obstacle",
              "N_t",           "w (d)",
              "sigma_w",       "h (d)",
              "sigma_h",       "p (d)",
              "c/p",           "X^arch elongated",
              "<P> (rho g d)", "with defects (dead ends, concavities)",
              "with gaps",     "note"};
  t.keys = {"point",          "clogs",          "arches",        "particle_obstacle",
            "arch_n",         "arch_width",     "arch_width_sd", "arch_height",
            "arch_height_sd", "arch_perimeter", "arch_c_over_p", "arch_elongated_fraction",
            "arch_pressure",  "with_defects",   "with_gaps",     "note"};
  for (std::size_t k = 0; k < v.points.size(); ++k) {
    const ArchSummary& a = sums[k];
    if (a.clogs == 0) continue;
    std::string note;
    if (a.arches < kThesisClogs)
      note = "fewer than " + std::to_string(kThesisClogs) + " arches (the thesis averages >= 100)";
    if (a.unsupported > 0)
      note += std::string(note.empty() ? "" : "; ") + std::to_string(a.unsupported) + " with an end off its support";
    t.rows.push_back({PointName(v, v.points[k]), Cell::Count(a.clogs), Cell::Count(a.arches),
                      std::to_string(a.particle_arches) + " / " + std::to_string(a.obstacle_arches),
                      Cell::Estimate(a.n), Cell::Estimate(a.width), Cell::Number(a.width_sd), Cell::Estimate(a.height),
                      Cell::Number(a.height_sd), Cell::Estimate(a.perimeter), Cell::Estimate(a.c_over_p),
                      Cell::Estimate(a.elongated_fraction), Cell::Estimate(a.mean_pressure),
                      Cell::Count(a.with_defects), Cell::Count(a.with_gaps), note});
  }
  s.blocks.push_back(t);
  if (obstacles)
    s.blocks.push_back(
        Text{"Obstacle arches run from the base to the obstacle and on to the base (fig. 3.4, first type); "
             "particle arches span the outlet without it. Both are in the means unless "
             "`/report/arches/obstacle_arches` is false; the counts are apart."});

  if (HasX(v)) {
    const std::pair<const char*, const char*> metrics[] = {
        {"arch_n", "N_t (bodies)"}, {"arch_width", "w (d)"},
        {"arch_height", "h (d)"},   {"arch_perimeter", "p (d)"},
        {"arch_c_over_p", "c/p"},   {"arch_elongated_fraction", "X^arch (elongated bodies in the arch)"}};
    for (const auto& [name, ylabel] : metrics) {
      std::vector<Series> series = PointSeries(v, in.points, name, name);
      if (series.empty()) continue;
      s.blocks.push_back(Figure{name, std::string(ylabel) + " against " + v.x_label, v.x_label, ylabel, series, false,
                                false, "Error bars: standard error over arches"});
    }
  }

  // Per angular position (figs. 6.6, 6.7) and per N_t (fig. 6.9): a few points drawn.
  const std::vector<std::size_t> drawn = SpreadPoints(v, [&](std::size_t k) { return sums[k].arches > 0; });
  Figure pressure{
      "arch_pressure_theta",
      "Pressure of arch bodies against their angular position",
      "theta (degrees)",
      "P (rho g d)",
      {},
      false,
      false,
      "Fig. 6.7: mean over the arch bodies in each bin of theta around the outlet's centre (90 = above it); "
      "error bars: standard error over bodies"};
  Figure mode{"arch_axis_mode_theta",
              "Most frequent axis angle of arch bodies against their angular position",
              "theta (degrees)",
              "mode of the axis angle (degrees)",
              {},
              false,
              false,
              "Fig. 6.6: the line is mode = theta (axes pointing at the outlet's centre)"};
  Figure by_n{"arch_pressure_n",
              "Mean arch pressure against the arch's size",
              "N_t (bodies)",
              "<P> (rho g d)",
              {},
              false,
              false,
              "Fig. 6.9: per arch size, error bars: standard error over arches"};
  Figure hist{"arch_n_distribution", "Arch sizes", "N_t (bodies)", "arches", {}, false, false, "Inset of fig. 6.9"};
  bool any_axis = false;
  for (std::size_t k : drawn) {
    const ArchSummary& a = sums[k];
    const std::string name = PointName(v, v.points[k]);
    Series sp{name, {"theta_deg", "P", "P_se", "bodies"}, {}, Series::Style::kErrorBars, 0, 1, 2};
    Series sm{name, {"theta_deg", "axis_mode_deg", "axes"}, {}, Series::Style::kLinesPoints};
    for (const ThetaBin& b : a.theta) {
      if (b.pressure.n > 0)
        sp.rows.push_back({Degrees(b.theta), b.pressure.mean, b.pressure.se, static_cast<double>(b.pressure.n)});
      if (b.elongated > 0)
        sm.rows.push_back({Degrees(b.theta), Degrees(b.axis_mode), static_cast<double>(b.elongated)});
    }
    if (!sp.rows.empty()) pressure.series.push_back(sp);
    if (!sm.rows.empty()) {
      mode.series.push_back(sm);
      any_axis = true;
    }
    Series sn{name, {"N_t", "P", "P_se", "arches"}, {}, Series::Style::kErrorBars, 0, 1, 2};
    for (const auto& b : a.pressure_by_n)
      sn.rows.push_back({static_cast<double>(b.n), b.pressure.mean, b.pressure.se, static_cast<double>(b.pressure.n)});
    if (!sn.rows.empty()) by_n.series.push_back(sn);
    const int lo = static_cast<int>(*std::min_element(a.n_values.begin(), a.n_values.end()));
    const int hi = static_cast<int>(*std::max_element(a.n_values.begin(), a.n_values.end()));
    Series sh{name, {"N_t", "arches"}, {}, Series::Style::kSteps};
    for (int n = lo; n <= hi; ++n)
      sh.rows.push_back(
          {static_cast<double>(n), static_cast<double>(std::count(a.n_values.begin(), a.n_values.end(), n))});
    hist.series.push_back(sh);
  }
  if (!pressure.series.empty()) s.blocks.push_back(pressure);
  if (any_axis) {
    mode.series.push_back(
        Series{"mode = theta", {"theta_deg", "mode_deg"}, {{0, 0}, {180, 180}}, Series::Style::kLines});
    s.blocks.push_back(mode);
  }
  if (!by_n.series.empty()) s.blocks.push_back(by_n);
  if (!hist.series.empty()) s.blocks.push_back(hist);
  AddPictures(in, sums, s);
  return s;
}

// For each point the clogs whose arch has the point's median N_t (fig. 3.4, 6.3).
void ArchesAnalysis::AddPictures(const SectionInput& in, const std::vector<ArchSummary>& sums, Section& s) const {
  if (o_.pictures <= 0) return;
  if (!in.draw_clog) {
    s.blocks.push_back(Text{"(No pictures of clogs: this report was written without the renderer.)"});
    return;
  }
  const CampaignView& v = in.view;
  NotDrawn not_drawn;
  std::filesystem::create_directories(in.out_dir / "pictures");
  for (std::size_t k = 0; k < v.points.size(); ++k) {
    if (sums[k].arches == 0) continue;
    const double median_n = Median(sums[k].n_values);
    struct Candidate {
      std::size_t run;  // index into CampaignView::used
      int clog;
      Arch arch;
      double distance;
    };
    std::vector<Candidate> candidates;
    for (std::size_t run : v.points[k].runs) {
      if (run >= in.results.runs.size() || in.results.runs[run].is_null()) continue;
      const std::vector<ClogArches> clogs = ClogsOf(in.results.runs[run]);
      for (std::size_t c = 0; c < clogs.size(); ++c)
        for (const Arch& a : clogs[c].arches)
          candidates.push_back({run, static_cast<int>(c) + 1, a, std::fabs(a.n - median_n)});
    }
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const Candidate& a, const Candidate& b) { return a.distance < b.distance; });
    Pictures pics;
    pics.caption = PointTitle(v, v.points[k]) +
                   ": clogs with the median arch size (N_t = " + FormatNumber(median_n, 3) + "), arch bodies outlined";
    for (std::size_t i = 0; i < candidates.size() && static_cast<int>(pics.pictures.size()) < o_.pictures; ++i) {
      const Candidate& c = candidates[i];
      const ClogPicture pic = ArchPicture(c.clog, c.arch);
      const std::string file =
          "pictures/arch-point-" + std::to_string(k + 1) + "-" + std::to_string(pics.pictures.size() + 1) + ".png";
      const RunRecord& record = *v.used[c.run].record;
      const std::string problem = in.draw_clog(record.run_dir, pic, in.out_dir / file);
      if (problem.empty()) {
        pics.pictures.push_back({file, "run `" + record.run_id.substr(0, 10) + "`, clog " + std::to_string(c.clog) +
                                           ": N_t = " + std::to_string(c.arch.n) + ", w = " +
                                           FormatNumber(c.arch.width, 3) + " d, h = " + FormatNumber(c.arch.height, 3) +
                                           " d" + (c.arch.obstacle ? ", through the obstacle" : "")});
      } else {
        not_drawn.Add(problem);
      }
    }
    if (!pics.pictures.empty()) s.blocks.push_back(pics);
  }
  not_drawn.AppendTo(s);
}

}  // namespace

ClogPicture ArchPicture(int clog, const Arch& arch) {
  ClogPicture pic;
  pic.clog = clog;
  double x_lo = 1e300, x_hi = -1e300, y_lo = 0, y_hi = -1e300;
  for (const ArchBody& b : arch.bodies) {
    pic.highlight.insert(b.id);
    x_lo = std::min(x_lo, b.x), x_hi = std::max(x_hi, b.x);
    y_lo = std::min(y_lo, b.y), y_hi = std::max(y_hi, b.y);
  }
  const double pad = 4 + 0.25 * (x_hi - x_lo);
  pic.x_lo = x_lo - pad, pic.x_hi = x_hi + pad, pic.y_lo = y_lo - 2.5, pic.y_hi = y_hi + pad;
  return pic;
}

ArchesOptions ReadArchesOptions(const nlohmann::json& options, const std::string& path) {
  ArchesOptions o;
  if (options.is_null()) return o;
  OptionObject(options, path, {"theta_bins", "axis_bins", "obstacle_arches", "pictures"});
  for (const auto& [k, v] : options.items()) {
    const std::string p = path + "/" + k;
    if (k == "theta_bins") o.summary.theta_bins = OptionInteger(v, p, 1, 180);
    if (k == "axis_bins") o.summary.axis_bins = OptionInteger(v, p, 1, 180);
    if (k == "obstacle_arches") o.summary.obstacle_arches = OptionBool(v, p);
    if (k == "pictures") o.pictures = OptionInteger(v, p, 0, 10);
  }
  return o;
}

nlohmann::json ArchesRunResult(const rundir::RunData& run) {
  nlohmann::json result = {{"present", false}, {"clogs", nlohmann::json::array()}, {"notes", nlohmann::json::array()}};
  try {
    rundir::ClogReader reader(run.dir);
    result["present"] = reader.Present();
    if (!reader.Present()) return result;  // a run directory written before the engines kept clogs
    rundir::ClogState clog;
    while (reader.Next(clog)) result["clogs"].push_back(to_json(AnalyseClog(clog, run.spec)));
  } catch (const std::exception& e) {
    result["clogs"] = nlohmann::json::array();
    result["notes"].push_back(std::string("arches: ") + e.what());
  }
  return result;
}

std::vector<ClogArches> ClogsOf(const nlohmann::json& result) {
  std::vector<ClogArches> clogs;
  if (!result.is_object() || !result.contains("clogs")) return clogs;
  for (const nlohmann::json& c : result.at("clogs")) clogs.push_back(ClogArchesFromJson(c));
  return clogs;
}

std::unique_ptr<Analysis> MakeArchesAnalysis(const nlohmann::json& options, const std::string& path) {
  return std::make_unique<ArchesAnalysis>(ReadArchesOptions(options, path));
}

}  // namespace granary::analysis
