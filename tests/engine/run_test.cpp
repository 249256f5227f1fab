// Small silo runs through the library and the real granary-engine executable: discharge,
// clogging, checkpoint/continue, determinism across seeds and thread counts, bed cache.
#include "engine/bed.h"
#include "engine/bench.h"
#include "run_helpers.h"
#include "engine/run.h"
#include "rundir/clogs.h"
#include "rundir/files.h"
#include "rundir/frames.h"
#include "rundir/hash.h"
#include "rundir/layout.h"
#include "rundir/manifest.h"
#include "rundir/stop.h"
#include "rundir/version.h"

#include <signal.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <chrono>
#include <thread>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <zlib.h>

namespace granary::engine {
namespace {
namespace fs = std::filesystem;

// Runs the executable; its exit status (or 128 + the signal that ended it) and its output.
std::pair<int, std::string> RunExeOutput(const std::string& args) {
  const std::string cmd = std::string(GRANARY_ENGINE_EXE) + " " + args + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  std::string out;
  char buf[512];
  while (p && std::fgets(buf, sizeof buf, p)) out += buf;
  const int status = p ? ::pclose(p) : -1;
  return {WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), out};
}

// The lines of `text` that start with `prefix`.
std::vector<std::string> LinesStartingWith(const std::string& text, const std::string& prefix) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (line.rfind(prefix, 0) == 0) lines.push_back(line);
  return lines;
}

TEST(Run, SmallSiloDischargesAndItsExitCountGrows) {
  const fs::path dir = FreshDir("discharge");
  WriteSpec(dir, SmallSpec(10.0, 5.0));
  const RunResult r = RunQuiet(dir);
  const std::vector<double> t = EventTimes(dir);
  // Beverloo-like 2-D flow for W = 10 d is about 8 dumbbells per sqrt(d/g) once flowing
  ASSERT_GT(t.size(), 15u);
  for (std::size_t k = 1; k < t.size(); ++k) EXPECT_LE(t[k - 1], t[k]);
  int late = 0;
  for (double x : t) late += x > 3.0;
  EXPECT_GT(late, 5);  // still flowing later on
  const nlohmann::json s = ReadJson(dir / "summary.json");
  EXPECT_EQ(s["exited"].get<std::size_t>(), t.size());
  EXPECT_EQ(s["exited"].get<int>() + s["remaining"].get<int>(), 120);
  EXPECT_EQ(r.exited, static_cast<int>(t.size()));
  EXPECT_TRUE(fs::exists(dir / "DONE"));
  // frames: one block per 0.5 time units including t = 0
  const std::string frames = Slurp(dir / "frames.dump");
  std::size_t blocks = 0;
  for (std::size_t p = frames.find("ITEM: TIMESTEP"); p != std::string::npos; p = frames.find("ITEM: TIMESTEP", p + 1))
    ++blocks;
  EXPECT_EQ(blocks, 11u);
  // The rate counts the discs still in the silo. Its ratio to the bed's figure is
  // the mean fraction of the 240 discs (120 dumbbells) in the silo over the steps, which the
  // exit times give: a body's 2 discs count up to the step it left.
  const double t_end = s["t_end"].get<double>();
  double missing = 0.0;
  for (double x : t) missing += 2.0 * (t_end - x);
  const double fraction = 1.0 - missing / (240.0 * t_end);
  const nlohmann::json& timing = s["timing"];
  EXPECT_LT(fraction, 0.95);
  EXPECT_NEAR(timing["disc_steps_per_s"].get<double>() / timing["bed_disc_steps_per_s"].get<double>(), fraction, 1e-9);
  EXPECT_NEAR(timing["bed_disc_steps_per_s"].get<double>() * timing["discharge_wall_s"].get<double>(),
              240.0 * static_cast<double>(s["steps"].get<std::int64_t>()),
              1e-6 * 240.0 * static_cast<double>(s["steps"].get<std::int64_t>()));
  // The manifest records what the run left: 11 frames, the exits as rows, every file whole.
  const nlohmann::json manifest = ReadJson(dir / "manifest.json");
  EXPECT_EQ(manifest["counts"]["frames"], 11);
  EXPECT_EQ(manifest["counts"]["events"], t.size());
  EXPECT_EQ(manifest["files"]["frames.dump"]["size"], fs::file_size(dir / "frames.dump"));
  EXPECT_EQ(rundir::VerifyRun(dir, {rundir::VerifyLevel::kChecksums, false}).integrity, rundir::Integrity::kWhole);
}

TEST(Run, TooNarrowOutletClogs) {
  const fs::path dir = FreshDir("clog");
  WriteSpec(dir, SmallSpec(2.0, 40.0));
  const RunResult r = RunQuiet(dir);
  EXPECT_EQ(r.end_reason, "clogged");
  EXPECT_LT(r.t_end, 40.0);
  EXPECT_LT(r.exited, 60);
  EXPECT_EQ(ReadJson(dir / "summary.json")["end_reason"], "clogged");
  // The clogged configuration is kept: every disc in the silo and its contact forces, at the
  // step the engine judged the clog (its last).
  const std::vector<rundir::ClogState> clogs = rundir::ReadClogs(dir);
  ASSERT_EQ(clogs.size(), 1u);
  EXPECT_EQ(clogs[0].frame.timestep, r.steps);
  EXPECT_EQ(static_cast<int>(rundir::BodiesOf(clogs[0].frame.discs).size()),
            ReadJson(dir / "summary.json")["remaining"].get<int>());
  EXPECT_EQ(clogs[0].contacts.timestep, r.steps);
  int pairs = 0, walls = 0;
  for (const auto& c : clogs[0].contacts.contacts) (c.body_j >= 0 ? pairs : walls) += 1;
  EXPECT_GT(pairs, 100);  // a settled bed of 120 dumbbells
  EXPECT_GT(walls, 10);
}

// Going on through a clog (stop_on_clog false), the clog is kept once, with the same bits at 1
// and 2 threads and after a kill and continue, whether the checkpoint before the kill was taken
// after the clog (the clog stays) or before it (the continued run judges it again).
TEST(Run, ClogsAreKeptOnceAtAnyThreadCountAndAcrossAContinue) {
  nlohmann::json spec = SmallSpec(2.0, 1.3);
  spec["discharge"]["stop_on_clog"] = false;
  spec["discharge"]["clog_window"] = 1.0;
  spec["output"]["checkpoint_interval"] = 0.3;
  const fs::path one = FreshDir("clogs-1"), two = FreshDir("clogs-2"), after = FreshDir("clogs-after"),
                 before = FreshDir("clogs-before");
  for (const fs::path& d : {one, two, after, before}) WriteSpec(d, spec);
  // Force blocks of 32 discs (8 blocks). One thread runs the serial loops (fast on 240 discs);
  // two threads the parallel ones (forcing them costs a fork per step, slow beside other tests).
  auto run = [](const fs::path& d, int threads, std::int64_t abort_after) {
    RunOptions o;
    o.threads = threads;
    o.quiet = true;
    o.abort_after_steps = abort_after;
    o.force_block = 32;
    if (threads > 1) o.parallel_min_discs = 0;
    return RunDirectory(d.string(), o);
  };
  EXPECT_EQ(run(one, 1, -1).end_reason, "time_limit");
  const std::vector<rundir::ClogState> clogs = rundir::ReadClogs(one);
  ASSERT_EQ(clogs.size(), 1u);
  // Nothing passes 2 d: the clog is judged after clog_window, at step 10000; checkpoints every 3000 steps.
  ASSERT_EQ(clogs[0].frame.timestep, 10000);
  run(two, 2, -1);
  EXPECT_EQ(run(after, 1, 12500).end_reason, "aborted");   // its checkpoint at 12000 holds the clog
  EXPECT_EQ(run(before, 1, 11000).end_reason, "aborted");  // its checkpoint at 9000 does not
  for (const fs::path& d : {after, before}) EXPECT_TRUE(run(d, 1, -1).continued);
  for (const fs::path& d : {two, after, before}) {
    SCOPED_TRACE(d.filename().string());
    EXPECT_TRUE(Slurp(one / "clog_frames.dump") == Slurp(d / "clog_frames.dump"));
    EXPECT_TRUE(Slurp(one / "clog_contacts.dump") == Slurp(d / "clog_contacts.dump"));
    EXPECT_TRUE(Slurp(one / "events.csv") == Slurp(d / "events.csv"));
  }
}

// Passages beside an obstacle over a narrow outlet jam with nothing over the opening itself; the
// stall is a clog (the bodies above are sealed off), and a wide outlet under a small obstacle
// discharges down to its dead zones (stall.h; tests/engine/stall_test.cpp has the geometry).
TEST(Run, ArchBesideAnObstacleIsAClogAndAnOpenCraterADischarge) {
  const fs::path narrow = FreshDir("obstacle-narrow"), wide = FreshDir("obstacle-wide");
  nlohmann::json spec = SmallSpec(4.0, 40.0);
  spec["silo"]["obstacles"] = {{{"x", 0.0}, {"y", 3.0}, {"diameter", 3.0}}};
  WriteSpec(narrow, spec);
  const RunResult jammed = RunQuiet(narrow);
  EXPECT_EQ(jammed.end_reason, "clogged");
  EXPECT_GT(ReadJson(narrow / "summary.json")["remaining"].get<int>(), 100);

  spec = SmallSpec(12.0, 40.0);
  spec["silo"]["obstacles"] = {{{"x", 0.0}, {"y", 6.0}, {"diameter", 2.0}}};
  WriteSpec(wide, spec);
  const RunResult open = RunQuiet(wide);
  EXPECT_EQ(open.end_reason, "discharged");
  EXPECT_LT(open.t_end, 40.0);
  EXPECT_LT(ReadJson(wide / "summary.json")["remaining"].get<int>(), 20);
}

// A disc alone on the floor of a drained silo is the stagnant remainder, not a flow: the contact
// law has no rolling resistance, so a disc rolling there rolls on (here away from the outlet to
// the side wall and back, reaching the outlet's edge long after max_time, never leaving the
// region near the outlet in this narrow silo), and the run must end discharged at the first
// stall check instead of at max_time. A disc that rolls over the outlet's edge is still
// flowing and leaves.
TEST(Run, ADiscRollingOnTheFloorOfADrainedSiloIsNoFlow) {
  for (const double vx : {0.05, -1.0}) {
    const fs::path dir = FreshDir(vx > 0 ? "rolling-away" : "rolling-out");
    nlohmann::json spec = {{"run_id", "test"},
                           {"seed", 1},
                           {"silo", {{"width", 8.0}, {"base_outlets", {{{"center", 0.0}, {"width", 4.0}}}}}},
                           {"bodies", {{"count", 1}, {"species", {{{"shape", "disc"}, {"diameter", 1.0}}}}}},
                           {"bed", {{"cache_file", (dir / "rolling-bed.json").string()}}},
                           {"discharge", {{"mode", "remove"}, {"max_time", 30.0}, {"clog_window", 2.0}}},
                           {"output", {{"checkpoint_interval", 0.0}, {"frame_interval", 0.0}}}};
    BedState bed;
    bed.species = {0};
    bed.x = {3.0};
    bed.y = {0.5};
    bed.theta = {0.0};
    bed.vx = {vx};
    bed.vy = {0.0};
    bed.omega = {-vx / 0.5};  // rolling without slipping
    bed.height = 1.0;
    std::ofstream(dir / "rolling-bed.json") << BedToJson(bed, RunSpec::FromJson(spec)).dump();
    WriteSpec(dir, spec);
    const RunResult r = RunQuiet(dir);
    EXPECT_EQ(r.end_reason, "discharged") << "vx " << vx;
    if (vx > 0) {
      EXPECT_EQ(r.exited, 0);
      EXPECT_LT(r.t_end, 3.0);  // the first check after clog_window
      EXPECT_EQ(ReadJson(dir / "summary.json")["remaining"], 1);
    } else {
      EXPECT_EQ(r.exited, 1);
      EXPECT_EQ(ReadJson(dir / "summary.json")["remaining"], 0);
    }
  }
}

// Discs, dumbbells and their mixture each take their own loops (world.cpp).
const char* const kShapes[] = {"dumbbell", "disc", "mixture"};

TEST(Run, ContinuedRunEqualsUninterruptedRun) {
  for (const std::string shape : kShapes) {
    const fs::path a = FreshDir("ckpt-a-" + shape), b = FreshDir("ckpt-b-" + shape);
    WriteSpec(a, SmallSpec(8.0, 4.0, 7, shape));
    WriteSpec(b, SmallSpec(8.0, 4.0, 7, shape));
    RunQuiet(a);
    // "killed" at t = 2.7, after the checkpoint at t = 2; continue with the real executable
    EXPECT_EQ(RunQuiet(b, 1, 27000).end_reason, "aborted");
    EXPECT_FALSE(fs::exists(b / "DONE"));
    ASSERT_EQ(RunExe("run " + b.string() + " --threads 1"), 0);
    EXPECT_TRUE(ReadJson(b / "summary.json")["continued_from_checkpoint"].get<bool>());
    EXPECT_GT(EventTimes(a).size(), 0u) << shape;
    EXPECT_EQ(Slurp(a / "events.csv"), Slurp(b / "events.csv")) << shape;
    EXPECT_EQ(Slurp(a / "frames.dump"), Slurp(b / "frames.dump")) << shape;
    // The continued run's manifest records the whole files, as the uninterrupted run's does
    // (the summaries differ: wall times, continued_from_checkpoint).
    const nlohmann::json ma = ReadJson(a / "manifest.json"), mb = ReadJson(b / "manifest.json");
    for (const char* file : {"events.csv", "frames.dump", "clog_frames.dump", "clog_contacts.dump", "run.json"})
      EXPECT_EQ(ma["files"][file], mb["files"][file]) << shape << " " << file;
    EXPECT_EQ(ma["counts"], mb["counts"]) << shape;
    EXPECT_EQ(rundir::VerifyRun(b, {rundir::VerifyLevel::kChecksums, false}).integrity, rundir::Integrity::kWhole);
  }
}

// output.format "gsd": a run killed (SIGKILL, at whatever step the machine's speed gives)
// after a checkpoint, with frames written past it, continues into the uninterrupted run's
// bytes, and HOOMD's own reader (python3-gsd) opens the continued file.
TEST(Run, AKilledGsdRunContinuesIntoTheUninterruptedRunsBytes) {
  const fs::path a = FreshDir("gsd-kill-a"), b = FreshDir("gsd-kill-b");
  nlohmann::json spec = SmallSpec(8.0, 4.0);
  spec["discharge"]["mode"] = "reinject";
  // 81 frames: the index outgrows its first two blocks (at frames 31 and 63).
  spec["output"] = {{"checkpoint_interval", 1.0},
                    {"frame_interval", 0.05},
                    {"format", "gsd"},
                    {"contact_forces", true},
                    {"contact_interval", 3}};
  WriteSpec(a, spec);
  WriteSpec(b, spec);
  RunQuiet(a);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    ::execl(GRANARY_ENGINE_EXE, GRANARY_ENGINE_EXE, "run", b.c_str(), "--threads", "1", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Killed once a checkpoint is written and a frame after it (frames.gsd has grown since): the
  // killed file holds frames the checkpoint does not know of.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  auto size = [&](const char* file) {
    std::error_code ec;
    const auto n = fs::file_size(b / file, ec);
    return ec ? std::uintmax_t{0} : n;
  };
  std::uintmax_t at_checkpoint = 0;
  while (std::chrono::steady_clock::now() < deadline && !fs::exists(b / "DONE")) {
    if (at_checkpoint == 0 && fs::exists(b / "checkpoint.bin")) at_checkpoint = size("frames.gsd");
    if (at_checkpoint > 0 && size("frames.gsd") > at_checkpoint + 4096) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the run ended before it could be killed after a checkpoint";
  ASSERT_FALSE(fs::exists(b / "DONE"));
  ASSERT_EQ(RunExe("run " + b.string() + " --threads 1"), 0);
  EXPECT_TRUE(ReadJson(b / "summary.json")["continued_from_checkpoint"].get<bool>());
  for (const char* file : {"events.csv", "frames.gsd", "contacts.gsd"}) {
    ASSERT_GT(fs::file_size(a / file), 100u) << file;
    EXPECT_TRUE(Slurp(a / file) == Slurp(b / file)) << file << " differs from the uninterrupted run's";
  }
  const nlohmann::json ma = ReadJson(a / "manifest.json"), mb = ReadJson(b / "manifest.json");
  for (const char* file : {"events.csv", "frames.gsd", "contacts.gsd"})
    EXPECT_EQ(ma["files"][file], mb["files"][file]) << file;
  EXPECT_EQ(rundir::VerifyRun(b, {rundir::VerifyLevel::kChecksums, false}).integrity, rundir::Integrity::kWhole);
  rundir::FrameReader r(b / "frames.gsd");
  rundir::Frame f;
  int frames = 0;
  while (r.Next(f)) ++frames;
  EXPECT_EQ(frames, 81);
  const std::string check = std::string(GRANARY_PYTHON) +
                            " -c 'import sys, gsd.hoomd; t = gsd.hoomd.open(sys.argv[1], \"rb\"); "
                            "sys.exit(0 if len(t) == 81 and t[80].particles.N > 0 else 1)' " +
                            (b / "frames.gsd").string() + " > /dev/null 2>&1";
  EXPECT_EQ(std::system(check.c_str()), 0) << check;
}

std::string Gunzip(const fs::path& p) {
  gzFile f = gzopen(p.c_str(), "rb");
  if (!f) return "";
  std::string out;
  char buf[65536];
  for (int n; (n = gzread(f, buf, sizeof buf)) > 0;) out.append(buf, static_cast<std::size_t>(n));
  gzclose(f);
  return out;
}

// output.compress: the same frames and contact frames, one gzip member per frame, so a run
// killed after a checkpoint continues into a valid file equal to the uncompressed one.
TEST(Run, CompressedFramesAreTheSameFramesAndSurviveAContinue) {
  const fs::path plain = FreshDir("gz-plain"), gz = FreshDir("gz-continued");
  nlohmann::json spec = SmallSpec(8.0, 4.0);
  spec["output"]["contact_forces"] = true;
  WriteSpec(plain, spec);
  spec["output"]["compress"] = true;
  WriteSpec(gz, spec);
  RunQuiet(plain);
  EXPECT_EQ(RunQuiet(gz, 1, 27000).end_reason, "aborted");
  ASSERT_EQ(RunExe("run " + gz.string() + " --threads 1"), 0);
  EXPECT_TRUE(ReadJson(gz / "summary.json")["continued_from_checkpoint"].get<bool>());
  EXPECT_FALSE(fs::exists(gz / "frames.dump"));
  EXPECT_FALSE(fs::exists(gz / "contacts.dump"));
  const std::string frames = Slurp(plain / "frames.dump"), contacts = Slurp(plain / "contacts.dump");
  ASSERT_GT(frames.size(), 10000u);
  EXPECT_EQ(Gunzip(gz / "frames.dump.gz"), frames);
  EXPECT_EQ(Gunzip(gz / "contacts.dump.gz"), contacts);
  EXPECT_LT(fs::file_size(gz / "frames.dump.gz"), frames.size() / 2);
  EXPECT_EQ(Slurp(plain / "events.csv"), Slurp(gz / "events.csv"));
  // The silo beside the frames, the same for both.
  EXPECT_EQ(Slurp(plain / "silo.vtk").rfind("# vtk DataFile Version 3.0\n", 0), 0u);
  EXPECT_EQ(Slurp(plain / "silo.vtk"), Slurp(gz / "silo.vtk"));
}

TEST(Run, SameSeedSameOutputOtherSeedOtherOutput) {
  const fs::path a = FreshDir("seed-a"), b = FreshDir("seed-b"), c = FreshDir("seed-c");
  WriteSpec(a, SmallSpec(8.0, 2.0, 7));
  WriteSpec(b, SmallSpec(8.0, 2.0, 7));
  WriteSpec(c, SmallSpec(8.0, 2.0, 8));
  RunQuiet(a);
  RunQuiet(b);
  RunQuiet(c);
  EXPECT_EQ(Slurp(a / "events.csv"), Slurp(b / "events.csv"));
  EXPECT_EQ(Slurp(a / "frames.dump"), Slurp(b / "frames.dump"));
  EXPECT_NE(Slurp(a / "frames.dump"), Slurp(c / "frames.dump"));
}

TEST(Run, OneAndTwoThreadsGiveIdenticalOutput) {
  for (const std::string shape : kShapes) {
    const fs::path a = FreshDir("threads-1-" + shape), b = FreshDir("threads-2-" + shape);
    // positions and velocities of every disc after 10^4 steps of a settled bed draining
    WriteSpec(a, SmallSpec(8.0, 1.0, 7, shape));
    WriteSpec(b, SmallSpec(8.0, 1.0, 7, shape));
    // blocks of 32 discs, so that pair reactions also cross blocks
    RunQuiet(a, 1, -1, 32);
    RunQuiet(b, 2, -1, 32);
    EXPECT_EQ(Slurp(a / "events.csv"), Slurp(b / "events.csv")) << shape;
    EXPECT_EQ(Slurp(a / "frames.dump"), Slurp(b / "frames.dump")) << shape;
    // The continued run's manifest records the whole files, as the uninterrupted run's does
    // (the summaries differ: wall times, continued_from_checkpoint).
    const nlohmann::json ma = ReadJson(a / "manifest.json"), mb = ReadJson(b / "manifest.json");
    for (const char* file : {"events.csv", "frames.dump", "clog_frames.dump", "clog_contacts.dump", "run.json"})
      EXPECT_EQ(ma["files"][file], mb["files"][file]) << shape << " " << file;
    EXPECT_EQ(ma["counts"], mb["counts"]) << shape;
    EXPECT_EQ(rundir::VerifyRun(b, {rundir::VerifyLevel::kChecksums, false}).integrity, rundir::Integrity::kWhole);
  }
}

TEST(Run, ReinjectKeepsTheBedAndReusesIds) {
  const fs::path dir = FreshDir("reinject");
  nlohmann::json spec = SmallSpec(8.0, 4.0);
  spec["discharge"]["mode"] = "reinject";
  spec["discharge"]["reinject_speed"] = 0.5;
  WriteSpec(dir, spec);
  const RunResult r = RunQuiet(dir);
  EXPECT_EQ(r.end_reason, "time_limit");
  const nlohmann::json s = ReadJson(dir / "summary.json");
  EXPECT_EQ(s["remaining"].get<int>(), 120);
  EXPECT_GT(s["exited"].get<int>(), 8);
  // every id is a valid body (reinjected bodies keep theirs)
  std::ifstream in(dir / "events.csv");
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    const int body = std::stoi(line.substr(line.find(',') + 1));
    EXPECT_GE(body, 0);
    EXPECT_LT(body, 120);
  }
}

// A returned body lands on the bed, not on an earlier return still in the air: the demo's
// W = 12 case (300 dumbbells in a 30 d silo, about 11 returns per time unit): returns put
// above the highest disc of their column, falling or not, would stack up into a rain (at
// t = 15, 90 % of the bodies below 41 d instead of 18 d) while the bed drained.
TEST(Run, ReturnedBodiesLandOnTheBedAndTheBedKeepsItsHeight) {
  const fs::path dir = FreshDir("reinject-height");
  nlohmann::json spec = SmallSpec(12.0, 15.0);
  spec["silo"]["width"] = 30.0;
  spec["bodies"]["count"] = 300;
  spec["bed"]["batch_size"] = 150;
  spec["bed"]["cache_file"] = BedCache(7, "dumbbell-300");
  spec["discharge"]["mode"] = "reinject";
  spec["discharge"]["reinject_speed"] = 0.0;
  WriteSpec(dir, spec);
  EXPECT_EQ(RunQuiet(dir).end_reason, "time_limit");
  EXPECT_GT(ReadJson(dir / "summary.json")["exited"].get<int>(), 100);
  rundir::FrameReader frames(dir / rundir::kFramesFile);
  rundir::Frame f;
  double p90_at_0 = -1, top_at_0 = -1;
  int frames_seen = 0;
  while (frames.Next(f)) {
    std::vector<double> y;
    for (const rundir::Body& b : rundir::BodiesOf(f.discs)) y.push_back(b.y);
    std::sort(y.begin(), y.end());
    const double p90 = y[y.size() * 9 / 10], top = y.back();
    if (p90_at_0 < 0) {
      p90_at_0 = p90;
      top_at_0 = top;
      continue;
    }
    ++frames_seen;
    // The few returns in the air at a time: over seeds 7-10 and the beds of main's 5 x and the
    // landed 8 x procedure, up to 12 bodies more than 5 d above the bed's top at t = 0 and the
    // highest 15.1 d above it (the 90th percentile up to 3.4 d; the rain: 23 d at t = 15).
    EXPECT_LT(p90, p90_at_0 + 3.0) << "t = " << f.time << ": the 90th percentile of the bodies' heights";
    EXPECT_LT(top, top_at_0 + 20.0) << "t = " << f.time << ": the highest body";
    EXPECT_LE(std::count_if(y.begin(), y.end(), [&](double v) { return v > top_at_0 + 5.0; }), 15) << "t = " << f.time;
  }
  EXPECT_EQ(frames_seen, 30);
  // The draws and velocities of the returns are the same bits on two threads and after a
  // checkpoint-continue ("killed" at t = 7.3, continued by the executable).
  const fs::path continued = FreshDir("reinject-height-continued");
  WriteSpec(continued, spec);
  EXPECT_EQ(RunQuiet(continued, 2, 73000).end_reason, "aborted");
  ASSERT_EQ(RunExe("run " + continued.string() + " --threads 2"), 0);
  EXPECT_EQ(Slurp(dir / "events.csv"), Slurp(continued / "events.csv"));
  EXPECT_EQ(Slurp(dir / "frames.dump"), Slurp(continued / "frames.dump"));
}

// Periodic reinjection (LIGGGHTS' y-periodicity): a counted body falls on to the bottom of the
// box, kPeriodicFall below the counting plane, and comes back at the top with its x and its
// velocity; nothing is lost, nothing is counted twice on the way down, and a continued run
// equals an uninterrupted one.
TEST(Run, PeriodicReinjectionReturnsBodiesThroughTheBottomOfTheBox) {
  const fs::path a = FreshDir("periodic-a"), b = FreshDir("periodic-b");
  nlohmann::json spec = SmallSpec(8.0, 4.0);
  spec["discharge"]["mode"] = "reinject";
  spec["discharge"]["reinject_position"] = "periodic";
  WriteSpec(a, spec);
  WriteSpec(b, spec);
  RunQuiet(a);
  const nlohmann::json s = ReadJson(a / "summary.json");
  EXPECT_EQ(s["remaining"].get<int>(), 120);
  EXPECT_GT(s["exited"].get<int>(), 8);
  EXPECT_EQ(s["spec"]["discharge"]["reinject_position"], "periodic");
  // Frames: some discs are between the counting plane (y = -2) and the bottom (y = -5), none
  // further down than a step's fall, and the top of the box holds the returned bodies.
  std::ifstream in(a / "frames.dump");
  std::string line;
  double lowest = 1e300;
  int falling = 0;
  while (std::getline(in, line)) {
    if (line.rfind("ITEM: ATOMS", 0) == 0 || line.rfind("ITEM", 0) == 0) continue;
    std::istringstream row(line);
    std::vector<double> v;
    for (double x; row >> x;) v.push_back(x);
    if (v.size() < 12) continue;
    const double y = v[4];
    lowest = std::min(lowest, y);
    falling += y < -2.0 - 0.5 ? 1 : 0;
  }
  EXPECT_GT(falling, 0);
  EXPECT_GT(lowest, -(2.0 + kPeriodicFall) - 0.5 - 0.01);
  // No body is counted twice within the time it needs to fall out and come back down
  // through the bed (> 1 time unit here).
  std::ifstream ev(a / "events.csv");
  std::getline(ev, line);
  std::map<int, double> last;
  while (std::getline(ev, line)) {
    const double t = std::stod(line.substr(0, line.find(',')));
    const int body = std::stoi(line.substr(line.find(',') + 1));
    if (last.count(body)) {
      EXPECT_GT(t - last[body], 1.0) << "body " << body;
    }
    last[body] = t;
  }
  // Checkpoint at t = 2 (bodies in flight below the base), killed at 2.7, continued.
  EXPECT_EQ(RunQuiet(b, 1, 27000).end_reason, "aborted");
  ASSERT_EQ(RunExe("run " + b.string() + " --threads 1"), 0);
  EXPECT_EQ(Slurp(a / "events.csv"), Slurp(b / "events.csv"));
  EXPECT_EQ(Slurp(a / "frames.dump"), Slurp(b / "frames.dump"));
}

// The shared bed is prepared without the obstacle: bodies the obstacle overlaps are taken
// out at t = 0, so nothing is fired off by an overlap, and the counts add up.
TEST(Run, AnObstacleClearsTheBodiesItOverlapsAtTheStart) {
  const fs::path dir = FreshDir("obstacle-clear");
  nlohmann::json spec = SmallSpec(8.0, 0.5);
  spec["silo"]["obstacles"] = {{{"x", 0.0}, {"y", 5.0}, {"diameter", 3.0}}};
  WriteSpec(dir, spec);
  RunQuiet(dir);
  const nlohmann::json s = ReadJson(dir / "summary.json");
  const int cleared = s["cleared_by_obstacles"].get<int>();
  EXPECT_GT(cleared, 0);
  EXPECT_LT(cleared, 10);
  EXPECT_EQ(s["bodies"].get<int>(), 120 - cleared);
  EXPECT_EQ(s["exited"].get<int>() + s["remaining"].get<int>(), s["bodies"].get<int>());
  // Half a time unit after opening nothing moves faster than the outlet flow does anyway.
  std::ifstream in(dir / "frames.dump");
  std::string line;
  double fastest = 0;
  while (std::getline(in, line)) {
    if (line.rfind("ITEM", 0) == 0) continue;
    std::istringstream row(line);
    std::vector<double> v;
    for (double x; row >> x;) v.push_back(x);
    if (v.size() < 12) continue;
    fastest = std::max(fastest, std::hypot(v[8], v[9]));
    EXPECT_GT(std::hypot(v[3] - 0.0, v[4] - 5.0), 1.5 + v[6] - 0.05) << line;  // no disc inside the obstacle
  }
  EXPECT_LT(fastest, 3.0);  // 2.1 without the obstacle (the outlet flow); an overlap of 0.1 d would give ~40
}

TEST(Run, BedIsPreparedOnceAndReused) {
  const fs::path a = FreshDir("bed-a"), b = FreshDir("bed-b");
  nlohmann::json spec = SmallSpec(8.0, 0.1, 11);
  fs::remove(BedCache(11));
  WriteSpec(a, spec);
  spec["silo"]["base_outlets"][0]["width"] = 6.0;  // outlets do not change the bed
  WriteSpec(b, spec);
  RunQuiet(a);
  RunQuiet(b);
  EXPECT_TRUE(ReadJson(a / "summary.json")["bed"]["prepared_here"].get<bool>());
  EXPECT_FALSE(ReadJson(b / "summary.json")["bed"]["prepared_here"].get<bool>());
  EXPECT_EQ(ReadJson(a / "summary.json")["bed"]["height"], ReadJson(b / "summary.json")["bed"]["height"]);
}

// With the only outlet high in a side wall, the settled bed rests on the walls: averaged
// over time (the bed breathes slightly), the wall forces in the contact dump carry its
// weight, 120 dumbbells of mass pi/2 with g = 1 (momentum balance).
TEST(Run, ContactDumpWallForcesCarryTheBedWeight) {
  const fs::path dir = FreshDir("contacts");
  nlohmann::json spec = SmallSpec(8.0, 0.5);
  spec["silo"]["base_outlets"] = nlohmann::json::array();
  spec["silo"]["height"] = 40.0;
  spec["silo"]["side_outlets"] = {{{"wall", "right"}, {"bottom", 30.0}, {"width", 5.0}}};
  spec["output"]["contact_forces"] = true;
  spec["output"]["frame_interval"] = 0.01;
  spec["bed"]["cache_file"] = "";            // silo height is part of the bed key: prepare in DIR
  spec["bed"]["settle_ke_per_body"] = 1e-7;  // bed momentum << weight x averaging time
  spec["bed"]["max_settle_time"] = 40.0;
  WriteSpec(dir, spec);
  RunQuiet(dir);
  EXPECT_TRUE(fs::exists(dir / "bed.json"));
  std::ifstream in(dir / "contacts.dump");
  std::string line;
  double wall_fy = 0;
  int frames = 0, walls = 0, pairs = 0;
  while (std::getline(in, line)) {
    if (line.rfind("ITEM: ENTRIES", 0) == 0) {
      EXPECT_EQ(line, "ITEM: ENTRIES body_i body_j xi yi xj yj cx cy fx fy");
      ++frames;
      continue;
    }
    if (line.rfind("ITEM", 0) == 0 || frames == 0) continue;
    std::istringstream row(line);
    double v[10];
    for (double& x : v) row >> x;
    if (!row) continue;  // a header value line
    if (v[1] < 0) {
      wall_fy += v[9];
      ++walls;
    } else {
      ++pairs;
    }
  }
  ASSERT_EQ(frames, 51);
  EXPECT_GT(pairs / frames, 120);
  EXPECT_GT(walls / frames, 10);
  const double weight = 120 * std::numbers::pi / 2;
  EXPECT_NEAR(wall_fy / frames, weight, 0.003 * weight);
}

TEST(Run, ExecutableReportsSpecErrorsAndHelp) {
  const fs::path dir = FreshDir("bad");
  nlohmann::json spec = SmallSpec(8.0, 1.0);
  spec["silo"]["base_outlets"][0]["width"] = -3.0;
  WriteSpec(dir, spec);
  const auto [code, out] = RunExeOutput("run " + dir.string());
  EXPECT_NE(code, 0);
  EXPECT_NE(out.find("/silo/base_outlets/0/width"), std::string::npos) << out;
  EXPECT_EQ(RunExe("run --help"), 0);
  EXPECT_EQ(RunExe("bench --help"), 0);
  EXPECT_NE(RunExe("frobnicate"), 0);
}

// The benchmark command with repeated rounds: one line per round and thread count, then
// per thread count the best and median rate (a tiny bed, so it takes about a second).
TEST(Run, BenchRepeatsRoundsAndSummarises) {
  const fs::path dir = FreshDir("bench");
  const auto [status, out] =
      RunExeOutput("bench --bodies 200 --steps 20 --threads-list 1,2 --repeat 3 --bed " + (dir / "bed.json").string());
  ASSERT_EQ(status, 0) << out;
  const std::vector<std::string> rounds = LinesStartingWith(out, "round="),
                                 summaries = LinesStartingWith(out, "summary ");
  ASSERT_EQ(rounds.size(), 6u);
  EXPECT_EQ(rounds[4].rfind("round=3 threads=1 ", 0), 0u) << rounds[4];
  ASSERT_EQ(summaries.size(), 2u);
  for (const std::string& line : summaries) {
    const double best = std::stod(line.substr(line.find("best=") + 5));
    const double median = std::stod(line.substr(line.find("median=") + 7));
    EXPECT_GT(median, 0.0) << line;
    EXPECT_GE(best, median) << line;
  }
  EXPECT_NE(summaries[0].find("median_speedup=1.000"), std::string::npos) << summaries[0];
  // two-thread lines say what a cache line cost between the cores in that round (0 where the
  // second thread got no core of its own: the suite runs beside other tests)
  EXPECT_EQ(rounds[4].find("core_round_trip_ns"), std::string::npos) << rounds[4];
  for (const std::string& line : {rounds[5], summaries[1]}) {
    const std::size_t at = line.find("round_trip_ns=");
    ASSERT_NE(at, std::string::npos) << line;
    EXPECT_GE(std::stod(line.substr(at + 14)), 0.0) << line;
  }
}

// The number after `key=` in `line` (the bench's key=value output).
double ValueAfter(const std::string& line, const std::string& key) {
  const std::size_t at = line.find(key + "=");
  if (at == std::string::npos) ADD_FAILURE() << "no " << key << " in: " << line;
  return at == std::string::npos ? -1.0 : std::stod(line.substr(at + key.size() + 1));
}

// bench --output-cost: per round and thread count the rate without and with frames and contact
// frames, what that costs and the bytes written; then the median cost per thread count.
TEST(Run, BenchOutputCostRunsTheCaseWithoutAndWithOutput) {
  const fs::path dir = FreshDir("bench-output");
  const auto [status, out] = RunExeOutput(
      "bench --shape disc --bodies 200 --steps 200 --output-cost 0.005 "
      "--threads-list 1,2 --repeat 2 --bed " +
      (dir / "bed.json").string());
  ASSERT_EQ(status, 0) << out;
  const std::vector<std::string> rounds = LinesStartingWith(out, "round="),
                                 summaries = LinesStartingWith(out, "summary ");
  ASSERT_EQ(rounds.size(), 4u) << out;
  for (const std::string& line : rounds) {
    EXPECT_GT(ValueAfter(line, "without_output"), 0.0) << line;
    EXPECT_GT(ValueAfter(line, "with_output"), 0.0) << line;
    // 200 steps of 1e-4 with frames every 0.005: four frames and four contact frames after t = 0
    EXPECT_GT(ValueAfter(line, "bytes"), 8 * 200 * 10.0) << line;
    // (the rates are printed to 4 digits: each off by up to 5e-4 of itself)
    const double cost = 1.0 - ValueAfter(line, "with_output") / ValueAfter(line, "without_output");
    EXPECT_NEAR(ValueAfter(line, "output_cost"), 100.0 * cost, 0.06 + 0.11 * (1.0 - cost)) << line;
  }
  EXPECT_EQ(rounds[2].find("core_round_trip_ns"), std::string::npos) << rounds[2];
  EXPECT_GE(ValueAfter(rounds[3], "core_round_trip_ns"), 0.0);
  ASSERT_EQ(summaries.size(), 2u) << out;
  EXPECT_EQ(summaries[1].rfind("summary threads=2 rounds=2 median_output_cost=", 0), 0u) << summaries[1];
}

// bench --versus lammps: the same settled bed on Debian's LAMMPS (one rank, then two under
// mpirun) and on the engine (one thread, then two), with the input LAMMPS ran kept.
TEST(Run, BenchVersusLammpsRunsBothEnginesOnTheSameBed) {
  const fs::path dir = FreshDir("bench-versus");
  const auto [status, out] = RunExeOutput(
      "bench --shape disc --bodies 200 --steps 100 --versus lammps "
      "--threads-list 1,2 --bed " +
      (dir / "bed.json").string() + " --lammps-dir " + (dir / "lammps").string());
  ASSERT_EQ(status, 0) << out;
  const std::vector<std::string> rows = LinesStartingWith(out, "threads=");
  ASSERT_EQ(rows.size(), 2u) << out;
  for (const std::string& line : rows) {
    const double lammps = ValueAfter(line, "lammps_disc_steps_per_s"),
                 native = ValueAfter(line, "native_disc_steps_per_s");
    EXPECT_GT(lammps, 0.0) << line;
    EXPECT_GT(native, 0.0) << line;
    EXPECT_NEAR(ValueAfter(line, "native/lammps"), native / lammps, 0.01 * native / lammps + 0.006) << line;
  }
  EXPECT_GE(ValueAfter(rows[1], "core_round_trip_ns"), 0.0);
  // LAMMPS read the bed's 200 discs and ran the steps asked for
  const std::string log = Slurp(dir / "lammps" / "log.lammps");
  EXPECT_NE(log.find("200 atoms"), std::string::npos) << log.substr(0, 2000);
  EXPECT_NE(log.find("for 100 steps with 200 atoms"), std::string::npos) << log.substr(0, 2000);
  EXPECT_TRUE(fs::exists(dir / "lammps" / "in.bench"));
}

// bench --bed-prep: per replica a line for the old procedure (1 x step, fixed wait) and the new
// one (8 x, next batch on landing), then per procedure a summary over the replicas and the
// speed-up line (a bed of 60 discs, about a second).
TEST(Run, BenchBedPrepComparesOldAndNewProcedurePerReplica) {
  const auto [status, out] = RunExeOutput("bench --bed-prep --shape disc --bodies 60 --repeat 2 --threads-list 1");
  ASSERT_EQ(status, 0) << out;
  const std::vector<std::string> rows = LinesStartingWith(out, "seed="), summaries = LinesStartingWith(out, "summary ");
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_EQ(rows[0].rfind("seed=1 procedure=old step_factor=1 next_batch=fixed ", 0), 0u) << rows[0];
  EXPECT_EQ(rows[3].rfind("seed=2 procedure=new step_factor=8 next_batch=landed ", 0), 0u) << rows[3];
  for (const std::string& line : rows) {
    EXPECT_GT(std::stod(line.substr(line.find("wall_s=") + 7)), 0.0) << line;
    EXPECT_GT(std::stod(line.substr(line.find("top=") + 4)), 0.5) << line;  // above the base
  }
  ASSERT_EQ(summaries.size(), 3u);
  EXPECT_EQ(summaries[0].rfind("summary procedure=old step_factor=1 next_batch=fixed replicas=2 ", 0), 0u)
      << summaries[0];
  EXPECT_EQ(summaries[1].rfind("summary procedure=new step_factor=8 next_batch=landed replicas=2 ", 0), 0u)
      << summaries[1];
  EXPECT_NE(summaries[2].find("speedup of the median wall time (old / new)"), std::string::npos) << summaries[2];
}

// The bench's default bed cache is named by the bed key: a bed prepared by another procedure
// (here the fixed wait) is another file, never read for the default one (it would be refused
// for its key, and the bench would stop).
TEST(Run, BenchBedFileIsNamedByTheBedKey) {
  BenchOptions options;
  options.shape = "disc";
  options.bodies = 8000;
  const nlohmann::json spec = BenchSpec(options);
  const std::string file = spec["bed"]["cache_file"];
  EXPECT_NE(file.find("granary-bench-bed-disc-8000-" + HashHex(RunSpec::FromJson(spec).BedKey().dump()) + ".json"),
            std::string::npos)
      << file;
  nlohmann::json fixed = spec;
  fixed["bed"].erase("cache_file");
  fixed["bed"]["next_batch"] = "fixed";
  EXPECT_NE(RunSpec::FromJson(fixed).BedKey(), RunSpec::FromJson(spec).BedKey());
  options.bed_file = "/somewhere/bed.json";
  EXPECT_EQ(BenchSpec(options)["bed"]["cache_file"], "/somewhere/bed.json");
}

// The bed measure of `bench --bed-prep` on a constructed bed: a square lattice of d = 1 discs
// filling the 100 d silo, rows at y = 0, 1, ..., 20. Top and surface 20.5; the band [5, 15.5]
// holds half of row 5 and rows 6..15 whole, so its packing fraction is that of the lattice,
// pi / 4, only if the discs cut by the band count with their part inside.
TEST(Run, BedMeasureOfASquareLattice) {
  BenchOptions options;
  options.shape = "disc";
  options.bodies = 2100;
  const RunSpec spec = RunSpec::FromJson(BenchSpec(options));
  BedState bed;
  for (int row = 0; row <= 20; ++row)
    for (int col = 0; col < 100; ++col) {
      bed.species.push_back(0);
      bed.x.push_back(-49.5 + col);
      bed.y.push_back(row);
      bed.theta.push_back(0.1 * col);
    }
  const BedShape shape = MeasureBed(bed, spec);
  EXPECT_DOUBLE_EQ(shape.top, 20.5);
  EXPECT_NEAR(shape.surface, 20.5, 1e-12);
  EXPECT_NEAR(shape.phi, std::numbers::pi / 4, 1e-12);
  // One disc on top raises the top, and the surface by 1/96 of its height (one column of 96).
  bed.species.push_back(0);
  bed.x.push_back(0.2);
  bed.y.push_back(30.0);
  bed.theta.push_back(0.0);
  const BedShape raised = MeasureBed(bed, spec);
  EXPECT_DOUBLE_EQ(raised.top, 30.5);
  EXPECT_NEAR(raised.surface, 20.5 + 10.0 / 96, 1e-12);
}

// Writes 64 bytes of garbage into the middle of a file (as the hostile user did).
void Scribble(const fs::path& file) {
  std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
  f.seekp(static_cast<std::streamoff>(fs::file_size(file) / 2));
  const std::string junk(64, '\x5a');
  f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
}

// A stop request (SIGTERM) during the discharge writes a checkpoint at that step, wherever it
// falls (not on the checkpoint interval), and the continued run gives the same bits. Also
// with checkpoint_interval 0 (before: everything since the last periodic checkpoint, or the
// whole run, was lost).
TEST(Run, AStopRequestCheckpointsAndTheContinuedRunIsTheSame) {
  for (const double interval : {1.0, 0.0}) {
    const fs::path a = FreshDir("stop-a"), b = FreshDir("stop-b");
    nlohmann::json spec = SmallSpec(8.0, 4.0);
    spec["output"]["checkpoint_interval"] = interval;
    WriteSpec(a, spec);
    WriteSpec(b, spec);
    RunQuiet(a);
    try {
      RunQuiet(b, 1, -1, 0, 23457);
      FAIL() << "expected a stop";
    } catch (const Stopped& e) {
      EXPECT_EQ(e.Signal(), SIGTERM);
      EXPECT_NE(std::string(e.what()).find("(step 23457); checkpoint written"), std::string::npos) << e.what();
    }
    EXPECT_TRUE(fs::exists(b / "checkpoint.bin"));
    EXPECT_FALSE(fs::exists(b / "DONE"));
    ASSERT_EQ(RunExe("run " + b.string() + " --threads 1"), 0);
    EXPECT_TRUE(ReadJson(b / "summary.json")["continued_from_checkpoint"].get<bool>());
    EXPECT_EQ(Slurp(a / "events.csv"), Slurp(b / "events.csv")) << "interval " << interval;
    EXPECT_EQ(Slurp(a / "frames.dump"), Slurp(b / "frames.dump")) << "interval " << interval;
  }
}

// The same through the executable and a real SIGTERM: the engine checkpoints and ends by the
// signal (the runner sees an interruption), and the checkpoint continues.
TEST(Run, SigtermMakesTheExecutableCheckpointAndEndByTheSignal) {
  const fs::path dir = FreshDir("sigterm");
  nlohmann::json spec = SmallSpec(8.0, 1000.0);
  spec["discharge"]["mode"] = "reinject";
  spec["discharge"]["stop_on_clog"] = false;
  spec["output"]["checkpoint_interval"] = 0.0;
  spec["output"]["frame_interval"] = 0.0;
  WriteSpec(dir, spec);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    ::execl(GRANARY_ENGINE_EXE, GRANARY_ENGINE_EXE, "run", dir.c_str(), "--threads", "1", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Once the discharge is under way (its first progress.json), not before.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (Slurp(dir / "progress.json").find("\"discharge\"") == std::string::npos &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ::kill(pid, SIGTERM);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << status;
  EXPECT_EQ(WTERMSIG(status), SIGTERM);
  ASSERT_TRUE(fs::exists(dir / "checkpoint.bin"));
  EXPECT_EQ(granary::RunDirectoryHolder(dir), "");
  EXPECT_TRUE(RunQuiet(dir, 1, 10).continued);
}

// 64 bytes overwritten in the middle of checkpoint.bin were accepted, and the run
// ended `done` with a different number of exits. Now the checksum refuses it, the run
// continues from the previous checkpoint, says so, and gives the uninterrupted run's bits.
TEST(Run, ACorruptCheckpointIsRefusedAndThePreviousOneUsed) {
  const fs::path a = FreshDir("corrupt-a"), b = FreshDir("corrupt-b");
  WriteSpec(a, SmallSpec(8.0, 4.0));
  WriteSpec(b, SmallSpec(8.0, 4.0));
  RunQuiet(a);
  EXPECT_EQ(RunQuiet(b, 1, 27000).end_reason, "aborted");  // checkpoints at t = 1 (prev) and 2
  ASSERT_TRUE(fs::exists(b / "checkpoint.prev.bin"));
  Scribble(b / "checkpoint.bin");
  const auto [code, out] = RunExeOutput("run " + b.string() + " --threads 1");
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("refusing checkpoint: checkpoint.bin is corrupt: CRC-32 of its payload is "), std::string::npos)
      << out;
  EXPECT_NE(out.find("continuing from the previous checkpoint (checkpoint.prev.bin)"), std::string::npos) << out;
  const nlohmann::json summary = ReadJson(b / "summary.json");
  EXPECT_TRUE(summary["continued_from_checkpoint"].get<bool>());
  ASSERT_EQ(summary["refused_checkpoints"].size(), 1u);
  EXPECT_TRUE(fs::exists(b / "checkpoint.bin.corrupt"));
  EXPECT_EQ(Slurp(a / "events.csv"), Slurp(b / "events.csv"));
  EXPECT_EQ(Slurp(a / "frames.dump"), Slurp(b / "frames.dump"));
}

// Both checkpoints bad (one corrupt, one truncated): the run starts over, and says why.
TEST(Run, WithNoUsableCheckpointTheRunStartsOver) {
  const fs::path a = FreshDir("nockpt-a"), b = FreshDir("nockpt-b");
  WriteSpec(a, SmallSpec(8.0, 3.0));
  WriteSpec(b, SmallSpec(8.0, 3.0));
  RunQuiet(a);
  EXPECT_EQ(RunQuiet(b, 1, 27000).end_reason, "aborted");
  Scribble(b / "checkpoint.bin");
  fs::resize_file(b / "checkpoint.prev.bin", fs::file_size(b / "checkpoint.prev.bin") - 100);
  const auto [code, out] = RunExeOutput("run " + b.string() + " --threads 1");
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("checkpoint.prev.bin is truncated or padded"), std::string::npos) << out;
  EXPECT_NE(out.find("no usable checkpoint; starting the run over"), std::string::npos) << out;
  const nlohmann::json summary = ReadJson(b / "summary.json");
  EXPECT_FALSE(summary["continued_from_checkpoint"].get<bool>());
  EXPECT_EQ(summary["refused_checkpoints"].size(), 2u);
  EXPECT_EQ(Slurp(a / "events.csv"), Slurp(b / "events.csv"));
}

// A checkpoint whose outputs were cut shorter than it recorded, or of an older format, is
// refused too (truncating a shorter events.csv to its offset would pad it with zeros).
TEST(Run, ACheckpointThatDoesNotMatchItsOutputsOrFormatIsRefused) {
  const fs::path b = FreshDir("mismatch");
  WriteSpec(b, SmallSpec(8.0, 3.0));
  EXPECT_EQ(RunQuiet(b, 1, 27000).end_reason, "aborted");
  fs::resize_file(b / "events.csv", 10);
  {
    std::string old = Slurp(b / "checkpoint.prev.bin");
    std::ofstream(b / "checkpoint.prev.bin", std::ios::binary)
        << std::string("\x14\0\0\0\0\0\0\0", 8) << "GRANARY-CHECKPOINT-3" << old;
  }
  const auto [code, out] = RunExeOutput("run " + b.string() + " --threads 1");
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("checkpoint.bin expects "), std::string::npos) << out;
  EXPECT_NE(out.find("bytes of events.csv, the file has 10"), std::string::npos) << out;
  EXPECT_NE(out.find("checkpoint.prev.bin is format GRANARY-CHECKPOINT-3, an older engine's"), std::string::npos)
      << out;
}

// A version-4 checkpoint (engines before the bed's packing fraction and surface were
// checkpointed) is still read: made here from a version-5 one by taking those two doubles out
// of the payload (after the spec, the counters, the outlets' exits and the bed's file, flag,
// height, settle time and wall time) and writing the header anew. The continued run is the
// uninterrupted one, and its summary has no bed shape to report.
TEST(Run, AVersion4CheckpointIsStillRead) {
  const fs::path a = FreshDir("v4-a"), b = FreshDir("v4-b");
  WriteSpec(a, SmallSpec(8.0, 4.0));
  WriteSpec(b, SmallSpec(8.0, 4.0));
  RunQuiet(a);
  EXPECT_EQ(RunQuiet(b, 1, 27000).end_reason, "aborted");
  fs::remove(b / "checkpoint.prev.bin");  // (no fallback: the version-4 file must be read)
  const std::string file = Slurp(b / "checkpoint.bin");
  auto u64 = [&](std::size_t pos) {
    std::uint64_t v;
    std::memcpy(&v, file.data() + pos, sizeof v);
    return static_cast<std::size_t>(v);
  };
  const std::size_t magic = 8 + u64(0);
  ASSERT_EQ(file.substr(8, magic - 8), "GRANARY-CHECKPOINT");
  std::uint32_t version;
  std::memcpy(&version, file.data() + magic, 4);
  ASSERT_EQ(version, 5u);
  const std::size_t payload = magic + 4 + 8 + 4;
  std::size_t at = payload;
  at += 8 + u64(at);      // spec
  at += 3 * 8;            // step, last exit step, disc steps
  at += 8 + 8 * u64(at);  // exits per outlet
  at += 4 + 1;            // clogs, in clog
  at += 8 + u64(at);      // bed file
  at += 1 + 3 * 8;        // prepared here, height, settle time, wall time
  std::string body = file.substr(payload);
  body.erase(at - payload, 16);  // packing fraction, surface
  std::string v4(file.data(), magic);
  const std::uint32_t four = 4, crc = Crc32(body);
  const std::uint64_t size = body.size();
  v4.append(reinterpret_cast<const char*>(&four), 4);
  v4.append(reinterpret_cast<const char*>(&size), 8);
  v4.append(reinterpret_cast<const char*>(&crc), 4);
  std::ofstream(b / "checkpoint.bin", std::ios::binary) << v4 << body;
  const auto [code, out] = RunExeOutput("run " + b.string() + " --threads 1");
  ASSERT_EQ(code, 0) << out;
  EXPECT_EQ(out.find("refusing checkpoint"), std::string::npos) << out;
  const nlohmann::json summary = ReadJson(b / "summary.json");
  EXPECT_TRUE(summary["continued_from_checkpoint"].get<bool>());
  EXPECT_FALSE(summary.value("bed", nlohmann::json::object()).contains("packing_fraction")) << summary.dump();
  EXPECT_TRUE(ReadJson(a / "summary.json").value("bed", nlohmann::json::object()).contains("packing_fraction"));
  EXPECT_EQ(Slurp(a / "events.csv"), Slurp(b / "events.csv"));
  EXPECT_EQ(Slurp(a / "frames.dump"), Slurp(b / "frames.dump"));
}

// Two engines never write one directory: the executable refuses a directory whose lock is
// held (exit 75), naming the holder, and touches nothing in it.
TEST(Run, TheExecutableRefusesADirectoryAnotherEngineHolds) {
  const fs::path dir = FreshDir("locked");
  WriteSpec(dir, SmallSpec(8.0, 0.2));
  std::ofstream(dir / "DONE") << "earlier\n";
  {
    const granary::RunDirectoryLock held(dir);
    const auto [code, out] = RunExeOutput("run " + dir.string() + " --threads 1");
    EXPECT_EQ(code, granary::kExitRunDirectoryBusy) << out;
    EXPECT_NE(out.find("is locked by engine pid " + std::to_string(::getpid())), std::string::npos) << out;
    EXPECT_EQ(Slurp(dir / "DONE"), "earlier\n");
    EXPECT_FALSE(fs::exists(dir / "events.csv"));
  }
  EXPECT_EQ(RunExe("run " + dir.string() + " --threads 1"), 0);  // free again
}

}  // namespace
}  // namespace granary::engine
