// See intermittency_analysis.h; the stretches and their statistics are clogging.h.
#include "analysis/intermittency_analysis.h"

#include <cmath>
#include <map>

#include "analysis/campaign_view.h"
#include "analysis/clogging.h"
#include "analysis/options.h"

namespace granary::analysis {
namespace {

nlohmann::json StretchesJson(const std::vector<Stretch>& stretches) {
  nlohmann::json out = nlohmann::json::array();
  for (const Stretch& s : stretches) out.push_back({s.start, s.end, s.exits, s.complete});
  return out;
}

std::vector<Stretch> StretchesOf(const nlohmann::json& j) {
  std::vector<Stretch> out;
  for (const auto& s : j)
    out.push_back({s.at(0).get<double>(), s.at(1).get<double>(), s.at(2).get<int>(), s.at(3).get<bool>()});
  return out;
}

std::vector<ClogSeries> SeriesOf(const nlohmann::json& result) {
  std::vector<ClogSeries> out;
  for (const auto& j : result.at("series")) {
    ClogSeries s;
    s.flowing = StretchesOf(j.at("flowing"));
    s.clogged = StretchesOf(j.at("clogged"));
    s.t_end = j.at("t_end").get<double>();
    out.push_back(std::move(s));
  }
  return out;
}

class IntermittencyAccumulator : public RunAccumulator {
 public:
  explicit IntermittencyAccumulator(const RunView& run) {
    const RunEnd end = RunEndOf(run.end_reason);
    result_ = {{"outlets", nlohmann::json::array()}, {"series", nlohmann::json::array()}};
    for (std::size_t o = 0; o < run.outlets.size(); ++o) {
      const ClogSeries s = ComputeClogSeries(run.data->events, static_cast<int>(o), run.t_end, run.clog_gap, end);
      result_["outlets"].push_back(run.outlets[o].label);
      result_["series"].push_back(
          {{"flowing", StretchesJson(s.flowing)}, {"clogged", StretchesJson(s.clogged)}, {"t_end", s.t_end}});
    }
  }
  nlohmann::json Finish() override { return result_; }

 private:
  nlohmann::json result_;
};

// Metric names of outlet k: without a suffix when the run has one outlet.
std::string Name(const std::string& base, std::size_t k, std::size_t outlets) {
  return outlets > 1 ? base + OutletSuffix(k) : base;
}

std::vector<PointMetric> StatsMetrics(const IntermittencyStats& st, std::size_t k, std::size_t outlets,
                                      const std::string& where, int runs) {
  const std::string at = outlets > 1 ? " at " + where : "";
  return {{Name("t_flowing", k, outlets), "sqrt(d/g)", st.t_flowing.mean, st.t_flowing.se, st.t_flowing.n,
           "<t_f> flowing time" + at, false, ""},
          {Name("t_clogged", k, outlets), "sqrt(d/g)", st.t_clogged.mean, st.t_clogged.se, st.t_clogged.n,
           "<t_c> clogged time" + at, false, ""},
          {Name("unclog_rate", k, outlets), "1/sqrt(d/g)", st.unclog_rate, kNaN, runs, "N_u unclogging rate" + at,
           false, ""}};
}

class IntermittencyAnalysis : public Analysis {
 public:
  std::string Key() const override { return "intermittency"; }
  int Version() const override { return 1; }
  PassUse PassOptionsUsed() const override { return {.window = false, .clog_gap = true, .frames = false}; }
  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    return std::make_unique<IntermittencyAccumulator>(run);
  }
  std::vector<Metric> RunMetrics(const nlohmann::json& result) const override {
    std::vector<Metric> m;
    const std::vector<ClogSeries> series = SeriesOf(result);
    for (std::size_t k = 0; k < series.size(); ++k) {
      const IntermittencyStats st = Intermittency(std::span<const ClogSeries>(&series[k], 1));
      for (const PointMetric& p : StatsMetrics(st, k, series.size(), result.at("outlets").at(k).get<std::string>(), 1))
        m.push_back({p.name, p.unit, p.mean, p.se, p.title, false});
    }
    return m;
  }
  // Stretches pooled over replicas (n = stretches); N_u over the replicas' total time.
  std::vector<PointMetric> PointMetrics(const AnalysisResults& results, std::size_t point) const override {
    std::vector<std::vector<ClogSeries>> by_outlet;
    std::vector<std::string> labels;
    const std::vector<const nlohmann::json*> runs = results.OfPoint(point);
    for (const nlohmann::json* r : runs) {
      const std::vector<ClogSeries> series = SeriesOf(*r);
      for (std::size_t k = 0; k < series.size(); ++k) {
        if (by_outlet.size() <= k) {
          by_outlet.emplace_back();
          labels.push_back(r->at("outlets").at(k).get<std::string>());
        }
        by_outlet[k].push_back(series[k]);
      }
    }
    std::vector<PointMetric> m;
    for (std::size_t k = 0; k < by_outlet.size(); ++k) {
      const IntermittencyStats st = Intermittency(by_outlet[k]);
      for (PointMetric& p : StatsMetrics(st, k, by_outlet.size(), labels[k], static_cast<int>(by_outlet[k].size()))) {
        if (p.name.rfind("unclog_rate", 0) == 0)
          p.note = std::to_string(st.unclogs) + " unclogs in " + FormatNumber(st.observed_time);
        m.push_back(p);
      }
    }
    return m;
  }
  std::optional<Section> BuildSection(const SectionInput& in) const override;
};

std::optional<Section> IntermittencyAnalysis::BuildSection(const SectionInput& in) const {
  const CampaignView& v = in.view;
  bool any = false;
  for (const nlohmann::json& r : in.results.runs)
    if (!r.is_null())
      for (const ClogSeries& s : SeriesOf(r)) any = any || s.Unclogs() > 0;
  if (!any) return std::nullopt;
  Section s{"intermittency", "Flowing and clogged times per outlet (ch. 7)", {}};
  s.blocks.push_back(
      Text{"From the exit stream of each outlet: a gap of at least clog_window is a clog (t_c from the "
           "last exit before it to the first after it); a flowing stretch runs from the opening or an "
           "unclog to the last exit before a clog (t_f). Censored stretches (the run ended) are left "
           "out of the means. N_u = unclogging events per unit time, over the replicas' total time."});
  Table t{"intermittency",
          "t_f, t_c and N_u per point and outlet (pooled over replicas)",
          {"point", "outlet", "<t_f> ± se (n)", "<t_c> ± se (n)", "N_u (1/sqrt(d/g))", "unclogs", "time"},
          {},
          {"point", "outlet", "t_flowing", "t_clogged", "unclog_rate", "unclogs", "time"}};
  // Figures against the x axis: one series per (group, outlet).
  Figure times{"intermittency_times",
               "Mean flowing and clogged times against " + v.x_label,
               v.x_label,
               "<t_f>, <t_c> (sqrt(d/g))",
               {},
               false,
               false,
               "Error bars: se over stretches pooled over replicas"};
  Figure rate{"unclogging_rate",
              "Unclogging rate N_u against " + v.x_label,
              v.x_label,
              "N_u (1/sqrt(d/g))",
              {},
              false,
              false,
              "Unclogging events per unit time over the replicas' total time"};
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
  for (std::size_t pi = 0; pi < v.points.size(); ++pi) {
    const Point& p = v.points[pi];
    std::vector<std::vector<ClogSeries>> by_outlet;
    std::vector<std::string> labels;
    for (const nlohmann::json* r : in.results.OfPoint(pi)) {
      const std::vector<ClogSeries> series = SeriesOf(*r);
      for (std::size_t k = 0; k < series.size(); ++k) {
        if (by_outlet.size() <= k) {
          by_outlet.emplace_back();
          labels.push_back("outlet " + std::to_string(k));
        }
        by_outlet[k].push_back(series[k]);
        labels[k] = r->at("outlets").at(k).get<std::string>();
      }
    }
    for (std::size_t o = 0; o < by_outlet.size(); ++o) {
      const IntermittencyStats st = Intermittency(by_outlet[o]);
      const std::string& label = labels[o];
      t.rows.push_back({PointName(v, p), label, Cell::Estimate(st.t_flowing), Cell::Estimate(st.t_clogged),
                        Cell::Number(st.unclog_rate), Cell::Count(st.unclogs), Cell::Number(st.observed_time)});
      if (!std::isfinite(p.x)) continue;
      const std::string key = label + (p.group.empty() ? "" : ", " + p.group);
      const std::string xname = v.x_name;
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
  if (HasX(v)) {
    if (!times.series.empty()) s.blocks.push_back(times);
    if (!rate.series.empty()) s.blocks.push_back(rate);
  }
  return s;
}

}  // namespace

std::unique_ptr<Analysis> MakeIntermittencyAnalysis(const nlohmann::json& options, const std::string& path) {
  if (!options.is_null()) OptionObject(options, path, {});
  return std::make_unique<IntermittencyAnalysis>();
}

}  // namespace granary::analysis
