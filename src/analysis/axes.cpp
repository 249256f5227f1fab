// See axes.h.
#include "analysis/axes.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "analysis/campaign_view.h"
#include "analysis/options.h"
#include "analysis/stats.h"
#include "analysis/system.h"

namespace granary::analysis {

bool IsIdentifier(const std::string& name) {
  if (name.empty() || std::isdigit(static_cast<unsigned char>(name.front()))) return false;
  return std::all_of(name.begin(), name.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

std::map<std::string, std::string> AxisShortNames(const std::vector<std::string>& axes,
                                                  const nlohmann::json& run_spec) {
  std::map<std::string, int> uses;
  for (const auto& axis : axes) ++uses[ResolveAxisNames(axis, run_spec).symbol];
  std::map<std::string, std::string> out;
  for (const auto& axis : axes) {
    const std::string symbol = ResolveAxisNames(axis, run_spec).symbol;
    out[axis] = uses[symbol] > 1 || symbol == axis ? ShortAxis(axis) : symbol;
  }
  return out;
}

std::vector<std::string> CampaignSpecAxes(const nlohmann::json& spec) {
  std::vector<std::string> axes;
  if (!spec.is_object() || !spec.contains("sweep") || !spec.at("sweep").is_object()) return axes;
  const nlohmann::json& sweep = spec.at("sweep");
  auto add = [&](const std::string& axis) {
    if (std::find(axes.begin(), axes.end(), axis) == axes.end()) axes.push_back(axis);
  };
  for (const char* kind : {"grid", "zip"})
    if (sweep.contains(kind) && sweep.at(kind).is_object())
      for (const auto& [axis, values] : sweep.at(kind).items()) add(axis);
  if (sweep.contains("points") && sweep.at("points").is_array())
    for (const auto& point : sweep.at("points"))
      if (point.is_object())
        for (const auto& [axis, value] : point.items()) add(axis);
  return axes;
}

CampaignAxes::CampaignAxes(const std::vector<std::string>& sweep, const nlohmann::json& run_spec,
                           const nlohmann::json& axes_block)
    : sweep_(sweep), short_(AxisShortNames(sweep, run_spec)) {
  if (axes_block.is_null()) return;
  if (!axes_block.is_object())
    throw OptionError("/axes", axes_block,
                      "must be an object {name: expression}, e.g. {\"D_eq\": \"sqrt(1 + D_b^2)\"}");
  std::vector<std::string> taken = Names();
  for (const auto& [name, text] : axes_block.items()) {
    const std::string path = "/axes/" + name;
    std::vector<std::string> usable;
    for (const auto& n : taken)
      if (IsIdentifier(n)) usable.push_back(n);
    std::string listed;
    for (const auto& n : usable) listed += (listed.empty() ? "" : ", ") + n;
    if (listed.empty()) listed = "none";
    if (name.empty() || name.find_first_of("=,") != std::string::npos)
      throw OptionError(path, text, "an axis name must be non-empty, without '=' or ','");
    if (std::find(taken.begin(), taken.end(), name) != taken.end())
      throw OptionError(path, text, "\"" + name + "\" already names an axis (names in use: " + listed + ")");
    if (!text.is_string())
      throw OptionError(path, text,
                        "must be an expression over the axes, e.g. \"sqrt(1 + D_b^2)\" (axes: " + listed + ")");
    Expression e;
    try {
      e = Expression::Parse(text.get<std::string>(), usable);
    } catch (const ExpressionError& err) {
      throw OptionError(path, text, std::string(err.what()) + " (axes: " + listed + ")");
    }
    if (!e.Parameters().empty()) {
      std::string unknown;
      for (const auto& p : e.Parameters()) unknown += (unknown.empty() ? "" : ", ") + p;
      throw OptionError(path, text, "names no axis: " + unknown + " (axes it can use: " + listed + ")");
    }
    derived_.push_back({name, std::move(e)});
    taken.push_back(name);
  }
}

CampaignAxes CampaignAxes::OfCampaignSpec(const nlohmann::json& spec) {
  std::vector<std::string> sweep = CampaignSpecAxes(spec);
  if (spec.is_object() && spec.contains("engine") && spec.at("engine").is_array() && spec.at("engine").size() > 1)
    sweep.push_back("/engine");
  const nlohmann::json base =
      spec.is_object() ? spec.value("base", nlohmann::json::object()) : nlohmann::json::object();
  const nlohmann::json block = spec.is_object() && spec.contains("axes") ? spec.at("axes") : nlohmann::json();
  return CampaignAxes(sweep, base, block);
}

std::string CampaignAxes::ShortName(const std::string& pointer) const {
  const auto it = short_.find(pointer);
  return it == short_.end() ? pointer : it->second;
}

std::optional<std::string> CampaignAxes::PointerOf(const std::string& name) const {
  for (const auto& axis : sweep_)
    if (axis == name || ShortName(axis) == name) return axis;
  return std::nullopt;
}

const DerivedAxis* CampaignAxes::FindDerived(const std::string& name) const {
  for (const DerivedAxis& d : derived_)
    if (d.name == name) return &d;
  return nullptr;
}

std::vector<std::string> CampaignAxes::Names() const {
  std::vector<std::string> out;
  for (const auto& axis : sweep_) out.push_back(ShortName(axis));
  for (const DerivedAxis& d : derived_) out.push_back(d.name);
  return out;
}

std::vector<std::string> CampaignAxes::ExpressionNames() const {
  std::vector<std::string> out;
  for (const auto& n : Names())
    if (IsIdentifier(n)) out.push_back(n);
  return out;
}

std::map<std::string, double> CampaignAxes::Values(const nlohmann::json& point, const nlohmann::json& spec) const {
  std::map<std::string, double> out;
  for (const auto& axis : sweep_) {
    const auto v = AxisValue(axis, point, spec);
    out[ShortName(axis)] = v && v->is_number() ? v->get<double>() : kNaN;
  }
  for (const DerivedAxis& d : derived_) {
    std::vector<double> vars;
    for (const auto& n : d.expression.Variables()) {
      const auto it = out.find(n);
      vars.push_back(it == out.end() ? kNaN : it->second);
    }
    out[d.name] = d.expression.Evaluate(vars, {});
  }
  return out;
}

std::optional<double> CampaignAxes::Value(const std::string& name, const nlohmann::json& point,
                                          const nlohmann::json& spec) const {
  const std::map<std::string, double> all = Values(point, spec);
  if (const auto it = all.find(name); it != all.end()) return it->second;
  if (const auto pointer = PointerOf(name)) return all.at(ShortName(*pointer));
  return std::nullopt;
}

}  // namespace granary::analysis
