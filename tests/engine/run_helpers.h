// What the small-silo run tests share: fresh run directories and cached beds in this build
// tree, a small spec, running a directory through the library or the real executable.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/bench.h"
#include "engine/run.h"
#include "rundir/version.h"

namespace granary::engine {
namespace fs = std::filesystem;

inline std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline nlohmann::json ReadJson(const fs::path& p) { return nlohmann::json::parse(Slurp(p)); }

// A fresh directory under this build tree's test area; beds are cached next to it and
// shared by every test (flock-protected).
inline fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::path(GRANARY_ENGINE_TEST_TMP) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// shape: "dumbbell" (the default species), "disc" or "mixture" (as the bench's).
inline std::string BedCache(std::uint64_t seed, const std::string& shape = "dumbbell") {
  const std::string name = shape == "dumbbell" ? "" : shape + "-";
  return (fs::path(GRANARY_ENGINE_TEST_TMP) /
          ("bed-" + name + std::to_string(seed) + "-" + granary::GitCommit() + ".json"))
      .string();
}

inline nlohmann::json SmallSpec(double outlet, double max_time, std::uint64_t seed = 7,
                                const std::string& shape = "dumbbell") {
  nlohmann::json bodies = {{"count", 120}};
  if (shape != "dumbbell") bodies["species"] = BenchSpecies(shape);
  return {{"run_id", "test"},
          {"seed", seed},
          {"silo", {{"width", 16.0}, {"base_outlets", {{{"center", 0.0}, {"width", outlet}}}}}},
          {"bodies", bodies},
          {"bed",
           {{"batch_size", 120},
            {"settle_ke_per_body", 1e-4},
            {"max_settle_time", 10.0},
            {"cache_file", BedCache(seed, shape)}}},
          {"discharge", {{"mode", "remove"}, {"max_time", max_time}, {"clog_window", 2.0}}},
          {"output", {{"checkpoint_interval", 1.0}, {"frame_interval", 0.5}}}};
}

inline void WriteSpec(const fs::path& dir, const nlohmann::json& spec) {
  std::ofstream(dir / "run.json") << spec.dump(2);
}

inline std::vector<double> EventTimes(const fs::path& dir) {
  std::ifstream in(dir / "events.csv");
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "time,body,shape,mass,outlet");
  std::vector<double> t;
  while (std::getline(in, line)) t.push_back(std::stod(line.substr(0, line.find(','))));
  return t;
}

inline RunResult RunQuiet(const fs::path& dir, int threads = 1, std::int64_t abort_after = -1, int force_block = 0,
                          std::int64_t stop_after = -1) {
  RunOptions o;
  o.stop_after_steps = stop_after;
  o.force_block = force_block;
  o.parallel_min_discs = 0;  // exercise the parallel loops even on these small systems
  o.threads = threads;
  o.quiet = true;
  o.abort_after_steps = abort_after;
  return RunDirectory(dir.string(), o);
}

inline int RunExe(const std::string& args) {
  const int status = std::system((std::string(GRANARY_ENGINE_EXE) + " " + args + " > /dev/null 2>&1").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace granary::engine
