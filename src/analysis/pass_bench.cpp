// granary-pass-bench: how fast the analysis pass reads frames. Writes a run directory with
// frames and contact frames of N dumbbells (positions on a jittered lattice, contacts between
// lattice neighbours; through the run-directory writers, so the text is the engines'), then
// runs an analysis that asks for every frame with its contacts and touches every disc, body
// and contact (`--work K` times, standing in for an analysis' own cost), with the pass on 1
// and on 2 threads, in interleaved rounds. Prints frames per second.
// Usage: granary-pass-bench [--bodies N] [--frames F] [--work K] [--repeat R] [--dir DIR] [--format text|gsd]
// (--format gsd: frames.gsd and contacts.gsd, output.format "gsd", docs/run-directory.md)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "analysis/run_pass.h"
#include "rundir/contacts.h"
#include "rundir/events.h"
#include "rundir/frames.h"
#include "rundir/run_directory.h"
#include "rundir/summary.h"

namespace {

namespace fs = std::filesystem;
using granary::analysis::Analysis;
using granary::analysis::FrameRequest;
using granary::analysis::FrameView;
using granary::analysis::Metric;
using granary::analysis::PassUse;
using granary::analysis::RunAccumulator;
using granary::analysis::RunView;

void WriteRun(const fs::path& dir, int bodies, int frames, bool gsd) {
  namespace rd = granary::rundir;
  fs::create_directories(dir);
  rd::WriteRunSpec(dir, {{"run_id", "bench"}, {"discharge", {{"mode", "reinject"}}}, {"bodies", {{"count", bodies}}}});
  rd::WriteEvents(dir / rd::kEventsFile, {});
  rd::Summary s;
  s.engine = "bench";
  s.bodies = bodies;
  s.remaining = bodies;
  s.t_end = frames;
  rd::WriteSummary(dir, s);
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> jitter(-0.05, 0.05);
  const int columns = 100;
  rd::FrameWriter fw = rd::FrameWriter::Create(dir / (gsd ? rd::kFramesGsdFile : rd::kFramesFile));
  rd::ContactWriter cw = rd::ContactWriter::Create(dir / (gsd ? rd::kContactsGsdFile : rd::kContactsFile));
  rd::Frame f;
  rd::ContactFrame c;
  for (int k = 0; k < frames; ++k) {
    f.timestep = c.timestep = 10000 * k;
    f.time = c.time = k;
    f.discs.clear();
    c.contacts.clear();
    for (int b = 0; b < bodies; ++b) {
      const double x = 2.0 * (b % columns) - columns + jitter(rng), y = 1.0 * (b / columns) + jitter(rng);
      f.discs.push_back({2 * b + 1, b, 1, x, y, 0.5, 0.7853981633974483, jitter(rng), -0.3 + jitter(rng), jitter(rng)});
      f.discs.push_back(
          {2 * b + 2, b, 1, x + 1.0, y, 0.5, 0.7853981633974483, jitter(rng), -0.3 + jitter(rng), jitter(rng)});
      // Contacts with the body to the right and the one above, and the base for the first row.
      if (b % columns + 1 < columns)
        c.contacts.push_back({b, b + 1, x + 1, y, x + 2, y, x + 1.5, y, jitter(rng), 1 + jitter(rng)});
      if (b + columns < bodies)
        c.contacts.push_back({b, b + columns, x, y, x, y + 1, x, y + 0.5, jitter(rng), 2 + jitter(rng)});
      if (b < columns) c.contacts.push_back({b, -1, x, y, x, y - 0.5, x, y - 0.5, 0, 3 + jitter(rng)});
    }
    fw.Write(f);
    cw.Write(c);
  }
  fw.Close();
  cw.Close();
}

// Asks for every frame with its contacts and sums something of every disc, body and contact,
// as a coarse-graining analysis would touch them, `work` times.
class TouchAll : public Analysis {
 public:
  explicit TouchAll(int work) : work_(work) {}
  std::string Key() const override { return "touch_all"; }
  int Version() const override { return 1; }
  PassUse PassOptionsUsed() const override { return {.window = false, .clog_gap = false, .frames = true}; }
  std::unique_ptr<RunAccumulator> Start(const RunView&) const override {
    class Acc : public RunAccumulator {
     public:
      explicit Acc(int work) : work_(work) {}
      FrameRequest Frames() const override { return {{{}}, true}; }
      void AddFrame(const FrameView& f) override {
        for (int k = 0; k < std::max(1, work_); ++k) {
          for (const auto& d : f.frame.discs) sum_ += std::sqrt(d.vx * d.vx + d.vy * d.vy + k);
          for (const auto& b : f.bodies) sum_ += std::sqrt(b.vx * b.vx + b.vy * b.vy + k);
          if (f.contacts)
            for (const auto& c : f.contacts->contacts) sum_ += std::sqrt(c.fx * c.fx + c.fy * c.fy + k);
        }
      }
      nlohmann::json Finish() override { return sum_; }

     private:
      int work_;
      double sum_ = 0.0;
    };
    return std::make_unique<Acc>(work_);
  }
  std::vector<Metric> RunMetrics(const nlohmann::json&) const override { return {}; }

 private:
  int work_;
};

}  // namespace

int main(int argc, char** argv) {
  int bodies = 15000, frames = 20, repeat = 3, work = 1;
  fs::path dir;
  bool gsd = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--bodies" && has_value)
      bodies = std::atoi(argv[++i]);
    else if (a == "--frames" && has_value)
      frames = std::atoi(argv[++i]);
    else if (a == "--repeat" && has_value)
      repeat = std::atoi(argv[++i]);
    else if (a == "--work" && has_value)
      work = std::atoi(argv[++i]);
    else if (a == "--dir" && has_value)
      dir = argv[++i];
    else if (a == "--format" && has_value)
      gsd = std::string(argv[++i]) == "gsd";
    else {
      std::fprintf(stderr,
                   "usage: granary-pass-bench [--bodies N] [--frames F] [--work K] [--repeat R] [--dir DIR] "
                   "[--format text|gsd]\n");
      return a == "--help" ? 0 : 2;
    }
  }
  const bool own_dir = dir.empty();
  if (own_dir) dir = fs::temp_directory_path() / ("granary-pass-bench-" + std::to_string(::getpid()));
  if (!fs::exists(dir / "frames.dump") && !fs::exists(dir / "frames.gsd")) WriteRun(dir, bodies, frames, gsd);
  const granary::rundir::RunData data = granary::rundir::ReadRun(dir);
  std::printf("pass bench: %d dumbbells (%d discs, ~%d contacts) x %d frames, %.1f MB of %s, work %d\n", bodies,
              2 * bodies, 2 * bodies, frames,
              static_cast<double>(fs::file_size(data.FramesFile()) + fs::file_size(data.ContactsFile())) / 1e6,
              data.gsd ? "GSD" : "dumps", work);
  const TouchAll analysis(work);
  granary::analysis::PassOptions pass;
  for (int round = 1; round <= repeat; ++round)
    for (int threads : {1, 2}) {
      granary::analysis::RunPassOptions o;
      o.threads = threads;
      o.read_cache = o.write_cache = false;
      const auto t0 = std::chrono::steady_clock::now();
      const auto r = granary::analysis::AnalyseRun(dir, {&analysis}, pass, o);
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::printf("round=%d threads=%d frames=%d seconds=%.3f frames_per_s=%.1f\n", round, threads, r.frames_parsed, s,
                  r.frames_parsed / s);
      std::fflush(stdout);
    }
  if (own_dir) fs::remove_all(dir);
  return 0;
}
