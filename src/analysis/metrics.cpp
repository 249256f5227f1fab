// Implementation of metrics.h.
#include "analysis/metrics.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace granary::analysis {

double stagnant_count(const std::vector<const RunAnalysis*>& runs) {
  std::vector<double> left;
  for (const RunAnalysis* r : runs)
    if (r->remove_mode && !r->clog.clogged) left.push_back(r->clog.undischarged);
  return left.empty() ? -1.0 : mean_se(left).mean;
}

PointMetrics point_metrics(const PointRuns& p, const AnalysisOptions& options, double stagnant_fallback,
                           const std::string& fallback_note) {
  PointMetrics m;
  m.point_id = p.point_id;
  m.point = p.point;
  m.runs = static_cast<int>(p.runs.size());
  std::vector<double> q, qm, phi, t1, t2, vmax, avalanches;
  std::vector<ClogRun> clog_runs;
  bool remove_mode = false;
  for (const RunAnalysis* r : p.runs) {
    q.push_back(r->flow.ok ? r->flow.q_count : kNaN);
    qm.push_back(r->flow.ok ? r->flow.q_mass : kNaN);
    if (r->has_region) {
      phi.push_back(r->region.phi.mean);
      t1.push_back(r->region.tg_translational.mean);
      t2.push_back(r->region.tg_full.mean);
    }
    if (r->has_profile) vmax.push_back(r->profile.v_max);
    for (double s : r->series.avalanche_sizes()) avalanches.push_back(s);
    if (r->remove_mode) {
      remove_mode = true;
      clog_runs.push_back(r->clog);
    }
  }
  m.q_count = mean_se_finite(q);
  m.q_mass = mean_se_finite(qm);
  m.phi = mean_se_finite(phi);
  m.tg_translational = mean_se_finite(t1);
  m.tg_full = mean_se_finite(t2);
  m.v_max = mean_se_finite(vmax);
  m.avalanche_size = mean_se(avalanches);
  std::size_t outlets = 0;
  for (const RunAnalysis* r : p.runs) outlets = std::max(outlets, r->outlets.size());
  for (std::size_t o = 0; o < outlets; ++o) {
    OutletMetrics om;
    std::vector<double> oq, oqm, ophi, ot1, ot2, ovmax, oaval;
    std::vector<ClogSeries> series;
    for (const RunAnalysis* r : p.runs) {
      if (o >= r->outlets.size()) continue;
      om.label = r->outlets[o].label;
      if (o < r->flow_per_outlet.size()) {
        const FlowRate& f = r->flow_per_outlet[o];
        oq.push_back(f.ok ? f.q_count : kNaN);
        oqm.push_back(f.ok ? f.q_mass : kNaN);
      }
      if (o < r->region_per_outlet.size()) {
        ophi.push_back(r->region_per_outlet[o].phi.mean);
        ot1.push_back(r->region_per_outlet[o].tg_translational.mean);
        ot2.push_back(r->region_per_outlet[o].tg_full.mean);
      }
      if (o < r->profile_per_outlet.size()) ovmax.push_back(r->profile_per_outlet[o].v_max);
      if (o < r->series_per_outlet.size()) {
        series.push_back(r->series_per_outlet[o]);
        for (double s : r->series_per_outlet[o].avalanche_sizes()) oaval.push_back(s);
      }
    }
    om.q_count = mean_se_finite(oq);
    om.q_mass = mean_se_finite(oqm);
    om.phi = mean_se_finite(ophi);
    om.tg_translational = mean_se_finite(ot1);
    om.tg_full = mean_se_finite(ot2);
    om.v_max = mean_se_finite(ovmax);
    om.avalanche_size = mean_se(oaval);
    om.intermittency = intermittency(series);
    m.per_outlet.push_back(std::move(om));
  }
  if (remove_mode) {
    const bool own = stagnant_count(p.runs) >= 0.0;
    m.clogging = clogging_index(clog_runs, options.min_exits_before_clog, own ? -1.0 : stagnant_fallback);
    if (!own && stagnant_fallback >= 0.0) m.clogging.note = fallback_note;
  }
  return m;
}

std::vector<PointComparison> compare_points(const std::vector<PointMetrics>& a, const std::vector<PointMetrics>& b) {
  std::vector<PointComparison> out;
  for (const PointMetrics& pa : a) {
    const auto pb = std::find_if(b.begin(), b.end(), [&](const PointMetrics& x) { return x.point == pa.point; });
    if (pb == b.end()) continue;
    PointComparison c;
    c.point = pa.point;
    c.point_id_a = pa.point_id;
    c.point_id_b = pb->point_id;
    const std::pair<const char*, MeanSe PointMetrics::*> fields[] = {
        {"q_count", &PointMetrics::q_count}, {"q_mass", &PointMetrics::q_mass},
        {"phi", &PointMetrics::phi},         {"tg_translational", &PointMetrics::tg_translational},
        {"tg_full", &PointMetrics::tg_full}, {"v_max", &PointMetrics::v_max},
        {"avalanche_size", &PointMetrics::avalanche_size}};
    auto add = [&](const char* name, const MeanSe& ma, const MeanSe& mb) {
      if (!std::isfinite(ma.mean) || !std::isfinite(mb.mean)) return;
      MetricDifference d{name, ma, mb, ma.mean - mb.mean, std::hypot(ma.se, mb.se), kNaN};
      if (d.se > 0.0) d.z = d.difference / d.se;
      c.metrics.push_back(d);
    };
    for (const auto& [name, field] : fields) add(name, pa.*field, (*pb).*field);
    add("psi", pa.clogging.psi, pb->clogging.psi);
    out.push_back(std::move(c));
  }
  return out;
}

std::vector<PointMetrics> compute_point_metrics(const std::vector<RunRecord>& runs, const AnalysisOptions& options) {
  std::vector<std::string> order;
  std::map<std::string, nlohmann::json> points;
  std::map<std::string, std::vector<RunAnalysis>> analysed;
  for (const RunRecord& r : runs) {
    if (!points.count(r.point_id)) {
      order.push_back(r.point_id);
      points[r.point_id] = r.point;
      analysed[r.point_id];
    }
    if (r.state != "done") continue;
    try {
      analysed[r.point_id].push_back(analyse_run(r.run_dir, options));
    } catch (const std::exception&) {
      // unreadable run: left out of the point (the report lists it with the reason)
    }
  }
  std::vector<const RunAnalysis*> all;
  for (const auto& id : order)
    for (const auto& a : analysed[id]) all.push_back(&a);
  const double campaign_stagnant = stagnant_count(all);
  std::vector<PointMetrics> out;
  for (const auto& id : order) {
    PointRuns pr{id, points[id], {}};
    for (const auto& a : analysed[id]) pr.runs.push_back(&a);
    out.push_back(point_metrics(pr, options, campaign_stagnant, "N_u from the campaign's freely discharging runs"));
  }
  return out;
}

}  // namespace granary::analysis
