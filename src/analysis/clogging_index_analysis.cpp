// See clogging_index_analysis.h; Psi itself is clogging_index (clogging.h).
#include "analysis/clogging_index_analysis.h"

#include <cmath>

#include "analysis/campaign_view.h"
#include "analysis/clogging.h"
#include "analysis/options.h"

namespace granary::analysis {
namespace {

class ClogRunAccumulator : public RunAccumulator {
 public:
  explicit ClogRunAccumulator(const RunView& run) {
    result_ = {{"remove_mode", run.remove_mode}};
    if (!run.remove_mode) return;
    result_["clogged"] = run_end_of(run.end_reason) == RunEnd::kClogged;
    result_["bodies"] = run.bodies;
    result_["exited"] = run.exited;
    result_["undischarged"] = run.undischarged;
  }
  nlohmann::json finish() override { return result_; }

 private:
  nlohmann::json result_;
};

std::optional<ClogRun> clog_run_of(const nlohmann::json& r) {
  if (!r.value("remove_mode", false)) return std::nullopt;
  return ClogRun{r.value("clogged", false), r.value("bodies", 0), r.value("undischarged", 0), r.value("exited", 0)};
}

// N_u of eq. 3.1: the mean number left by the runs that discharged without clogging, or -1.
double stagnant_count(const std::vector<const nlohmann::json*>& runs) {
  std::vector<double> left;
  for (const nlohmann::json* r : runs)
    if (const auto c = clog_run_of(*r); c && !c->clogged) left.push_back(c->undischarged);
  return left.empty() ? -1.0 : mean_se(left).mean;
}

class ClogIndexAnalysis : public Analysis {
 public:
  explicit ClogIndexAnalysis(int min_exits) : min_exits_(min_exits) {}
  std::string key() const override { return "clogging_index"; }
  int version() const override { return 1; }
  std::unique_ptr<RunAccumulator> start(const RunView& run) const override {
    return std::make_unique<ClogRunAccumulator>(run);
  }
  std::vector<Metric> run_metrics(const nlohmann::json& result) const override {
    const auto c = clog_run_of(result);
    if (!c) return {};
    return {{"clogged", "1", c->clogged ? 1.0 : 0.0, kNaN, "clogged (1) or not (0)", false},
            {"undischarged", "bodies", static_cast<double>(c->undischarged), kNaN, "bodies left in the silo", false}};
  }

  // Psi of the point; when none of its runs discharged freely (every run clogged: narrow
  // outlets), N_u from the freely discharging runs of its group (same silo, other widths),
  // else of the whole campaign.
  std::vector<PointMetric> point_metrics(const AnalysisResults& results, std::size_t point) const override {
    const std::vector<const nlohmann::json*> runs = results.of_point(point);
    std::vector<ClogRun> clog_runs;
    for (const nlohmann::json* r : runs)
      if (const auto c = clog_run_of(*r)) clog_runs.push_back(*c);
    if (clog_runs.empty()) return {};
    double fallback = -1.0;
    std::string note;
    if (stagnant_count(runs) < 0.0) {
      const CampaignView& v = *results.view;
      const std::string& group = v.points[point].group;
      std::vector<const nlohmann::json*> in_group, all;
      for (std::size_t p = 0; p < v.points.size(); ++p)
        for (const nlohmann::json* r : results.of_point(p)) {
          all.push_back(r);
          if (v.points[p].group == group) in_group.push_back(r);
        }
      fallback = stagnant_count(in_group);
      if (fallback >= 0.0) {
        note = "every run clogged: N_u from the freely discharging runs of " + (group.empty() ? std::string("the campaign") : group);
      } else {
        fallback = stagnant_count(all);
        if (fallback >= 0.0) note = "every run clogged: N_u from the campaign's freely discharging runs";
      }
    }
    const ClogIndex ci = clogging_index(clog_runs, min_exits_, fallback);
    if (note.empty()) note = ci.note;
    return {{"psi", "1", ci.psi.mean, ci.psi.se, ci.psi.n, "clogging index Psi", true, note},
            {"n_stagnant", "bodies", ci.n_stagnant, kNaN, ci.psi.n, "N_u (stagnant bodies)", false, note},
            {"clogged_runs", "runs", static_cast<double>(ci.clogged), kNaN, static_cast<int>(clog_runs.size()),
             "clogged runs", false, "", false},
            {"discarded_runs", "runs", static_cast<double>(ci.discarded), kNaN, static_cast<int>(clog_runs.size()),
             "runs discarded (clogged too early)", false, "", false}};
  }

  std::optional<Section> section(const SectionInput& in) const override {
    const CampaignView& v = in.view;
    bool any = false;
    for (const auto& m : in.points)
      if (const PointMetric* c = find_metric(m, "clogged_runs")) any = any || c->mean > 0;
    if (!any) return std::nullopt;
    Section s{"clogging-index", "Clogging index Psi (ch. 3, eq. 3.1)", {}};
    s.blocks.push_back(Text{"Psi = (1/n) sum_i (N_undis,i - N_u) / (N_total - N_u), N_u the mean number left in the "
                            "point's runs that did not clog (stagnant zones). Runs that clogged before " +
                            std::to_string(min_exits_) + " bodies left are discarded."});
    Table t{"clogging_index", "Clogging index per point",
            {"point", "Psi", "clogged runs", "discarded", "N_u", "note"}, {},
            {"point", "psi", "clogged_runs", "discarded_runs", "n_stagnant", "note"}};
    for (std::size_t p = 0; p < v.points.size(); ++p) {
      const PointMetric* psi = find_metric(in.points[p], "psi");
      if (!psi) continue;
      const PointMetric* clogged = find_metric(in.points[p], "clogged_runs");
      const PointMetric* discarded = find_metric(in.points[p], "discarded_runs");
      const PointMetric* nu = find_metric(in.points[p], "n_stagnant");
      if (psi->n == 0 && discarded->mean == 0) continue;
      t.rows.push_back({point_name(v, v.points[p]), Cell::estimate(psi->estimate()), Cell::number(clogged->mean),
                        Cell::number(discarded->mean), Cell::number(nu->mean), psi->note});
    }
    s.blocks.push_back(t);
    if (has_x(v))
      s.blocks.push_back(Figure{"clogging_index", "Clogging index Psi against " + v.x_label, v.x_label, "Psi",
                                point_series(v, in.points, "psi", "Psi"), false, false, "Error bars: se over replicas"});
    return s;
  }

 private:
  int min_exits_;
};

}  // namespace

std::unique_ptr<Analysis> make_clogging_index_analysis(const nlohmann::json& options, const std::string& path) {
  int min_exits = 100;  // ch. 3 discard rule
  if (!options.is_null()) {
    option_object(options, path, {"min_exits_before_clog"});
    if (options.contains("min_exits_before_clog"))
      min_exits = option_integer(options.at("min_exits_before_clog"), path + "/min_exits_before_clog", 0, 1000000000);
  }
  return std::make_unique<ClogIndexAnalysis>(min_exits);
}

}  // namespace granary::analysis
