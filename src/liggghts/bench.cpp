// Standard benchmark on LIGGGHTS and the native engine (bench.h).
#include "liggghts/bench.h"

#include <unistd.h>

#include <boost/process.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <regex>

#include "engine/run_spec.h"
#include "liggghts/backend.h"

namespace granary::liggghts {

namespace fs = std::filesystem;
namespace bp = boost::process;

double SphereStepsPerSecond(const std::string& log_file) {
  static const std::regex loop(R"(Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms)");
  std::ifstream in(log_file);
  std::string line;
  double work = 0, seconds = 0;
  while (std::getline(in, line)) {
    std::smatch m;
    if (!std::regex_search(line, m, loop)) continue;
    seconds += std::stod(m[1]);
    work += std::stod(m[3]) * std::stod(m[4]);
  }
  return seconds > 0 ? work / seconds : 0.0;
}

void RunBench(const BenchOptions& o) {
  const fs::path base = o.bed_dir.empty() ? fs::temp_directory_path() : fs::path(o.bed_dir);
  const fs::path dir = base / ("granary-liggghts-bench-" + std::to_string(o.bodies));
  fs::create_directories(dir);
  nlohmann::json spec = {
      {"run_id", "bench"},
      {"seed", 1},
      {"engine", "liggghts"},
      {"silo", {{"width", 100.0}, {"base_outlets", {{{"center", 0.0}, {"width", 14.0}}}}}},
      {"bodies", {{"count", o.bodies}, {"species", {{{"shape", "dumbbell"}}}}}},
      {"bed", {{"settle_ke_per_body", 1e-4}, {"max_settle_time", 30.0},
               {"cache_file", (base / ("granary-liggghts-bench-bed-" + std::to_string(o.bodies) + ".json")).string()}}},
      {"discharge", {{"mode", "reinject"}, {"max_time", o.steps * 1e-4}, {"stop_on_clog", false}}},
      {"output", {{"checkpoint_interval", 0.0}}}};
  std::ofstream(dir / "run.json") << RunSpec::from_json(spec).to_json().dump(2) << "\n";
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().rfind("checkpoint.", 0) == 0) fs::remove(e.path());
  std::printf("bench: LIGGGHTS, %d dumbbells, %d steps (the bed is prepared once and cached; not timed)\n", o.bodies, o.steps);
  std::fflush(stdout);
  BackendOptions bo;
  bo.quiet = true;
  RunDirectory(dir.string(), bo);
  const double lig = SphereStepsPerSecond((dir / "log.discharge").string());
  std::printf("engine=liggghts threads=1 disc_steps_per_s=%.4g\n", lig);
  std::fflush(stdout);
  if (!o.native) return;
  char self[4096];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
  if (n <= 0) throw std::runtime_error("cannot locate granary-engine");
  self[n] = 0;
  const fs::path native = fs::path(self).parent_path() / "granary-engine";
  bp::ipstream out;
  bp::child c(native.string(), "bench", "--bodies", std::to_string(o.bodies), "--steps", std::to_string(o.steps),
              "--threads-list", "1", bp::std_out > out);
  std::string line;
  double nat = 0;
  static const std::regex rate(R"(disc_steps_per_s=([0-9.eE+-]+))");
  while (std::getline(out, line)) {
    std::smatch m;
    if (std::regex_search(line, m, rate)) nat = std::stod(m[1]);
  }
  c.wait();
  if (c.exit_code() != 0 || nat <= 0) throw std::runtime_error("granary-engine bench failed");
  std::printf("engine=native threads=1 disc_steps_per_s=%.4g\n", nat);
  std::printf("ratio native/liggghts = %.2f\n", lig > 0 ? nat / lig : 0.0);
}

}  // namespace granary::liggghts
