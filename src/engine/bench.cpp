// The standard benchmark, and the disc case on LAMMPS beside it (bench.h).
#include "engine/bench.h"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <omp.h>

#include "engine/run.h"
#include "external/bench_log.h"
#include "silo/shapes.h"
#include "rundir/files.h"
#include "rundir/hash.h"
#include "rundir/layout.h"
#include "rundir/run_directory.h"
#include "rundir/summary.h"

extern char** environ;

namespace granary::engine {
namespace fs = std::filesystem;

nlohmann::json BenchSpecies(const std::string& shape) {
  if (shape == "disc") return {{{"shape", "disc"}}};
  if (shape == "dumbbell") return {{{"shape", "dumbbell"}}};
  if (shape == "mixture")
    return {{{"shape", "dumbbell"}, {"fraction", 0.5}},
            {{"shape", "disc"}, {"diameter", std::numbers::sqrt2}, {"fraction", 0.5}}};
  throw std::invalid_argument("bench: --shape must be disc, dumbbell or mixture (got \"" + shape + "\")");
}

nlohmann::json BenchSpec(const BenchOptions& options) {
  nlohmann::json spec = {
      {"run_id", "bench"},
      {"seed", std::uint64_t{1}},
      {"silo", {{"width", 100.0}, {"base_outlets", {{{"center", 0.0}, {"width", 14.0}}}}}},
      {"bodies", {{"count", options.bodies}, {"species", BenchSpecies(options.shape)}}},
      {"discharge",
       {{"mode", "reinject"}, {"max_time", static_cast<double>(options.steps) * 1e-4}, {"stop_on_clog", false}}},
      {"output", {{"checkpoint_interval", 0.0}, {"frame_interval", 0.0}}},
      {"bed", {{"batch_size", 2000}, {"settle_ke_per_body", 1e-4}, {"max_settle_time", 30.0}}}};
  // The default cache file is named by the bed key (as the runner's), so that a bed cached by
  // an engine with another bed procedure is not read for this one.
  spec["bed"]["cache_file"] =
      options.bed_file.empty()
          ? (fs::temp_directory_path() / ("granary-bench-bed-" + options.shape + "-" + std::to_string(options.bodies) +
                                          "-" + HashHex(RunSpec::FromJson(spec).BedKey().dump()) + ".json"))
                .string()
          : options.bed_file;
  return spec;
}

namespace {

// The largest thread count of the runs (a round with two or more first measures the core round trip).
int MostThreads(const BenchOptions& options) {
  return *std::max_element(options.threads.begin(), options.threads.end());
}

// Prepares (or loads) the bench bed once with every thread of the list; not timed.
ObtainedBed BenchBed(const BenchOptions& options, const nlohmann::json& spec, const fs::path& dir) {
  omp_set_num_threads(MostThreads(options));
  return ObtainBed(RunSpec::FromJson(spec), dir.string(), [](double f, double t) {
    std::printf("bench: preparing bed fraction=%.3f t=%.4g\n", f, t);
    std::fflush(stdout);
  });
}

// One timed native run of the bench case in `dir` (a fresh run directory).
double ProcessCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

BenchResult NativeRound(const nlohmann::json& spec, const fs::path& dir, int round, int threads) {
  fs::remove_all(dir);
  rundir::WriteRunSpec(dir, spec);
  RunOptions ro;
  ro.threads = threads;
  ro.quiet = true;
  const double cpu0 = ProcessCpuSeconds();
  RunDirectory(dir.string(), ro);
  const double cpu = ProcessCpuSeconds() - cpu0;
  const rundir::Summary summary = rundir::ReadSummary(dir / rundir::kSummaryFile);
  BenchResult r{round, threads, summary.timing->disc_steps_per_s, summary.timing->discharge_wall_s};
  // The round's disc-steps over the CPU time of the whole round (loading the bed included).
  if (cpu > 0) r.cpu_disc_steps_per_s = summary.timing->disc_steps_per_s * summary.timing->discharge_wall_s / cpu;
  return r;
}

}  // namespace

double CoreRoundTripNs() {
  struct alignas(64) Line {
    std::atomic<std::int64_t> value{0};
  };
  Line ping, pong;  // one cache line each
  using Clock = std::chrono::steady_clock;
  std::thread echo([&] {
    for (std::int64_t seen = 0;;) {
      const std::int64_t v = ping.value.load(std::memory_order_acquire);
      if (v < 0) return;
      if (v != seen) pong.value.store(seen = v, std::memory_order_release);
    }
  });
  // 2000 round trips to start, then as many as fit in 50 ms (1 s at most if the echo is slow),
  // looking at the clock every 256 (it costs a fifth of a round trip).
  const auto start = Clock::now();
  auto timed_from = start;
  std::int64_t n = 0, timed = 0;
  bool stalled = false;
  while (!stalled && (n < 2000 || n % 256 != 0 || Clock::now() - timed_from < std::chrono::milliseconds(50))) {
    ping.value.store(++n, std::memory_order_release);
    for (int spins = 0; pong.value.load(std::memory_order_acquire) != n;)
      if (++spins % 4096 == 0 && Clock::now() - start > std::chrono::seconds(1)) {
        stalled = true;
        break;
      }
    if (n == 2000) timed_from = Clock::now();
    if (n > 2000) ++timed;
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - timed_from).count();
  ping.value.store(-1, std::memory_order_release);
  echo.join();
  return stalled || timed == 0 ? 0.0 : seconds / static_cast<double>(timed) * 1e9;
}

std::vector<BenchResult> RunBenchmark(const BenchOptions& options) {
  const fs::path base = fs::temp_directory_path() / ("granary-bench-" + std::to_string(::getpid()));
  fs::create_directories(base);
  const nlohmann::json spec = BenchSpec(options);
  BenchBed(options, spec, base);
  std::vector<BenchResult> results;
  for (int round = 1; round <= options.repeat; ++round) {
    const double round_trip = MostThreads(options) > 1 ? CoreRoundTripNs() : 0.0;
    for (int threads : options.threads) {
      results.push_back(NativeRound(spec, base / ("t" + std::to_string(threads)), round, threads));
      if (threads > 1) results.back().core_round_trip_ns = round_trip;
    }
  }
  fs::remove_all(base);
  return results;
}

std::vector<OutputCostResult> RunOutputCost(const BenchOptions& options, double interval) {
  const fs::path base = fs::temp_directory_path() / ("granary-bench-" + std::to_string(::getpid()));
  fs::create_directories(base);
  const nlohmann::json quiet = BenchSpec(options);
  nlohmann::json loud = quiet;
  loud["output"]["frame_interval"] = interval;
  loud["output"]["contact_forces"] = true;
  BenchBed(options, quiet, base);
  std::vector<OutputCostResult> results;
  for (int round = 1; round <= options.repeat; ++round) {
    const double round_trip = MostThreads(options) > 1 ? CoreRoundTripNs() : 0.0;
    for (int threads : options.threads) {
      const BenchResult without = NativeRound(quiet, base / "none", round, threads);
      const fs::path dir = base / "frames";
      const BenchResult with = NativeRound(loud, dir, round, threads);
      // Bytes written in the timed steps: all but the first block (t = 0) of each dump.
      double bytes = 0.0;
      for (const char* name : {rundir::kFramesFile, rundir::kContactsFile}) {
        std::ifstream in(dir / name, std::ios::binary);
        std::string line, all;
        std::int64_t first_block = -1, offset = 0, blocks = 0;
        while (std::getline(in, line)) {
          if (line == "ITEM: TIME" && ++blocks == 2) first_block = offset;
          offset += static_cast<std::int64_t>(line.size()) + 1;
        }
        if (first_block >= 0) bytes += static_cast<double>(offset - first_block);
      }
      results.push_back(
          {round, threads, without.disc_steps_per_s, with.disc_steps_per_s, bytes, threads > 1 ? round_trip : 0.0});
    }
  }
  fs::remove_all(base);
  return results;
}

std::vector<BedPrepResult> RunBedPrep(const BenchOptions& options, const std::vector<BedProcedure>& procedures) {
  omp_set_num_threads(MostThreads(options));
  std::vector<BedPrepResult> results;
  for (int seed = 1; seed <= options.repeat; ++seed) {
    for (const BedProcedure& procedure : procedures) {
      nlohmann::json j = BenchSpec(options);
      j["seed"] = seed;
      j["bed"]["time_step"] = procedure.step_factor * RunSpec::FromJson(j).time_step;
      j["bed"]["next_batch"] = ToString(procedure.next_batch);
      const RunSpec spec = RunSpec::FromJson(j);
      const auto start = std::chrono::steady_clock::now();
      const BedState bed = PrepareBed(spec, nullptr, procedure.skin);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      results.push_back({seed, procedure, wall, bed.settle_time, MeasureBed(bed, spec)});
    }
  }
  return results;
}

LammpsInput LammpsBenchInput(const RunSpec& spec, const BedState& bed, const std::string& data_file,
                             std::int64_t steps) {
  const std::vector<silo::ShapeTemplate> templates = MakeTemplates(spec);
  for (const silo::ShapeTemplate& t : templates)
    if (t.r.size() != 1)
      throw std::invalid_argument("LAMMPS side by side: every body must be a disc (species \"" + t.name + "\" is not)");
  if (spec.silo.base_outlets.size() != 1 || !spec.silo.side_outlets.empty() || !spec.silo.obstacles.empty())
    throw std::invalid_argument("LAMMPS side by side: the silo must have exactly one base outlet and nothing else");
  const double hw = spec.silo.width / 2;
  const BaseOutlet& outlet = spec.silo.base_outlets[0];
  double top = 0.0, r_max = 0.0;
  for (std::size_t b = 0; b < bed.x.size(); ++b) top = std::max(top, bed.y[b]);
  for (const silo::ShapeTemplate& t : templates) r_max = std::max(r_max, t.r[0]);
  const double ylo = -(spec.discharge.exit_distance + kPeriodicFall), yhi = top + 2 * r_max + 1.0;

  std::ostringstream data;
  data.precision(17);
  data << "LAMMPS data file: Granary bench bed, " << bed.x.size() << " discs\n\n"
       << bed.x.size() << " atoms\n"
       << templates.size() << " atom types\n\n"
       << -hw - 1 << " " << hw + 1 << " xlo xhi\n"
       << ylo << " " << yhi << " ylo yhi\n-0.5 0.5 zlo zhi\n\n"
       << "Atoms # sphere\n\n";
  for (std::size_t b = 0; b < bed.x.size(); ++b) {
    const silo::ShapeTemplate& t = templates[static_cast<std::size_t>(bed.species[b])];
    data << b + 1 << " " << bed.species[b] + 1 << " " << 2 * t.r[0] << " " << spec.bodies.density << " " << bed.x[b]
         << " " << bed.y[b] << " 0\n";
  }
  data << "\nVelocities\n\n";
  for (std::size_t b = 0; b < bed.x.size(); ++b)
    data << b + 1 << " " << bed.vx[b] << " " << bed.vy[b] << " 0 0 0 " << bed.omega[b] << "\n";

  const Contact& c = spec.contact;
  auto law = [&](double mu) {
    std::ostringstream o;
    o.precision(17);
    o << "hertz/history " << c.kn << " " << c.kt << " " << c.gamma_n << " " << c.gamma_t << " " << mu << " 1";
    return o.str();
  };
  const std::string pair_law = law(c.mu), wall_law = law(c.mu_wall);
  std::ostringstream in;
  in.precision(17);
  in << "# Granary's bench case on LAMMPS (granary-engine bench --versus lammps, docs/benchmarks.md):\n"
     << "# a settled bed of discs, the outlet open at t = 0, gran/hertz/history, true 2-D.\n"
     << "units lj\ndimension 2\natom_style sphere\natom_modify map array\nboundary f p p\n"
     << "processors * 1 1   # ranks side by side in x\n"
     << "comm_modify vel yes\n"
     << "read_data " << data_file << "\n"
     << "set group all density/disc " << spec.bodies.density << "   # disc mass rho pi r^2 (docs/model.md)\n"
     << "pair_style gran/" << pair_law << "\npair_coeff * *\n"
     << "neighbor 0.2 bin\nneigh_modify delay 0 every 1 check yes\n"
     << "timestep " << spec.time_step << "\n"
     << "fix integrate all nve/sphere   # sphere inertia 0.4 m r^2, as the engine\n"
     << "fix gravity all gravity " << spec.gravity << " vector 0 -1 0\n"
     << "fix plane all enforce2d\n"
     << "fix side_walls all wall/gran " << wall_law << " xplane " << -hw << " " << hw
     << "\n"
     // The base left and right of the outlet: blocks below y = 0 whose outside the discs
     // touch, on their top faces or (at the outlet) their corners.
     << "region base_left block " << -hw - 10 << " " << outlet.center - outlet.width / 2 << " " << ylo - 10
     << " 0 -1 1 side out\n"
     << "region base_right block " << outlet.center + outlet.width / 2 << " " << hw + 10 << " " << ylo - 10
     << " 0 -1 1 side out\n"
     << "fix base_left all wall/gran/region " << wall_law << " region base_left\n"
     << "fix base_right all wall/gran/region " << wall_law << " region base_right\n"
     << "thermo " << steps << "\n"
     << "run " << steps << "\n";
  return {data.str(), in.str()};
}

namespace {

// Runs argv (searched in PATH) and waits; returns its exit status (-1 if it did not exit).
int RunProgram(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawnp(&pid, args[0], nullptr, nullptr, args.data(), environ) != 0)
    throw std::runtime_error("cannot start " + argv[0]);
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) throw std::runtime_error("waitpid failed for " + argv[0]);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

double LammpsRound(const fs::path& dir, int processes) {
  const fs::path log = dir / "log.lammps";
  fs::remove(log);
  std::vector<std::string> argv;
  if (processes > 1) {
    argv = {"mpirun"};
    if (::geteuid() == 0) argv.push_back("--allow-run-as-root");
    argv.insert(argv.end(), {"-np", std::to_string(processes)});
  }
  argv.insert(argv.end(), {"lmp", "-in", (dir / "in.bench").string(), "-log", log.string(), "-screen", "none"});
  const int status = RunProgram(argv);
  const double rate = external::LoopTimeRate(log.string());
  if (status != 0 || rate <= 0)
    throw std::runtime_error("LAMMPS failed (exit status " + std::to_string(status) + "); last lines of " +
                             log.string() + ":\n" + TailOfFile(log, 15));
  return rate;
}

}  // namespace

std::vector<VersusResult> RunBenchVersusLammps(const BenchOptions& options, const std::string& dir_name) {
  const fs::path dir = fs::absolute(dir_name);
  fs::create_directories(dir);
  const nlohmann::json spec_json = BenchSpec(options);
  const RunSpec spec = RunSpec::FromJson(spec_json);
  const ObtainedBed bed = BenchBed(options, spec_json, dir);
  const LammpsInput input = LammpsBenchInput(spec, bed.bed, (dir / "bed.data").string(), options.steps);
  WriteAtomically(dir / "bed.data", input.data);
  WriteAtomically(dir / "in.bench", input.script);
  std::vector<VersusResult> results;
  for (int round = 1; round <= options.repeat; ++round) {
    const double round_trip = MostThreads(options) > 1 ? CoreRoundTripNs() : 0.0;
    for (int threads : options.threads) {
      const double lammps = LammpsRound(dir, threads);
      const BenchResult native = NativeRound(spec_json, dir / "native", round, threads);
      results.push_back({round, threads, native.disc_steps_per_s, lammps, threads > 1 ? round_trip : 0.0});
    }
  }
  fs::remove_all(dir / "native");
  return results;
}

}  // namespace granary::engine
