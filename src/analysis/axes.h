// A campaign's axes by name: one short name per sweep axis (the thesis' symbol, "D_b" for
// /bodies/species/0/big_diameter; the short path "species.0.diameter" where two axes share a
// symbol) and the derived axes the campaign spec declares once under /axes
// ({"D_eq": "sqrt(1 + D_b^2)", "W/D_eq": "W / D_eq"}). The report, the figures, the export and
// `--only` all name axes through this, so that an axis reads the same everywhere. Pure.
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/expression.h"

namespace granary::analysis {

struct DerivedAxis {
  std::string name;       // "D_eq", "W/D_eq"
  Expression expression;  // over the sweep axes' short names and the derived axes before it
};

class CampaignAxes {
 public:
  CampaignAxes() = default;
  // `sweep` the sweep axes (JSON pointers, "/engine" allowed), `run_spec` a resolved run spec of
  // the campaign (species names and shapes give some symbols), `axes_block` the campaign spec's
  // /axes (null: none). Throws OptionError at /axes/<name> for a derived axis that does not
  // parse, names an axis there is not, or takes a name already used.
  CampaignAxes(const std::vector<std::string>& sweep, const nlohmann::json& run_spec, const nlohmann::json& axes_block);
  // From a whole campaign spec: its sweep axes (grid, zip, points) and its /axes, symbols from
  // its /base. For checking a spec before it is planned.
  static CampaignAxes OfCampaignSpec(const nlohmann::json& campaign_spec);

  const std::vector<std::string>& Sweep() const { return sweep_; }
  // The short name of a sweep axis; the pointer itself if it is not one.
  std::string ShortName(const std::string& pointer) const;
  // The sweep axis a name stands for: its short name or its pointer.
  std::optional<std::string> PointerOf(const std::string& name) const;
  const std::vector<DerivedAxis>& Derived() const { return derived_; }
  const DerivedAxis* FindDerived(const std::string& name) const;
  // Every name an axis can be asked for by: the sweep axes' short names, then the derived axes.
  std::vector<std::string> Names() const;
  // The names usable inside expressions (those that are identifiers), in Names() order.
  std::vector<std::string> ExpressionNames() const;
  // The numeric value of every sweep axis (by short name; strings and missing values: NaN) and
  // every derived axis at a point (`point` the sweep values, `spec` its resolved run spec).
  std::map<std::string, double> Values(const nlohmann::json& point, const nlohmann::json& spec) const;
  // One axis (short name, pointer or derived name); nullopt if no axis has that name.
  std::optional<double> Value(const std::string& name, const nlohmann::json& point, const nlohmann::json& spec) const;

 private:
  std::vector<std::string> sweep_;
  std::map<std::string, std::string> short_;  // pointer -> short name
  std::vector<DerivedAxis> derived_;
};

// The short names of `axes` (pointers): each axis' symbol (system.h axis_names), or its short
// path (short_axis) where two axes share a symbol.
std::map<std::string, std::string> AxisShortNames(const std::vector<std::string>& axes, const nlohmann::json& run_spec);
// Whether `name` can stand in an expression (letters, digits and '_', not starting with a digit).
bool IsIdentifier(const std::string& name);
// The sweep axes of a campaign spec, in the planner's order: grid, zip, then point keys.
std::vector<std::string> CampaignSpecAxes(const nlohmann::json& campaign_spec);

}  // namespace granary::analysis
