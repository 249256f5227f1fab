// See calibration.h.
#include "runner/calibration.h"

#include <sys/stat.h>
#include <unistd.h>

#include <boost/asio.hpp>
#include <boost/process.hpp>
#include <chrono>
#include <ctime>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <regex>
#include <set>
#include <sstream>

#include "rundir/files.h"
#include "rundir/hash.h"
#include "rundir/version.h"
#include "runner/campaign_db.h"

namespace granary::runner {

namespace fs = std::filesystem;
namespace bp = boost::process;
using nlohmann::json;

namespace {

// Small enough to take seconds (the bed is most of it), large enough that the cell lists,
// not the start, dominate the timed steps.
constexpr int kBodies = 1500;
constexpr int kSteps = 4000;

std::string CpuModel() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      return colon == std::string::npos ? line : line.substr(colon + 2);
    }
  return "unknown";
}

std::string Host() {
  char host[256] = {0};
  gethostname(host, sizeof host - 1);
  return host;
}

fs::path CacheFile(const std::string& key) {
  return fs::path(CalibrationDir()) / ("calibration-" + HashHex(key) + ".json");
}

// One `granary-engine bench` of `shape`; its disc-steps per second, or 0 with `error` set.
double Bench(const std::string& exe, const std::string& shape, std::string& error) {
  const std::string bed =
      (fs::path(CalibrationDir()) / ("bench-bed-" + shape + "-" + std::to_string(kBodies) + ".json")).string();
  const std::vector<std::string> args = {
      "bench",          "--shape", shape,   "--bodies", std::to_string(kBodies), "--steps", std::to_string(kSteps),
      "--threads-list", "1",       "--bed", bed};
  boost::asio::io_context io;
  std::future<std::string> out, err;
  std::error_code ec;
  bp::child child(exe, bp::args(args), bp::std_in<bp::null, bp::std_out> out, bp::std_err > err, io, ec);
  if (ec) {
    error = "cannot start " + exe + ": " + ec.message();
    return 0.0;
  }
  io.run();
  child.wait(ec);
  const std::string text = out.get();
  const std::string errors = err.get();
  std::smatch m;
  // Per CPU second: a core-hour's worth, whatever else the machine runs meanwhile.
  static const std::regex kRate(R"(threads=1 disc_steps_per_s=[0-9.eE+-]+ .*cpu_disc_steps_per_s=([0-9.eE+-]+))");
  if (child.exit_code() != 0 || !std::regex_search(text, m, kRate)) {
    error = exe + " bench --shape " + shape + " failed (exit " + std::to_string(child.exit_code()) +
            "): " + (errors.empty() ? text.substr(0, 200) : errors.substr(0, 200));
    return 0.0;
  }
  return std::stod(m[1].str());
}

}  // namespace

std::string CalibrationDir() {
  if (const char* env = std::getenv("GRANARY_CALIBRATION_DIR"); env && *env) return env;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
    return (fs::path(xdg) / "granary" / "calibration").string();
  const char* home = std::getenv("HOME");
  return (fs::path(home && *home ? home : "/tmp") / ".cache" / "granary" / "calibration").string();
}

std::string CalibrationKey(const std::string& engine_exe) {
  struct stat st {};
  const bool found = ::stat(engine_exe.c_str(), &st) == 0;
  json key = {{"host", Host()},
              {"cpu", CpuModel()},
              {"version", GRANARY_VERSION},
              {"commit", granary::GitCommit()},
              {"engine", engine_exe},
              {"engine_size", found ? static_cast<long long>(st.st_size) : -1},
              {"engine_mtime", found ? static_cast<long long>(st.st_mtime) : -1},
              {"bench", {{"bodies", kBodies}, {"steps", kSteps}, {"threads", 1}}}};
  return key.dump();
}

Calibration CachedCalibration(const std::string& engine_exe) {
  Calibration c;
  const std::string key = CalibrationKey(engine_exe);
  const fs::path file = CacheFile(key);
  std::ifstream in(file);
  if (!in) {
    c.source = "no calibration cached for this machine and build";
    return c;
  }
  try {
    const json j = json::parse(in);
    if (j.at("key").dump() != json::parse(key).dump()) throw std::runtime_error("key differs");
    c.disc_rate = j.at("disc_steps_per_s_disc").get<double>();
    c.clump_rate = j.at("disc_steps_per_s_dumbbell").get<double>();
    c.source = "granary-engine bench on " + j.at("key").at("host").get<std::string>() + ", cached in " + file.string();
  } catch (const std::exception& e) {
    c = Calibration{};
    c.source = "the cached calibration " + file.string() + " is unreadable (" + e.what() + ")";
  }
  return c;
}

Calibration ObtainCalibration(const std::string& engine_exe, const std::function<void(const std::string&)>& say) {
  Calibration c = CachedCalibration(engine_exe);
  if (c.Valid()) return c;
  if (!fs::exists(engine_exe)) {
    c.source = "no calibration: the engine " + engine_exe + " is not there to measure";
    return c;
  }
  std::error_code ec;
  fs::create_directories(CalibrationDir(), ec);
  if (say)
    say("calibrating: " + engine_exe + " bench on " + std::to_string(kBodies) +
        " discs and dumbbells, one thread (once per machine and build; cached in " + CalibrationDir() + ")");
  std::string error;
  const double disc = Bench(engine_exe, "disc", error);
  const double dumbbell = disc > 0 ? Bench(engine_exe, "dumbbell", error) : 0.0;
  if (disc <= 0 || dumbbell <= 0) {
    c = Calibration{};
    c.source = "no calibration: " + error;
    return c;
  }
  const std::string key = CalibrationKey(engine_exe);
  const json doc = {{"key", json::parse(key)},
                    {"disc_steps_per_s_disc", disc},
                    {"disc_steps_per_s_dumbbell", dumbbell},
                    {"measured_at", static_cast<long long>(std::time(nullptr))}};
  try {
    WriteAtomically(CacheFile(key), doc.dump(2) + "\n");
  } catch (const std::exception&) {
    // Not cached: measured again next time; the estimate stands.
  }
  c.disc_rate = disc;
  c.clump_rate = dumbbell;
  c.source = "granary-engine bench on " + Host() + ", measured now, cached in " + CacheFile(key).string();
  return c;
}

CampaignEstimate EstimateRuns(const std::vector<PlannedRun>& runs, Store* store, const std::string& exe_dir, int jobs,
                              bool measure, const std::function<void(const std::string&)>& say) {
  const std::string exe = (fs::path(exe_dir) / "granary-engine").string();
  Calibration cal = measure ? ObtainCalibration(exe, say) : CachedCalibration(exe);
  if (store) ScaleFromFinished(cal, LoadFinished(*store));
  std::set<std::string> ready;
  for (const PlannedRun& r : runs) {
    const std::string bed = r.Params().value("bed", json::object()).value("cache_file", std::string());
    if (!bed.empty() && fs::exists(bed)) ready.insert(bed);
  }
  return EstimateCampaign(runs, cal, jobs, ready);
}

PlannedRun ToPlannedRun(const RunRow& r) {
  PlannedRun p;
  p.run_id = r.run_id;
  p.point_id = r.point_id;
  p.point = r.point;
  p.engine = r.engine;
  p.params_json = r.params.dump();
  return p;
}

std::vector<PlannedRun> RunsLeft(Store& store) {
  std::vector<PlannedRun> left;
  for (const RunRow& r : LoadRuns(store, true))
    if (r.state != RunState::kDone && r.state != RunState::kRetired) left.push_back(ToPlannedRun(r));
  return left;
}

}  // namespace granary::runner
