// See clogging_index_analysis.h; Psi itself is clogging_index (clogging.h).
#include "analysis/clogging_index_analysis.h"

#include <cmath>

#include "analysis/campaign_view.h"
#include "analysis/clogging.h"
#include "analysis/options.h"

namespace granary::analysis {
namespace {

const char* EndName(RunEnd e) {
  return e == RunEnd::kClogged ? "clogged" : e == RunEnd::kDischarged ? "discharged" : "neither";
}

// How a remove-mode run ended for eq. 3.1. A run that stopped at its time limit (or was cut
// short) while still flowing did neither: its N_undis is what was left when time ran out, not
// a clogged count nor the stagnant zones. A run whose engine kept going after a clog
// (stop_on_clog false) and reached the limit still sealed ended clogged all the same.
class ClogRunAccumulator : public RunAccumulator {
 public:
  explicit ClogRunAccumulator(const RunView& run) {
    result_ = {{"remove_mode", run.remove_mode}};
    if (!run.remove_mode) return;
    if (run.on_clog == "unclog") {
      // Eq. 3.1 is of runs that stop at their first clog; one that broke its clogs has none.
      result_["unclog"] = true;
      result_["notes"] = {"clogging index: left out: the engine broke its clogs (on_clog \"unclog\")"};
      return;
    }
    RunEnd end = RunEndOf(run.end_reason);
    nlohmann::json notes = nlohmann::json::array();
    const std::string at =
        "t = " + FormatNumber(run.t_end) + " with " + std::to_string(run.undischarged) + " bodies inside";
    if (end == RunEnd::kOther && !run.stop_on_clog && run.data) {
      const ClogSeries s = ComputeClogSeries(run.data->events, -1, run.t_end, run.clog_gap, RunEnd::kOther);
      const bool ends_in_a_gap = !s.clogged.empty() && !s.clogged.back().complete;
      if (ends_in_a_gap && run.data->summary.clogs.value_or(0) > 0) {
        end = RunEnd::kClogged;
        notes.push_back("clogging index: counted as clogged: it was still clogged at " + at +
                        " (the engine does not stop at clogs)");
      }
    }
    if (end == RunEnd::kOther)
      notes.push_back("clogging index: left out: it ended (" +
                      (run.end_reason.empty() ? std::string("no end reason") : run.end_reason) + ") at " + at +
                      ", neither clogged nor discharged");
    result_["end"] = EndName(end);
    result_["bodies"] = run.bodies;
    result_["exited"] = run.exited;
    result_["undischarged"] = run.undischarged;
    result_["notes"] = notes;
  }
  nlohmann::json Finish() override { return result_; }

 private:
  nlohmann::json result_;
};

std::optional<ClogRun> ClogRunOf(const nlohmann::json& r) {
  if (!r.is_object() || !r.value("remove_mode", false) || r.value("unclog", false)) return std::nullopt;
  const std::string end = r.value("end", std::string());
  return ClogRun{end == "clogged"      ? RunEnd::kClogged
                 : end == "discharged" ? RunEnd::kDischarged
                                       : RunEnd::kOther,
                 r.value("bodies", 0), r.value("undischarged", 0), r.value("exited", 0)};
}

// N_u of eq. 3.1 from the runs that discharged: their mean N_undis and how many, or n = 0.
MeanSe StagnantCount(const std::vector<const nlohmann::json*>& runs) {
  std::vector<double> left;
  for (const nlohmann::json* r : runs)
    if (const auto c = ClogRunOf(*r); c && c->end == RunEnd::kDischarged) left.push_back(c->undischarged);
  return MeanAndSe(left);
}

std::string ReplicasText(const std::vector<int>& replicas) {
  std::string s = replicas.size() == 1 ? "replica " : "replicas ";
  for (std::size_t k = 0; k < replicas.size(); ++k) s += (k ? ", " : "") + std::to_string(replicas[k]);
  return s;
}

class ClogIndexAnalysis : public Analysis {
 public:
  std::string Key() const override { return "clogging_index"; }
  int Version() const override { return 2; }
  PassUse PassOptionsUsed() const override { return {.window = false, .clog_gap = true, .frames = false}; }
  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    return std::make_unique<ClogRunAccumulator>(run);
  }
  std::vector<Metric> RunMetrics(const nlohmann::json& result) const override {
    const auto c = ClogRunOf(result);
    if (!c) return {};
    return {{"clogged", "1", c->end == RunEnd::kClogged ? 1.0 : 0.0, kNaN, "clogged (1) or not (0)", false},
            {"undischarged", "bodies", static_cast<double>(c->undischarged), kNaN, "bodies left in the silo", false}};
  }

  // Psi of the point over its runs that clogged or discharged. N_u from the point's
  // discharged runs; when it has none (every run clogged: narrow outlets; or ran out of time),
  // from the discharged runs of its group (same silo, other widths), else of the whole
  // campaign, else missing. The note says which runs were used and which were left out.
  std::vector<PointMetric> PointMetrics(const AnalysisResults& results, std::size_t point) const override {
    const CampaignView& v = *results.view;
    // The same rule as the flow window's start-up clogs: one threshold for both.
    const int min_exits = results.pass.window.min_exits_before_clog;
    std::vector<ClogRun> clog_runs;
    std::vector<int> early, neither;
    for (std::size_t u : v.points[point].runs) {
      if (u >= results.runs.size()) continue;
      const auto c = ClogRunOf(results.runs[u]);
      if (!c) continue;
      clog_runs.push_back(*c);
      const int replica = v.used[u].record ? v.used[u].record->replica : 0;
      if (c->end == RunEnd::kOther) neither.push_back(replica);
      if (c->end == RunEnd::kClogged && c->exited < min_exits) early.push_back(replica);
    }
    if (clog_runs.empty()) return {};
    const MeanSe own = StagnantCount(results.OfPoint(point));
    double stagnant = -1.0;
    std::string source;
    if (own.n > 0) {
      source = "the point's " + std::to_string(own.n) + " discharged run" + (own.n == 1 ? "" : "s");
    } else {
      const std::string& group = v.points[point].group;
      std::vector<const nlohmann::json*> in_group, all;
      for (std::size_t p = 0; p < v.points.size(); ++p)
        for (const nlohmann::json* r : results.OfPoint(p)) {
          all.push_back(r);
          if (v.points[p].group == group) in_group.push_back(r);
        }
      const MeanSe g = StagnantCount(in_group);
      const MeanSe a = StagnantCount(all);
      const MeanSe& from = g.n > 0 ? g : a;
      if (from.n > 0) {
        stagnant = from.mean;
        source = "the " + std::to_string(from.n) + " discharged run" + (from.n == 1 ? "" : "s") + " of " +
                 (g.n > 0 && !group.empty() ? group : std::string("the campaign"));
      }
    }
    const ClogIndex ci = CloggingIndex(clog_runs, min_exits, stagnant);
    std::string note = "used " + std::to_string(ci.clogged) + " clogged and " + std::to_string(ci.discharged) +
                       " discharged run" + (ci.clogged + ci.discharged == 1 ? "" : "s");
    if (!early.empty())
      note += "; left out " + ReplicasText(early) + ": clogged before " + std::to_string(min_exits) + " exits";
    if (!neither.empty())
      note += "; left out " + ReplicasText(neither) + ": neither clogged nor discharged (time limit)";
    note += source.empty() ? "; " + ci.note : "; N_u from " + source;
    return {
        {"psi", "1", ci.psi.mean, ci.psi.se, ci.psi.n, "clogging index Psi", true, note},
        {"n_stagnant", "bodies", ci.n_stagnant, kNaN, ci.psi.n, "N_u (stagnant bodies)", false, note},
        {"clogged_runs", "runs", static_cast<double>(ci.clogged), kNaN, static_cast<int>(clog_runs.size()),
         "clogged runs", false, "", false},
        {"discharged_runs", "runs", static_cast<double>(ci.discharged), kNaN, static_cast<int>(clog_runs.size()),
         "discharged runs", false, "", false},
        {"discarded_runs", "runs", static_cast<double>(ci.discarded), kNaN, static_cast<int>(clog_runs.size()),
         "runs discarded (clogged too early)", false, "", false},
        {"unfinished_runs", "runs", static_cast<double>(ci.unfinished), kNaN, static_cast<int>(clog_runs.size()),
         "runs left out (neither clogged nor discharged)", false, "", false},
        {"psi_low", "1", ci.psi_low, kNaN, ci.unfinished, "Psi with the left-out runs as discharged", false, "", false},
        {"psi_high", "1", ci.psi_high, kNaN, ci.unfinished, "Psi with the left-out runs as clogged at their end", false,
         "", false}};
  }

  std::optional<Section> BuildSection(const SectionInput& in) const override {
    const CampaignView& v = in.view;
    bool any = false;
    for (const auto& m : in.points)
      if (const PointMetric* c = FindMetric(m, "clogged_runs")) any = any || c->mean > 0;
    if (!any) return std::nullopt;
    Section s{"clogging-index", "Clogging index Psi (ch. 3, eq. 3.1)", {}};
    s.blocks.push_back(Text{
        "Psi = (1/n) sum_i (N_undis,i - N_u) / (N_total - N_u) over the point's runs that clogged or discharged, N_u "
        "the mean number left by runs that discharged (the stagnant zones): the point's own, else those of its group "
        "(same silo, other widths), else of the campaign; without any, N_u and Psi are missing. Runs that clogged "
        "before " +
        std::to_string(in.pass.window.min_exits_before_clog) +
        " bodies left are discarded (/report/window/min_exits_before_clog, as for the flow window). A run that reached its time limit still "
        "flowing neither clogged nor discharged: it is left out, and 'range' gives Psi with those runs counted as if "
        "they had discharged afterwards (low) or clogged at their end (high)."});
    Table t{"clogging_index",
            "Clogging index per point: which runs it used, and why others were left out",
            {"point", "Psi", "clogged runs", "discharged runs", "discarded", "left out (time limit)", "N_u",
             "range with left-out runs", "note"},
            {},
            {"point", "psi", "clogged_runs", "discharged_runs", "discarded_runs", "unfinished_runs", "n_stagnant",
             "psi_range", "note"}};
    for (std::size_t p = 0; p < v.points.size(); ++p) {
      const PointMetric* psi = FindMetric(in.points[p], "psi");
      if (!psi) continue;
      auto count = [&](const char* name) {
        const PointMetric* m = FindMetric(in.points[p], name);
        return m ? m->mean : kNaN;
      };
      const double low = count("psi_low"), high = count("psi_high");
      const std::string range = std::isfinite(low) ? FormatNumber(low) + " .. " + FormatNumber(high) : "";
      t.rows.push_back({PointName(v, v.points[p]), Cell::Estimate(psi->Estimate()), Cell::Number(count("clogged_runs")),
                        Cell::Number(count("discharged_runs")), Cell::Number(count("discarded_runs")),
                        Cell::Number(count("unfinished_runs")), Cell::Number(count("n_stagnant")), range, psi->note});
    }
    s.blocks.push_back(t);
    if (HasX(v))
      s.blocks.push_back(Figure{"clogging_index", "Clogging index Psi against " + v.x_label, v.x_label, "Psi",
                                PointSeries(v, in.points, "psi", "Psi"), false, false, "Error bars: se over replicas"});
    return s;
  }
};

}  // namespace

std::unique_ptr<Analysis> MakeCloggingIndexAnalysis(const nlohmann::json& options, const std::string& path) {
  // Its discard rule is the flow window's start-up clog rule: one threshold, one place.
  if (options.is_object() && options.contains("min_exits_before_clog"))
    throw OptionError(path + "/min_exits_before_clog", options.at("min_exits_before_clog"),
                      "moved to /report/window/min_exits_before_clog");
  if (!options.is_null()) OptionObject(options, path, {});
  return std::make_unique<ClogIndexAnalysis>();
}

}  // namespace granary::analysis
