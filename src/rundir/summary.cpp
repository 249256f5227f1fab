// See summary.h.
#include "rundir/summary.h"

#include <fstream>

#include "rundir/files.h"
#include "rundir/layout.h"

namespace granary::rundir {

nlohmann::json Summary::ToJson() const {
  nlohmann::json j;
  j["engine"] = engine;
  j["engine_version"] = engine_version;
  if (!granary_version.empty()) j["granary_version"] = granary_version;
  j["granary_commit"] = granary_commit;
  j["run_id"] = run_id;
  j["spec"] = spec;
  j["end_reason"] = end_reason;
  j["bodies"] = bodies;
  if (cleared_by_obstacles) j["cleared_by_obstacles"] = *cleared_by_obstacles;
  j["exited"] = exited;
  j["remaining"] = remaining;
  j["exits_per_outlet"] = exits_per_outlet;
  j["t_end"] = t_end;
  j["steps"] = steps;
  if (clogs) j["clogs"] = *clogs;
  if (unclogs) j["unclogs"] = *unclogs;
  if (unclog_removed) j["unclog_removed"] = *unclog_removed;
  j["bed"] = {{"file", bed.file},
              {"height", bed.height},
              {"prepared_here", bed.prepared_here},
              {"settle_time", bed.settle_time}};
  if (!bed.refused.empty()) j["bed"]["refused"] = bed.refused;
  if (bed.packing_fraction) j["bed"]["packing_fraction"] = *bed.packing_fraction;
  if (bed.surface) j["bed"]["surface"] = *bed.surface;
  if (timing)
    j["timing"] = {{"wall_s", timing->wall_s},
                   {"bed_wall_s", timing->bed_wall_s},
                   {"discharge_wall_s", timing->discharge_wall_s},
                   {"disc_steps_per_s", timing->disc_steps_per_s},
                   {"threads", timing->threads}};
  if (timing && timing->bed_disc_steps_per_s > 0) j["timing"]["bed_disc_steps_per_s"] = timing->bed_disc_steps_per_s;
  j["continued_from_checkpoint"] = continued_from_checkpoint;
  if (!extended_from.empty()) j["extended_from"] = extended_from;
  if (!refused_checkpoints.empty()) j["refused_checkpoints"] = refused_checkpoints;
  if (max_out_of_plane) j["max_out_of_plane"] = *max_out_of_plane;
  if (!tangential_cap.empty()) j["tangential_cap"] = tangential_cap;
  if (!reinject_position.empty()) j["reinject_position"] = reinject_position;
  return j;
}

Summary Summary::FromJson(const nlohmann::json& j, const std::string& where) {
  if (!j.is_object()) throw ReadError(where + ": summary is not a JSON object");
  Summary s;
  s.raw = j;
  try {
    s.engine = j.value("engine", "");
    s.engine_version = j.value("engine_version", "");
    s.granary_version = j.value("granary_version", "");
    s.granary_commit = j.value("granary_commit", "");
    s.run_id = j.value("run_id", "");
    if (j.contains("spec")) s.spec = j.at("spec");
    s.end_reason = j.value("end_reason", "");
    s.bodies = j.value("bodies", 0);
    if (j.contains("cleared_by_obstacles")) s.cleared_by_obstacles = j.at("cleared_by_obstacles").get<int>();
    s.exited = j.value("exited", 0);
    s.remaining = j.value("remaining", s.bodies - s.exited);
    if (j.contains("exits_per_outlet")) s.exits_per_outlet = j.at("exits_per_outlet").get<std::vector<int>>();
    s.t_end = j.value("t_end", 0.0);
    s.steps = j.value("steps", std::int64_t{0});
    if (j.contains("clogs") && j.at("clogs").is_number()) s.clogs = j.at("clogs").get<int>();
    if (j.contains("unclogs")) s.unclogs = j.at("unclogs").get<int>();
    if (j.contains("unclog_removed")) s.unclog_removed = j.at("unclog_removed").get<int>();
    if (j.contains("bed") && j.at("bed").is_object()) {
      const nlohmann::json& b = j.at("bed");
      s.bed.file = b.value("file", "");
      s.bed.height = b.value("height", 0.0);
      s.bed.prepared_here = b.value("prepared_here", false);
      s.bed.settle_time = b.value("settle_time", 0.0);
      s.bed.refused = b.value("refused", std::string());
      if (b.contains("packing_fraction") && b.at("packing_fraction").is_number())
        s.bed.packing_fraction = b.at("packing_fraction").get<double>();
      if (b.contains("surface") && b.at("surface").is_number()) s.bed.surface = b.at("surface").get<double>();
    }
    if (j.contains("timing") && j.at("timing").is_object()) {
      const nlohmann::json& t = j.at("timing");
      Timing timing;
      timing.wall_s = t.value("wall_s", 0.0);
      timing.bed_wall_s = t.value("bed_wall_s", 0.0);
      timing.discharge_wall_s = t.value("discharge_wall_s", 0.0);
      timing.disc_steps_per_s = t.value("disc_steps_per_s", 0.0);
      timing.threads = t.value("threads", 0);
      timing.bed_disc_steps_per_s = t.value("bed_disc_steps_per_s", 0.0);
      s.timing = timing;
    }
    s.continued_from_checkpoint = j.value("continued_from_checkpoint", false);
    s.extended_from = j.value("extended_from", std::string());
    s.refused_checkpoints = j.value("refused_checkpoints", std::vector<std::string>{});
    if (j.contains("max_out_of_plane")) s.max_out_of_plane = j.at("max_out_of_plane").get<double>();
    s.tangential_cap = j.value("tangential_cap", "");
    s.reinject_position = j.value("reinject_position", "");
  } catch (const nlohmann::json::exception& e) {
    throw ReadError(where + ": " + e.what());
  }
  return s;
}

void WriteSummary(const std::filesystem::path& dir, const Summary& summary) {
  WriteAtomically(dir / kSummaryFile, summary.ToJson().dump(2) + "\n");
}

Summary ReadSummary(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw ReadError(file.string() + ": cannot open");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw ReadError(file.string() + ": not valid JSON: " + e.what());
  }
  return Summary::FromJson(j, file.string());
}

}  // namespace granary::rundir
