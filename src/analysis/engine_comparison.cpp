// See engine_comparison.h.
#include "analysis/engine_comparison.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

namespace granary::analysis {

std::vector<PointComparison> ComparePoints(const std::vector<EnginePoint>& a, const std::vector<EnginePoint>& b) {
  std::vector<PointComparison> out;
  for (const EnginePoint& pa : a) {
    const auto pb = std::find_if(b.begin(), b.end(), [&](const EnginePoint& x) { return x.point == pa.point; });
    if (pb == b.end()) continue;
    PointComparison c;
    c.point = pa.point;
    c.point_id_a = pa.point_id;
    c.point_id_b = pb->point_id;
    for (const PointMetric& ma : pa.metrics) {
      const PointMetric* mb = FindMetric(pb->metrics, ma.name);
      if (!ma.compare || !mb || !std::isfinite(ma.mean) || !std::isfinite(mb->mean)) continue;
      MetricDifference d{ma.name, ma.Estimate(), mb->Estimate(), ma.mean - mb->mean, std::hypot(ma.se, mb->se),
                         kNaN,    ma.title,      ma.headline};
      if (d.se > 0.0) d.z = d.difference / d.se;
      c.metrics.push_back(d);
    }
    out.push_back(std::move(c));
  }
  return out;
}

MetricAgreement AgreementOf(const MetricDifference& d) {
  MetricAgreement m;
  m.difference = d;
  if (d.a.mean != 0.0 && std::isfinite(d.a.mean) && std::isfinite(d.b.mean)) {
    m.ratio = d.b.mean / d.a.mean;
    const double ra = d.a.se / d.a.mean, rb = d.b.mean != 0.0 ? d.b.se / d.b.mean : kNaN;
    m.ratio_se = std::fabs(m.ratio) * std::hypot(ra, rb);
  }
  if (std::isfinite(d.z)) m.agree = std::fabs(d.z) <= kAgreementSigmas;
  // Zero uncertainty on both sides (every replica alike, e.g. Psi = 0): equal values agree,
  // different ones do not.
  else if (d.se == 0.0 && std::isfinite(d.difference))
    m.agree = d.difference == 0.0;
  // Otherwise an se is unknown (one replica): nothing can be said.
  return m;
}

std::string AgreementText(const std::optional<bool>& agree) {
  if (!agree) return "n/a";
  return *agree ? "yes" : "no";
}

EngineCost SumEngineCost(const std::string& engine, const std::vector<RunTiming>& runs) {
  EngineCost c;
  c.engine = engine;
  std::vector<double> rates;
  for (const RunTiming& t : runs) {
    ++c.runs;
    if (std::isfinite(t.wall_s)) c.wall_s += t.wall_s;
    if (std::isfinite(t.discharge_wall_s)) c.discharge_wall_s += t.discharge_wall_s;
    if (std::isfinite(t.disc_steps_per_s) && t.disc_steps_per_s > 0) rates.push_back(t.disc_steps_per_s);
    c.threads = std::max(c.threads, t.threads);
  }
  c.disc_steps_per_s = MeanSeFinite(rates);
  return c;
}

EngineComparison CompareEngines(const std::string& engine_a, const std::vector<EnginePoint>& a,
                                const std::vector<RunTiming>& timings_a, const std::string& engine_b,
                                const std::vector<EnginePoint>& b, const std::vector<RunTiming>& timings_b) {
  EngineComparison c;
  c.engine_a = engine_a;
  c.engine_b = engine_b;
  for (const PointComparison& pc : ComparePoints(a, b)) {
    PointAgreement p;
    p.point = pc.point;
    for (const MetricDifference& d : pc.metrics) p.metrics.push_back(AgreementOf(d));
    c.points.push_back(std::move(p));
  }
  c.costs = {SumEngineCost(engine_a, timings_a), SumEngineCost(engine_b, timings_b)};
  return c;
}

namespace {
nlohmann::json Number(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }
nlohmann::json MeanSeJson(const MeanSe& m) { return {{"mean", Number(m.mean)}, {"se", Number(m.se)}, {"n", m.n}}; }
}  // namespace

nlohmann::json to_json(const EngineComparison& c) {
  nlohmann::json points = nlohmann::json::array();
  for (const PointAgreement& p : c.points) {
    nlohmann::json metrics = nlohmann::json::object();
    for (const MetricAgreement& m : p.metrics) {
      metrics[m.difference.name] = {{c.engine_a, MeanSeJson(m.difference.a)},
                                    {c.engine_b, MeanSeJson(m.difference.b)},
                                    {"ratio", Number(m.ratio)},
                                    {"ratio_se", Number(m.ratio_se)},
                                    {"z", Number(m.difference.z)},
                                    {"agree", m.agree ? nlohmann::json(*m.agree) : nlohmann::json(nullptr)},
                                    {"title", m.difference.title},
                                    {"headline", m.difference.headline}};
    }
    nlohmann::json point = {{"point", p.point}, {"metrics", metrics}};
    if (!p.name.empty()) point["name"] = p.name;
    points.push_back(point);
  }
  nlohmann::json costs = nlohmann::json::array();
  for (const EngineCost& e : c.costs) {
    costs.push_back({{"engine", e.engine},
                     {"runs", e.runs},
                     {"wall_s", e.wall_s},
                     {"discharge_wall_s", e.discharge_wall_s},
                     {"disc_steps_per_s", MeanSeJson(e.disc_steps_per_s)},
                     {"threads", e.threads}});
  }
  // Metric names in the analyses' order (the objects above are keyed, hence sorted).
  nlohmann::json order = nlohmann::json::array();
  for (const PointAgreement& p : c.points)
    for (const MetricAgreement& m : p.metrics)
      if (std::find(order.begin(), order.end(), m.difference.name) == order.end()) order.push_back(m.difference.name);
  return {{"engine_a", c.engine_a},
          {"engine_b", c.engine_b},
          {"metric_order", order},
          {"ratio", c.engine_b + " / " + c.engine_a},
          {"agreement", "|z| <= " + std::to_string(static_cast<int>(kAgreementSigmas)) + " combined standard errors"},
          {"points", points},
          {"costs", costs}};
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

namespace {

// The point of `engine` with these sweep values, or nullptr.
const Point* ToEnginePoint(const CampaignView& c, const nlohmann::json& point, const std::string& engine) {
  for (const Point& p : c.points)
    if (p.engine == engine && p.point == point) return &p;
  return nullptr;
}

// The report's name of a compared point: the x value and the groups without the engine.
std::string SharedPointName(const CampaignView& c, const nlohmann::json& point, const std::string& engine) {
  const Point* p = ToEnginePoint(c, point, engine);
  if (!p) return point.dump();
  std::string s = p->shared_group;
  if (!c.x_axis.empty()) s = XText(c, p->x, NameForm::kShort) + (s.empty() ? "" : ", " + s);
  return s;
}

}  // namespace

std::optional<EngineComparison> EngineComparisonOf(const CampaignView& c,
                                                   const std::vector<std::vector<PointMetric>>& metrics) {
  if (c.engines.size() < 2) return std::nullopt;
  const bool has_native = std::find(c.engines.begin(), c.engines.end(), "native") != c.engines.end();
  const std::string a = has_native ? "native" : c.engines[0];
  std::string b;
  for (const auto& e : c.engines)
    if (e != a && b.empty()) b = e;
  std::vector<EnginePoint> ma, mb;
  for (std::size_t i = 0; i < c.points.size(); ++i) {
    const Point& p = c.points[i];
    const EnginePoint ep{p.point, p.id, i < metrics.size() ? metrics[i] : std::vector<PointMetric>{}};
    if (p.engine == a) ma.push_back(ep);
    if (p.engine == b) mb.push_back(ep);
  }
  std::vector<RunTiming> ta, tb;
  for (const UsedRun& r : c.used) {
    if (r.record->engine == a) ta.push_back(r.timing);
    if (r.record->engine == b) tb.push_back(r.timing);
  }
  EngineComparison k = CompareEngines(a, ma, ta, b, mb, tb);
  for (PointAgreement& p : k.points) p.name = SharedPointName(c, p.point, a);
  return k;
}

std::optional<Section> EngineComparisonSection(const CampaignView& c, const EngineComparison& k) {
  const std::string& a = k.engine_a;
  const std::string& b = k.engine_b;
  Section s{"engine-comparison", "Engine comparison: " + a + " and " + b, {}};
  std::map<std::string, std::set<std::string>> caps, reinjections;
  for (const UsedRun& r : c.used) {
    caps[r.record->engine].insert(r.tangential_cap);
    if (!r.reinjection.empty()) reinjections[r.record->engine].insert(r.reinjection);
  }
  auto list_text = [](const std::set<std::string>& values) {
    std::string t;
    for (const auto& x : values) t += (t.empty() ? "" : ", ") + x;
    return t.empty() ? std::string("?") : t;
  };
  auto cap_text = [&](const std::string& e) { return list_text(caps[e]); };
  const std::string reinjection_text =
      reinjections.empty()
          ? std::string()
          : " Reinjection: " + a + " `" + list_text(reinjections[a]) + "`, " + b + " `" + list_text(reinjections[b]) +
                "` (`random`: a random place on top of the bed, the thesis; `periodic`: "
                "through the bottom of a y-periodic box, same x and velocity, LIGGGHTS' way).";
  // LAMMPS discharges the bed the native engine prepared (docs/lammps.md); LIGGGHTS prepares its own.
  const bool same_beds = (a == "native" || a == "lammps") && (b == "native" || b == "lammps");
  s.blocks.push_back(Text{
      "The same sweep points and replica seeds on both engines (" +
      std::string(same_beds ? "both discharge the bed the native engine prepared for each seed, so replicas start "
                              "from the same configurations"
                            : "beds are prepared by each engine, so replicas are statistically, not bodily, the same") +
      "). Ratio = " + b + " / " + a +
      ", with the standard error of both "
      "means propagated. **agree**: the difference is within " +
      FormatNumber(kAgreementSigmas) + " combined standard errors. Coulomb cap of the tangential force: " + a + " `" +
      cap_text(a) + "`, " + b + " `" + cap_text(b) +
      "` (`lammps` caps spring + damping, `liggghts` the spring part only; docs/liggghts.md)." + reinjection_text});
  std::map<std::string, std::string> titles;
  std::vector<std::string> headline;
  for (const PointAgreement& p : k.points)
    for (const MetricAgreement& m : p.metrics) {
      const MetricDifference& d = m.difference;
      titles.emplace(d.name, d.title.empty() ? d.name : d.title);
      if (d.headline && std::find(headline.begin(), headline.end(), d.name) == headline.end())
        headline.push_back(d.name);
    }
  auto metric_title = [&](const std::string& name) { return titles.count(name) ? titles.at(name) : name; };
  // One line per metric: how many points agree and the spread of the ratio.
  std::map<std::string, std::vector<const MetricAgreement*>> by_metric;
  std::vector<std::string> metric_order;
  for (const PointAgreement& p : k.points)
    for (const MetricAgreement& m : p.metrics) {
      if (!by_metric.count(m.difference.name)) metric_order.push_back(m.difference.name);
      by_metric[m.difference.name].push_back(&m);
    }
  Table overview{"engine_agreement",
                 "Agreement per metric over all compared points (n/a: no standard error on one side, e.g. one "
                 "replica, so agreement cannot be judged)",
                 {"metric", "points", "agree", "disagree", "n/a", "ratio min", "ratio mean", "ratio max"},
                 {},
                 {"metric", "points", "agree", "disagree", "unknown", "ratio_min", "ratio_mean", "ratio_max"}};
  for (const auto& name : metric_order) {
    int agree = 0, disagree = 0, unknown = 0;
    double lo = kInf, hi = -kInf, sum = 0;
    int n = 0;
    for (const MetricAgreement* m : by_metric[name]) {
      (m->agree ? (*m->agree ? agree : disagree) : unknown) += 1;
      if (!std::isfinite(m->ratio)) continue;
      lo = std::min(lo, m->ratio);
      hi = std::max(hi, m->ratio);
      sum += m->ratio;
      ++n;
    }
    overview.rows.push_back({name, Cell::Count(static_cast<long long>(by_metric[name].size())), Cell::Count(agree),
                             Cell::Count(disagree), Cell::Count(unknown), Cell::Number(n ? lo : kNaN),
                             Cell::Number(n ? sum / n : kNaN), Cell::Number(n ? hi : kNaN)});
  }
  if (k.points.empty()) {
    s.blocks.push_back(Text{"No sweep point has finished runs on both engines yet."});
  } else {
    s.blocks.push_back(overview);
    Table t{"engine_comparison",
            "Every metric of every point on both engines (mean ± se (n) over replicas)",
            {"point", "metric", "", a, b, "ratio " + b + "/" + a, "z", "agree"},
            {},
            {"point", "metric", "title", a, b, "ratio", "z", "agree"}};
    for (const PointAgreement& p : k.points) {
      const std::string name = p.name.empty() ? SharedPointName(c, p.point, a) : p.name;
      for (const MetricAgreement& m : p.metrics) {
        const MetricDifference& d = m.difference;
        t.rows.push_back({name, d.name, metric_title(d.name), Cell::Estimate(d.a), Cell::Estimate(d.b),
                          Cell::Estimate(m.ratio, m.ratio_se, -1), Cell::Number(d.z, 3), AgreementText(m.agree)});
      }
    }
    s.blocks.push_back(t);
  }
  // Ratio against x, one series per (metric, group), with the 10 % band.
  if (HasX(c) && !k.points.empty()) {
    Figure f{"engine_ratio",
             "Ratio " + b + " / " + a + " against " + c.x_label,
             c.x_label,
             b + " / " + a,
             {},
             false,
             false,
             "Error bars: propagated se of both means. Reference lines: equal (solid black), -10 % (dashed grey) "
             "and +10 % (dotted grey)"};
    double xlo = kInf, xhi = -kInf;
    for (const std::string& metric : headline) {
      std::map<std::string, Series> by_group;
      std::vector<std::string> order;
      for (const PointAgreement& p : k.points) {
        const Point* pa = ToEnginePoint(c, p.point, a);
        if (!pa || !std::isfinite(pa->x)) continue;
        for (const MetricAgreement& m : p.metrics) {
          if (m.difference.name != metric || !std::isfinite(m.ratio)) continue;
          if (!by_group.count(pa->shared_group)) {
            order.push_back(pa->shared_group);
            Series ser;
            ser.label = metric_title(metric) + (pa->shared_group.empty() ? "" : ", " + pa->shared_group);
            ser.columns = {c.x_name, "ratio", "ratio_se"};
            ser.style = Series::Style::kErrorBars;
            ser.err = 2;
            by_group[pa->shared_group] = ser;
          }
          by_group[pa->shared_group].rows.push_back({pa->x, m.ratio, m.ratio_se});
          xlo = std::min(xlo, pa->x);
          xhi = std::max(xhi, pa->x);
        }
      }
      for (const auto& g : order) {
        Series& ser = by_group[g];
        std::sort(ser.rows.begin(), ser.rows.end());
        f.series.push_back(std::move(ser));
      }
    }
    if (!f.series.empty()) {
      for (const double level : {1.0, 0.9, 1.1}) {  // equal first: the solid black line
        Series line;
        line.label = level == 1.0 ? "equal" : (level < 1 ? "-10 %" : "+10 %");
        line.columns = {c.x_name, "ratio"};
        line.style = Series::Style::kLines;
        line.role = Series::Role::kReference;
        line.rows = {{xlo, level}, {xhi, level}};
        f.series.push_back(std::move(line));
      }
      s.blocks.push_back(f);
    }
  }
  Table cost{"engine_cost",
             "What each engine cost on this campaign (discharge throughput: disc-steps per second "
             "per run; one disc = one sphere of a LIGGGHTS multisphere body)",
             {"engine", "runs", "wall time (bed + discharge, s)", "discharge wall time (s)", "disc-steps/s per run",
              "threads per run", "throughput / " + a},
             {},
             {"engine", "runs", "wall_s", "discharge_wall_s", "disc_steps_per_s", "threads", "throughput_ratio"}};
  const double base_rate = k.costs.empty() ? kNaN : k.costs.front().disc_steps_per_s.mean;
  for (const EngineCost& e : k.costs) {
    cost.rows.push_back({e.engine, Cell::Count(e.runs), Cell::Number(e.wall_s), Cell::Number(e.discharge_wall_s),
                         Cell::Estimate(e.disc_steps_per_s), Cell::Count(e.threads),
                         Cell::Number(e.disc_steps_per_s.mean / base_rate, 3)});
  }
  s.blocks.push_back(cost);
  return s;
}

}  // namespace granary::analysis
