// See inspect.h.
#include "runner/inspect.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>

#include "analysis/python_analysis.h"
#include "rundir/analysis_cache.h"
#include "rundir/files.h"
#include "rundir/layout.h"
#include "rundir/manifest.h"

namespace granary::runner {

namespace fs = std::filesystem;
using nlohmann::json;

std::uintmax_t DiskBytes(const fs::path& path) {
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) return fs::file_size(path, ec);
  if (!fs::is_directory(path, ec)) return 0;
  std::uintmax_t n = 0;
  for (auto it = fs::recursive_directory_iterator(path, fs::directory_options::skip_permission_denied, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    std::error_code e;
    if (it->is_regular_file(e)) n += it->file_size(e);
  }
  return n;
}

std::string HumanBytes(std::uintmax_t bytes) {
  if (bytes < 1000) return std::to_string(bytes) + " B";
  const char* units[] = {"kB", "MB", "GB", "TB"};
  double v = static_cast<double>(bytes);
  int u = -1;
  while (v >= 1000 && u < 3) {
    v /= 1000;
    ++u;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, v < 10 ? "%.2f %s" : v < 100 ? "%.1f %s" : "%.0f %s", v, units[u]);
  return buf;
}

json RunDetails(Store& store, const RunRow& r, int log_lines) {
  json files = json::array();
  std::error_code ec;
  if (fs::is_directory(r.run_dir, ec)) {
    std::vector<fs::directory_entry> entries;
    for (const auto& e : fs::directory_iterator(r.run_dir, ec)) entries.push_back(e);
    std::sort(entries.begin(), entries.end(),
              [](const auto& a, const auto& b) { return a.path().filename() < b.path().filename(); });
    for (const auto& e : entries)
      files.push_back(
          {{"name", e.path().filename().string() + (e.is_directory() ? "/" : "")}, {"bytes", DiskBytes(e.path())}});
  }
  json results = json::object();
  for (const auto& [key, value] : LoadResults(store, r.run_id)) results[key] = value;
  json j = {{"run_id", r.run_id},
            {"point_id", r.point_id},
            {"point", r.point},
            {"replica", r.replica},
            {"state", r.state},
            {"attempts", r.attempts},
            {"engine", r.engine},
            {"engine_version", r.engine_version},
            {"host", r.host},
            {"started_at", r.started_at > 0 ? json(r.started_at) : json(nullptr)},
            {"ended_at", r.ended_at > 0 ? json(r.ended_at) : json(nullptr)},
            {"wall_s", r.wall_s > 0 ? json(r.wall_s) : json(nullptr)},
            {"end_reason", r.end_reason.empty() ? json(nullptr) : json(r.end_reason)},
            {"failure", r.failure.empty() ? json(nullptr) : json(r.failure)},
            {"run_dir", r.run_dir},
            {"run_dir_exists", fs::is_directory(r.run_dir, ec)},
            {"params", r.params},
            {"results", results},
            {"files", files}};
  if (r.state == RunState::kRunning) j["progress"] = r.progress;
  if (r.state == RunState::kDone && fs::is_directory(r.run_dir, ec)) {
    // Checksums only of what changed since the run was last found whole (manifest.h).
    const rundir::Verification v = rundir::VerifyRun(r.run_dir);
    j["integrity"] = rundir::IntegrityName(v.integrity);
    json problems = json::array();
    for (const auto& p : v.problems) problems.push_back({{"file", p.file}, {"what", p.what}});
    if (!problems.empty()) j["problems"] = problems;
  }
  // Analyses of the campaign spec that failed on this run (a Python analysis' script that
  // raised), from the caches the last report, export or compare wrote; the caches of analyses
  // the spec no longer names are not the campaign's.
  json failed = json::array();
  std::vector<std::string> current;
  if (const auto campaign = LoadCampaign(store); campaign && campaign->spec.is_object()) {
    const json python = campaign->spec.value("report", json::object()).value("python", json::array());
    if (python.is_array())
      for (const auto& e : python)
        if (e.is_object() && e.contains("key") && e.at("key").is_string())
          current.push_back(e.at("key").get<std::string>());
  }
  if (fs::is_directory(fs::path(r.run_dir) / rundir::kAnalysesDir, ec)) {
    std::vector<std::string> keys;
    for (const auto& e : fs::directory_iterator(fs::path(r.run_dir) / rundir::kAnalysesDir, ec))
      if (e.path().extension() == ".json" &&
          std::find(current.begin(), current.end(), e.path().stem().string()) != current.end())
        keys.push_back(e.path().stem().string());
    std::sort(keys.begin(), keys.end());
    for (const auto& key : keys)
      if (const auto cached = rundir::ReadCachedResult(r.run_dir, key))
        if (const std::string why = analysis::PythonFailure(cached->result); !why.empty())
          failed.push_back({{"analysis", key}, {"error", why}});
  }
  j["analysis_failures"] = failed;
  const std::string tail = TailOfFile(fs::path(r.run_dir) / rundir::kEngineLogFile, log_lines);
  json lines = json::array();
  std::istringstream in(tail);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  j["log_tail"] = lines;
  return j;
}

namespace {

// A lock file that nobody holds now and nobody touched for a minute: an flock taken and
// released at once. (A process that opened it just before the unlink would lock a file no
// longer in the directory; the minute makes that window negligible, and the locks only keep
// deterministic work such as preparing a bed from being done twice.)
bool LockIsFree(const fs::path& file) {
  std::error_code ec;
  const auto age = fs::file_time_type::clock::now() - fs::last_write_time(file, ec);
  if (ec || age < std::chrono::minutes(1)) return false;
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool free = ::flock(fd, LOCK_EX | LOCK_NB) == 0;
  if (free) ::flock(fd, LOCK_UN);
  ::close(fd);
  return free;
}

bool IsLockName(const fs::path& p) {
  const std::string name = p.filename().string();
  return p.extension() == ".lock" || name.ends_with(".lock.helpers");
}

}  // namespace

std::vector<std::string> CachedAnalyses(const fs::path& run_dir) {
  std::vector<std::string> keys;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(run_dir / rundir::kAnalysesDir, ec)) {
    const fs::path p = e.path();
    if (p.extension() != ".json" || p.filename() == "verified.json") continue;
    if (rundir::ReadCachedResult(run_dir, p.stem().string())) keys.push_back(p.stem().string());
  }
  std::sort(keys.begin(), keys.end());
  return keys;
}

std::vector<CleanItem> PlanClean(Store& store, const CleanOptions& o, std::vector<std::string>* frames_kept) {
  std::vector<CleanItem> items;
  const std::vector<RunRow> runs = LoadRuns(store, true);
  std::error_code ec;
  for (const RunRow& r : runs) {
    // Frames of done runs once their analyses are cached: what the report reads from then on.
    if (o.frames && r.state == RunState::kDone && fs::is_directory(r.run_dir, ec)) {
      std::vector<CleanItem> files;
      for (const char* name :
           {rundir::kFramesFile, rundir::kFramesGzFile, rundir::kFramesGsdFile, rundir::kFramesDataFile,
            rundir::kContactsFile, rundir::kContactsGzFile, rundir::kContactsGsdFile})
        if (fs::exists(fs::path(r.run_dir) / name, ec))
          files.push_back({"frames", fs::path(r.run_dir) / name, r.run_id, DiskBytes(fs::path(r.run_dir) / name)});
      std::string kept;
      if (files.empty()) continue;
      if (CachedAnalyses(r.run_dir).empty())
        kept = "no analysis of it is cached yet (campaign report first)";
      else if (!fs::exists(fs::path(r.run_dir) / rundir::kManifestFile, ec))
        kept = "written before manifests: nothing would record that its frames were removed on purpose";
      if (kept.empty())
        items.insert(items.end(), files.begin(), files.end());
      else if (frames_kept)
        frames_kept->push_back(r.run_id + ": " + kept);
    }
    const bool dir = fs::is_directory(r.run_dir, ec);
    if (dir && ((o.retired && r.state == RunState::kRetired) || (o.failed && r.state == RunState::kFailed)))
      items.push_back({ToString(r.state), r.run_dir, r.run_id, DiskBytes(r.run_dir)});
    else if (dir && o.locks && r.state != RunState::kRunning)
      for (const auto& e : fs::directory_iterator(r.run_dir, ec))
        if (IsLockName(e.path()) && LockIsFree(e.path()))
          items.push_back({"lock", e.path(), r.run_id, DiskBytes(e.path())});
  }
  // Beds: which runs of this campaign use which cached bed.
  std::map<std::string, bool> bed_needed;  // file -> some run not finished still needs it
  for (const RunRow& r : runs) {
    const json::json_pointer p("/bed/cache_file");
    if (!r.params.contains(p) || !r.params[p].is_string()) continue;
    const std::string file = r.params[p].get<std::string>();
    if (file.empty()) continue;
    bed_needed[file] = bed_needed[file] || !(r.state == RunState::kDone || r.state == RunState::kRetired);
  }
  std::set<fs::path> taken;
  if (o.beds)
    for (const auto& [file, needed] : bed_needed)
      if (!needed && fs::exists(file, ec)) {
        items.push_back({"bed", file, "", DiskBytes(file)});
        taken.insert(file);
      }
  if (o.locks && !o.cache_dir.empty() && fs::is_directory(o.cache_dir, ec))
    for (const auto& e : fs::directory_iterator(o.cache_dir, ec)) {
      if (!IsLockName(e.path())) continue;
      // A bed's lock: <bed>.lock. Removed with its bed, or when nobody holds it.
      const fs::path bed = e.path().parent_path() / e.path().stem();
      if (taken.count(bed) || LockIsFree(e.path())) items.push_back({"lock", e.path(), "", DiskBytes(e.path())});
    }
  return items;
}

std::uintmax_t ExecuteClean(Store& store, const std::vector<CleanItem>& items) {
  std::uintmax_t freed = 0;
  for (const CleanItem& it : items) {
    std::error_code ec;
    const std::uintmax_t bytes = DiskBytes(it.path);
    if (it.kind == "frames") {
      // Recorded first: a file gone without its record would read as damage. frames.data is
      // not in the manifest (it is derived from the first frame).
      const fs::path dir = it.path.parent_path();
      const auto m = rundir::ReadManifest(dir);
      if (m && m->files.count(it.path.filename().string()))
        rundir::RecordDropped(dir, it.path.filename().string(), "campaign clean --frames");
    }
    fs::remove_all(it.path, ec);
    if (ec) continue;
    freed += bytes;
    if (it.kind == "retired") ForgetRetiredResults(store, it.run_id);
  }
  return freed;
}

}  // namespace granary::runner
