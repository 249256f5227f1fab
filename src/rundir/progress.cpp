// See progress.h.
#include "rundir/progress.h"

#include <algorithm>
#include <cstdio>
#include <fstream>

#include "rundir/files.h"
#include "rundir/layout.h"

namespace granary::rundir {

nlohmann::json Progress::ToJson() const {
  return {{"phase", phase}, {"fraction", fraction}, {"t", t}, {"t_end", t_end}, {"exited", exited}, {"wall_s", wall_s}};
}

std::string Progress::Line() const {
  char buf[256];
  std::snprintf(buf, sizeof buf, "fraction=%.3f t=%.4g exited=%d", fraction, t, exited);
  return "progress phase=" + phase + " " + buf;
}

void WriteProgress(const std::filesystem::path& dir, const Progress& progress, bool print) {
  Progress p = progress;
  p.fraction = std::clamp(p.fraction, 0.0, 1.0);
  // Rewritten at every progress step and only ever read for display: visible, not durable.
  WriteAtomically(dir / kProgressFile, p.ToJson().dump() + "\n", Durability::kVisible);
  if (print) {
    std::printf("%s\n", p.Line().c_str());
    std::fflush(stdout);
  }
}

std::optional<Progress> ReadProgress(const std::filesystem::path& dir) {
  std::ifstream in(dir / kProgressFile);
  if (!in) return std::nullopt;
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (!j.is_object()) return std::nullopt;
  try {
    Progress p;
    p.phase = j.value("phase", "");
    p.fraction = j.value("fraction", 0.0);
    p.t = j.value("t", 0.0);
    p.t_end = j.value("t_end", 0.0);
    p.exited = j.value("exited", 0);
    p.wall_s = j.value("wall_s", 0.0);
    return p;
  } catch (const nlohmann::json::exception&) {
    return std::nullopt;
  }
}

}  // namespace granary::rundir
