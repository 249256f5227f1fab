// Parsing, validation and canonical serialisation of the resolved run spec (run_spec.h).
// Every error is a SpecError naming the JSON Pointer of the offending value, the value and
// what is allowed, so a user can fix a campaign without reading code.
// Keys, defaults and allowed values are documented in docs/run-spec.md.
#include "rundir/run_spec.h"
#include "rundir/json_pointer.h"

// GCC 12 reports a false -Warray-bounds inside nlohmann::json's object construction when
// JSON_DIAGNOSTICS is on (also seen in src/analysis); it is not a bug in this file.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"
#endif

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <utility>

#include "rundir/shape_table.h"

namespace granary {

using nlohmann::json;

SpecError::SpecError(std::string path, std::string message)
    : std::runtime_error(path + ": " + message), path_(std::move(path)), message_(std::move(message)) {}

// Levenshtein distance for "did you mean" suggestions.
std::string ForbiddenCharacterIn(const std::string& name, const std::string& extra) {
  char buf[64];
  for (std::size_t i = 0; i < name.size();) {
    const auto c = static_cast<unsigned char>(name[i]);
    // Decode one UTF-8 sequence (the JSON parser has checked it is valid UTF-8).
    std::uint32_t cp = c;
    std::size_t n = 1;
    if (c >= 0xF0) {
      n = 4;
      cp = c & 0x07u;
    } else if (c >= 0xE0) {
      n = 3;
      cp = c & 0x0Fu;
    } else if (c >= 0xC0) {
      n = 2;
      cp = c & 0x1Fu;
    }
    if (i + n > name.size()) return "an incomplete UTF-8 sequence";
    for (std::size_t k = 1; k < n; ++k) cp = (cp << 6) | (static_cast<unsigned char>(name[i + k]) & 0x3Fu);
    i += n;
    if (cp < 0x80 && extra.find(static_cast<char>(cp)) != std::string::npos) {
      std::snprintf(buf, sizeof buf, "'%c'", static_cast<char>(cp));
      return buf;
    }
    const char* what = nullptr;
    if (cp == 0x00)
      what = "NUL";
    else if (cp == 0x0A)
      what = "LINE FEED";
    else if (cp == 0x0D)
      what = "CARRIAGE RETURN";
    else if (cp == 0x09)
      what = "TAB";
    else if (cp == 0x0B)
      what = "LINE TABULATION (\\v)";
    else if (cp == 0x0C)
      what = "FORM FEED (\\f)";
    else if (cp < 0x20 || cp == 0x7F)
      what = "a control character";
    else if (cp == 0x85)
      what = "NEXT LINE";
    else if (cp >= 0x80 && cp <= 0x9F)
      what = "a control character";
    else if (cp == 0x2028)
      what = "LINE SEPARATOR";
    else if (cp == 0x2029)
      what = "PARAGRAPH SEPARATOR";
    else if ((cp >= 0x200B && cp <= 0x200F) || (cp >= 0x202A && cp <= 0x202E) || (cp >= 0x2066 && cp <= 0x2069) ||
             cp == 0xFEFF)
      what = "an invisible format character";
    if (what) {
      std::snprintf(buf, sizeof buf, "U+%04X (%s)", cp, what);
      return buf;
    }
  }
  return "";
}

std::size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0u : 1u)});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string EscapePointerToken(const std::string& token) {
  std::string out;
  for (char c : token) {
    if (c == '~')
      out += "~0";
    else if (c == '/')
      out += "~1";
    else
      out += c;
  }
  return out;
}

namespace {

// A value as it appears in JSON, for messages ("got -3", "got \"abc\"").
std::string Shown(const json& v) { return v.dump(); }
std::string Shown(double v) { return json(v).dump(); }

std::string TypeName(const json& v) {
  if (v.is_number()) return "number";
  return v.type_name();
}

std::string Quoted(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i) out += ", ";
    out += "\"" + names[i] + "\"";
  }
  return out;
}

std::string UnknownKeyMessage(const std::string& key, const std::vector<std::string>& allowed) {
  std::string best;
  std::size_t best_d = std::numeric_limits<std::size_t>::max();
  for (const auto& a : allowed) {
    const std::size_t d = EditDistance(key, a);
    if (d < best_d) {
      best_d = d;
      best = a;
    }
  }
  // A suggestion further than this is noise; list the allowed keys instead.
  if (!best.empty() && best_d <= std::max<std::size_t>(2, best.size() / 3)) {
    return "unknown key; did you mean \"" + best + "\"?";
  }
  return "unknown key; allowed: " + Quoted(allowed);
}

// A JSON object being read: checks for unknown keys up front (the keys of RunSpecTable()
// at this place) and hands out typed values with their JSON Pointer for error messages; the
// type each key must have is the table's too.
class Reader {
 public:
  Reader(const json& j, std::string path) : j_(j), path_(std::move(path)) {
    if (!j.is_object()) {
      throw SpecError(path_.empty() ? "/" : path_, "must be an object (got " + TypeName(j) + ")");
    }
    const std::vector<std::string> keys = RunSpecTable().Keys(SpecPattern(path_));
    for (const auto& [key, value] : j.items()) {
      if (std::find(keys.begin(), keys.end(), key) == keys.end()) {
        throw SpecError(Path(key), UnknownKeyMessage(key, keys));
      }
    }
  }

  std::string Path(const std::string& key) const { return path_ + "/" + EscapePointerToken(key); }
  bool Has(const std::string& key) const { return j_.contains(key); }
  const json& At(const std::string& key) const { return j_.at(key); }

  void Number(const std::string& key, double& out) const {
    Expect(key, SpecType::kNumber);
    if (!Has(key)) return;
    const json& v = j_.at(key);
    if (!v.is_number()) throw SpecError(Path(key), "must be a number (got " + Shown(v) + ")");
    out = v.get<double>();
    if (!std::isfinite(out)) throw SpecError(Path(key), "must be finite (got " + Shown(v) + ")");
  }
  void Integer(const std::string& key, int& out) const {
    Expect(key, SpecType::kInteger);
    if (!Has(key)) return;
    const json& v = j_.at(key);
    if (!v.is_number_integer() || v.get<std::int64_t>() > std::numeric_limits<int>::max() ||
        v.get<std::int64_t>() < std::numeric_limits<int>::min()) {
      throw SpecError(Path(key), "must be an integer (got " + Shown(v) + ")");
    }
    out = v.get<int>();
  }
  void Unsigned(const std::string& key, std::uint64_t& out) const {
    Expect(key, SpecType::kUnsigned);
    if (!Has(key)) return;
    const json& v = j_.at(key);
    // A signed integer >= 0 is fine too (JSON built in code rather than parsed from text).
    if (!v.is_number_unsigned() && !(v.is_number_integer() && v.get<std::int64_t>() >= 0)) {
      throw SpecError(Path(key), "must be a non-negative integer (got " + Shown(v) + ")");
    }
    out = v.get<std::uint64_t>();
  }
  void Bool(const std::string& key, bool& out) const {
    Expect(key, SpecType::kBoolean);
    if (!Has(key)) return;
    const json& v = j_.at(key);
    if (!v.is_boolean()) throw SpecError(Path(key), "must be true or false (got " + Shown(v) + ")");
    out = v.get<bool>();
  }
  void String(const std::string& key, std::string& out) const {
    Expect(key, SpecType::kString);
    if (!Has(key)) return;
    const json& v = j_.at(key);
    if (!v.is_string()) throw SpecError(Path(key), "must be a string (got " + Shown(v) + ")");
    out = v.get<std::string>();
  }
  template <typename E, typename Table>
  void Enum(const std::string& key, E& out, const Table& table) const {
    Expect(key, SpecType::kEnum);
    if (!Has(key)) return;
    const json& v = j_.at(key);
    std::vector<std::string> names;
    for (const auto& [name, value] : table) names.push_back(name);
    if (v.is_string()) {
      for (const auto& [name, value] : table) {
        if (v.get<std::string>() == name) {
          out = value;
          return;
        }
      }
    }
    throw SpecError(Path(key), "must be one of " + Quoted(names) + " (got " + Shown(v) + ")");
  }
  const json& Array(const std::string& key) const {
    Expect(key, SpecType::kArray);
    const json& v = j_.at(key);
    if (!v.is_array()) throw SpecError(Path(key), "must be an array (got " + TypeName(v) + ")");
    return v;
  }

 private:
  // The code reads each key as the type the table gives it (a mismatch is a bug here).
  void Expect(const std::string& key, SpecType type) const {
    if (RunSpecTable().At(SpecPattern(Path(key))).type != type)
      throw std::logic_error("run spec table: " + Path(key) + " is read with another type than the table's");
  }
  const json& j_;
  std::string path_;
};

// The spec's shape names, from the shape table.
std::vector<std::pair<const char*, Shape>> ShapeNames() {
  std::vector<std::pair<const char*, Shape>> names;
  for (const ShapeRow& row : ShapeTable()) names.emplace_back(row.name, row.shape);
  return names;
}

// "disc, dumbbell, snowman or rod": the shapes for the spec table's description.
std::string ShapeChoices() {
  std::string out;
  const std::vector<ShapeRow>& table = ShapeTable();
  for (std::size_t k = 0; k < table.size(); ++k)
    out += (k == 0 ? "" : k + 1 == table.size() ? " or " : ", ") + std::string(table[k].name);
  return out;
}
constexpr std::initializer_list<std::pair<const char*, DischargeMode>> kModes = {
    {"remove", DischargeMode::kRemove}, {"reinject", DischargeMode::kReinject}};
constexpr std::initializer_list<std::pair<const char*, ReinjectPosition>> kReinjectPositions = {
    {"random", ReinjectPosition::kRandom}, {"periodic", ReinjectPosition::kPeriodic}};
constexpr std::initializer_list<std::pair<const char*, FrameFormat>> kFrameFormats = {{"text", FrameFormat::kText},
                                                                                      {"gsd", FrameFormat::kGsd}};
constexpr std::initializer_list<std::pair<const char*, OnClog>> kOnClogs = {
    {"stop", OnClog::kStop}, {"wait", OnClog::kWait}, {"unclog", OnClog::kUnclog}};
constexpr std::initializer_list<std::pair<const char*, UnclogMethod>> kUnclogMethods = {
    {"remove_arch", UnclogMethod::kRemoveArch}, {"kick", UnclogMethod::kKick}};
constexpr std::initializer_list<std::pair<const char*, UnclogFallback>> kUnclogFallbacks = {
    {"none", UnclogFallback::kNone}, {"kick", UnclogFallback::kKick}};
constexpr std::initializer_list<std::pair<const char*, NextBatch>> kNextBatches = {{"landed", NextBatch::kLanded},
                                                                                   {"fixed", NextBatch::kFixed}};
constexpr std::initializer_list<std::pair<const char*, BedSettler>> kSettlers = {{"native", BedSettler::kNative},
                                                                                 {"lammps", BedSettler::kLammps}};
constexpr std::initializer_list<std::pair<const char*, NormalModel>> kNormalModels = {{"hertz", NormalModel::kHertz},
                                                                                      {"hooke", NormalModel::kHooke}};
constexpr std::initializer_list<std::pair<const char*, TangentialCap>> kCaps = {{"lammps", TangentialCap::kLammps},
                                                                                {"liggghts", TangentialCap::kLiggghts}};
constexpr std::initializer_list<std::pair<const char*, Wall>> kWalls = {{"left", Wall::kLeft}, {"right", Wall::kRight}};

// The run spec's keys (docs/run-spec.md). Types and ranges here are all the validator knows of
// single values; Validate() adds the checks that relate several values.
SpecTable MakeRunSpecTable() {
  using T = SpecType;
  const SpecBound positive{0.0, true}, non_negative{0.0, false};
  auto names = [](const auto& table) {
    std::vector<std::string> v;
    for (const auto& [name, value] : table) v.push_back(name);
    return v;
  };
  auto number = [](std::string p, json def, std::optional<SpecBound> min, std::string what) {
    SpecField f{std::move(p), T::kNumber, std::move(what), std::move(def)};
    f.minimum = min;
    return f;
  };
  auto integer = [](std::string p, json def, double min, std::string what) {
    SpecField f{std::move(p), T::kInteger, std::move(what), std::move(def)};
    f.minimum = SpecBound{min, false};
    return f;
  };
  auto enumeration = [](std::string p, json def, std::vector<std::string> values, std::string what) {
    SpecField f{std::move(p), T::kEnum, std::move(what), std::move(def)};
    f.values = std::move(values);
    return f;
  };
  auto plain = [](std::string p, T type, json def, std::string what) {
    return SpecField{std::move(p), type, std::move(what), std::move(def)};
  };
  SpecField species{"/bodies/species", T::kArray, "the kinds of body in the bed (number fractions sum to 1)",
                    json::array({{{"name", "dumbbell"},
                                  {"shape", "dumbbell"},
                                  {"fraction", 1.0},
                                  {"diameter", 1.0},
                                  {"big_diameter", 1.0},
                                  {"n", 2}}})};
  species.min_items = 1;
  SpecField fraction = number("/bodies/species/*/fraction", 1.0, non_negative, "number fraction among all bodies");
  fraction.maximum = SpecBound{1.0, false};
  return SpecTable({
      plain("/run_id", T::kString, "", "set by the runner: the hash of the resolved parameters"),
      plain("/seed", T::kUnsigned, 1, "bed and reinjection randomness (the runner sets it per replica)"),
      enumeration("/engine", "native", {"native", "liggghts", "lammps"}, "the engine that runs it"),
      number("/time_step", 1e-4, positive, "integration time step, in sqrt(d/g)"),
      number("/gravity", 1.0, positive, "g"),
      plain("/silo", T::kObject, nullptr, "the silo: side walls at x = +-width/2, base at y = 0"),
      number("/silo/width", 100.0, positive, "distance between the side walls, in d (larger than the longest body)"),
      number("/silo/height", 0.0, non_negative, "side-wall height in d; 0 = tall enough for the bed"),
      plain("/silo/base_outlets", T::kArray, json::array({{{"center", 0.0}, {"width", 10.0}}}),
            "outlets in the base ([] only with side outlets)"),
      plain("/silo/base_outlets/*", T::kObject, nullptr, "an outlet in the base"),
      number("/silo/base_outlets/*/center", 0.0, std::nullopt, "x of its centre, in d; it must lie inside the base"),
      number("/silo/base_outlets/*/width", 10.0, positive, "W, in d; less than the silo width, no overlaps"),
      plain("/silo/side_outlets", T::kArray, json::array(), "outlets in the side walls"),
      plain("/silo/side_outlets/*", T::kObject, nullptr, "an outlet in a side wall"),
      enumeration("/silo/side_outlets/*/wall", "right", names(kWalls), "which wall"),
      number("/silo/side_outlets/*/bottom", 3.5, non_negative, "height of its lower edge above the base, in d"),
      number("/silo/side_outlets/*/width", 25.0, positive, "its height, in d; the top below silo/height when set"),
      plain("/silo/obstacles", T::kArray, json::array(), "circular obstacles"),
      plain("/silo/obstacles/*", T::kObject, nullptr, "a circular obstacle; it must not cross a wall or the base"),
      number("/silo/obstacles/*/x", 0.0, std::nullopt, "x of its centre, in d"),
      number("/silo/obstacles/*/y", 10.0, std::nullopt, "height of its centre above the base, in d"),
      number("/silo/obstacles/*/diameter", 6.0, positive, "in d"),
      plain("/bodies", T::kObject, nullptr, "the bed"),
      integer("/bodies/count", 1000, 1, "number of bodies"),
      number("/bodies/density", 1.0, positive, "areal density: disc mass = rho pi r^2"),
      species,
      plain("/bodies/species/*", T::kObject, nullptr, "one kind of body"),
      plain(
          "/bodies/species/*/name", T::kString, nullptr,
          "label in events.csv and the report: unique, no commas or line breaks (default: the shape, rod<n> for rods)"),
      enumeration("/bodies/species/*/shape", "dumbbell", names(ShapeNames()), ShapeChoices() + " of discs"),
      fraction,
      number("/bodies/species/*/diameter", 1.0, positive, "disc: D; dumbbell: d; snowman: D_s; rod: each disc"),
      number("/bodies/species/*/big_diameter", 1.0, positive, "snowman only: D_b, with D_b/D_s in [1, 2]"),
      integer("/bodies/species/*/n", 2, 2, "rod only: number of discs in a line"),
      plain("/contact", T::kObject, nullptr, "the contact law (docs/model.md)"),
      number("/contact/kn", 2.0e6, positive, "normal stiffness"),
      number("/contact/kt", 2.45e6, positive, "tangential stiffness"),
      number("/contact/gamma_n", 1000.0, non_negative, "normal damping"),
      number("/contact/gamma_t", 1000.0, non_negative, "tangential damping"),
      number("/contact/mu", 0.5, non_negative, "friction between bodies"),
      number("/contact/mu_wall", nullptr, non_negative, "friction with walls and obstacles (default: mu)"),
      enumeration("/contact/normal_model", "hertz", names(kNormalModels),
                  "hertz: F_n ~ sqrt(R_eff delta) delta (gran/hertz/history); hooke: linear spring-dashpot "
                  "(gran/hooke/history)"),
      enumeration("/contact/tangential_cap", "lammps", names(kCaps),
                  "lammps: the Coulomb cap on spring + damping; liggghts: on the spring part only"),
      plain("/contact/clip_normal", T::kBoolean, false, "clip an attractive normal force to zero"),
      plain("/bed", T::kObject, nullptr, "how the bed is prepared"),
      integer("/bed/batch_size", 500, 1, "bodies inserted per batch"),
      number("/bed/settle_ke_per_body", 1e-6, positive,
             "settled when the kinetic energy per body is below this (m g d)"),
      number("/bed/max_settle_time", 200.0, positive, "give up settling after this long"),
      number("/bed/time_step", 0.0, non_negative,
             "native engine: the bed-preparation time step; 0 = 8 x time_step (docs/run-spec.md)"),
      enumeration(
          "/bed/next_batch", "landed", names(kNextBatches),
          "native engine: the next batch once the previous has landed, or after the fixed wait sqrt(2 h/g) + 1"),
      enumeration("/bed/settled_by", "native", names(kSettlers),
                  "LAMMPS backend: its bed settled by the native engine (the native runs' bed) or by LAMMPS itself"),
      plain("/bed/cache_file", T::kString, "", "set by the runner: where the prepared bed is kept"),
      plain("/discharge", T::kObject, nullptr, "the discharge after the outlets open"),
      enumeration("/discharge/mode", "remove", names(kModes),
                  "remove: bodies that leave are gone; reinject: they come back on top"),
      number("/discharge/max_time", 100.0, positive, "stop at this time after the opening"),
      plain("/discharge/stop_on_clog", T::kBoolean, true,
            "stop at the first clog (false: wait for the flow to resume); the older spelling of on_clog stop/wait"),
      enumeration("/discharge/on_clog", "stop", names(kOnClogs),
                  "at a clog: stop the run; wait for the flow to resume by itself; or unclog (break the arch, go on)"),
      plain("/discharge/unclog", T::kObject, nullptr, "on_clog \"unclog\": how a clog is broken and when the run ends"),
      enumeration("/discharge/unclog/method", "remove_arch", names(kUnclogMethods),
                  "remove_arch: take out the bodies of the arch that seals the outlet; kick: give the bodies near the "
                  "outlet a random upward velocity, again until the flow resumes"),
      integer("/discharge/unclog/max_clogs", 100, 1, "the run ends at this clog (it is not broken)"),
      integer(
          "/discharge/unclog/max_attempts", 10, 1,
          "attempts on one clog (kicks, or arch removals that re-clog before a body leaves) before the run ends clogged"),
      number("/discharge/unclog/kick_speed", 1.0, positive,
             "kick (and the kick fallback): the speed each body gets, in sqrt(g d)"),
      number("/discharge/unclog/kick_radius", 0.0, non_negative,
             "kick (and the kick fallback): bodies whose centre is within this of an outlet's centre, in d; 0 = the "
             "outlet's width"),
      enumeration("/discharge/unclog/fallback", "none", names(kUnclogFallbacks),
                  "remove_arch only: an attempt that finds no arch to take out (no arch seals the stalled outlet) "
                  "kicks instead (kick_speed, kick_radius); none: it takes out nothing, and max_attempts such "
                  "attempts end the run clogged"),
      number("/discharge/clog_window", 5.0, positive, "a clog: no exit for this long ..."),
      number("/discharge/clog_ke_per_body", 1e-4, non_negative,
             "... and kinetic energy per body near the outlets below this (m g d)"),
      number(
          "/discharge/reinject_speed", 0.0, non_negative,
          "reinject: least downward speed of a returned body (it sinks with the body it is put on when that is faster)"),
      enumeration("/discharge/reinject_position", "random", names(kReinjectPositions),
                  "random: a free place on top of the bed (the thesis); periodic: through the bottom of a y-periodic "
                  "box, as LIGGGHTS does (not with side outlets)"),
      number("/discharge/periodic_headroom", 1.0, non_negative, "room above the bed in the periodic box, in d"),
      number("/discharge/exit_distance", 2.0, non_negative,
             "a body has left when its centre is this far past the outlet"),
      plain("/output", T::kObject, nullptr, "what the engine writes"),
      number("/output/frame_interval", 0.0, non_negative, "time between frames (0 = no frames)"),
      plain("/output/contact_forces", T::kBoolean, false, "also contact-force frames"),
      integer("/output/contact_interval", 1, 1, "contact-force frames at every k-th frame only"),
      plain("/output/compress", T::kBoolean, false, "gzip the frames (text format)"),
      enumeration("/output/format", "text", names(kFrameFormats),
                  "text: LAMMPS text dumps (frames.dump, contacts.dump); gsd: GSD, HOOMD's binary format "
                  "(frames.gsd, contacts.gsd), about a tenth of the bytes"),
      number("/output/checkpoint_interval", 10.0, non_negative, "time between checkpoints (0 = none)"),
  });
}

}  // namespace

const SpecTable& RunSpecTable() {
  static const SpecTable kTable = MakeRunSpecTable();
  return kTable;
}

namespace {

// The table's range for the value at `pointer` (a concrete JSON Pointer).
void CheckBounds(const std::string& pointer, double v) {
  const std::string problem = SpecBoundError(RunSpecTable().At(SpecPattern(pointer)), v);
  if (!problem.empty()) throw SpecError(pointer, problem + " (got " + Shown(v) + ")");
}
void CheckBounds(const std::string& pointer, int v) {
  const std::string problem = SpecBoundError(RunSpecTable().At(SpecPattern(pointer)), v);
  if (!problem.empty()) throw SpecError(pointer, problem + " (got " + std::to_string(v) + ")");
}

void CheckUnclogBounds(const Unclog& u) {
  CheckBounds("/discharge/unclog/max_clogs", u.max_clogs);
  CheckBounds("/discharge/unclog/max_attempts", u.max_attempts);
  CheckBounds("/discharge/unclog/kick_speed", u.kick_speed);
  CheckBounds("/discharge/unclog/kick_radius", u.kick_radius);
}

std::string DefaultSpeciesName(const Species& s) {
  return ShapeText(ShapeRowOf(s.shape).default_name, [&](const std::string& key) {
    if (key == "n") return std::to_string(s.n);
    throw std::logic_error("shape table: default name of " + ToString(s.shape) + " uses {" + key + "}");
  });
}

Species ParseSpecies(const json& j, const std::string& path) {
  Reader r(j, path);
  Species s;
  r.Enum("shape", s.shape, ShapeNames());
  r.Number("fraction", s.fraction);
  r.Number("diameter", s.diameter);
  r.Number("big_diameter", s.big_diameter);
  r.Integer("n", s.n);
  s.name = DefaultSpeciesName(s);
  r.String("name", s.name);
  // The name is the `shape` column of events.csv and a label in dumps and reports.
  if (const std::string bad = ForbiddenCharacterIn(s.name, ","); s.name.empty() || !bad.empty())
    throw SpecError(path + "/name",
                    "must be a non-empty name without commas, control characters or line breaks "
                    "(it is a column of events.csv) (got " +
                        json(s.name).dump() + (bad.empty() ? "" : ", which holds " + bad) + ")");
  return s;
}

void ParseBodies(const Reader& parent, Bodies& b) {
  if (!parent.Has("bodies")) {
    b.species = {Species{}};
    b.species[0].name = DefaultSpeciesName(b.species[0]);
    return;
  }
  const std::string path = parent.Path("bodies");
  Reader r(parent.At("bodies"), path);
  r.Integer("count", b.count);
  r.Number("density", b.density);
  if (r.Has("species")) {
    const json& arr = r.Array("species");
    for (std::size_t i = 0; i < arr.size(); ++i) {
      b.species.push_back(ParseSpecies(arr[i], r.Path("species") + "/" + std::to_string(i)));
    }
  } else {
    b.species = {Species{}};
    b.species[0].name = DefaultSpeciesName(b.species[0]);
  }
}

void ParseSilo(const Reader& parent, Silo& s) {
  bool outlets_given = false;
  if (parent.Has("silo")) {
    Reader r(parent.At("silo"), parent.Path("silo"));
    r.Number("width", s.width);
    r.Number("height", s.height);
    if (r.Has("base_outlets")) {
      outlets_given = true;
      const json& arr = r.Array("base_outlets");
      for (std::size_t i = 0; i < arr.size(); ++i) {
        Reader o(arr[i], r.Path("base_outlets") + "/" + std::to_string(i));
        BaseOutlet out;
        o.Number("center", out.center);
        o.Number("width", out.width);
        s.base_outlets.push_back(out);
      }
    }
    if (r.Has("side_outlets")) {
      const json& arr = r.Array("side_outlets");
      for (std::size_t i = 0; i < arr.size(); ++i) {
        Reader o(arr[i], r.Path("side_outlets") + "/" + std::to_string(i));
        SideOutlet out;
        o.Enum("wall", out.wall, kWalls);
        o.Number("bottom", out.bottom);
        o.Number("width", out.width);
        s.side_outlets.push_back(out);
      }
    }
    if (r.Has("obstacles")) {
      const json& arr = r.Array("obstacles");
      for (std::size_t i = 0; i < arr.size(); ++i) {
        Reader o(arr[i], r.Path("obstacles") + "/" + std::to_string(i));
        Obstacle ob;
        o.Number("x", ob.x);
        o.Number("y", ob.y);
        o.Number("diameter", ob.diameter);
        s.obstacles.push_back(ob);
      }
    }
  }
  if (!outlets_given) s.base_outlets = {BaseOutlet{}};
}

}  // namespace

std::string ToString(Shape shape) { return ShapeRowOf(shape).name; }
std::string ToString(DischargeMode mode) {
  for (const auto& [name, value] : kModes) {
    if (value == mode) return name;
  }
  return "?";
}
std::string ToString(ReinjectPosition position) {
  for (const auto& [name, value] : kReinjectPositions) {
    if (value == position) return name;
  }
  return "?";
}
std::string ToString(FrameFormat format) {
  for (const auto& [name, value] : kFrameFormats) {
    if (value == format) return name;
  }
  return "?";
}
std::string ToString(NextBatch next) {
  for (const auto& [name, value] : kNextBatches) {
    if (value == next) return name;
  }
  return "?";
}
std::string ToString(BedSettler settler) {
  for (const auto& [name, value] : kSettlers) {
    if (value == settler) return name;
  }
  return "?";
}
std::string ToString(OnClog on_clog) {
  for (const auto& [name, value] : kOnClogs) {
    if (value == on_clog) return name;
  }
  return "?";
}
std::string ToString(UnclogMethod method) {
  for (const auto& [name, value] : kUnclogMethods) {
    if (value == method) return name;
  }
  return "?";
}
std::string ToString(UnclogFallback fallback) {
  for (const auto& [name, value] : kUnclogFallbacks) {
    if (value == fallback) return name;
  }
  return "?";
}
std::string ToString(NormalModel model) {
  for (const auto& [name, value] : kNormalModels) {
    if (value == model) return name;
  }
  return "?";
}
std::string ToString(TangentialCap cap) {
  for (const auto& [name, value] : kCaps) {
    if (value == cap) return name;
  }
  return "?";
}

RunSpec RunSpec::FromJson(const json& j) {
  Reader r(j, "");
  RunSpec s;
  r.String("run_id", s.run_id);
  r.Unsigned("seed", s.seed);
  if (r.Has("engine")) {
    const json& v = r.At("engine");
    if (!v.is_string() || (v != "native" && v != "liggghts" && v != "lammps")) {
      throw SpecError("/engine", "must be one of \"native\", \"liggghts\", \"lammps\" (got " + Shown(v) + ")");
    }
    s.engine = v.get<std::string>();
  }
  r.Number("time_step", s.time_step);
  r.Number("gravity", s.gravity);
  ParseSilo(r, s.silo);
  ParseBodies(r, s.bodies);
  if (r.Has("contact")) {
    Reader c(r.At("contact"), "/contact");
    c.Number("kn", s.contact.kn);
    c.Number("kt", s.contact.kt);
    c.Number("gamma_n", s.contact.gamma_n);
    c.Number("gamma_t", s.contact.gamma_t);
    c.Number("mu", s.contact.mu);
    s.contact.mu_wall = s.contact.mu;  // docs/model.md "Boundaries": wall friction defaults to mu
    c.Number("mu_wall", s.contact.mu_wall);
    c.Enum("normal_model", s.contact.normal_model, kNormalModels);
    c.Enum("tangential_cap", s.contact.tangential_cap, kCaps);
    c.Bool("clip_normal", s.contact.clip_normal);
  }
  if (r.Has("bed")) {
    Reader b(r.At("bed"), "/bed");
    b.Integer("batch_size", s.bed.batch_size);
    b.Number("settle_ke_per_body", s.bed.settle_ke_per_body);
    b.Number("max_settle_time", s.bed.max_settle_time);
    b.Number("time_step", s.bed.time_step);
    b.Enum("next_batch", s.bed.next_batch, kNextBatches);
    b.Enum("settled_by", s.bed.settled_by, kSettlers);
    b.String("cache_file", s.bed.cache_file);
  }
  if (r.Has("discharge")) {
    Reader d(r.At("discharge"), "/discharge");
    d.Enum("mode", s.discharge.mode, kModes);
    d.Number("max_time", s.discharge.max_time);
    bool stop_on_clog = true;
    d.Bool("stop_on_clog", stop_on_clog);
    s.discharge.on_clog = stop_on_clog ? OnClog::kStop : OnClog::kWait;
    if (d.Has("on_clog")) {
      d.Enum("on_clog", s.discharge.on_clog, kOnClogs);
      // Both spellings given: they must say the same.
      if (d.Has("stop_on_clog") && stop_on_clog != (s.discharge.on_clog == OnClog::kStop))
        throw SpecError("/discharge/stop_on_clog", "contradicts /discharge/on_clog \"" + ToString(s.discharge.on_clog) +
                                                       "\"; give only on_clog (got " + Shown(d.At("stop_on_clog")) +
                                                       ")");
    }
    if (d.Has("unclog")) {
      Reader u(d.At("unclog"), "/discharge/unclog");
      u.Enum("method", s.discharge.unclog.method, kUnclogMethods);
      u.Integer("max_clogs", s.discharge.unclog.max_clogs);
      u.Integer("max_attempts", s.discharge.unclog.max_attempts);
      u.Number("kick_speed", s.discharge.unclog.kick_speed);
      u.Number("kick_radius", s.discharge.unclog.kick_radius);
      u.Enum("fallback", s.discharge.unclog.fallback, kUnclogFallbacks);
      CheckUnclogBounds(s.discharge.unclog);
      // A kick that finds no body near the outlet is no empty arch removal: only remove_arch
      // falls back, and a fallback said for kick would be ignored.
      if (s.discharge.unclog.method != UnclogMethod::kRemoveArch &&
          s.discharge.unclog.fallback != UnclogFallback::kNone)
        throw SpecError("/discharge/unclog/fallback", "applies only to the method \"remove_arch\" (the method is \"" +
                                                          ToString(s.discharge.unclog.method) +
                                                          "\"); leave it out or give \"none\" (got \"" +
                                                          ToString(s.discharge.unclog.fallback) + "\")");
      // Said, but not used: never silently.
      if (s.discharge.on_clog != OnClog::kUnclog)
        throw SpecError("/discharge/unclog", "applies only with /discharge/on_clog \"unclog\" (on_clog is \"" +
                                                 ToString(s.discharge.on_clog) + "\")");
    }
    d.Number("clog_window", s.discharge.clog_window);
    d.Number("clog_ke_per_body", s.discharge.clog_ke_per_body);
    d.Number("reinject_speed", s.discharge.reinject_speed);
    d.Enum("reinject_position", s.discharge.reinject_position, kReinjectPositions);
    d.Number("periodic_headroom", s.discharge.periodic_headroom);
    d.Number("exit_distance", s.discharge.exit_distance);
  }
  if (r.Has("output")) {
    Reader o(r.At("output"), "/output");
    o.Number("frame_interval", s.output.frame_interval);
    o.Bool("contact_forces", s.output.contact_forces);
    o.Integer("contact_interval", s.output.contact_interval);
    o.Bool("compress", s.output.compress);
    o.Enum("format", s.output.format, kFrameFormats);
    o.Number("checkpoint_interval", s.output.checkpoint_interval);
  }
  Validate(s);
  return s;
}

void Validate(const RunSpec& s) {
  CheckBounds("/time_step", s.time_step);
  CheckBounds("/gravity", s.gravity);

  // Contact parameters (docs/model.md "Contact law"): stiffnesses positive, damping and friction >= 0.
  CheckBounds("/contact/kn", s.contact.kn);
  CheckBounds("/contact/kt", s.contact.kt);
  CheckBounds("/contact/gamma_n", s.contact.gamma_n);
  CheckBounds("/contact/gamma_t", s.contact.gamma_t);
  CheckBounds("/contact/mu", s.contact.mu);
  CheckBounds("/contact/mu_wall", s.contact.mu_wall);

  // Bodies.
  const Bodies& b = s.bodies;
  CheckBounds("/bodies/count", b.count);
  CheckBounds("/bodies/density", b.density);
  if (b.species.empty()) throw SpecError("/bodies/species", "must list at least one species (got [])");
  double fraction_sum = 0.0;
  double max_length = 0.0;
  double mean_area = 0.0;
  for (std::size_t i = 0; i < b.species.size(); ++i) {
    const Species& sp = b.species[i];
    const std::string p = "/bodies/species/" + std::to_string(i);
    CheckBounds(p + "/fraction", sp.fraction);
    CheckBounds(p + "/diameter", sp.diameter);
    CheckBounds(p + "/big_diameter", sp.big_diameter);
    CheckBounds(p + "/n", sp.n);
    if (const auto check = ShapeRowOf(sp.shape).check) check(sp, p);
    if (sp.name.empty()) throw SpecError(p + "/name", "must not be empty (got \"\")");
    for (std::size_t k = 0; k < i; ++k) {
      if (b.species[k].name == sp.name) {
        throw SpecError(p + "/name",
                        "duplicate species name (got \"" + sp.name + "\", also species " + std::to_string(k) + ")");
      }
    }
    fraction_sum += sp.fraction;
    max_length = std::max(max_length, BodyLength(sp));
    mean_area += sp.fraction * BodyArea(sp);
  }
  if (std::abs(fraction_sum - 1.0) > 1e-9) {
    throw SpecError("/bodies/species", "fractions must sum to 1 (got " + Shown(fraction_sum) + ")");
  }

  // Silo geometry: walls at x = +-width/2, base at y = 0 (docs/model.md "Units").
  const Silo& silo = s.silo;
  CheckBounds("/silo/width", silo.width);
  CheckBounds("/silo/height", silo.height);
  const double half = silo.width / 2.0;
  if (max_length >= silo.width) {
    throw SpecError("/silo/width",
                    "bodies of length " + Shown(max_length) + " cannot fit in a silo of width " + Shown(silo.width));
  }
  if (silo.height > 0) {
    // A random loose packing of discs fills ~80% of the area; a bed needing more than the silo
    // holds cannot be prepared.
    const double bed_area = b.count * mean_area / 0.8;
    if (bed_area > silo.width * silo.height) {
      throw SpecError("/silo/height", "the bed of " + std::to_string(b.count) + " bodies needs a height of about " +
                                          Shown(std::ceil(bed_area / silo.width)) + " (got " + Shown(silo.height) +
                                          ")");
    }
  }
  if (silo.base_outlets.empty() && silo.side_outlets.empty()) {
    throw SpecError("/silo/base_outlets", "the silo needs at least one outlet (got none)");
  }
  for (std::size_t i = 0; i < silo.base_outlets.size(); ++i) {
    const BaseOutlet& o = silo.base_outlets[i];
    const std::string p = "/silo/base_outlets/" + std::to_string(i);
    CheckBounds(p + "/width", o.width);
    if (o.width >= silo.width) {
      throw SpecError(p + "/width", "must be < the silo width " + Shown(silo.width) + " (got " + Shown(o.width) + ")");
    }
    const double lo = o.center - o.width / 2.0;
    const double hi = o.center + o.width / 2.0;
    if (lo < -half || hi > half) {
      throw SpecError(p, "outlet [" + Shown(lo) + ", " + Shown(hi) + "] lies outside the base [" + Shown(-half) + ", " +
                             Shown(half) + "]");
    }
    for (std::size_t k = 0; k < i; ++k) {
      const BaseOutlet& q = silo.base_outlets[k];
      if (lo < q.center + q.width / 2.0 && q.center - q.width / 2.0 < hi) {
        throw SpecError(p, "overlaps base outlet " + std::to_string(k) + " ([" + Shown(lo) + ", " + Shown(hi) +
                               "] and [" + Shown(q.center - q.width / 2.0) + ", " + Shown(q.center + q.width / 2.0) +
                               "])");
      }
    }
  }
  for (std::size_t i = 0; i < silo.side_outlets.size(); ++i) {
    const SideOutlet& o = silo.side_outlets[i];
    const std::string p = "/silo/side_outlets/" + std::to_string(i);
    CheckBounds(p + "/bottom", o.bottom);
    CheckBounds(p + "/width", o.width);
    if (silo.height > 0 && o.bottom + o.width > silo.height) {
      throw SpecError(p, "top " + Shown(o.bottom + o.width) + " is above the wall height " + Shown(silo.height));
    }
    for (std::size_t k = 0; k < i; ++k) {
      const SideOutlet& q = silo.side_outlets[k];
      if (q.wall == o.wall && o.bottom < q.bottom + q.width && q.bottom < o.bottom + o.width) {
        throw SpecError(p, "overlaps side outlet " + std::to_string(k) + " on the same wall");
      }
    }
  }
  for (std::size_t i = 0; i < silo.obstacles.size(); ++i) {
    const Obstacle& o = silo.obstacles[i];
    const std::string p = "/silo/obstacles/" + std::to_string(i);
    CheckBounds(p + "/diameter", o.diameter);
    const double r = o.diameter / 2.0;
    if (std::abs(o.x) + r > half) {
      throw SpecError(p, "obstacle at x = " + Shown(o.x) + " of diameter " + Shown(o.diameter) +
                             " crosses a side wall at x = +-" + Shown(half));
    }
    if (o.y - r < 0) {
      throw SpecError(
          p, "obstacle at y = " + Shown(o.y) + " of diameter " + Shown(o.diameter) + " crosses the base at y = 0");
    }
    if (silo.height > 0 && o.y + r > silo.height) {
      throw SpecError(p, "obstacle top " + Shown(o.y + r) + " is above the wall height " + Shown(silo.height));
    }
  }

  CheckBounds("/bed/batch_size", s.bed.batch_size);
  CheckBounds("/bed/settle_ke_per_body", s.bed.settle_ke_per_body);
  CheckBounds("/bed/max_settle_time", s.bed.max_settle_time);
  CheckBounds("/bed/time_step", s.bed.time_step);

  CheckBounds("/discharge/max_time", s.discharge.max_time);
  CheckBounds("/discharge/clog_window", s.discharge.clog_window);
  CheckBounds("/discharge/clog_ke_per_body", s.discharge.clog_ke_per_body);
  CheckBounds("/discharge/reinject_speed", s.discharge.reinject_speed);
  CheckBounds("/discharge/exit_distance", s.discharge.exit_distance);
  CheckBounds("/discharge/periodic_headroom", s.discharge.periodic_headroom);
  CheckUnclogBounds(s.discharge.unclog);
  if (s.discharge.mode == DischargeMode::kReinject && s.discharge.reinject_position == ReinjectPosition::kPeriodic &&
      !s.silo.side_outlets.empty())
    throw SpecError("/discharge/reinject_position",
                    "\"periodic\" returns bodies through the bottom of the box, which a body leaving through a side "
                    "outlet never reaches; use \"random\" with side outlets (got \"periodic\")");
  if (s.discharge.on_clog == OnClog::kUnclog && s.discharge.mode == DischargeMode::kReinject &&
      s.discharge.reinject_position == ReinjectPosition::kPeriodic &&
      s.discharge.unclog.method == UnclogMethod::kRemoveArch)
    throw SpecError("/discharge/unclog/method",
                    "remove_arch returns the arch's bodies on top of the bed, which the periodic box has no place for; "
                    "use reinject_position \"random\" or the method \"kick\" (got \"remove_arch\")");

  CheckBounds("/output/frame_interval", s.output.frame_interval);
  CheckBounds("/output/checkpoint_interval", s.output.checkpoint_interval);
  CheckBounds("/output/contact_interval", s.output.contact_interval);
  // Said, but not used: never silently.
  if (s.output.compress && s.output.format == FrameFormat::kGsd)
    throw SpecError("/output/compress",
                    "gzips text dumps; GSD frames are binary already (got true with format \"gsd\")");
  if (s.output.contact_interval != 1 && !s.output.contact_forces)
    throw SpecError("/output/contact_interval", "applies only with /output/contact_forces true (got " +
                                                    std::to_string(s.output.contact_interval) + ")");

  if (s.bed.settled_by == BedSettler::kLammps && s.engine != "lammps")
    throw SpecError("/bed/settled_by", "only the LAMMPS backend settles its bed in LAMMPS; the " + s.engine +
                                           " engine prepares its own (got \"lammps\", allowed: \"native\")");
  // What the LIGGGHTS backend cannot do is refused when the run is planned, not when it runs.
  if (s.engine == "liggghts") ValidateForLiggghts(s);
  if (s.engine == "lammps") ValidateForLammps(s);
}

namespace {
// The external engines' frames are converted to text dumps; GSD and the contact interval are
// the native engine's for now.
void ValidateExternalOutput(const RunSpec& s, const std::string& backend) {
  if (s.output.format != FrameFormat::kText)
    throw SpecError("/output/format", "the " + backend + " backend writes text dumps only (got \"" +
                                          ToString(s.output.format) + "\", allowed: \"text\")");
  if (s.output.contact_interval != 1)
    throw SpecError("/output/contact_interval", "the " + backend +
                                                    " backend writes a contact frame at every frame (got " +
                                                    std::to_string(s.output.contact_interval) + ", allowed: 1)");
}
}  // namespace

void ValidateForLammps(const RunSpec& s) {
  ValidateExternalOutput(s, "LAMMPS");
  if (s.discharge.on_clog == OnClog::kUnclog)
    throw SpecError("/discharge/on_clog",
                    "the LAMMPS backend cannot break a clog yet: it runs one LAMMPS input to the end, with no step "
                    "at which to take out an arch or kick the bodies over the outlet; use the native engine, or "
                    "\"stop\" or \"wait\" (got \"unclog\")");
  if (s.contact.clip_normal)
    throw SpecError("/contact/clip_normal",
                    "LAMMPS' pair gran/hertz/history and gran/hooke/history have no clipping "
                    "of an attractive normal force (got true, allowed: false)");
  if (s.discharge.mode == DischargeMode::kReinject && !s.silo.side_outlets.empty())
    throw SpecError("/discharge/mode",
                    "the LAMMPS backend reinjects through y-periodicity, which cannot return bodies that leave "
                    "through a side outlet; use \"remove\" with side outlets (got \"reinject\")");
}

void ValidateForLiggghts(const RunSpec& s) {
  ValidateExternalOutput(s, "LIGGGHTS");
  if (s.contact.normal_model != Contact{}.normal_model)
    throw SpecError("/contact/normal_model", "the LIGGGHTS backend writes model hertz/stiffness only; " +
                                                 ToString(s.contact.normal_model) + " is the native engine's (got \"" +
                                                 ToString(s.contact.normal_model) + "\", allowed: \"hertz\")");
  if (s.discharge.on_clog == OnClog::kUnclog)
    throw SpecError("/discharge/on_clog",
                    "the LIGGGHTS backend cannot break a clog: it runs LIGGGHTS' input script to the end, with no "
                    "step at which to take out an arch or kick the bodies over the outlet; use the native engine, or "
                    "\"stop\" or \"wait\" (got \"unclog\")");
  if (s.bed.next_batch != Bed{}.next_batch)
    throw SpecError("/bed/next_batch", "bed/next_batch is the native engine's (got \"" + ToString(s.bed.next_batch) +
                                           "\", allowed: the default)");
  if (s.bed.time_step != Bed{}.time_step)
    throw SpecError("/bed/time_step",
                    "the LIGGGHTS backend prepares its bed at time_step; bed/time_step is the "
                    "native engine's (got " +
                        Shown(s.bed.time_step) + ", allowed: 0)");
  if (s.discharge.mode == DischargeMode::kReinject && !s.silo.side_outlets.empty())
    throw SpecError("/discharge/mode",
                    "the LIGGGHTS backend reinjects through y-periodicity, which cannot return bodies that leave "
                    "through a side outlet; use \"remove\" with side outlets (got \"reinject\")");
}

namespace {

json SpeciesJson(const Species& sp) {
  return {{"name", sp.name},         {"shape", ToString(sp.shape)},     {"fraction", sp.fraction},
          {"diameter", sp.diameter}, {"big_diameter", sp.big_diameter}, {"n", sp.n}};
}

json BodiesJson(const Bodies& b) {
  json species = json::array();
  for (const auto& sp : b.species) species.push_back(SpeciesJson(sp));
  return {{"count", b.count}, {"species", species}, {"density", b.density}};
}

json ContactJson(const Contact& c) {
  json j = {{"kn", c.kn},
            {"kt", c.kt},
            {"gamma_n", c.gamma_n},
            {"gamma_t", c.gamma_t},
            {"mu", c.mu},
            {"mu_wall", c.mu_wall},
            {"tangential_cap", ToString(c.tangential_cap)},
            {"clip_normal", c.clip_normal}};
  // Only when not the default, so that run ids planned before this option existed stay valid.
  if (c.normal_model != Contact{}.normal_model) j["normal_model"] = ToString(c.normal_model);
  return j;
}

json BedJson(const Bed& b, bool with_cache_file) {
  json j = {{"batch_size", b.batch_size},
            {"settle_ke_per_body", b.settle_ke_per_body},
            {"max_settle_time", b.max_settle_time}};
  if (with_cache_file) j["cache_file"] = b.cache_file;
  // Only when not the default, so that run ids planned before this option existed stay valid.
  if (b.time_step != Bed{}.time_step) j["time_step"] = b.time_step;
  if (b.next_batch != Bed{}.next_batch) j["next_batch"] = ToString(b.next_batch);
  if (b.settled_by != Bed{}.settled_by) j["settled_by"] = ToString(b.settled_by);
  return j;
}

}  // namespace

json RunSpec::ToJson() const {
  json base = json::array();
  for (const auto& o : silo.base_outlets) base.push_back({{"center", o.center}, {"width", o.width}});
  json side = json::array();
  for (const auto& o : silo.side_outlets) {
    side.push_back({{"wall", o.wall == Wall::kLeft ? "left" : "right"}, {"bottom", o.bottom}, {"width", o.width}});
  }
  json obstacles = json::array();
  for (const auto& o : silo.obstacles) obstacles.push_back({{"x", o.x}, {"y", o.y}, {"diameter", o.diameter}});
  json out = {{"run_id", run_id},
              {"seed", seed},
              {"engine", engine},
              {"time_step", time_step},
              {"gravity", gravity},
              {"silo",
               {{"width", silo.width},
                {"height", silo.height},
                {"base_outlets", base},
                {"side_outlets", side},
                {"obstacles", obstacles}}},
              {"bodies", BodiesJson(bodies)},
              {"contact", ContactJson(contact)},
              {"bed", BedJson(bed, true)},
              {"discharge",
               {{"mode", ToString(discharge.mode)},
                {"max_time", discharge.max_time},
                {"stop_on_clog", discharge.StopOnClog()},
                {"clog_window", discharge.clog_window},
                {"clog_ke_per_body", discharge.clog_ke_per_body},
                {"reinject_speed", discharge.reinject_speed},
                {"exit_distance", discharge.exit_distance}}},
              {"output",
               {{"frame_interval", output.frame_interval},
                {"contact_forces", output.contact_forces},
                {"checkpoint_interval", output.checkpoint_interval}}}};
  // Only when not the default, so that run ids planned before this option existed stay valid.
  if (discharge.reinject_position != ReinjectPosition::kRandom)
    out["discharge"]["reinject_position"] = ToString(discharge.reinject_position);
  if (discharge.periodic_headroom != Discharge{}.periodic_headroom)
    out["discharge"]["periodic_headroom"] = discharge.periodic_headroom;
  if (output.compress) out["output"]["compress"] = true;
  // Only when not the default, so that run ids planned before these options existed stay valid.
  if (output.format != FrameFormat::kText) out["output"]["format"] = ToString(output.format);
  if (output.contact_interval != 1) out["output"]["contact_interval"] = output.contact_interval;
  // The unclog protocol only when chosen (stop and wait are stop_on_clog true and false), so
  // run ids planned before it existed stay valid.
  if (discharge.on_clog == OnClog::kUnclog) {
    out["discharge"]["on_clog"] = ToString(discharge.on_clog);
    out["discharge"]["unclog"] = {{"method", ToString(discharge.unclog.method)},
                                  {"max_clogs", discharge.unclog.max_clogs},
                                  {"max_attempts", discharge.unclog.max_attempts},
                                  {"kick_speed", discharge.unclog.kick_speed},
                                  {"kick_radius", discharge.unclog.kick_radius}};
    // Only when chosen, so that run ids planned before it existed stay valid (and a run.json
    // without it is what those runs did: no fallback).
    if (discharge.unclog.fallback != UnclogFallback::kNone)
      out["discharge"]["unclog"]["fallback"] = ToString(discharge.unclog.fallback);
  }
  return out;
}

json RunSpec::BedKey() const {
  // Everything the bed preparation (docs/model.md "A run", step 1) depends on, and nothing
  // about outlets or obstacles, so runs differing only in those share one prepared bed.
  // A LAMMPS run discharges the native engine's bed (docs/lammps.md): the same key, one bed.
  const std::string bed_engine =
      engine == "lammps" ? (bed.settled_by == BedSettler::kLammps ? "lammps" : "native") : engine;
  json key = {{"engine", bed_engine},         {"seed", seed},
              {"time_step", time_step},       {"gravity", gravity},
              {"silo_width", silo.width},     {"silo_height", silo.height},
              {"bodies", BodiesJson(bodies)}, {"contact", ContactJson(contact)},
              {"bed", BedJson(bed, false)}};
  // The native engine's bed depends on the step it is prepared at (the resolved value: a bed
  // prepared before bed/time_step existed, at time_step, is not taken for one at 8 x).
  if (bed_engine == "native") {
    key["bed"]["resolved_time_step"] = BedTimeStep();
    // Beds of before (fixed wait) are not taken for beds whose batches follow on landing, nor
    // beds landed by another criterion for these.
    key["bed"]["next_batch"] = ToString(bed.next_batch);
    if (bed.next_batch == NextBatch::kLanded) key["bed"]["landed_ke_per_body"] = kBedLandedKePerBody;
  }
  return key;
}

const std::vector<std::string>& ExtendableKeys() {
  static const std::vector<std::string> kEys = {"/discharge/max_time", "/discharge/unclog/max_clogs"};
  return kEys;
}

bool Extends(const nlohmann::json& from, const nlohmann::json& to) {
  if (!from.is_object() || !to.is_object()) return false;
  nlohmann::json a = from, b = to;
  bool raised = false;
  for (const std::string& key : ExtendableKeys()) {
    const nlohmann::json::json_pointer p(key);
    if (!a.contains(p) && !b.contains(p)) continue;  // a limit of a block neither has (no unclog protocol)
    if (!a.contains(p) || !b.contains(p) || !a.at(p).is_number() || !b.at(p).is_number()) return false;
    const double old_value = a.at(p).get<double>(), new_value = b.at(p).get<double>();
    if (new_value < old_value) return false;
    raised = raised || new_value > old_value;
    b[p] = a.at(p);
  }
  for (nlohmann::json* j : {&a, &b}) {
    j->erase("run_id");
    if (j->contains("bed") && (*j)["bed"].is_object()) (*j)["bed"].erase("cache_file");
  }
  return raised && a == b;
}

}  // namespace granary
