// Standard benchmark on LIGGGHTS and the native engine (bench.h).
#include "liggghts/bench.h"

#include <algorithm>
#include <boost/process.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <regex>
#include <vector>

#include "external/bench_log.h"
#include "liggghts/backend.h"
#include "rundir/run_directory.h"
#include "rundir/run_spec.h"

namespace granary::liggghts {

namespace fs = std::filesystem;
namespace bp = boost::process;

namespace {

// `granary-engine bench` (next to this executable) on the same case with one thread.
double NativeBenchRate(const BenchOptions& o) {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("cannot locate granary-engine: " + ec.message());
  const fs::path native = self.parent_path() / "granary-engine";
  bp::ipstream out;
  bp::child c(native.string(), "bench", "--bodies", std::to_string(o.bodies), "--steps", std::to_string(o.steps),
              "--threads-list", "1", bp::std_out > out);
  std::string line;
  double nat = 0;
  static const std::regex kRate(R"(disc_steps_per_s=([0-9.eE+-]+))");
  while (std::getline(out, line)) {
    std::smatch m;
    if (std::regex_search(line, m, kRate)) nat = std::stod(m[1]);
  }
  c.wait();
  if (c.exit_code() != 0 || nat <= 0) throw std::runtime_error("granary-engine bench failed");
  return nat;
}

}  // namespace

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
      {"bed",
       {{"settle_ke_per_body", 1e-4},
        {"max_settle_time", 30.0},
        {"cache_file", (base / ("granary-liggghts-bench-bed-" + std::to_string(o.bodies) + ".json")).string()}}},
      {"discharge", {{"mode", "reinject"}, {"max_time", o.steps * 1e-4}, {"stop_on_clog", false}}},
      {"output", {{"checkpoint_interval", 0.0}}}};
  rundir::WriteRunSpec(dir, RunSpec::FromJson(spec).ToJson());
  std::printf("bench: LIGGGHTS, %d dumbbells, %d steps (the bed is prepared once and cached; not timed)\n", o.bodies,
              o.steps);
  std::fflush(stdout);
  std::vector<double> lig_rates, native_rates;
  for (int round = 1; round <= o.repeat; ++round) {
    const std::string tag = o.repeat > 1 ? "round=" + std::to_string(round) + " " : "";
    for (const auto& e : fs::directory_iterator(dir)) {  // a fresh discharge every round
      const std::string name = e.path().filename().string();
      if (name.rfind("checkpoint.", 0) == 0 || name.rfind("log.discharge", 0) == 0 || name == rundir::kDoneFile)
        fs::remove(e.path());
    }
    BackendOptions bo;
    bo.quiet = true;
    RunDirectory(dir.string(), bo);
    const double lig = external::LoopTimeRate((dir / "log.discharge").string());
    lig_rates.push_back(lig);
    std::printf("%sengine=liggghts threads=1 disc_steps_per_s=%.4g\n", tag.c_str(), lig);
    std::fflush(stdout);
    if (!o.native) continue;
    const double nat = NativeBenchRate(o);
    native_rates.push_back(nat);
    std::printf("%sengine=native threads=1 disc_steps_per_s=%.4g\n", tag.c_str(), nat);
    std::printf("%sratio native/liggghts = %.2f\n", tag.c_str(), lig > 0 ? nat / lig : 0.0);
    std::fflush(stdout);
  }
  if (o.repeat < 2) return;
  auto best = [](const std::vector<double>& v) { return *std::max_element(v.begin(), v.end()); };
  std::printf("summary engine=liggghts rounds=%zu best=%.4g median=%.4g\n", lig_rates.size(), best(lig_rates),
              external::BenchMedian(lig_rates));
  if (!o.native) return;
  std::printf("summary engine=native rounds=%zu best=%.4g median=%.4g\n", native_rates.size(), best(native_rates),
              external::BenchMedian(native_rates));
  std::printf("summary ratio native/liggghts: of the bests %.2f, of the medians %.2f\n",
              best(native_rates) / best(lig_rates),
              external::BenchMedian(native_rates) / external::BenchMedian(lig_rates));
}

}  // namespace granary::liggghts
