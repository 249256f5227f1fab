// progress.json: where a running engine is, replaced atomically every few seconds
// (docs/run-directory.md), and the matching line an engine prints on stdout. One struct,
// one writer, one reader.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace granary::rundir {

struct Progress {
  std::string phase;      // "bed" or "discharge"
  double fraction = 0.0;  // of the phase, 0..1
  double t = 0.0;         // simulated time of the phase
  double t_end = 0.0;     // the phase's simulated time limit
  int exited = 0;
  double wall_s = 0.0;  // wall time of the phase so far

  nlohmann::json ToJson() const;
  // `progress phase=discharge fraction=0.420 t=4.2 exited=130` (no newline).
  std::string Line() const;
};

// Replaces DIR/progress.json atomically (fraction clamped to [0, 1]); with `print`, also
// prints Line() to stdout and flushes.
void WriteProgress(const std::filesystem::path& dir, const Progress& progress, bool print);
// DIR/progress.json, or nothing if it does not exist or cannot be parsed (an engine that has
// not started yet); a reader polls it, so it never throws.
std::optional<Progress> ReadProgress(const std::filesystem::path& dir);

}  // namespace granary::rundir
