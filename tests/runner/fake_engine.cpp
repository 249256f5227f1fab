// A fake engine for the runner tests, obeying the run-directory contract
// (docs/run-directory.md) without physics: it counts steps with a short sleep each, writes
// progress.json atomically and a checkpoint after every step, continues from the checkpoint
// when restarted, and ends with summary.json then DONE. Every start and finish is appended to
// DIR/launches.txt so tests can prove that nothing ran twice.
// Behaviour from run.json: /discharge/max_time == 13 -> fails (exit 3); == 666 -> hangs.
// FAKE_ENGINE_STEPS (default 10) and FAKE_ENGINE_STEP_MS (default 30) set the length.
// FAKE_ENGINE_HOLD=PATH: at the middle step (after its checkpoint) wait until PATH exists, so
// a test can act on a run known to be mid-way without timing it.
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

namespace fs = std::filesystem;

namespace {
int EnvInt(const char* name, int def) {
  const char* v = std::getenv(name);
  return v && *v ? std::atoi(v) : def;
}
void WriteAtomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << text;
  }
  fs::rename(tmp, path);
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 3 || std::string(argv[1]) != "run") {
    std::cerr << "usage: fake_engine run DIR [--threads N]\n";
    return 2;
  }
  const fs::path dir = argv[2];
  std::ifstream in(dir / "run.json");
  if (!in) {
    std::cerr << "fake_engine: no run.json in " << dir << "\n";
    return 2;
  }
  const nlohmann::json spec = nlohmann::json::parse(in);
  {
    std::ofstream log(dir / "launches.txt", std::ios::app);
    log << "start " << getpid() << "\n";
  }
  const double max_time = spec["discharge"]["max_time"].get<double>();
  const int steps = EnvInt("FAKE_ENGINE_STEPS", 10);
  const int step_ms = EnvInt("FAKE_ENGINE_STEP_MS", 30);
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
    WriteAtomically(dir / "checkpoint.fake", std::to_string(step + 1));
    const double f = static_cast<double>(step + 1) / steps;
    WriteAtomically(dir / "progress.json",
                    nlohmann::json{{"phase", "discharge"}, {"fraction", f}, {"t", step + 1}, {"t_end", steps},
                                   {"exited", step + 1}, {"wall_s", 0.0}}
                        .dump());
    std::cout << "progress phase=discharge fraction=" << f << " t=" << step + 1 << " exited=" << step + 1 << std::endl;
  }
  nlohmann::json summary = {{"engine", "fake"},
                            {"engine_version", "0.0"},
                            {"run_id", spec["run_id"]},
                            {"spec", spec},
                            {"end_reason", "discharged"},
                            {"bodies", spec["bodies"]["count"]},
                            {"exited", steps},
                            {"remaining", 0},
                            {"t_end", static_cast<double>(steps)},
                            {"timing", {{"wall_s", steps * step_ms / 1000.0}, {"threads", 1}}}};
  WriteAtomically(dir / "summary.json", summary.dump(2));
  {
    std::ofstream log(dir / "launches.txt", std::ios::app);
    log << "finish " << getpid() << "\n";
  }
  WriteAtomically(dir / "DONE", "");
  return 0;
}
