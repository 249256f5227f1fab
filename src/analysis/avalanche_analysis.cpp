// See avalanche_analysis.h; clog series and the tail fit are clogging.h and stats.h.
#include "analysis/avalanche_analysis.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "analysis/campaign_view.h"
#include "analysis/clogging.h"
#include "analysis/options.h"

namespace granary::analysis {
namespace {

// Ch. 4 and 6 average <s> over at least this many avalanches per point.
constexpr int kThesisAvalanches = 100;

class AvalancheAccumulator : public RunAccumulator {
 public:
  explicit AvalancheAccumulator(const RunView& run) {
    const std::vector<rundir::ExitEvent>& events = run.data->events;
    const RunEnd end = RunEndOf(run.end_reason);
    nlohmann::json per_outlet = nlohmann::json::array(), labels = nlohmann::json::array();
    if (run.on_clog == "unclog") {
      // The engine broke each clog: an avalanche is what left between two unclogs, whatever
      // gaps the stream has (the clogs are the engine's, each with its frame in clog_frames.dump).
      std::vector<double> cuts;
      int last_clog = 0;
      for (const rundir::UnclogEvent& u : run.data->unclogs)
        if (u.clog != last_clog) cuts.push_back(u.time), last_clog = u.clog;
      // A clog the protocol could not break ends the run with its attempts and no exit after
      // them: they are no unclog, and the stretch before them is the avalanche that ended in it
      // (not one of size 0 after them).
      if (end == RunEnd::kClogged && !cuts.empty() &&
          std::none_of(events.begin(), events.end(), [&](const rundir::ExitEvent& e) { return e.time > cuts.back(); }))
        cuts.pop_back();
      const std::vector<double> sizes = AvalanchesBetweenUnclogs(events, -1, cuts, end);
      for (std::size_t o = 0; o < run.outlets.size(); ++o) {
        per_outlet.push_back(JsonNumbers(AvalanchesBetweenUnclogs(events, static_cast<int>(o), cuts, end)));
        labels.push_back(run.outlets[o].label);
      }
      result_ = {{"sizes", JsonNumbers(sizes)},
                 {"clogs", cuts.size() + (end == RunEnd::kClogged ? 1 : 0)},
                 {"unclogs", cuts.size()},
                 {"per_outlet", per_outlet},
                 {"outlets", labels}};
      return;
    }
    const ClogSeries all = ComputeClogSeries(events, -1, run.t_end, run.clog_gap, end, run.stop_on_clog);
    for (std::size_t o = 0; o < run.outlets.size(); ++o) {
      // A run that stopped on a clog stopped with every outlet blocked; one that discharged,
      // with every outlet open.
      per_outlet.push_back(
          JsonNumbers(ComputeClogSeries(events, static_cast<int>(o), run.t_end, run.clog_gap, end).AvalancheSizes()));
      labels.push_back(run.outlets[o].label);
    }
    result_ = {{"sizes", JsonNumbers(all.AvalancheSizes())},
               {"clogs", all.clogged.size()},
               {"per_outlet", per_outlet},
               {"outlets", labels}};
  }
  nlohmann::json Finish() override { return result_; }

 private:
  nlohmann::json result_;
};

std::string SizeName(std::size_t k) { return "avalanche_size" + OutletSuffix(k); }

class AvalancheAnalysis : public Analysis {
 public:
  std::string Key() const override { return "avalanches"; }
  int Version() const override { return 3; }
  PassUse PassOptionsUsed() const override { return {.window = false, .clog_gap = true, .frames = false}; }
  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    return std::make_unique<AvalancheAccumulator>(run);
  }
  std::vector<Metric> RunMetrics(const nlohmann::json& result) const override {
    const std::vector<double> sizes = NumbersOf(result.at("sizes"));
    const MeanSe s = MeanAndSe(sizes);
    std::vector<Metric> m = {{"avalanche_size", "bodies", s.mean, s.se, "mean avalanche size", true},
                             {"avalanches", "avalanches", static_cast<double>(sizes.size()), kNaN, "avalanches", false},
                             {"clogs", "clogs", NumberAt(result, "clogs"), kNaN, "clogs in the exit stream", true}};
    const nlohmann::json& per_outlet = result.at("per_outlet");
    if (per_outlet.size() > 1)
      for (std::size_t k = 0; k < per_outlet.size(); ++k) {
        const std::vector<double> so = NumbersOf(per_outlet[k]);
        const MeanSe x = MeanAndSe(so);
        const std::string where = result.at("outlets").at(k).get<std::string>();
        m.push_back({SizeName(k), "bodies", x.mean, x.se, "mean avalanche size at " + where, false});
        m.push_back({"avalanches" + OutletSuffix(k), "avalanches", static_cast<double>(so.size()), kNaN,
                     "avalanches at " + where, false});
      }
    return m;
  }
  // Sizes pooled over every avalanche of every replica (n = avalanches), per outlet too.
  std::vector<PointMetric> PointMetrics(const AnalysisResults& results, std::size_t point) const override {
    const std::vector<const nlohmann::json*> runs = results.OfPoint(point);
    if (runs.empty()) return {};
    std::vector<double> all;
    std::vector<std::vector<double>> per_outlet;
    std::vector<std::string> labels;
    std::vector<double> clogs;
    for (const nlohmann::json* r : runs) {
      for (double s : NumbersOf(r->at("sizes"))) all.push_back(s);
      clogs.push_back(NumberAt(*r, "clogs"));
      const nlohmann::json& po = r->at("per_outlet");
      for (std::size_t k = 0; k < po.size(); ++k) {
        if (per_outlet.size() <= k) {
          per_outlet.emplace_back();
          labels.push_back(r->at("outlets").at(k).get<std::string>());
        }
        for (double s : NumbersOf(po[k])) per_outlet[k].push_back(s);
      }
    }
    const MeanSe s = MeanAndSe(all), c = MeanSeFinite(clogs);
    std::vector<PointMetric> m = {{"avalanche_size", "bodies", s.mean, s.se, s.n, "mean avalanche size", true, ""},
                                  {"clogs", "clogs", c.mean, c.se, c.n, "clogs in the exit stream per run", true, ""}};
    if (per_outlet.size() > 1)
      for (std::size_t k = 0; k < per_outlet.size(); ++k) {
        const MeanSe x = MeanAndSe(per_outlet[k]);
        m.push_back({SizeName(k), "bodies", x.mean, x.se, x.n, "mean avalanche size at " + labels[k], false, ""});
      }
    return m;
  }
  std::optional<Section> BuildSection(const SectionInput& in) const override;
  // Every avalanche's size (thesis figs. 4.7, 6.7: P(s)); its mean is the metric avalanche_size.
  std::vector<DistributionInfo> DistributionNames() const override {
    return {{"avalanche_sizes", "avalanche size s", "bodies"}};
  }
  Samples Distribution(const std::string& name, const nlohmann::json& result) const override {
    if (name != "avalanche_sizes" || !result.contains("sizes")) return {};
    return {NumbersOf(result.at("sizes")), {}};
  }
};

std::optional<Section> AvalancheAnalysis::BuildSection(const SectionInput& in) const {
  const CampaignView& v = in.view;
  auto metric = [&](std::size_t p, const std::string& name) {
    const PointMetric* m = FindMetric(in.points[p], name);
    return m ? m->Estimate() : MeanSe{};
  };
  bool any = false, any_per_outlet = false;
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    any = any || metric(p, "avalanche_size").n > 0;
    for (std::size_t k = 0; k < v.outlets; ++k) any_per_outlet = any_per_outlet || metric(p, SizeName(k)).n > 0;
  }
  if (!any && !(v.outlets > 1 && any_per_outlet)) return std::nullopt;
  Section s{"avalanches", "Avalanche sizes (ch. 4, 6)", {}};
  s.blocks.push_back(
      Text{"An avalanche is the number of bodies that leave between the opening (or an unclog) and a "
           "clog; a clog is a gap of at least the run's clog_window in the exit stream of all outlets "
           "together, or the engine's own stop on a clog. A stretch still flowing when a run ended is "
           "not an avalanche. The tail fit is the maximum-likelihood geometric law P(s) ~ "
           "exp(-s/s_decay) for s above the median."});
  Table t{"avalanches",
          "Avalanche statistics per point (pooled over replicas)",
          {"point", "<s> ± se (avalanches)", "tail from s", "s_decay", "s_decay se", "tail n", "note"},
          {},
          {"point", "avalanche_size", "tail_from", "s_decay", "s_decay_se", "tail_n", "note"}};
  Figure dist{"avalanche_distribution",
              "Avalanche size distribution",
              "s (bodies)",
              "probability density",
              {},
              false,
              true,
              "Pooled over replicas; at most 6 points drawn (all in the table and CSVs)"};
  int colour = 0;
  // The distribution figure shows at most 6 points, spread over the list, to stay legible;
  // the table and the CSVs have them all.
  std::vector<std::size_t> with_avalanches;
  for (std::size_t p = 0; p < v.points.size(); ++p)
    if (metric(p, "avalanche_size").n > 0) with_avalanches.push_back(p);
  std::set<std::size_t> drawn;
  constexpr std::size_t kMaxDrawn = 6;
  for (std::size_t k = 0; k < std::min(kMaxDrawn, with_avalanches.size()); ++k)
    drawn.insert(with_avalanches[k * with_avalanches.size() / std::min(kMaxDrawn, with_avalanches.size())]);
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    std::vector<double> sizes;
    for (const nlohmann::json* r : in.results.OfPoint(p))
      for (double x : NumbersOf(r->at("sizes"))) sizes.push_back(x);
    if (sizes.empty()) continue;
    const AvalancheStats st = ComputeAvalancheStats(sizes);
    const std::string name = PointName(v, v.points[p]);
    t.rows.push_back({name, Cell::Estimate(st.size), Cell::Number(st.tail.s_min), Cell::Number(st.tail.s_decay),
                      Cell::Number(st.tail.s_decay_se, 2), Cell::Count(st.tail.n_tail),
                      st.size.n < kThesisAvalanches ? "fewer than " + std::to_string(kThesisAvalanches) +
                                                          " avalanches (the thesis averages >= 100)"
                                                    : ""});
    if (!drawn.count(p)) continue;
    Series se;
    se.label = name;
    se.columns = {"s", "density", "count"};
    se.style = Series::Style::kPoints;
    for (std::size_t i = 0; i < st.histogram.counts.size(); ++i)
      if (st.histogram.counts[i] > 0)
        se.rows.push_back({st.histogram.Center(i), st.histogram.Density(i), st.histogram.counts[i]});
    se.color = colour;
    dist.series.push_back(se);
    // The fitted tail drawn on the same density scale: (n_tail / n) (1 - q) q^(s - s_min).
    if (std::isfinite(st.tail.q) && st.size.n > 0) {
      Series tail;
      tail.label = "tail fit, " + name;
      tail.columns = {"s", "density_fit"};
      tail.style = Series::Style::kLines;
      tail.role = Series::Role::kFit;
      tail.color = colour;
      const double norm = static_cast<double>(st.tail.n_tail) / st.size.n * (1.0 - st.tail.q);
      for (std::size_t i = 0; i < st.histogram.counts.size(); ++i) {
        const double sv = st.histogram.Center(i);
        if (sv >= st.tail.s_min) tail.rows.push_back({sv, norm * std::pow(st.tail.q, sv - st.tail.s_min)});
      }
      if (!tail.rows.empty()) dist.series.push_back(tail);
    }
    ++colour;
  }
  if (!t.rows.empty()) s.blocks.push_back(t);
  if (HasX(v) && any)
    s.blocks.push_back(Figure{"avalanche_mean", "Mean avalanche size against " + v.x_label, v.x_label, "<s> (bodies)",
                              PointSeries(v, in.points, "avalanche_size", "s_mean"), false, false,
                              "Error bars: standard error over avalanches"});
  if (!dist.series.empty()) s.blocks.push_back(dist);
  if (v.outlets > 1 && any_per_outlet) {
    // Several outlets: the exit stream of each outlet on its own (ch. 7: the small outlet
    // clogs and unclogs while the large one keeps the silo flowing).
    s.blocks.push_back(
        Text{"Per outlet: the same rule applied to each outlet's own exit stream (gaps counted from "
             "the first exit through any outlet), so an outlet that clogs while another keeps flowing "
             "has avalanches too."});
    Table po{"avalanches_per_outlet",
             "Avalanche sizes per point and outlet (pooled over replicas)",
             {"point", "outlet", "<s> ± se (avalanches)"},
             {},
             {"point", "outlet", "avalanche_size"}};
    for (std::size_t p = 0; p < v.points.size(); ++p)
      for (std::size_t k = 0; k < v.outlets; ++k) {
        if (!FindMetric(in.points[p], SizeName(k))) continue;
        const MeanSe m = metric(p, SizeName(k));
        po.rows.push_back({PointName(v, v.points[p]), k < v.outlet_labels.size() ? v.outlet_labels[k] : "",
                           m.n > 0 ? Cell::Estimate(m) : Cell("no avalanche")});
      }
    s.blocks.push_back(po);
    if (HasX(v))
      s.blocks.push_back(Figure{"avalanche_mean_per_outlet", "Mean avalanche size per outlet against " + v.x_label,
                                v.x_label, "<s> (bodies)",
                                OutletSeries(v, in.points, SizeName, v.outlet_labels, "s_mean"), false, false,
                                "Error bars: standard error over avalanches"});
  }
  return s;
}

}  // namespace

std::unique_ptr<Analysis> MakeAvalancheAnalysis(const nlohmann::json& options, const std::string& path) {
  if (!options.is_null()) OptionObject(options, path, {});
  return std::make_unique<AvalancheAnalysis>();
}

}  // namespace granary::analysis
