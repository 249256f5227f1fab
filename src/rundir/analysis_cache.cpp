// See analysis_cache.h.
#include "rundir/analysis_cache.h"

#include <fstream>

#include "rundir/files.h"

namespace granary::rundir {

void WriteCachedResult(const std::filesystem::path& dir, const CachedResult& c) {
  const std::filesystem::path folder = dir / kAnalysesDir;
  std::filesystem::create_directories(folder);
  const nlohmann::json j = {
      {"analysis", c.analysis}, {"key", c.key}, {"summary_hash", c.summary_hash}, {"result", c.result}};
  WriteAtomically(folder / (c.analysis + ".json"), j.dump() + "\n");
}

std::optional<CachedResult> ReadCachedResult(const std::filesystem::path& dir, const std::string& analysis) {
  std::ifstream in(dir / kAnalysesDir / (analysis + ".json"));
  if (!in) return std::nullopt;
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (!j.is_object() || !j.contains("result") || !j.contains("key")) return std::nullopt;
  CachedResult c;
  c.analysis = j.value("analysis", "");
  c.key = j.at("key");
  c.summary_hash = j.value("summary_hash", "");
  c.result = j.at("result");
  if (c.analysis != analysis) return std::nullopt;
  return c;
}

}  // namespace granary::rundir
