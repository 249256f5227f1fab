// See export.h.
#include "analysis/export.h"

#include <array>
#include <cmath>
#include <map>

#include "analysis/report_document.h"

namespace granary::analysis {
namespace {

// The sweep axes as columns (the engine has a column of its own).
std::vector<std::string> AxesOf(const CampaignView& v) {
  std::vector<std::string> out;
  for (const auto& axis : v.axes)
    if (axis != "/engine") out.push_back(axis);
  return out;
}

nlohmann::json AxisCell(const std::string& axis, const nlohmann::json& point, const nlohmann::json& spec) {
  const auto value = AxisValue(axis, point, spec);
  if (!value || value->is_null()) return nullptr;
  if (value->is_number() || value->is_string() || value->is_boolean()) return *value;
  return value->dump();
}

nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

// The campaign's derived axes (/axes) as columns after the sweep axes.
void AddDerived(const CampaignView& v, const nlohmann::json& point, const nlohmann::json& spec,
                std::vector<nlohmann::json>& head) {
  if (v.named.Derived().empty()) return;
  const std::map<std::string, double> values = v.named.Values(point, spec);
  for (const DerivedAxis& d : v.named.Derived()) head.push_back(Number(values.at(d.name)));
}

// Metric columns in analysis order, then first appearance.
class Columns {
 public:
  std::size_t Index(const std::string& name) {
    const auto it = index_.find(name);
    if (it != index_.end()) return it->second;
    names_.push_back(name);
    return index_[name] = names_.size() - 1;
  }
  const std::vector<std::string>& Names() const { return names_; }

 private:
  std::vector<std::string> names_;
  std::map<std::string, std::size_t> index_;
};

}  // namespace

ExportTable MakeExportTable(const CampaignAnalysis& a, ExportLevel level) {
  const CampaignView& v = a.view;
  const std::vector<std::string> axes = AxesOf(v);
  ExportTable t;
  Columns metrics;
  // Values per row and metric column: {value, se, n}.
  std::vector<std::map<std::size_t, std::array<nlohmann::json, 3>>> values;
  std::vector<std::vector<nlohmann::json>> heads;
  if (level == ExportLevel::kRun) {
    t.columns = {"run_id", "point_id", "replica", "engine", "end_reason"};
    for (const Point& p : v.points)
      for (std::size_t u : p.runs) {
        const UsedRun& r = v.used[u];
        std::vector<nlohmann::json> head = {r.record->run_id, r.record->point_id, r.record->replica, r.record->engine,
                                            r.summary.end_reason};
        for (const auto& axis : axes) head.push_back(AxisCell(axis, r.record->point, r.record->spec));
        AddDerived(v, r.record->point, r.record->spec, head);
        heads.push_back(head);
        values.emplace_back();
        for (std::size_t k = 0; k < a.results.size(); ++k)
          for (const Metric& m : a.RunMetrics(k, u))
            values.back()[metrics.Index(m.name)] = {Number(m.value), Number(m.se), nullptr};
      }
  } else {
    t.columns = {"point_id", "engine", "runs"};
    for (std::size_t p = 0; p < v.points.size(); ++p) {
      const Point& point = v.points[p];
      std::vector<nlohmann::json> head = {
          point.id, point.engine.empty() && !v.engines.empty() ? v.engines.front() : point.engine, point.runs.size()};
      for (const auto& axis : axes) head.push_back(AxisCell(axis, point.point, point.spec));
      AddDerived(v, point.point, point.spec, head);
      heads.push_back(head);
      values.emplace_back();
      for (const PointMetric& m : a.AllPointMetrics(p))
        values.back()[metrics.Index(m.name)] = {Number(m.mean), Number(m.se), m.n};
    }
  }
  for (const auto& axis : axes) t.columns.push_back(v.named.ShortName(axis));
  for (const DerivedAxis& d : v.named.Derived()) t.columns.push_back(d.name);
  for (const auto& name : metrics.Names()) {
    t.columns.push_back(name);
    t.columns.push_back(name + "_se");
    if (level == ExportLevel::kPoint) t.columns.push_back(name + "_n");
  }
  const std::size_t per_metric = level == ExportLevel::kPoint ? 3 : 2;
  for (std::size_t i = 0; i < heads.size(); ++i) {
    std::vector<nlohmann::json> row = heads[i];
    for (std::size_t k = 0; k < metrics.Names().size(); ++k) {
      const auto it = values[i].find(k);
      for (std::size_t c = 0; c < per_metric; ++c)
        row.push_back(it == values[i].end() ? nlohmann::json(nullptr) : it->second[c]);
    }
    t.rows.push_back(std::move(row));
  }
  return t;
}

std::string ToCsv(const ExportTable& t) {
  std::string out;
  for (std::size_t i = 0; i < t.columns.size(); ++i) out += (i ? "," : "") + CsvEscape(t.columns[i]);
  out += "\n";
  for (const auto& row : t.rows) {
    for (std::size_t i = 0; i < row.size(); ++i) {
      if (i) out += ",";
      const nlohmann::json& c = row[i];
      if (c.is_number()) {
        out += CsvNumber(c.get<double>());
      } else if (c.is_string()) {
        out += CsvEscape(c.get<std::string>());
      } else if (c.is_boolean()) {
        out += c.get<bool>() ? "true" : "false";
      }
    }
    out += "\n";
  }
  return out;
}

nlohmann::ordered_json to_json(const ExportTable& t) {
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const auto& row : t.rows) {
    nlohmann::ordered_json o = nlohmann::ordered_json::object();
    for (std::size_t i = 0; i < row.size() && i < t.columns.size(); ++i) o[t.columns[i]] = row[i];
    out.push_back(std::move(o));
  }
  return out;
}

}  // namespace granary::analysis
