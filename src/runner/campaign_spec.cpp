// Campaign spec parsing and sweep expansion; see campaign_spec.h and docs/campaign-spec.md.
#include "runner/campaign_spec.h"

#include <cstdlib>
#include <filesystem>

#include "runner/util.h"

namespace granary::runner {

using nlohmann::json;

namespace {

void CheckKeys(const json& j, const std::string& path, const std::vector<std::string>& allowed) {
  if (!j.is_object()) throw SpecError(path.empty() ? "/" : path, "must be an object (got " + std::string(j.type_name()) + ")");
  for (const auto& [key, value] : j.items()) {
    if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
    const std::string best = nearest(key, allowed);
    std::string msg = "unknown key; ";
    if (!best.empty()) {
      msg += "did you mean \"" + best + "\"?";
    } else {
      msg += "allowed:";
      for (std::size_t i = 0; i < allowed.size(); ++i) msg += (i ? ", \"" : " \"") + allowed[i] + "\"";
    }
    throw SpecError(path + "/" + escape_pointer_token(key), msg);
  }
}

void CheckPointer(const std::string& key, const std::string& path) {
  if (key.empty() || key[0] != '/') {
    throw SpecError(path, "an axis must be a JSON Pointer into the run spec such as \"/silo/width\" (got \"" + key + "\")");
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

}  // namespace

CampaignSpec CampaignSpec::from_json(const json& j) {
  CheckKeys(j, "", {"name", "description", "seed", "replicas", "engine", "base", "sweep", "report"});
  CampaignSpec s;
  s.raw = j;
  if (!j.contains("name") || !j["name"].is_string() || j["name"].get<std::string>().empty()) {
    throw SpecError("/name", "must be a non-empty string (got " + (j.contains("name") ? j["name"].dump() : "nothing") + ")");
  }
  s.name = j["name"];
  if (j.contains("description")) {
    if (!j["description"].is_string()) throw SpecError("/description", "must be a string (got " + j["description"].dump() + ")");
    s.description = j["description"];
  }
  if (j.contains("seed")) {
    if (!j["seed"].is_number_unsigned()) throw SpecError("/seed", "must be a non-negative integer (got " + j["seed"].dump() + ")");
    s.seed = j["seed"];
  }
  if (j.contains("replicas")) {
    const json& r = j["replicas"];
    if (!r.is_number_integer() || r.get<std::int64_t>() < 1 || r.get<std::int64_t>() > 100000) {
      throw SpecError("/replicas", "must be an integer in [1, 100000] (got " + r.dump() + ")");
    }
    s.replicas = r.get<int>();
  }
  if (j.contains("engine")) {
    const json& e = j["engine"];
    if (!e.is_string() || (e != "native" && e != "liggghts")) {
      throw SpecError("/engine", "must be one of \"native\", \"liggghts\" (got " + e.dump() + ")");
    }
    s.engine = e;
  }
  if (j.contains("base")) {
    if (!j["base"].is_object()) throw SpecError("/base", "must be an object (got " + std::string(j["base"].type_name()) + ")");
    s.base = j["base"];
  }
  if (j.contains("report") && !j["report"].is_object()) {
    throw SpecError("/report", "must be an object (got " + std::string(j["report"].type_name()) + ")");
  }
  if (j.contains("sweep")) {
    const json& sw = j["sweep"];
    CheckKeys(sw, "/sweep", {"grid", "zip", "points"});
    if (sw.contains("grid")) {
      if (!sw["grid"].is_object()) throw SpecError("/sweep/grid", "must be an object of axis -> values");
      for (const auto& [key, values] : sw["grid"].items()) {
        const std::string path = "/sweep/grid/" + escape_pointer_token(key);
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
        const std::string path = "/sweep/zip/" + escape_pointer_token(key);
        CheckPointer(key, path);
        CheckAxisArray(values, path);
        if (first.empty()) {
          first = key;
          length = values.size();
        } else if (values.size() != length) {
          throw SpecError(path, "zipped axes must have equal lengths (got " + std::to_string(values.size()) +
                                    ", \"" + first + "\" has " + std::to_string(length) + ")");
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
      if (!pts.is_array() || pts.empty()) throw SpecError("/sweep/points", "must be a non-empty array of {axis: value} objects");
      for (std::size_t i = 0; i < pts.size(); ++i) {
        const std::string path = "/sweep/points/" + std::to_string(i);
        if (!pts[i].is_object()) throw SpecError(path, "must be an object {axis: value} (got " + pts[i].dump() + ")");
        for (const auto& [key, value] : pts[i].items()) {
          CheckPointer(key, path + "/" + escape_pointer_token(key));
          const bool in_grid_or_zip = s.grid.contains(key) || s.zip.contains(key);
          if (in_grid_or_zip) throw SpecError(path + "/" + escape_pointer_token(key), "axis is already swept in grid or zip");
          if (std::find(s.axes.begin(), s.axes.end(), key) == s.axes.end()) s.axes.push_back(key);
        }
      }
      s.points = pts;
    }
  }
  // The base must be a valid run spec on its own; errors point into /base.
  json base = s.base;
  base["engine"] = s.engine;
  try {
    RunSpec::from_json(base);
  } catch (const SpecError& e) {
    throw SpecError("/base" + e.path(), e.message());
  }
  return s;
}

std::string CampaignSpec::spec_hash() const { return hash_hex(raw.dump()); }

std::string default_cache_dir() {
  if (const char* env = std::getenv("GRANARY_CACHE_DIR"); env && *env) return env;
  const char* home = std::getenv("HOME");
  return std::string(home && *home ? home : "/tmp") + "/.cache/granary/beds";
}

std::string run_id_of(const RunSpec& spec) {
  json j = spec.to_json();
  j["run_id"] = "";
  j["bed"]["cache_file"] = "";
  return hash_hex(j.dump());
}

std::vector<PlannedRun> expand(const CampaignSpec& spec, const std::string& cache_dir) {
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
  base["engine"] = spec.engine;
  const json canonical = RunSpec::from_json(base).to_json();

  std::vector<PlannedRun> runs;
  runs.reserve(points.size() * static_cast<std::size_t>(spec.replicas));
  for (std::size_t pi = 0; pi < points.size(); ++pi) {
    const json& point = points[pi];
    const std::string where = "point " + std::to_string(pi) + " " + point.dump();
    json params = canonical;
    for (const auto& [key, value] : point.items()) {
      try {
        Apply(params, key, value, "/sweep");
      } catch (const SpecError& e) {
        throw SpecError("/sweep", where + ": axis \"" + key + "\": " + e.message());
      }
    }
    // A swept seed replaces the campaign seed as the source of the replica seeds.
    const std::uint64_t seed_source = point.contains("/seed") && params["seed"].is_number_unsigned()
                                          ? params["seed"].get<std::uint64_t>()
                                          : spec.seed;
    // Validate the point once (replicas differ only in the seed, which cannot make a spec
    // invalid), then derive each replica from the canonical JSON: planning 10,000 runs
    // stays well under a second.
    RunSpec rs;
    try {
      rs = RunSpec::from_json(params);
    } catch (const SpecError& e) {
      throw SpecError("/sweep", where + ": " + e.what());
    }
    rs.run_id.clear();
    rs.bed.cache_file.clear();
    json resolved = rs.to_json();
    resolved["seed"] = 0;
    const std::string point_id = hash_hex(resolved.dump());
    for (int r = 0; r < spec.replicas; ++r) {
      rs.seed = replica_seed(seed_source, r);
      resolved["seed"] = rs.seed;
      resolved["run_id"] = "";
      resolved["bed"]["cache_file"] = "";
      PlannedRun run;
      run.run_id = hash_hex(resolved.dump());  // == run_id_of(rs)
      run.point_id = point_id;
      run.point = point;
      run.replica = r;
      run.params = resolved;
      run.params["run_id"] = run.run_id;
      run.params["bed"]["cache_file"] =
          (std::filesystem::path(cache_dir) / (hash_hex(rs.bed_key().dump()) + ".bed")).string();
      run.engine = rs.engine;
      runs.push_back(std::move(run));
    }
  }
  return runs;
}

}  // namespace granary::runner
