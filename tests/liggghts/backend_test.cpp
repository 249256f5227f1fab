// Real LIGGGHTS 3.8 runs of tiny silos through granary-liggghts (a real subprocess), read
// back with the analyses' run reader: beds settle and discharge, events come back, failures
// are reported with LIGGGHTS' log, a hostile spec string runs nothing, a killed run continues.
#include <gtest/gtest.h>
#include <signal.h>

#include <boost/process.hpp>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <map>
#include <set>
#include <thread>

#include "analysis/arches.h"
#include "rundir/clogs.h"
#include "rundir/contacts.h"
#include "rundir/files.h"
#include "rundir/frames.h"
#include "rundir/manifest.h"
#include "rundir/run_directory.h"

namespace {

namespace fs = std::filesystem;
namespace bp = boost::process;
using nlohmann::json;
namespace rundir = granary::rundir;
using namespace granary::rundir;

const fs::path kTmp = GRANARY_LIGGGHTS_TEST_TMP;

struct Outcome {
  int exit_code = -1;
  std::string output;  // stdout + stderr
};

Outcome RunBackend(const fs::path& dir, bp::environment env = boost::this_process::environment(),
                   const std::vector<std::string>& extra = {}) {
  bp::ipstream out;
  std::vector<std::string> args = {"run", dir.string()};
  args.insert(args.end(), extra.begin(), extra.end());
  bp::child c(GRANARY_LIGGGHTS_EXE, bp::args = args, (bp::std_out & bp::std_err) > out, env);
  Outcome o;
  std::string line;
  while (std::getline(out, line)) o.output += line + "\n";
  c.wait();
  o.exit_code = c.exit_code();
  return o;
}

// Processes whose working directory is `dir` (LIGGGHTS and its ranks run there).
std::vector<int> ProcessesIn(const fs::path& dir) {
  std::vector<int> pids;
  const fs::path want = fs::canonical(dir);
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::error_code ec;
    const fs::path cwd = fs::read_symlink(e.path() / "cwd", ec);
    if (!ec && cwd == want) pids.push_back(std::stoi(name));
  }
  return pids;
}

// Waits until nothing holds DIR's lock; every time the lock is seen free, no LIGGGHTS
// process may still be running in DIR (the lock outlives the ranks, never the reverse).
::testing::AssertionResult WaitUntilFree(const fs::path& dir) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    if (granary::RunDirectoryHolder(dir).empty()) {
      const std::vector<int> left = ProcessesIn(dir);
      if (!left.empty())
        return ::testing::AssertionFailure() << "lock free while " << left.size() << " processes still run in " << dir;
      return ::testing::AssertionSuccess();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return ::testing::AssertionFailure() << dir << " still locked after 60 s";
}

std::string ReadText(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A fresh run directory with run.json; beds are cached in one directory shared by the tests.
fs::path MakeRun(const std::string& name, const json& overrides) {
  const fs::path dir = kTmp / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  json j = {
      {"run_id", name},
      {"seed", 3},
      {"engine", "liggghts"},
      {"silo", {{"width", 16}, {"base_outlets", {{{"center", 0}, {"width", 5}}}}}},
      {"bodies", {{"count", 60}, {"species", {{{"shape", "disc"}}}}}},
      {"bed",
       {{"settle_ke_per_body", 1e-3}, {"max_settle_time", 6}, {"cache_file", (kTmp / "beds" / "bed.json").string()}}},
      {"discharge", {{"mode", "remove"}, {"max_time", 3}, {"clog_window", 3}}},
      {"output", {{"checkpoint_interval", 0}}}};
  if (overrides.is_object()) j.merge_patch(overrides);
  std::ofstream(dir / "run.json") << j.dump(2);
  return dir;
}

TEST(LiggghtsBackend, DiscBedSettlesAndDischargesInRemoveMode) {
  const fs::path dir = MakeRun("discs_remove", {{"output", {{"frame_interval", 1.0}}}});
  const Outcome o = RunBackend(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const RunData run = ReadRun(dir);
  EXPECT_EQ(run.summary.engine, "liggghts");
  EXPECT_NE(run.summary.engine_version.find("3.8"), std::string::npos);
  ASSERT_GT(run.events.size(), 5u) << "a 5 d outlet lets discs out";
  std::set<std::int64_t> bodies;
  for (const rundir::ExitEvent& e : run.events) {
    EXPECT_EQ(e.shape, "disc");
    EXPECT_EQ(e.outlet, 0);
    EXPECT_NEAR(e.mass, std::numbers::pi / 4, 1e-12);
    EXPECT_GE(e.time, 0.0);
    EXPECT_LE(e.time, 3.0 + 1e-9);
    EXPECT_GE(e.body, 0);
    EXPECT_LT(e.body, 60);
    EXPECT_TRUE(bodies.insert(e.body).second) << "removed bodies leave once";
  }
  EXPECT_EQ(run.summary.exited, static_cast<int>(run.events.size()));
  EXPECT_EQ(run.summary.exited + run.summary.remaining, 60);
  EXPECT_LT(run.summary.raw.at("max_out_of_plane").get<double>(), 1e-5);
  EXPECT_EQ(run.summary.raw.at("tangential_cap"), "liggghts");
  EXPECT_TRUE(fs::exists(dir / "DONE"));
  // Frames: every remaining disc, with the body ids of the events.
  FrameReader frames(dir / "frames.dump");
  Frame f;
  int n = 0;
  while (frames.Next(f)) {
    ++n;
    for (const rundir::Disc& d : f.discs) EXPECT_NEAR(d.mass, std::numbers::pi * d.radius * d.radius, 1e-9);
  }
  EXPECT_GE(n, 3);  // t = 0, 1, 2 (3 if the run reached it)
  // The backend records what it wrote, through the same call as the native engine.
  const auto manifest = rundir::ReadManifest(dir);
  ASSERT_TRUE(manifest.has_value());
  EXPECT_EQ(manifest->counts.at("frames"), n);
  EXPECT_EQ(manifest->counts.at("events"), static_cast<std::int64_t>(run.events.size()));
  EXPECT_EQ(rundir::VerifyRun(dir, {rundir::VerifyLevel::kChecksums, false}).integrity, rundir::Integrity::kWhole);
  // The rate counts the spheres still in the silo: below the bed's figure once discs left.
  const nlohmann::json& timing = run.summary.raw.at("timing");
  EXPECT_LT(timing.at("disc_steps_per_s").get<double>(), timing.at("bed_disc_steps_per_s").get<double>());
}

// Stalls in remove mode are judged as the native engine judges them (silo/stall.h) on
// LIGGGHTS' final positions: an arch over a narrow outlet is a clog (and the run goes on through
// it when asked), a wide outlet leaves only the dead zones and the run has discharged.
TEST(LiggghtsBackend, AStallIsAClogOrADischargeAsOnTheNativeEngine) {
  const json narrow = {{"silo", {{"base_outlets", {{{"center", 0}, {"width", 1.6}}}}}},
                       {"discharge", {{"max_time", 12}}}};  // clog_window 3: the first exit takes ~2
  const fs::path clog = MakeRun("stall_clog", narrow);
  Outcome o = RunBackend(clog);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  RunData run = ReadRun(clog);
  EXPECT_EQ(run.summary.end_reason, "clogged") << o.output;
  EXPECT_EQ(run.summary.raw.at("clogs"), 1);
  EXPECT_LT(run.summary.t_end, 12.0);
  EXPECT_GT(run.summary.remaining, 40);
  // The clog's configuration and pair forces are kept (no wall rows: walls are primitives here).
  const std::vector<ClogState> clogs = ReadClogs(clog);
  ASSERT_EQ(clogs.size(), 1u);
  EXPECT_EQ(clogs[0].frame.timestep, std::llround(run.summary.t_end / 1e-4));
  EXPECT_EQ(static_cast<int>(BodiesOf(clogs[0].frame.discs).size()), run.summary.remaining);
  EXPECT_GT(clogs[0].contacts.contacts.size(), 40u);
  for (const ContactRow& c : clogs[0].contacts.contacts) {
    EXPECT_GE(c.body_j, 0);
    EXPECT_NE(c.body_i, c.body_j);
  }
  // The arches analysis reads LIGGGHTS' clog as the native engine's: one arch over the outlet,
  // its bodies touching one another (pair rows), its ends on the base (from the geometry, as
  // LIGGGHTS reports no wall rows for primitive walls), wider than the outlet.
  const granary::analysis::ClogArches arches = granary::analysis::AnalyseClog(clogs[0], run.spec);
  ASSERT_EQ(arches.arches.size(), 1u);
  const granary::analysis::Arch& arch = arches.arches[0];
  EXPECT_EQ(arch.outlet, 0);
  EXPECT_GE(arch.n, 2);
  EXPECT_EQ(arch.gaps, 0);
  EXPECT_TRUE(arch.supported);
  EXPECT_GT(arch.width, 1.6 - 1.0) << "end bodies' centres at least one diameter less than the outlet apart";
  EXPECT_GT(arches.contact_types.Total(), 40);

  json through = narrow;
  through["discharge"]["stop_on_clog"] = false;
  const fs::path intermittent = MakeRun("stall_through", through);
  o = RunBackend(intermittent);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const RunData on = ReadRun(intermittent);
  EXPECT_EQ(on.summary.end_reason, "time_limit") << o.output;
  EXPECT_NEAR(on.summary.t_end, 12.0, 1e-9);
  EXPECT_EQ(on.summary.raw.at("clogs"), 1) << "a clog is counted once until the next exit";
  EXPECT_EQ(on.summary.raw.at("continued_from_checkpoint"), false);
  EXPECT_EQ(on.events.size(), run.events.size()) << "the same arch holds on";
  const std::vector<ClogState> held = ReadClogs(intermittent);
  ASSERT_EQ(held.size(), 1u);
  EXPECT_EQ(held[0].frame.timestep, clogs[0].frame.timestep);
  EXPECT_EQ(held[0].frame.discs.size(), clogs[0].frame.discs.size());

  const fs::path wide = MakeRun("stall_discharged", {{"silo", {{"base_outlets", {{{"center", 0}, {"width", 8}}}}}},
                                                     {"discharge", {{"max_time", 40}}}});
  o = RunBackend(wide);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  run = ReadRun(wide);
  EXPECT_EQ(run.summary.end_reason, "discharged") << o.output;
  EXPECT_EQ(run.summary.raw.at("clogs"), 0);
  EXPECT_LT(run.summary.t_end, 40.0);
  EXPECT_GT(run.summary.remaining, 0) << "the dead zones of the flat bottom stay";
  // What the script kept of the stall went with it: no clog.
  EXPECT_TRUE(ClogReader(wide).Present());
  EXPECT_TRUE(ReadClogs(wide).empty());
  for (const auto& e : fs::directory_iterator(wide))
    EXPECT_NE(e.path().filename().string().rfind("clog.", 0), 0u) << e.path();
}

// In reinject mode the script stops at the clog itself: it is counted, and kept with the wall
// forces when every wall is a mesh (output.contact_forces).
TEST(LiggghtsBackend, AReinjectClogIsCountedAndKeptWithItsWallForces) {
  const fs::path dir = MakeRun("reinject_clog", {{"silo", {{"base_outlets", {{{"center", 0}, {"width", 1.6}}}}}},
                                                 {"discharge", {{"mode", "reinject"}, {"max_time", 12}}},
                                                 {"output", {{"contact_forces", true}}}});
  const Outcome o = RunBackend(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const RunData run = ReadRun(dir);
  EXPECT_EQ(run.summary.end_reason, "clogged") << o.output;
  EXPECT_EQ(run.summary.raw.at("clogs"), 1);
  const std::vector<ClogState> clogs = ReadClogs(dir);
  ASSERT_EQ(clogs.size(), 1u);
  EXPECT_EQ(BodiesOf(clogs[0].frame.discs).size(), 60u);
  int pairs = 0, on_base = 0;
  double wall_fy = 0;
  for (const ContactRow& c : clogs[0].contacts.contacts) {
    if (c.body_j >= 0) {
      ++pairs;
      continue;
    }
    EXPECT_TRUE(std::fabs(c.cy) < 1e-6 || std::fabs(std::fabs(c.cx) - 8) < 1e-6) << c.cx << " " << c.cy;
    on_base += std::fabs(c.cy) < 1e-6;
    wall_fy += c.fy;
  }
  EXPECT_GT(pairs, 20);
  EXPECT_GT(on_base, 5);
  // The walls hold the bed up. (Not its weight exactly: LIGGGHTS judges a clog by the exits
  // alone, and its bed still creeps when it stops.)
  EXPECT_GT(wall_fy, 0.5 * 60 * std::numbers::pi / 4);
}

// Contact-force frames from LIGGGHTS in the common format: with the only outlet high in a side
// wall the bed rests on the base, the side walls and an obstacle, whose reported wall forces
// carry its weight (40 dumbbells of mass pi/2, g = 1); pairs join two different bodies and
// their contact point lies on the first disc's surface.
TEST(LiggghtsBackend, ContactFramesCarryTheWeightOfTheBedOnWallsAndObstacle) {
  const fs::path dir = MakeRun("contacts", {{"bodies", {{"count", 40}, {"species", {{{"shape", "dumbbell"}}}}}},
                                            {"silo",
                                             {{"base_outlets", json::array()},
                                              {"side_outlets", {{{"wall", "right"}, {"bottom", 10}, {"width", 3}}}},
                                              {"obstacles", {{{"x", 0}, {"y", 2}, {"diameter", 2}}}}}},
                                            {"bed", {{"settle_ke_per_body", 1e-7}, {"max_settle_time", 40}}},
                                            {"discharge", {{"max_time", 1}}},
                                            {"output", {{"frame_interval", 0.05}, {"contact_forces", true}}}});
  const Outcome o = RunBackend(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const RunData run = ReadRun(dir);
  ASSERT_TRUE(run.has_contacts);
  ContactReader contacts(run.ContactsFile());
  ContactFrame f;
  int frames = 0, on_obstacle = 0, on_base = 0, on_sides = 0, repulsive = 0, pairs = 0;
  double wall_fy = 0;
  while (contacts.Next(f)) {
    ++frames;
    for (const ContactRow& c : f.contacts) {
      ASSERT_GE(c.body_i, 0);
      ASSERT_LT(c.body_i, 40);
      if (c.body_j < 0) {
        wall_fy += c.fy;
        const double from_obstacle = std::hypot(c.cx, c.cy - 2);
        on_obstacle += from_obstacle > 1 - 1e-6 && from_obstacle < 1.0013;
        on_base += std::fabs(c.cy) < 1e-6;
        on_sides += std::fabs(std::fabs(c.cx) - 8) < 1e-6;
        continue;
      }
      ++pairs;
      EXPECT_NE(c.body_i, c.body_j);
      EXPECT_LT(c.body_j, 40);
      EXPECT_NEAR(std::hypot(c.cx - c.xi, c.cy - c.yi), 0.5, 1e-6);
      repulsive += c.fx * (c.xi - c.xj) + c.fy * (c.yi - c.yj) > 0;
    }
  }
  EXPECT_EQ(frames, 21);  // t = 0, 0.05, ..., 1
  EXPECT_GT(on_obstacle, 0);
  EXPECT_GT(on_base, 0);
  EXPECT_GT(on_sides, 0);
  EXPECT_GT(repulsive, 0.9 * pairs);
  const double weight = 40 * std::numbers::pi / 2;
  EXPECT_NEAR(wall_fy / frames, weight, 0.02 * weight);
}

TEST(LiggghtsBackend, DumbbellBedReinjectsEveryBodyThatLeaves) {
  const fs::path dir =
      MakeRun("dumbbells_reinject", {{"bodies", {{"count", 50}, {"species", {{{"shape", "dumbbell"}}}}}},
                                     {"silo", {{"width", 20}, {"base_outlets", {{{"center", 0}, {"width", 10}}}}}},
                                     {"discharge", {{"mode", "reinject"}, {"max_time", 4}, {"stop_on_clog", false}}},
                                     {"output", {{"frame_interval", 2.0}}}});
  const Outcome o = RunBackend(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const RunData run = ReadRun(dir);
  ASSERT_GT(run.events.size(), 2u) << o.output;
  for (const rundir::ExitEvent& e : run.events) {
    EXPECT_EQ(e.shape, "dumbbell");
    EXPECT_NEAR(e.mass, std::numbers::pi / 2, 1e-12);
  }
  EXPECT_EQ(run.summary.remaining, 50) << "reinject mode keeps every body";
  EXPECT_EQ(run.summary.end_reason, "time_limit");
  EXPECT_LT(run.summary.raw.at("max_out_of_plane").get<double>(), 1e-5);
  FrameReader frames(dir / "frames.dump");
  Frame f;
  ASSERT_TRUE(frames.Next(f));
  const std::vector<rundir::Body> bodies = rundir::BodiesOf(f.discs);
  ASSERT_EQ(bodies.size(), 50u);
  for (const rundir::Body& b : bodies) {
    EXPECT_EQ(b.n_discs, 2);
    EXPECT_NEAR(b.mass, std::numbers::pi / 2, 1e-9);
  }
  // The two discs of a dumbbell stay one diameter apart: the clump is rigid.
  std::map<std::int64_t, std::vector<const rundir::Disc*>> by_body;
  for (const rundir::Disc& d : f.discs) by_body[d.mol].push_back(&d);
  for (const auto& [id, discs] : by_body)
    EXPECT_NEAR(std::hypot(discs[0]->x - discs[1]->x, discs[0]->y - discs[1]->y), 1.0, 1e-6);
}

// granary-liggghts run --threads 2 starts two MPI ranks (mpirun); multisphere clumps cross the
// boundary between the ranks' subdomains and stay whole, in the plane, and flow alike.
TEST(LiggghtsBackend, TwoMpiRanksRunClumpsAsOneRankDoes) {
  const json spec = {{"bodies", {{"count", 50}, {"species", {{{"shape", "dumbbell"}}}}}},
                     {"silo", {{"width", 20}, {"base_outlets", {{{"center", 0}, {"width", 10}}}}}},
                     {"discharge", {{"mode", "reinject"}, {"max_time", 4}, {"stop_on_clog", false}}},
                     {"output", {{"frame_interval", 1.0}}}};
  const fs::path one = MakeRun("ranks_1", spec), two = MakeRun("ranks_2", spec);
  ASSERT_EQ(RunBackend(one).exit_code, 0);
  bp::ipstream out;
  bp::child c(GRANARY_LIGGGHTS_EXE, "run", two.string(), "--threads", "2", (bp::std_out & bp::std_err) > out);
  std::string line, log;
  while (std::getline(out, line)) log += line + "\n";
  c.wait();
  ASSERT_EQ(c.exit_code(), 0) << log;
  const RunData a = ReadRun(one), b = ReadRun(two);
  EXPECT_EQ(b.summary.raw.at("timing").at("threads"), 2);
  EXPECT_NE(ReadText(two / "log.discharge").find("2 by 1 by 1 MPI processor grid"), std::string::npos);
  EXPECT_EQ(b.summary.remaining, 50);
  EXPECT_LT(b.summary.raw.at("max_out_of_plane").get<double>(), 1e-5);
  ASSERT_GT(a.events.size(), 5u);
  EXPECT_NEAR(static_cast<double>(b.events.size()), static_cast<double>(a.events.size()),
              0.25 * static_cast<double>(a.events.size()));
  FrameReader frames(two / "frames.dump");
  Frame f;
  int n = 0;
  while (frames.Next(f)) {
    ++n;
    std::map<std::int64_t, std::vector<const rundir::Disc*>> by_body;
    for (const rundir::Disc& d : f.discs) by_body[d.mol].push_back(&d);
    ASSERT_EQ(by_body.size(), 50u);
    for (const auto& [id, discs] : by_body) {
      ASSERT_EQ(discs.size(), 2u);
      EXPECT_NEAR(std::hypot(discs[0]->x - discs[1]->x, discs[0]->y - discs[1]->y), 1.0, 1e-6);
    }
  }
  EXPECT_EQ(n, 5);
}

TEST(LiggghtsBackend, AHostileSpecStringRunsNothing) {
  const fs::path marker = kTmp / "pwned";
  fs::remove(marker);
  const std::string hostile = "x\nshell touch " + marker.string() + " ; $(touch " + marker.string() + ")";
  // Species names cannot hold line breaks or commas (a spec error), but substitutions and commands can.
  const std::string hostile_name = "x; shell touch " + marker.string() + " ; $(touch " + marker.string() + ") ${x} v_x";
  const fs::path dir = MakeRun("hostile", {{"run_id", hostile},
                                           {"bodies", {{"species", {{{"shape", "disc"}, {"name", hostile_name}}}}}},
                                           {"discharge", {{"max_time", 0.5}}}});
  const Outcome o = RunBackend(dir);
  EXPECT_EQ(o.exit_code, 0) << o.output;
  EXPECT_FALSE(fs::exists(marker));
  for (const char* f : {"bed.in", "discharge.in"})
    if (fs::exists(dir / f)) {
      std::ifstream in(dir / f);
      const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      EXPECT_EQ(text.find("pwned"), std::string::npos) << f;
    }
}

TEST(LiggghtsBackend, ALiggghtsErrorFailsTheRunWithTheTailOfItsLog) {
  // A corrupt cached bed: LIGGGHTS' read_restart fails on it.
  const fs::path cache = kTmp / "corrupt-cache";
  fs::remove_all(cache);
  const fs::path dir = MakeRun("corrupt", {{"bed", {{"cache_file", (cache / "bed.json").string()}}}});
  // Learn the cache file names from a dry look at what the backend would use: prepare nothing,
  // plant garbage under every name the backend might read.
  fs::create_directories(cache);
  {
    // First run prepares the bed into the cache ...
    ASSERT_EQ(RunBackend(dir).exit_code, 0);
  }
  // A restart LIGGGHTS cannot read, recorded with its checksum (as if LIGGGHTS had written it
  // so): the cache check passes it and LIGGGHTS itself fails.
  for (const auto& e : fs::directory_iterator(cache)) {
    if (e.path().extension() != ".restart") continue;
    std::ofstream(e.path(), std::ios::trunc) << "not a restart file";
    fs::path meta = e.path();
    meta.replace_extension(".json");
    json j = json::parse(ReadText(meta));
    j["restart_crc32"] = granary::Crc32("not a restart file");
    std::ofstream(meta) << j.dump();
  }
  fs::remove(dir / "DONE");
  const Outcome o = RunBackend(dir);
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_NE(o.output.find("LIGGGHTS failed during the discharge"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("last lines of log.discharge"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("ERROR"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(dir / "DONE"));
}

TEST(LiggghtsBackend, AMissingLiggghtsIsAClearError) {
  const fs::path dir = MakeRun("missing", json::object());
  bp::environment env = boost::this_process::environment();
  env["GRANARY_LIGGGHTS"] = "/nonexistent/liggghts";
  const Outcome o = RunBackend(dir, env);
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_NE(o.output.find("LIGGGHTS executable not found"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("liggghts"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "DONE"));
}

TEST(LiggghtsBackend, AKilledRunContinuesFromItsCheckpointWithTheSameEarlierEvents) {
  const json spec = {{"discharge", {{"mode", "reinject"}, {"max_time", 3}, {"stop_on_clog", false}}},
                     {"bodies", {{"count", 80}}},
                     {"output", {{"checkpoint_interval", 1.0}, {"frame_interval", 0.5}, {"contact_forces", true}}}};
  const fs::path whole = MakeRun("whole", spec);
  ASSERT_EQ(RunBackend(whole).exit_code, 0);
  const fs::path cut = MakeRun("cut", spec);
  {
    bp::child c(GRANARY_LIGGGHTS_EXE, "run", cut.string(), bp::std_out > bp::null, bp::std_err > bp::null);
    // Kill it once a checkpoint past t = 1 exists and LIGGGHTS has moved on.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    while (c.running() && !fs::exists(cut / "checkpoint.20000.restart") && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    ASSERT_TRUE(c.running()) << "the run ended before it could be killed";
    ::kill(c.id(), SIGKILL);
    c.wait();
  }
  // LIGGGHTS dies with the backend (PR_SET_PDEATHSIG), a moment later: until then the
  // directory stays locked and a second backend would refuse it.
  ASSERT_TRUE(WaitUntilFree(cut));
  ASSERT_FALSE(fs::exists(cut / "DONE"));
  const Outcome o = RunBackend(cut);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const RunData a = ReadRun(whole), b = ReadRun(cut);
  EXPECT_TRUE(b.summary.raw.at("continued_from_checkpoint").get<bool>());
  // Up to the checkpoint the runs are the same computation; after it LIGGGHTS rebuilds its
  // neighbour lists, so later events agree only statistically (docs/liggghts.md).
  std::vector<std::pair<double, std::int64_t>> early_a, early_b;
  for (const rundir::ExitEvent& e : a.events)
    if (e.time <= 1.0) early_a.emplace_back(e.time, e.body);
  for (const rundir::ExitEvent& e : b.events)
    if (e.time <= 1.0) early_b.emplace_back(e.time, e.body);
  EXPECT_EQ(early_a, early_b);
  EXPECT_GT(b.events.size(), early_b.size()) << "events after the restart are recorded";
  EXPECT_EQ(b.summary.t_end, 3.0);
  // Contact frames: one per frame time in both, the same up to the checkpoint.
  ContactReader ca(a.ContactsFile()), cb(b.ContactsFile());
  ContactFrame fa, fb;
  int frames = 0;
  while (ca.Next(fa)) {
    ASSERT_TRUE(cb.Next(fb)) << "frame " << frames;
    EXPECT_EQ(fa.timestep, fb.timestep);
    if (fa.time <= 1.0) {
      ASSERT_EQ(fa.contacts.size(), fb.contacts.size()) << "t = " << fa.time;
      for (std::size_t k = 0; k < fa.contacts.size(); ++k) {
        EXPECT_EQ(fa.contacts[k].body_i, fb.contacts[k].body_i);
        EXPECT_EQ(fa.contacts[k].fy, fb.contacts[k].fy);
      }
    }
    ++frames;
  }
  EXPECT_FALSE(cb.Next(fb));
  EXPECT_EQ(frames, 7);
}

// With two MPI ranks, the ranks outlived a kill -9 of the backend by up to a second
// and kept writing the directory while a new runner could start. Now each rank holds the
// directory's helper lock (exec-helper) and dies with mpirun: the directory is never free
// while one of them runs, and a second backend refuses it until then (exit 75).
TEST(LiggghtsBackend, TheDirectoryStaysLockedUntilEveryRankOfAKilledRunIsGone) {
  const json spec = {{"discharge", {{"mode", "reinject"}, {"max_time", 20}, {"stop_on_clog", false}}},
                     {"bodies", {{"count", 60}}}};
  const fs::path dir = MakeRun("ranks_killed", spec);
  bp::child c(GRANARY_LIGGGHTS_EXE, "run", dir.string(), "--threads", "2", bp::std_out > bp::null,
              bp::std_err > bp::null);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (c.running() && ReadText(dir / "progress.json").find("discharge") == std::string::npos &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_TRUE(c.running()) << "the run ended before it could be killed";
  EXPECT_GE(ProcessesIn(dir).size(), 2u);  // mpirun and its ranks
  ::kill(c.id(), SIGKILL);
  c.wait();
  const Outcome refused = RunBackend(dir);
  // Refused by whichever lock is still held: the backend's own (mpirun not yet reaped) or
  // the ranks' helper lock (mpirun gone, a rank winding down). Which one is a race.
  if (refused.exit_code == granary::kExitRunDirectoryBusy) {
    EXPECT_TRUE(refused.output.find("two engines never write one directory") != std::string::npos ||
                refused.output.find("still has helper processes of an earlier engine") != std::string::npos)
        << refused.output;
  }
  ASSERT_TRUE(WaitUntilFree(dir));
  EXPECT_TRUE(ProcessesIn(dir).empty());
}

// SIGTERM during the discharge: LIGGGHTS writes a checkpoint at the end of its chunk, the
// backend ends by SIGTERM (the runner marks the run interrupted), and the next start continues
// from that checkpoint (with checkpoint_interval 0 it is the only one).
TEST(LiggghtsBackend, SigtermCheckpointsTheDischargeBeforeTheBackendEnds) {
  const json spec = {{"discharge", {{"mode", "reinject"}, {"max_time", 30}, {"stop_on_clog", false}}},
                     {"bodies", {{"count", 60}}},
                     {"output", {{"checkpoint_interval", 0}}}};
  // Long enough that the signal, sent on the first progress line the test reads, always
  // arrives with chunks left: a loaded machine delivers the piped lines late.
  const fs::path dir = MakeRun("sigterm", spec);
  bp::ipstream out;
  bp::child c(GRANARY_LIGGGHTS_EXE, "run", dir.string(), (bp::std_out & bp::std_err) > out);
  std::string line, log;
  bool sent = false;
  while (std::getline(out, line)) {
    log += line + "\n";
    // Once the discharge is under way (its first progress line), not before.
    if (!sent && line.find("phase=discharge") != std::string::npos) {
      ::kill(c.id(), SIGTERM);
      sent = true;
    }
  }
  c.wait();
  ASSERT_TRUE(sent) << log;
  EXPECT_EQ(c.native_exit_code() & 0x7f, SIGTERM) << log;  // ended by the signal
  EXPECT_NE(log.find("stop requested"), std::string::npos) << log;
  EXPECT_NE(log.find("checkpointed by LIGGGHTS (checkpoint."), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(dir / "DONE"));
  int checkpoints = 0;
  for (const auto& e : fs::directory_iterator(dir))
    checkpoints += e.path().filename().string().rfind("checkpoint.", 0) == 0;
  EXPECT_EQ(checkpoints, 1);
  EXPECT_TRUE(WaitUntilFree(dir));
  const Outcome o = RunBackend(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const RunData r = ReadRun(dir);
  EXPECT_TRUE(r.summary.raw.at("continued_from_checkpoint").get<bool>());
  EXPECT_EQ(r.summary.t_end, 30.0);
}

// A stand-in LIGGGHTS (a shell script) that fails the way a real one can.
fs::path FakeLiggghts(const std::string& name, const std::string& body) {
  const fs::path p = kTmp / ("fake-liggghts-" + name);
  std::ofstream(p) << "#!/bin/sh\n" << body << "\n";
  fs::permissions(p, fs::perms::owner_all);
  return p;
}

Outcome RunWithLiggghts(const fs::path& dir, const fs::path& liggghts, const std::vector<std::string>& extra = {}) {
  bp::environment env = boost::this_process::environment();
  env["GRANARY_LIGGGHTS"] = liggghts.string();
  return RunBackend(dir, env, extra);
}

// A crash by a signal was "exit status 11", garbage output with exit 0 gave an
// empty tail, a hang only "wall-time limit exceeded". Now signals are named, LIGGGHTS' own
// screen output comes with its log's tail, and silence ends a hung LIGGGHTS.
TEST(LiggghtsBackend, FailuresNameTheSignalAndShowTheScreenOutputAndTheLog) {
  const fs::path dir = MakeRun("crash", json::object());
  json j = json::parse(ReadText(dir / "run.json"));
  j["bed"]["cache_file"] = "";  // prepare here: the fake LIGGGHTS runs for the bed
  std::ofstream(dir / "run.json") << j.dump(2);

  Outcome o = RunWithLiggghts(
      dir, FakeLiggghts("segv", "echo 'LIGGGHTS (Version fake)'\necho 'reading bed.in' > log.bed\nkill -SEGV $$"));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_NE(
      o.output.find("LIGGGHTS failed while preparing the bed (LIGGGHTS killed by signal 11 (Segmentation fault))"),
      std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("--- LIGGGHTS screen output, last lines ---\nLIGGGHTS (Version fake)\n"), std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("--- last lines of log.bed ---\nreading bed.in\n"), std::string::npos) << o.output;

  o = RunWithLiggghts(dir, FakeLiggghts("garbage", "echo 'n\\xfd#@ garbage'\nexit 0"));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_NE(
      o.output.find("LIGGGHTS ended without writing bed.restart while preparing the bed (LIGGGHTS exit status 0)"),
      std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("garbage"), std::string::npos) << o.output;

  // A hang the runner ends (its --time-limit sends SIGTERM): what LIGGGHTS said is printed at
  // once, so the run's failure shows it even if LIGGGHTS then has to be killed.
  {
    bp::environment env = boost::this_process::environment();
    env["GRANARY_LIGGGHTS"] =
        FakeLiggghts("hang-term", "echo 'about to hang'\ntouch started\nexec sleep 1000").string();
    fs::remove(dir / "started");
    bp::ipstream out;
    bp::child c(GRANARY_LIGGGHTS_EXE, "run", dir.string(), (bp::std_out & bp::std_err) > out, env);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!fs::exists(dir / "started") && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ::kill(c.id(), SIGTERM);
    std::string line, text;
    while (std::getline(out, line)) text += line + "\n";
    c.wait();
    EXPECT_EQ(c.native_exit_code() & 0x7f, SIGTERM) << text;
    EXPECT_NE(text.find("granary-liggghts: signal 15 (Terminated) received; LIGGGHTS so far:"), std::string::npos)
        << text;
    EXPECT_NE(text.find("about to hang"), std::string::npos) << text;
  }
  o = RunWithLiggghts(dir, FakeLiggghts("hang", "echo 'about to hang'\nexec sleep 1000"), {"--silence-limit", "1"});
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_NE(o.output.find("LIGGGHTS printed nothing for 1 s and was ended (hung?"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("about to hang"), std::string::npos) << o.output;
  EXPECT_TRUE(WaitUntilFree(dir));
}

// A cached LIGGGHTS bed carries the CRC-32 of its restart and dump: a corrupt one is refused,
// put aside and prepared again.
TEST(LiggghtsBackend, ACorruptCachedBedIsRefusedAndPreparedAgain) {
  const fs::path cache = kTmp / "beds-corrupt";
  fs::remove_all(cache);
  const json spec = {{"bed", {{"cache_file", (cache / "bed.json").string()}}}, {"discharge", {{"max_time", 0.5}}}};
  ASSERT_EQ(RunBackend(MakeRun("bed_first", spec)).exit_code, 0);
  fs::path restart;
  for (const auto& e : fs::directory_iterator(cache))
    if (e.path().extension() == ".restart") restart = e.path();
  ASSERT_FALSE(restart.empty());
  {
    std::fstream f(restart, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(fs::file_size(restart) / 2));
    f.write("\x5a\x5a\x5a\x5a\x5a\x5a\x5a\x5a", 8);
  }
  const Outcome o = RunBackend(MakeRun("bed_second", spec));
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_NE(o.output.find("refusing the cached bed liggghts-bed-"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find(".restart is corrupt (CRC-32 "), std::string::npos) << o.output;
  EXPECT_TRUE(ReadRun(kTmp / "bed_second").summary.raw.at("bed").at("prepared_here").get<bool>());
}

}  // namespace
