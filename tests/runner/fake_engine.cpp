// A fake engine for the runner tests, obeying the run-directory contract
// (docs/run-directory.md) without physics, through the run-directory library's writers: it
// counts steps with a short sleep each, writes progress.json and a checkpoint after every step, continues from the checkpoint
// when restarted, and ends with summary.json then DONE. Every start and finish is appended to
// DIR/launches.txt so tests can prove that nothing ran twice. Like the engines, it holds the
// directory's writer lock (rundir/files.h) for its life.
// Behaviour from run.json: /discharge/max_time == 13 -> fails (exit 3); == 666 -> hangs;
// == 21 -> its exits are 1 + (seed % 5) / 4 apart, so the flow rate differs between replicas
// by a known, deterministic amount (the adaptive-replica tests).
// FAKE_ENGINE_STEPS (default 10) and FAKE_ENGINE_STEP_MS (default 30) set the length;
// FAKE_ENGINE_FIRST_LAUNCH_STEP_MS the step of a run's first launch (long: it cannot finish
// before a test kills it; the relaunch is quick).
// FAKE_ENGINE_HOLD=PATH: at the middle step (after its checkpoint) wait until PATH exists, so
// a test can act on a run known to be mid-way without timing it.
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "rundir/events.h"
#include "rundir/files.h"
#include "rundir/progress.h"
#include "rundir/run_directory.h"
#include "rundir/summary.h"

namespace fs = std::filesystem;

namespace {
int EnvInt(const char* name, int def) {
  const char* v = std::getenv(name);
  return v && *v ? std::atoi(v) : def;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 3 || std::string(argv[1]) != "run") {
    std::cerr << "usage: fake_engine run DIR [--threads N]\n";
    return 2;
  }
  const fs::path dir = argv[2];
  std::unique_ptr<granary::RunDirectoryLock> lock;
  try {
    lock = std::make_unique<granary::RunDirectoryLock>(dir);
  } catch (const granary::RunDirectoryBusy& e) {
    std::cerr << "fake_engine: " << e.what() << "\n";
    return granary::kExitRunDirectoryBusy;
  }
  nlohmann::json spec;
  try {
    spec = granary::rundir::ReadRunSpecJson(dir);
  } catch (const granary::rundir::ReadError& e) {
    std::cerr << "fake_engine: " << e.what() << "\n";
    return 2;
  }
  const bool first_launch = !fs::exists(dir / "launches.txt");
  {
    std::ofstream log(dir / "launches.txt", std::ios::app);
    log << "start " << getpid() << "\n";
  }
  const double max_time = spec["discharge"]["max_time"].get<double>();
  const int steps = EnvInt("FAKE_ENGINE_STEPS", 10);
  int step_ms = EnvInt("FAKE_ENGINE_STEP_MS", 30);
  if (first_launch) step_ms = EnvInt("FAKE_ENGINE_FIRST_LAUNCH_STEP_MS", step_ms);
  int step = 0;
  if (std::ifstream ck(dir / "checkpoint.fake"); ck) {
    ck >> step;
    std::cout << "continuing from checkpoint at step " << step << std::endl;
  }
  const char* hold = std::getenv("FAKE_ENGINE_HOLD");
  for (; step < steps; ++step) {
    if (hold && *hold && step == steps / 2) {
      while (!fs::exists(hold)) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (max_time == 13 && step == steps / 2) {
      std::cerr << "fake_engine: deliberate failure at step " << step << std::endl;
      return 3;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(max_time == 666 ? 100000 : step_ms));
    granary::WriteAtomically(dir / "checkpoint.fake", std::to_string(step + 1));
    const double f = static_cast<double>(step + 1) / steps;
    granary::rundir::WriteProgress(dir, {"discharge", f, step + 1.0, static_cast<double>(steps), step + 1, 0.0}, true);
  }
  granary::rundir::Summary summary;
  summary.engine = "fake";
  summary.engine_version = "0.0";
  summary.run_id = spec["run_id"];
  summary.spec = spec;
  summary.end_reason = "discharged";
  summary.bodies = spec["bodies"]["count"];
  summary.exited = steps;
  summary.remaining = 0;
  const double dt = max_time == 21 ? 1.0 + static_cast<double>(spec["seed"].get<std::uint64_t>() % 5) / 4.0 : 1.0;
  summary.t_end = steps * dt;
  summary.timing = granary::rundir::Timing{steps * step_ms / 1000.0, 0.0, steps * step_ms / 1000.0, 0.0, 1};
  granary::rundir::WriteSummary(dir, summary);
  {
    std::ofstream log(dir / "launches.txt", std::ios::app);
    log << "finish " << getpid() << "\n";
  }
  // One exit per step, as summary.json says (a finished run whose events.csv disagrees with
  // its summary is damaged).
  std::vector<granary::rundir::ExitEvent> exits;
  for (int k = 0; k < steps; ++k) exits.push_back({(k + 1) * dt, k, "disc", 0.785, 0});
  granary::rundir::WriteEvents(dir / "events.csv", exits);
  granary::rundir::WriteDone(dir, summary.end_reason);
  return 0;
}
