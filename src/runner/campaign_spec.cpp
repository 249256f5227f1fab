// Campaign spec parsing and sweep expansion; see campaign_spec.h and docs/campaign-spec.md.
#include "runner/campaign_spec.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "runner/slurm.h"
#include "rundir/json_pointer.h"
#include "runner/util.h"
#ifdef GRANARY_HAVE_ANALYSIS
#include "analysis/expectations.h"
#endif

namespace granary::runner {

using nlohmann::json;

void CheckKeys(const json& j, const std::string& path, const std::vector<std::string>& allowed) {
  if (!j.is_object())
    throw SpecError(path.empty() ? "/" : path, "must be an object (got " + std::string(j.type_name()) + ")");
  for (const auto& [key, value] : j.items()) {
    if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
    const std::string best = Nearest(key, allowed);
    std::string msg = "unknown key; ";
    if (!best.empty()) {
      msg += "did you mean \"" + best + "\"?";
    } else {
      msg += "allowed:";
      for (std::size_t i = 0; i < allowed.size(); ++i) msg += (i ? ", \"" : " \"") + allowed[i] + "\"";
    }
    throw SpecError(path + "/" + EscapePointerToken(key), msg);
  }
}

namespace {

void CheckPointer(const std::string& key, const std::string& path) {
  if (key.empty() || key[0] != '/') {
    throw SpecError(path,
                    "an axis must be a JSON Pointer into the run spec such as \"/silo/width\" (got \"" + key + "\")");
  }
}

void CheckAxisArray(const json& v, const std::string& path) {
  if (!v.is_array() || v.empty()) {
    throw SpecError(path, "must be a non-empty array of values (got " + v.dump() + ")");
  }
}

// Applies a sweep point to the canonical base; the pointer's parent must exist.
void Apply(json& params, const std::string& pointer, const json& value, const std::string& where) {
  json::json_pointer ptr;
  try {
    ptr = json::json_pointer(pointer);
  } catch (const json::exception&) {
    throw SpecError(where, "not a valid JSON Pointer (got \"" + pointer + "\")");
  }
  if (!params.contains(ptr.parent_pointer())) {
    throw SpecError(where, "\"" + ptr.parent_pointer().to_string() + "\" does not exist in the run spec");
  }
  params[ptr] = value;
}

SpecTable MakeCampaignSpecTable() {
  using T = SpecType;
  SpecField name{"/name", T::kString, "the campaign's name"};
  name.required = true;
  name.min_length = 1;
  // An integer or the adaptive block (rundir/replica_rule.h, which validates it; the schema's
  // oneOf is written by CampaignSpecSchema()).
  SpecField replicas{"/replicas", T::kOpenObject,
                     "runs per sweep point, differing only in their seed: N, or {\"min\": N, \"max\": M, \"until\": "
                     "{\"metric\": NAME, \"rel_se\" | \"se\": X}} (more replicas until the metric's standard error "
                     "reaches the target; docs/campaign-spec.md)"};
  SpecField engine{"/engine", T::kEnumOrList,
                   "native, liggghts, lammps, or several as a list: every sweep point is then planned once per engine",
                   "native"};
  engine.values = {"native", "liggghts", "lammps"};
  SpecField size{"/size", T::kEnum,
                 "the campaign's size: quick (minutes, for trying), medium (the thesis' trends) or full (the "
                 "thesis' system and statistics); /expect is judged at full size only (docs/analyses.md)"};
  size.values = {"quick", "medium", "full"};
  return SpecTable({
      {"/$schema", T::kString, "the JSON Schema an editor checks this file with (campaign schema); ignored by Granary"},
      name,
      {"/description", T::kString, "free text: what the campaign is for", ""},
      {"/seed", T::kUnsigned, "the source of every replica's seed", 1},
      size,
      replicas,
      engine,
      {"/base", T::kRunSpec, "the run spec every run starts from (docs/run-spec.md); missing keys take their defaults"},
      {"/sweep", T::kObject, "points = grid x zip rows x explicit points; each run `replicas` times"},
      {"/sweep/grid", T::kAxisValues, "{axis: [values]}: the cartesian product, first axis slowest"},
      {"/sweep/zip", T::kAxisValues, "{axis: [values]}: paired lists of equal length"},
      {"/sweep/points", T::kAxisPoints, "[{axis: value, ...}]: explicit points"},
      {"/axes", T::kOpenObject,
       "derived axes {name: expression over the sweep axes' short names}, e.g. {\"D_eq\": \"sqrt(1 + D_b^2)\"}: usable "
       "in --only, the export and /report/figures (docs/campaign-spec.md)"},
      {"/report", T::kOpenObject, "report options, checked by the analysis library (docs/analyses.md)"},
      {"/expect", T::kArray,
       "expected values with their source, judged in the report's Key results and campaign export --expectations "
       "(docs/analyses.md)"},
      {"/expect/*", T::kOpenObject,
       "{\"metric\", \"at\": {axis: value}, \"value\", \"tolerance\", \"source\"} or {\"fit\": figure, \"parameter\", "
       "\"value\", ...}"},
      {"/executor", T::kOpenObject,
       "where runs go: {\"type\": \"local\"} or {\"type\": \"slurm\", ...} with the options of campaign run "
       "--executor slurm (docs/slurm.md); command-line flags win"},
  });
}

// Line and column (1-based) of byte `offset` of `text`.
std::pair<std::size_t, std::size_t> LineColumn(const std::string& text, std::size_t offset) {
  std::size_t line = 1, column = 1;
  for (std::size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return {line, column};
}

std::vector<std::string> Tokens(const std::string& pointer) {
  json::json_pointer p(pointer);  // (throws for a malformed pointer)
  std::vector<std::string> out;
  for (; !p.empty(); p.pop_back()) out.push_back(p.back());
  std::reverse(out.begin(), out.end());
  return out;
}

// Whether `a` is `b` or addresses a part of it (a JSON Pointer prefix at a token boundary).
bool Within(const std::string& a, const std::string& b) {
  return a == b || (a.size() > b.size() && a.compare(0, b.size(), b) == 0 && a[b.size()] == '/');
}

// The axis `pointer` must address a place in the resolved run spec: every parent an object
// that has the key, or an array with the index; the last token may add a key to an object or
// an element at the end of an array. `where` is the axis' path in the campaign spec.
void CheckAxisResolves(const json& params, const std::string& pointer, const std::string& where) {
  std::vector<std::string> tokens;
  try {
    tokens = Tokens(pointer);
  } catch (const json::exception&) {
    throw SpecError(where, "not a valid JSON Pointer (got \"" + pointer + "\")");
  }
  const json* at = &params;
  std::string walked;
  for (std::size_t k = 0; k < tokens.size(); ++k) {
    const std::string& t = tokens[k];
    const bool last = k + 1 == tokens.size();
    const std::string here = walked.empty() ? "the run spec" : "\"" + walked + "\"";
    if (at->is_object()) {
      if (!at->contains(t)) {
        if (last) return;  // a new key: the run spec's own validation judges it
        // The closest key there, as the whole corrected axis.
        std::vector<std::string> keys;
        for (const auto& [key, value] : at->items()) keys.push_back(key);
        const std::string best = Nearest(t, keys);
        std::string hint;
        if (!best.empty()) {
          // (appended piece by piece: GCC 12 reports a false -Wrestrict on a + "/" + b, bug 105329)
          std::string fixed = walked;
          for (std::size_t j = k; j < tokens.size(); ++j) {
            fixed += '/';
            fixed += EscapePointerToken(j == k ? best : tokens[j]);
          }
          hint = "; did you mean \"";
          hint += fixed;
          hint += "\"?";
        }
        throw SpecError(where,
                        "axis \"" + pointer + "\" does not resolve: " + here + " has no key \"" + t + "\"" + hint);
      }
      at = &(*at)[t];
    } else if (at->is_array()) {
      const bool digits = !t.empty() && t.size() <= 9 && t.find_first_not_of("0123456789") == std::string::npos &&
                          (t == "0" || t[0] != '0');
      const std::size_t n = at->size();
      if (!digits || std::stoul(t) > n || (std::stoul(t) == n && !last))
        throw SpecError(where, "axis \"" + pointer + "\" does not resolve: " + here + " is an array of " +
                                   std::to_string(n) + " element" + (n == 1 ? "" : "s") + " (indices 0 to " +
                                   std::to_string(n) + "), not \"" + t + "\"");
      if (std::stoul(t) == n) return;
      at = &(*at)[std::stoul(t)];
    } else {
      throw SpecError(where, "axis \"" + pointer + "\" does not resolve: " + here + " is a " +
                                 std::string(at->is_number() ? "number" : at->type_name()) +
                                 ", not an object or array");
    }
    walked += "/" + EscapePointerToken(t);
  }
}

}  // namespace

const SpecTable& CampaignSpecTable() {
  static const SpecTable kTable = MakeCampaignSpecTable();
  return kTable;
}

json CampaignSpecSchema() {
  const SpecTable& campaign = CampaignSpecTable();
  // An axis is a JSON Pointer to a place of the run spec (the runner sets run_id and the cache).
  const std::string axes = RunSpecTable().PointerRegex({"/run_id", "/bed/cache_file"});
  json s = {{"$schema", "http://json-schema.org/draft-07/schema#"},
            {"title", "Granary campaign spec"},
            {"description",
             "A base run spec, sweeps over any of its parameters, and replicas (docs/campaign-spec.md). "
             "Generated by campaign schema from the tables the validator reads."}};
  s.update(campaign.JsonSchema("", axes));
  json run_spec = RunSpecTable().JsonSchema("", axes);
  run_spec["description"] = "a run spec (docs/run-spec.md): every key optional";
  s["definitions"] = {{"run_spec", run_spec}};
  if (s.contains("properties") && s["properties"].contains("replicas")) {
    const json target = {
        {"type", "object"},
        {"properties",
         {{"metric", {{"type", "string"}, {"pattern", "^[a-z0-9_]+$"}, {"description", "a point metric"}}},
          {"rel_se", {{"type", "number"}, {"exclusiveMinimum", 0}, {"description", "target se/|mean|"}}},
          {"se", {{"type", "number"}, {"exclusiveMinimum", 0}, {"description", "target se"}}}}},
        {"required", {"metric"}},
        {"oneOf", json::array({{{"required", {"rel_se"}}}, {{"required", {"se"}}}})},
        {"additionalProperties", false}};
    const json count = {{"type", "integer"}, {"minimum", 1}, {"maximum", 100000}};
    json& r = s["properties"]["replicas"];
    const json description = r.value("description", json(""));
    r = {{"description", description},
         {"default", 1},
         {"oneOf",
          json::array(
              {count,
               {{"type", "object"},
                {"properties",
                 {{"min", count},
                  {"max", count},
                  {"until",
                   {{"oneOf", json::array({target, {{"type", "array"}, {"minItems", 1}, {"items", target}}})}}}}},
                {"required", {"max", "until"}},
                {"additionalProperties", false}}})}};
  }
#ifdef GRANARY_HAVE_ANALYSIS
  // The blocks the analysis library reads, in detail.
  if (s.contains("properties")) {
    json& p = s["properties"];
    if (p.contains("axes")) p["axes"] = analysis::AxesJsonSchema();
    if (p.contains("expect")) p["expect"] = analysis::ExpectJsonSchema();
    if (p.contains("report")) p["report"]["properties"]["figures"] = analysis::FiguresJsonSchema();
  }
#endif
  return s;
}

json ParseSpecText(const std::string& text, const std::string& source) {
  // Nesting first: a parse and every later walk of the document recurse as deep as it is.
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxSpecDepth) {
        const auto [line, column] = LineColumn(text, i);
        throw std::invalid_argument(source + ":" + std::to_string(line) + ":" + std::to_string(column) +
                                    ": nested deeper than " + std::to_string(kMaxSpecDepth) +
                                    " levels (a campaign spec needs fewer than 10)");
      }
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    const auto [line, column] = LineColumn(text, e.byte > 0 ? e.byte - 1 : 0);
    std::string what = e.what();
    // "[json.exception.parse_error.101] parse error at line 3, column 17: syntax error ..."
    if (const auto colon = what.find(": "); what.rfind("[json.exception", 0) == 0 && colon != std::string::npos)
      what = what.substr(colon + 2);
    throw std::invalid_argument(source + ":" + std::to_string(line) + ":" + std::to_string(column) +
                                ": not valid JSON: " + what);
  } catch (const json::out_of_range& e) {
    // "[json.exception.out_of_range.406] number overflow parsing '1e400'": nlohmann gives no
    // position, so the number is found in the text (its first occurrence outside a string).
    const std::string what = e.what();
    const std::size_t open = what.find("parsing '");
    const std::size_t close = open == std::string::npos ? open : what.find('\'', open + 9);
    std::string number = close == std::string::npos ? std::string() : what.substr(open + 9, close - open - 9);
    std::size_t at = 0;
    bool quoted = false;
    for (std::size_t i = 0; !number.empty() && i < text.size(); ++i) {
      const char c = text[i];
      if (quoted) {
        if (c == '\\')
          ++i;
        else if (c == '"')
          quoted = false;
      } else if (c == '"') {
        quoted = true;
      } else if (text.compare(i, number.size(), number) == 0) {
        at = i;
        break;
      }
    }
    const auto [line, column] = LineColumn(text, at);
    throw std::invalid_argument(source + ":" + std::to_string(line) + ":" + std::to_string(column) + ": the number " +
                                (number.empty() ? std::string("here") : number) +
                                " is out of range (a JSON number must fit a double, magnitude below 1.8e308)");
  }
}

void ResolveSpecPaths(json& spec, const std::string& spec_file) {
  if (!spec.is_object() || !spec.contains("report") || !spec["report"].is_object()) return;
  json& report = spec["report"];
  if (!report.contains("python") || !report["python"].is_array()) return;
  const std::filesystem::path folder = std::filesystem::absolute(spec_file).parent_path();
  for (json& entry : report["python"]) {
    if (!entry.is_object() || !entry.contains("script") || !entry["script"].is_string()) continue;
    const std::filesystem::path script = entry["script"].get<std::string>();
    if (script.is_relative()) entry["script"] = (folder / script).lexically_normal().string();
  }
}

CampaignSpec CampaignSpec::FromJson(const json& j) {
  CheckKeys(j, "", CampaignSpecTable().Keys(""));
  CampaignSpec s;
  s.raw = j;
  if (!j.contains("name") || !j["name"].is_string() || j["name"].get<std::string>().empty()) {
    throw SpecError("/name",
                    "must be a non-empty string (got " + (j.contains("name") ? j["name"].dump() : "nothing") + ")");
  }
  s.name = j["name"];
  if (j.contains("$schema") && !j["$schema"].is_string())
    throw SpecError("/$schema", "must be a string (got " + j["$schema"].dump() + ")");
  if (const std::string bad = ForbiddenCharacterIn(s.name); !bad.empty())
    throw SpecError("/name", "must not hold control characters or line breaks (got " + j["name"].dump() +
                                 ", which holds " + bad + ")");
  if (j.contains("description")) {
    if (!j["description"].is_string())
      throw SpecError("/description", "must be a string (got " + j["description"].dump() + ")");
    s.description = j["description"];
  }
  if (j.contains("size")) {
    const std::vector<std::string>& known = CampaignSpecTable().At("/size").values;
    if (!j["size"].is_string() || std::find(known.begin(), known.end(), j["size"].get<std::string>()) == known.end())
      throw SpecError("/size", "must be \"quick\", \"medium\" or \"full\" (got " + j["size"].dump() + ")");
    s.size = j["size"];
  }
  if (j.contains("seed")) {
    if (!j["seed"].is_number_unsigned())
      throw SpecError("/seed", "must be a non-negative integer (got " + j["seed"].dump() + ")");
    s.seed = j["seed"];
  }
  if (j.contains("replicas")) {
    s.replica_rule = ReplicaRule::FromJson(j["replicas"], "/replicas");
    s.replicas = s.replica_rule.min;
  }
  if (j.contains("engine")) {
    const json& e = j["engine"];
    const auto bad = [&] {
      return SpecError(
          "/engine",
          "must be \"native\", \"liggghts\", \"lammps\" or a list of them, e.g. [\"native\", \"lammps\"] (got " +
              e.dump() + ")");
    };
    s.engines.clear();
    const std::vector<std::string>& known = CampaignSpecTable().At("/engine").values;
    for (const json& one : e.is_array() ? e : json::array({e})) {
      if (!one.is_string() || std::find(known.begin(), known.end(), one.get<std::string>()) == known.end()) throw bad();
      if (std::find(s.engines.begin(), s.engines.end(), one) != s.engines.end()) throw bad();
      s.engines.push_back(one);
    }
    if (s.engines.empty()) throw bad();
  }
  if (j.contains("base")) {
    if (!j["base"].is_object())
      throw SpecError("/base", "must be an object (got " + std::string(j["base"].type_name()) + ")");
    s.base = j["base"];
  }
  // The engine is set in one place: the campaign's "engine", or else /base/engine.
  if (s.base.contains("engine")) {
    const json& e = s.base["engine"];
    if (!e.is_string() || (e != "native" && e != "liggghts" && e != "lammps"))
      throw SpecError("/base/engine", "must be \"native\", \"liggghts\" or \"lammps\" (got " + e.dump() + ")");
    if (!j.contains("engine")) {
      s.engines = {e.get<std::string>()};
    } else if (s.engines != std::vector<std::string>{e.get<std::string>()}) {
      throw SpecError("/base/engine", e.dump() + " conflicts with the campaign's \"engine\" " + j["engine"].dump() +
                                          "; set the engine in one place (the campaign's \"engine\")");
    }
  }
  if (j.contains("executor")) {
    SlurmOptions unused;
    ParseExecutorBlock(j["executor"], "/executor", unused);
    s.executor = j["executor"];
  }
  if (j.contains("report") && !j["report"].is_object()) {
    throw SpecError("/report", "must be an object (got " + std::string(j["report"].type_name()) + ")");
  }
  if (j.contains("sweep")) {
    const json& sw = j["sweep"];
    CheckKeys(sw, "/sweep", CampaignSpecTable().Keys("/sweep"));
    if (sw.contains("grid")) {
      if (!sw["grid"].is_object()) throw SpecError("/sweep/grid", "must be an object of axis -> values");
      for (const auto& [key, values] : sw["grid"].items()) {
        const std::string path = "/sweep/grid/" + EscapePointerToken(key);
        CheckPointer(key, path);
        CheckAxisArray(values, path);
        s.axes.push_back(key);
      }
      s.grid = sw["grid"];
    }
    if (sw.contains("zip")) {
      if (!sw["zip"].is_object()) throw SpecError("/sweep/zip", "must be an object of axis -> values");
      std::size_t length = 0;
      std::string first;
      for (const auto& [key, values] : sw["zip"].items()) {
        const std::string path = "/sweep/zip/" + EscapePointerToken(key);
        CheckPointer(key, path);
        CheckAxisArray(values, path);
        if (first.empty()) {
          first = key;
          length = values.size();
        } else if (values.size() != length) {
          throw SpecError(path, "zipped axes must have equal lengths (got " + std::to_string(values.size()) + ", \"" +
                                    first + "\" has " + std::to_string(length) + ")");
        }
        if (std::find(s.axes.begin(), s.axes.end(), key) != s.axes.end()) {
          throw SpecError(path, "axis is already swept in /sweep/grid");
        }
        s.axes.push_back(key);
      }
      s.zip = sw["zip"];
    }
    if (sw.contains("points")) {
      const json& pts = sw["points"];
      if (!pts.is_array() || pts.empty())
        throw SpecError("/sweep/points", "must be a non-empty array of {axis: value} objects");
      for (std::size_t i = 0; i < pts.size(); ++i) {
        const std::string path = "/sweep/points/" + std::to_string(i);
        if (!pts[i].is_object()) throw SpecError(path, "must be an object {axis: value} (got " + pts[i].dump() + ")");
        for (const auto& [key, value] : pts[i].items()) {
          CheckPointer(key, path + "/" + EscapePointerToken(key));
          const bool in_grid_or_zip = s.grid.contains(key) || s.zip.contains(key);
          if (in_grid_or_zip)
            throw SpecError(path + "/" + EscapePointerToken(key), "axis is already swept in grid or zip");
          if (std::find(s.axes.begin(), s.axes.end(), key) == s.axes.end()) s.axes.push_back(key);
        }
      }
      s.points = pts;
    }
  }
  // The base must be a valid run spec on its own; errors point into /base.
  json canonical;
  for (const auto& engine : s.engines) {
    json base = s.base;
    base["engine"] = engine;
    try {
      canonical = RunSpec::FromJson(base).ToJson();
    } catch (const SpecError& e) {
      throw SpecError("/base" + e.Path(), e.Message());
    }
  }
  // Every axis addresses a place in the resolved run spec, and no axis sets part of another.
  std::vector<std::pair<std::string, std::string>> where;  // axis, its path in the spec
  for (const char* kind : {"grid", "zip"})
    for (const auto& [key, values] : (std::string(kind) == "grid" ? s.grid : s.zip).items())
      where.emplace_back(key, "/sweep/" + std::string(kind) + "/" + EscapePointerToken(key));
  for (std::size_t i = 0; i < s.points.size(); ++i)
    for (const auto& [key, value] : s.points[i].items())
      where.emplace_back(key, "/sweep/points/" + std::to_string(i) + "/" + EscapePointerToken(key));
  for (const auto& [axis, path] : where) {
    CheckAxisResolves(canonical, axis, path);
    for (const auto& [other, other_path] : where) {
      if (axis != other && Within(axis, other))
        throw SpecError(path, "axis \"" + axis + "\" sets part of the axis \"" + other + "\" (" + other_path +
                                  "); sweep each value in one place");
    }
  }
  return s;
}

std::string CampaignSpec::SpecHash() const { return HashHex(raw.dump()); }

std::string DefaultCacheDir() {
  if (const char* env = std::getenv("GRANARY_CACHE_DIR"); env && *env) return env;
  const char* home = std::getenv("HOME");
  return std::string(home && *home ? home : "/tmp") + "/.cache/granary/beds";
}

std::string RunIdOf(const RunSpec& spec) {
  json j = spec.ToJson();
  j["run_id"] = "";
  j["bed"]["cache_file"] = "";
  return HashHex(j.dump());
}

DumpTemplate::DumpTemplate(json doc, const std::vector<std::string>& pointers) : doc_(std::move(doc)) {
  for (const auto& p : pointers) pointers_.emplace_back(p);
  // Placeholders no run spec value contains in practice; if one does, Fill() dumps in full.
  std::vector<std::string> marks;
  for (std::size_t i = 0; i < pointers_.size(); ++i) {
    const std::string mark = "\x01granary-field-" + std::to_string(i) + "\x01";
    doc_[pointers_[i]] = mark;
    marks.push_back(json(mark).dump());
  }
  const std::string text = doc_.dump();
  std::vector<std::pair<std::size_t, std::size_t>> at;  // (position in text, field index)
  for (std::size_t i = 0; i < marks.size(); ++i) {
    const std::size_t pos = text.find(marks[i]);
    if (pos == std::string::npos || text.find(marks[i], pos + 1) != std::string::npos) return;  // keep doc_
    at.emplace_back(pos, i);
  }
  std::sort(at.begin(), at.end());
  std::size_t from = 0;
  for (const auto& [pos, field] : at) {
    pieces_.push_back(text.substr(from, pos - from));
    order_.push_back(field);
    from = pos + marks[field].size();
  }
  pieces_.push_back(text.substr(from));
}

std::string DumpTemplate::Fill(const std::vector<std::string>& values) const {
  if (pieces_.empty()) {  // placeholders not unique: set the fields and dump the whole document
    json doc = doc_;
    for (std::size_t i = 0; i < pointers_.size(); ++i) doc[pointers_[i]] = json::parse(values.at(i));
    return doc.dump();
  }
  std::size_t size = 0;
  for (const auto& p : pieces_) size += p.size();
  for (const auto& v : values) size += v.size();
  std::string out;
  out.reserve(size);
  for (std::size_t i = 0; i < order_.size(); ++i) out.append(pieces_[i]).append(values.at(order_[i]));
  out.append(pieces_.back());
  return out;
}

std::uint64_t PlannedRunCount(const CampaignSpec& spec) {
  constexpr std::uint64_t kCap = std::uint64_t{1} << 63;
  std::uint64_t n = 1;
  const auto times = [&](std::uint64_t k) { n = (k != 0 && n > kCap / k) ? kCap : n * k; };
  for (const auto& [key, values] : spec.grid.items()) times(values.size());
  if (!spec.zip.empty()) times(spec.zip.begin()->size());
  if (!spec.points.empty()) times(spec.points.size());
  times(spec.engines.size());
  times(static_cast<std::uint64_t>(spec.replicas));
  return n;
}

std::vector<PlannedRun> Expand(const CampaignSpec& spec, const std::string& cache_dir, std::uint64_t max_runs,
                               int replicas_upto) {
  const int replicas = std::max(spec.replicas, replicas_upto);
  // Counted before anything is allocated: a typo of a few zeros must not end in bad_alloc.
  if (const std::uint64_t n = PlannedRunCount(spec); n > max_runs) {
    std::string factors;
    for (const auto& [key, values] : spec.grid.items())
      factors += (factors.empty() ? "" : " x ") + std::to_string(values.size());
    if (!spec.zip.empty())
      factors += (factors.empty() ? "" : " x ") + std::to_string(spec.zip.begin()->size()) + " zip rows";
    if (!spec.points.empty())
      factors += (factors.empty() ? "" : " x ") + std::to_string(spec.points.size()) + " points";
    if (factors.empty()) factors = "1 point";
    throw SpecError("/sweep", "expands to " + std::to_string(n) + " runs (" + factors + " x " +
                                  std::to_string(spec.engines.size()) + " engine(s) x " +
                                  std::to_string(spec.replicas) + " replicas), more than the limit of " +
                                  std::to_string(max_runs) + "; narrow the sweep, or raise the limit with --max-runs");
  }
  // Sweep points: grid (cartesian, first axis slowest) x zip rows x explicit points.
  std::vector<json> points = {json::object()};
  for (const auto& [key, values] : spec.grid.items()) {
    std::vector<json> next;
    for (const auto& p : points) {
      for (const auto& v : values) {
        json q = p;
        q[key] = v;
        next.push_back(q);
      }
    }
    points = std::move(next);
  }
  if (!spec.zip.empty()) {
    const std::size_t rows = spec.zip.begin()->size();
    std::vector<json> next;
    for (const auto& p : points) {
      for (std::size_t i = 0; i < rows; ++i) {
        json q = p;
        for (const auto& [key, values] : spec.zip.items()) q[key] = values[i];
        next.push_back(q);
      }
    }
    points = std::move(next);
  }
  if (!spec.points.empty()) {
    std::vector<json> next;
    for (const auto& p : points) {
      for (const auto& extra : spec.points) {
        json q = p;
        for (const auto& [key, value] : extra.items()) q[key] = value;
        next.push_back(q);
      }
    }
    points = std::move(next);
  }

  json base = spec.base;
  base["engine"] = spec.engines.front();
  const json canonical = RunSpec::FromJson(base).ToJson();
  const std::string no_text = json("").dump();

  std::vector<PlannedRun> runs;
  runs.reserve(points.size() * spec.engines.size() * static_cast<std::size_t>(replicas));
  for (std::size_t pi = 0; pi < points.size(); ++pi) {
    const json& point = points[pi];
    const std::string where = "point " + std::to_string(pi) + " " + point.dump();
    json params = canonical;
    for (const auto& [key, value] : point.items()) {
      try {
        Apply(params, key, value, "/sweep");
      } catch (const SpecError& e) {
        throw SpecError("/sweep", where + ": axis \"" + key + "\": " + e.Message());
      }
    }
    // A species named by default takes the name of its shape, also when the shape is swept
    // (the resolved base names it after the base's shape).
    if (params.contains("bodies") && params["bodies"].contains("species")) {
      json& species = params["bodies"]["species"];
      for (std::size_t i = 0; i < species.size(); ++i) {
        const std::string name_key = "/bodies/species/" + std::to_string(i) + "/name";
        if (point.contains(name_key) || spec.base.contains(json::json_pointer(name_key))) continue;
        if (point.contains("/bodies/species/" + std::to_string(i) + "/shape") ||
            point.contains("/bodies/species/" + std::to_string(i) + "/n")) {
          species[i].erase("name");
        }
      }
    }
    // A swept seed replaces the campaign seed as the source of the replica seeds.
    const std::uint64_t seed_source = point.contains("/seed") && params["seed"].is_number_unsigned()
                                          ? params["seed"].get<std::uint64_t>()
                                          : spec.seed;
    const std::string point_text = point.dump();
    // One engine after the other at each point, with the same replica seeds. A point that
    // sets /engine itself is planned for that engine only.
    const std::vector<std::string> engines = point.contains("/engine") ? std::vector<std::string>{""} : spec.engines;
    for (const auto& engine : engines) {
      if (!engine.empty()) params["engine"] = engine;
      // Validate and resolve the point once: replicas differ only in the seed, which cannot
      // make a spec invalid. The canonical JSON of every replica is then the point's dump
      // with seed, run id and bed file filled in (no copy or dump of the whole spec per run).
      RunSpec rs;
      try {
        rs = RunSpec::FromJson(params);
      } catch (const SpecError& e) {
        throw SpecError("/sweep", where + ": " + e.what());
      }
      const DumpTemplate resolved(rs.ToJson(), {"/seed", "/run_id", "/bed/cache_file"});
      const DumpTemplate bed_key(rs.BedKey(), {"/seed"});
      // Seed 0 stands for "any replica": replicas of one point share the point id.
      const std::string point_id = HashHex(resolved.Fill({"0", no_text, no_text}));
      for (int r = 0; r < replicas; ++r) {
        const std::string seed = std::to_string(ReplicaSeed(seed_source, r));
        PlannedRun run;
        run.run_id = HashHex(resolved.Fill({seed, no_text, no_text}));  // == RunIdOf(the replica's RunSpec)
        run.point_id = point_id;
        run.point = point;
        run.point_json = point_text;
        run.replica = r;
        const std::string bed_file =
            (std::filesystem::path(cache_dir) / (HashHex(bed_key.Fill({seed})) + ".bed")).string();
        run.params_json = resolved.Fill({seed, json(run.run_id).dump(), json(bed_file).dump()});
        run.engine = rs.engine;
        runs.push_back(std::move(run));
      }
    }
  }
  return runs;
}

std::string EngineProgram(const std::string& engine) {
  if (engine == "liggghts") return "granary-liggghts";
  if (engine == "lammps") return "granary-lammps";
  return "granary-engine";
}

}  // namespace granary::runner
