// summary.json: what happened in a run, written once by the engine before DONE
// (docs/run-directory.md). One struct, one writer, one reader; the reader keeps every key,
// including those it does not know, in `raw`.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace granary::rundir {

struct BedInfo {
  std::string file;  // the prepared bed (a cache file or in the run directory)
  double height = 0.0;
  bool prepared_here = false;  // false: taken from the cache
  double settle_time = 0.0;
  std::string refused;  // a cached bed file refused (corrupt, old format) and prepared again, or ""
  // The settled bed's packing fraction (the full-width band from 5 d above the base to 5 d
  // below the surface) and surface (mean top of 1 d columns); absent in older runs.
  std::optional<double> packing_fraction;
  std::optional<double> surface;
};

struct Timing {
  double wall_s = 0.0;  // bed + discharge
  double bed_wall_s = 0.0;
  double discharge_wall_s = 0.0;
  // Discharge throughput: the discs in the silo at each step (those that left no longer
  // count), summed over the steps, per second of discharge wall time (disc = one sphere of a
  // LIGGGHTS clump).
  double disc_steps_per_s = 0.0;
  int threads = 0;
  // The bed's discs times the steps, per second, counting the discs that left too (twice the
  // true rate for a full remove-mode discharge); runs of older engines report this figure as
  // disc_steps_per_s and 0 here.
  double bed_disc_steps_per_s = 0.0;
};

struct Summary {
  std::string engine;  // "native", "liggghts"
  std::string engine_version;
  std::string granary_version;  // "" = not written (the native engine's version is engine_version)
  std::string granary_commit;
  std::string run_id;
  nlohmann::json spec;                      // the resolved run spec as the engine saw it
  std::string end_reason;                   // discharged, clogged, time_limit
  int bodies = 0;                           // in the silo at t = 0
  std::optional<int> cleared_by_obstacles;  // native, silos with obstacles: bed bodies an obstacle overlapped
  int exited = 0;
  int remaining = 0;
  std::vector<int> exits_per_outlet;
  double t_end = 0.0;
  std::int64_t steps = 0;
  std::optional<int> clogs;           // clogs the engine counted (kinetic-energy confirmed)
  std::optional<int> unclogs;         // on_clog "unclog": clogs it broke (unclogs.csv has every attempt)
  std::optional<int> unclog_removed;  // remove_arch in remove mode: arch bodies taken out (not exits)
  BedInfo bed;
  std::optional<Timing> timing;
  bool continued_from_checkpoint = false;
  // The run whose checkpoint this one continued to a larger limit (granary::extends), or "".
  std::string extended_from;
  std::vector<std::string> refused_checkpoints;  // why checkpoints were refused (corrupt, ...), if any
  // LIGGGHTS only (docs/liggghts.md): the conventions it applied whatever the spec asked.
  std::optional<double> max_out_of_plane;
  std::string tangential_cap;     // "" = not written
  std::string reinject_position;  // "" = not written

  nlohmann::json raw;  // as read: every key, including unknown ones (reader only)

  nlohmann::json ToJson() const;
  // Missing keys take the defaults above (remaining: bodies - exited); wrong types throw
  // ReadError naming `where`.
  static Summary FromJson(const nlohmann::json& j, const std::string& where);
};

// Writes DIR/summary.json atomically.
void WriteSummary(const std::filesystem::path& dir, const Summary& summary);
// Reads a summary.json; throws ReadError if it is missing or malformed.
Summary ReadSummary(const std::filesystem::path& file);

}  // namespace granary::rundir
