// What was simulated, in words a researcher uses: human names for sweep axes ("outlet width W",
// "dumbbell fraction X_db" rather than /silo/base_outlets/0/width) and the table of a campaign's
// fixed parameters (silo, bodies, contact law, time step, mode, stop conditions). Pure: run
// spec JSON in, text out. The report's first section, "The system", is made of them.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/report_document.h"

namespace granary::analysis {

// The name of a sweep axis (a JSON pointer into the run spec) for a reader; `run_spec` gives the
// species' names and how many outlets there are. Unknown pointers come back as they are.
std::string AxisName(const std::string& pointer, const nlohmann::json& run_spec);

// An axis' long name and its short form for narrow table columns and figure keys: the thesis'
// symbol ("W", "X_db", "N"), or a word where the quantity has none ("shape", "mode", "engine").
// Unknown pointers: the pointer itself in both.
struct AxisNames {
  std::string name;    // "outlet width W"
  std::string symbol;  // "W"
};
AxisNames ResolveAxisNames(const std::string& pointer, const nlohmann::json& run_spec);

// The unit of a sweep axis' values in the report's reduced units: "d" for lengths (widths,
// positions, heights, a big disc's diameter), "sqrt(d/g)" for times, "sqrt(g d)" for speeds;
// "" for pure numbers, words and the disc diameter d itself (the unit).
std::string AxisUnit(const std::string& pointer);

// The report's units, said once ("The system"): every quantity of every table, figure and
// export is in these reduced units.
inline constexpr char kUnitsText[] =
    "units: lengths in d (the disc diameter), times in sqrt(d/g), masses in rho d^2 (rho the areal density); so "
    "velocities in sqrt(g d), flow rates in bodies/sqrt(d/g), forces in rho g d^2, 2-D stresses (force per length) in "
    "rho g d, energies in rho g d^3, T_g per unit mass (ch. 3) in g d";

// Rows {group, parameter, value} of everything a run of the campaign shares, from one resolved
// run spec; a parameter under one of the sweep `axes` reads "swept (below)".
Table FixedParameters(const nlohmann::json& run_spec, const std::vector<std::string>& axes);

}  // namespace granary::analysis
