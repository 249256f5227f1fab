// See analysis.h.
#include "analysis/analysis.h"

#include <cmath>

#include "analysis/campaign_view.h"

namespace granary::analysis {

std::vector<const nlohmann::json*> AnalysisResults::OfPoint(std::size_t p) const {
  std::vector<const nlohmann::json*> out;
  if (!view || p >= view->points.size()) return out;
  for (std::size_t i : view->points[p].runs)
    if (i < runs.size() && !runs[i].is_null()) out.push_back(&runs[i]);
  return out;
}

std::vector<PointMetric> Analysis::PointMetrics(const AnalysisResults& results, std::size_t point) const {
  return MeanOverRuns(*this, results.OfPoint(point));
}

std::vector<PointMetric> MeanOverRuns(const Analysis& analysis, const std::vector<const nlohmann::json*>& runs) {
  std::vector<PointMetric> out;
  std::vector<std::vector<double>> values;
  for (const nlohmann::json* r : runs) {
    for (const Metric& m : analysis.RunMetrics(*r)) {
      auto it = std::find_if(out.begin(), out.end(), [&](const PointMetric& p) { return p.name == m.name; });
      if (it == out.end()) {
        out.push_back({m.name, m.unit, kNaN, kNaN, 0, m.title, m.headline, ""});
        values.emplace_back();
        it = out.end() - 1;
      }
      values[static_cast<std::size_t>(it - out.begin())].push_back(m.value);
    }
  }
  for (std::size_t k = 0; k < out.size(); ++k) {
    const MeanSe s = MeanSeFinite(values[k]);
    out[k].mean = s.mean;
    out[k].se = s.se;
    out[k].n = s.n;
  }
  return out;
}

const Metric* FindMetric(const std::vector<Metric>& metrics, const std::string& name) {
  for (const Metric& m : metrics)
    if (m.name == name) return &m;
  return nullptr;
}

const PointMetric* FindMetric(const std::vector<PointMetric>& metrics, const std::string& name) {
  for (const PointMetric& m : metrics)
    if (m.name == name) return &m;
  return nullptr;
}

nlohmann::json to_json(const MeanSe& m) { return {{"mean", JsonNumber(m.mean)}, {"se", JsonNumber(m.se)}, {"n", m.n}}; }

MeanSe MeanSeOf(const nlohmann::json& j) {
  if (!j.is_object()) return {};
  return {NumberAt(j, "mean"), NumberAt(j, "se"), j.value("n", 0)};
}

std::vector<double> NumbersOf(const nlohmann::json& array) {
  std::vector<double> out;
  if (!array.is_array()) return out;
  out.reserve(array.size());
  for (const auto& v : array) out.push_back(NumberOf(v));
  return out;
}

nlohmann::json JsonNumbers(const std::vector<double>& values) {
  nlohmann::json out = nlohmann::json::array();
  for (double v : values) out.push_back(JsonNumber(v));
  return out;
}

std::string StringAt(const nlohmann::json& array, std::size_t k) {
  return array.is_array() && k < array.size() && array[k].is_string() ? array[k].get<std::string>() : "";
}

}  // namespace granary::analysis
