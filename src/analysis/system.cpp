// See system.h.
#include "analysis/system.h"

#include <algorithm>

#include "rundir/shape_table.h"

namespace granary::analysis {
namespace {

using nlohmann::json;

std::string Num(const json& v) {
  if (v.is_number()) return FormatNumber(v.get<double>(), 7);
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

const json& At(const json& j, const char* key) {
  static const json kNull;
  return j.is_object() && j.contains(key) ? j.at(key) : kNull;
}

// Species k's name, or "species k".
std::string SpeciesName(const json& spec, std::size_t k) {
  const json& species = At(At(spec, "bodies"), "species");
  if (species.is_array() && k < species.size() && species[k].contains("name"))
    return species[k]["name"].get<std::string>();
  return "species " + std::to_string(k);
}

// The shape table's symbol ("X_db" for dumbbells, the thesis' symbols), else "X_<name>", or
// "X_<k>" for a species without a name.
std::string FractionSymbol(const json& spec, std::size_t k) {
  const json& species = At(At(spec, "bodies"), "species");
  const std::string shape = species.is_array() && k < species.size() ? species[k].value("shape", "") : "";
  if (const ShapeRow* row = FindShapeRow(shape); row && *row->fraction_symbol) return row->fraction_symbol;
  const bool named = species.is_array() && k < species.size() && species[k].contains("name");
  return "X_" + (named ? SpeciesName(spec, k) : std::to_string(k));
}

std::size_t Count(const json& spec, const char* group, const char* list) {
  const json& l = At(At(spec, group), list);
  return l.is_array() ? l.size() : 0;
}

std::vector<std::string> Split(const std::string& pointer) {
  std::vector<std::string> parts;
  std::size_t start = 1;
  while (start <= pointer.size()) {
    const std::size_t end = pointer.find('/', start);
    parts.push_back(pointer.substr(start, end == std::string::npos ? std::string::npos : end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return parts;
}

bool IsIndex(const std::string& s) { return !s.empty() && std::all_of(s.begin(), s.end(), ::isdigit); }

bool Swept(const std::string& pointer, const std::vector<std::string>& axes) {
  for (const auto& a : axes)
    if (a == pointer || pointer.rfind(a + "/", 0) == 0 || a.rfind(pointer + "/", 0) == 0) return true;
  return false;
}

}  // namespace

AxisNames ResolveAxisNames(const std::string& pointer, const json& spec) {
  if (pointer == "engine" || pointer == "/engine") return {"engine", "engine"};
  const std::vector<std::string> p = Split(pointer);
  const auto is = [&](std::initializer_list<const char*> want) {
    if (p.size() != want.size()) return false;
    std::size_t i = 0;
    for (const char* w : want) {
      if (std::string(w) == "#" ? !IsIndex(p[i]) : p[i] != w) return false;
      ++i;
    }
    return true;
  };
  const auto index = [&](std::size_t i) { return static_cast<std::size_t>(std::stoul(p[i])); };
  const auto nth = [&](const char* what, std::size_t k, const char* group, const char* list) {
    return Count(spec, group, list) > 1 ? std::string(what) + " " + std::to_string(k + 1) : std::string(what);
  };
  // {words with the symbol, the symbol}
  const auto named = [](std::string words, const std::string& symbol) {
    return AxisNames{words + " " + symbol, symbol};
  };
  if (is({"silo", "base_outlets", "#", "width"})) {
    const std::string k = std::to_string(index(2) + 1);
    return Count(spec, "silo", "base_outlets") > 1 ? AxisNames{"width W_" + k + " of outlet " + k, "W_" + k}
                                                   : named("outlet width", "W");
  }
  if (is({"silo", "base_outlets", "#", "center"})) {
    const std::string k = std::to_string(index(2) + 1);
    return {"position x_" + k + " of " + nth("outlet", index(2), "silo", "base_outlets"), "x_" + k};
  }
  if (is({"silo", "side_outlets", "#", "width"}))
    return named(nth("side outlet", index(2), "silo", "side_outlets") + " width", "W_s");
  if (is({"silo", "side_outlets", "#", "bottom"}))
    return named(nth("side outlet", index(2), "silo", "side_outlets") + " height above the base", "h_s");
  if (is({"silo", "obstacles", "#", "y"}))
    return named(nth("obstacle", index(2), "silo", "obstacles") + " height", "h");
  if (is({"silo", "obstacles", "#", "x"}))
    return named(nth("obstacle", index(2), "silo", "obstacles") + " position", "x_o");
  if (is({"silo", "obstacles", "#", "diameter"}))
    return named(nth("obstacle", index(2), "silo", "obstacles") + " diameter", "D_o");
  if (is({"silo", "width"})) return named("silo width", "L");
  if (is({"silo", "height"})) return {"silo height", "silo height"};
  if (is({"bodies", "count"})) return named("number of bodies", "N");
  if (is({"bodies", "density"})) return named("areal density", "rho");
  if (is({"bodies", "species", "#", "fraction"}))
    return named(SpeciesName(spec, index(2)) + " fraction", FractionSymbol(spec, index(2)));
  if (is({"bodies", "species", "#", "shape"}))
    return {
        Count(spec, "bodies", "species") > 1 ? "shape of " + SpeciesName(spec, index(2)) : std::string("body shape"),
        "shape"};
  if (is({"bodies", "species", "#", "diameter"})) return named(SpeciesName(spec, index(2)) + " disc diameter", "d");
  if (is({"bodies", "species", "#", "big_diameter"}))
    return named(SpeciesName(spec, index(2)) + " big-disc diameter", "D_b");
  if (is({"bodies", "species", "#", "n"})) return named(SpeciesName(spec, index(2)) + " discs per rod", "n");
  if (is({"contact", "mu"})) return named("friction", "mu");
  if (is({"contact", "mu_wall"})) return named("wall friction", "mu_w");
  if (is({"contact", "kn"})) return named("normal stiffness", "K_n");
  if (is({"contact", "kt"})) return named("tangential stiffness", "K_t");
  if (is({"contact", "gamma_n"})) return named("normal damping", "gamma_n");
  if (is({"contact", "gamma_t"})) return named("tangential damping", "gamma_t");
  if (is({"time_step"})) return named("time step", "dt");
  if (is({"gravity"})) return named("gravity", "g");
  if (is({"discharge", "mode"})) return {"discharge mode", "mode"};
  if (is({"discharge", "reinject_speed"})) return {"reinjection speed", "reinjection speed"};
  if (is({"discharge", "max_time"})) return {"maximum time", "t_max"};
  if (is({"seed"})) return {"seed", "seed"};
  return {pointer, pointer};
}

std::string AxisName(const std::string& pointer, const json& spec) { return ResolveAxisNames(pointer, spec).name; }

std::string AxisUnit(const std::string& pointer) {
  const std::vector<std::string> p = Split(pointer);
  if (p.empty()) return "";
  const std::string& last = p.back();
  if (p.front() == "silo" && (last == "width" || last == "center" || last == "bottom" || last == "x" || last == "y" ||
                              last == "diameter" || last == "height"))
    return "d";
  if (p.front() == "bodies" && last == "big_diameter") return "d";
  if (pointer == "/time_step" || pointer == "/discharge/max_time") return "sqrt(d/g)";
  if (pointer == "/discharge/reinject_speed") return "sqrt(g d)";
  return "";
}

Table FixedParameters(const json& spec, const std::vector<std::string>& axes) {
  Table t;
  t.name = "system-parameters";
  t.caption = "Fixed parameters (" + std::string(kUnitsText) + ")";
  t.header = {"", "parameter", "value"};
  // pointer "": a row of several parameters, each of which says itself whether it is swept (V).
  const auto add = [&](const std::string& group, const std::string& name, const std::string& pointer,
                       const std::string& value) {
    t.rows.push_back({group, name, !pointer.empty() && Swept(pointer, axes) ? "swept (below)" : value});
  };
  const auto V = [&](const std::string& pointer, const json& value) {
    return Swept(pointer, axes) ? ResolveAxisNames(pointer, spec).symbol + " (swept, below)" : Num(value);
  };
  const json& silo = At(spec, "silo");
  add("silo", "width L", "/silo/width", Num(At(silo, "width")));
  const double height = At(silo, "height").is_number() ? At(silo, "height").get<double>() : 0.0;
  add("silo", "height", "/silo/height", height > 0 ? Num(At(silo, "height")) : "as tall as the bed needs");
  const json& base = At(silo, "base_outlets");
  for (std::size_t k = 0; base.is_array() && k < base.size(); ++k) {
    const std::string name = base.size() > 1 ? "base outlet " + std::to_string(k + 1) : "base outlet";
    const std::string ptr = "/silo/base_outlets/" + std::to_string(k);
    add("silo", name + ": width W", ptr + "/width", Num(At(base[k], "width")));
    add("silo", name + ": centre x", ptr + "/center", Num(At(base[k], "center")));
  }
  const json& side = At(silo, "side_outlets");
  for (std::size_t k = 0; side.is_array() && k < side.size(); ++k) {
    const std::string name = "side outlet" + (side.size() > 1 ? " " + std::to_string(k + 1) : std::string());
    const std::string ptr = "/silo/side_outlets/" + std::to_string(k);
    add("silo", name + ": wall", ptr + "/wall", Num(At(side[k], "wall")));
    add("silo", name + ": width W_s", ptr + "/width", Num(At(side[k], "width")));
    add("silo", name + ": lower edge above the base", ptr + "/bottom", Num(At(side[k], "bottom")));
  }
  if (!side.is_array() || side.empty()) {
    if (!base.is_array() || base.empty()) add("silo", "outlets", "/silo/base_outlets", "none");
  }
  const json& obstacles = At(silo, "obstacles");
  for (std::size_t k = 0; obstacles.is_array() && k < obstacles.size(); ++k) {
    const std::string name = "obstacle" + (obstacles.size() > 1 ? " " + std::to_string(k + 1) : std::string());
    const std::string ptr = "/silo/obstacles/" + std::to_string(k);
    add("silo", name + ": centre (x, y)", "",
        "(" + V(ptr + "/x", At(obstacles[k], "x")) + ", " + V(ptr + "/y", At(obstacles[k], "y")) + ")");
    add("silo", name + ": diameter D_o", ptr + "/diameter", Num(At(obstacles[k], "diameter")));
  }
  const json& bodies = At(spec, "bodies");
  add("bodies", "number N", "/bodies/count", Num(At(bodies, "count")));
  add("bodies", "areal density rho", "/bodies/density", Num(At(bodies, "density")));
  const json& species = At(bodies, "species");
  for (std::size_t k = 0; species.is_array() && k < species.size(); ++k) {
    const json& s = species[k];
    const std::string shape = s.value("shape", "");
    const std::string ptr = "/bodies/species/" + std::to_string(k);
    const ShapeRow* row = FindShapeRow(shape);
    const std::string form =
        row ? ShapeText(row->form, [&](const std::string& key) { return V(ptr + "/" + key, At(s, key.c_str())); })
            : shape;
    add("bodies", "species " + std::to_string(k + 1) + " \"" + s.value("name", "") + "\"", ptr + "/shape", form);
    add("bodies", "species " + std::to_string(k + 1) + " number fraction " + FractionSymbol(spec, k), ptr + "/fraction",
        Num(At(s, "fraction")));
  }
  const json& contact = At(spec, "contact");
  add("contact law", "model", "/contact/tangential_cap",
      "Hertz with tangential history; Coulomb cap on " +
          std::string(At(contact, "tangential_cap") == "liggghts" ? "the spring part (LIGGGHTS)"
                                                                  : "spring + damping (LAMMPS)") +
          (At(contact, "clip_normal") == true ? "; attractive normal force clipped" : ""));
  add("contact law", "stiffness K_n, K_t", "",
      V("/contact/kn", At(contact, "kn")) + ", " + V("/contact/kt", At(contact, "kt")));
  add("contact law", "damping gamma_n, gamma_t", "",
      V("/contact/gamma_n", At(contact, "gamma_n")) + ", " + V("/contact/gamma_t", At(contact, "gamma_t")));
  add("contact law", "friction mu (bodies), mu_w (walls)", "",
      V("/contact/mu", At(contact, "mu")) + ", " + V("/contact/mu_wall", At(contact, "mu_wall")));
  add("integration", "time step dt", "/time_step", Num(At(spec, "time_step")));
  add("integration", "gravity g", "/gravity", Num(At(spec, "gravity")));
  add("integration", "engine", "/engine", Num(At(spec, "engine")));
  const json& d = At(spec, "discharge");
  const std::string mode = At(d, "mode").is_string() ? At(d, "mode").get<std::string>() : "remove";
  std::string mode_text = mode == "reinject" ? "reinject: a body that leaves comes back on top of the bed"
                                             : "remove: a body that leaves is gone";
  if (mode == "reinject" && At(d, "reinject_position") == "periodic")
    mode_text += " (through a periodic box, as LIGGGHTS)";
  add("discharge", "mode", "/discharge/mode", mode_text);
  add("discharge", "a body has left", "/discharge/exit_distance",
      "its centre " + Num(At(d, "exit_distance")) + " past the outlet");
  add("discharge", "stops at time", "/discharge/max_time", Num(At(d, "max_time")));
  if (At(d, "on_clog") == "unclog") {
    const json& u = At(d, "unclog");
    const std::string kick = "kicks the bodies within " +
                             (At(u, "kick_radius") == 0.0 ? std::string("W") : Num(At(u, "kick_radius"))) +
                             " of the outlet upwards at " + Num(At(u, "kick_speed"));
    // run.json names the fallback only when there is one.
    const std::string how = At(u, "method") == "kick" ? kick
                            : At(u, "fallback") == "kick"
                                ? "takes out the arch's bodies; " + kick + " when it finds none"
                                : std::string("takes out the arch's bodies");
    add("discharge", "on a clog", "/discharge/on_clog",
        "unclogs: " + how + " (up to " + Num(At(u, "max_attempts")) + " attempts) and goes on; ends at clog " +
            Num(At(u, "max_clogs")));
  } else {
    add("discharge", "on a clog", "/discharge/stop_on_clog",
        At(d, "stop_on_clog") == false ? "runs on (intermittent flow)" : "stops");
  }
  add("discharge", "a clog", "/discharge/clog_window",
      "no exit for " + Num(At(d, "clog_window")) + " and kinetic energy per body near the outlets below " +
          Num(At(d, "clog_ke_per_body")) + " m g d");
  const json& out = At(spec, "output");
  add("output", "frames every", "/output/frame_interval",
      At(out, "frame_interval").is_number() && At(out, "frame_interval").get<double>() > 0
          ? Num(At(out, "frame_interval"))
          : "no frames");
  return t;
}

}  // namespace granary::analysis
