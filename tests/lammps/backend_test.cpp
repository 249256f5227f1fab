// Real LAMMPS runs of tiny silos through granary-lammps (a real subprocess, Debian's `lmp`),
// starting from the native engine's bed: the same bodies leave at the same times as on the
// native engine, every shape and geometry runs, a killed backend or a killed `lmp` continues
// from its checkpoint, and LAMMPS' errors, a missing `lmp` and a hung one fail the run with
// the log tail.
#include <gtest/gtest.h>
#include <signal.h>

#include <boost/process.hpp>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <tuple>
#include <thread>

#include "rundir/clogs.h"
#include "rundir/contacts.h"
#include "rundir/files.h"
#include "rundir/frames.h"
#include "rundir/run_directory.h"

namespace {

namespace fs = std::filesystem;
namespace bp = boost::process;
using nlohmann::json;
using namespace granary::rundir;

const fs::path kTmp = GRANARY_LAMMPS_TEST_TMP;

struct Outcome {
  int exit_code = -1;
  std::string output;
};

Outcome RunProgram(const std::string& exe, const std::vector<std::string>& args,
                   bp::environment env = boost::this_process::environment()) {
  bp::ipstream out;
  bp::child c(exe, bp::args = args, (bp::std_out & bp::std_err) > out, env);
  Outcome o;
  for (std::string line; std::getline(out, line);) o.output += line + "\n";
  c.wait();
  o.exit_code = c.exit_code();
  return o;
}
Outcome RunLammps(const fs::path& dir, bp::environment env = boost::this_process::environment(),
                  const std::vector<std::string>& extra = {}) {
  std::vector<std::string> args = {"run", dir.string()};
  args.insert(args.end(), extra.begin(), extra.end());
  return RunProgram(GRANARY_LAMMPS_EXE, args, env);
}

// A fresh run directory with run.json; native beds are cached in one directory.
fs::path MakeRun(const std::string& name, const json& overrides, const std::string& engine = "lammps") {
  const fs::path dir = kTmp / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  json j = {{"run_id", name},
            {"seed", 3},
            {"engine", engine},
            {"silo", {{"width", 16}, {"base_outlets", {{{"center", 0}, {"width", 5}}}}}},
            {"bodies", {{"count", 80}, {"species", {{{"shape", "disc"}}}}}},
            {"bed", {{"max_settle_time", 40}, {"cache_file", (kTmp / "beds" / (name + ".json")).string()}}},
            {"discharge", {{"mode", "remove"}, {"max_time", 4}, {"clog_window", 3}}},
            {"output", {{"checkpoint_interval", 0}}}};
  if (overrides.is_object()) j.merge_patch(overrides);
  std::ofstream(dir / "run.json") << j.dump(2);
  return dir;
}

// The same spec run by the native engine, in DIR-native (same bed cache file).
fs::path NativeTwin(const fs::path& dir) {
  const fs::path twin = dir.string() + "-native";
  fs::remove_all(twin);
  fs::create_directories(twin);
  json j = json::parse(std::ifstream(dir / "run.json"));
  j["engine"] = "native";
  std::ofstream(twin / "run.json") << j.dump(2);
  const Outcome o = RunProgram(GRANARY_ENGINE_EXE, {"run", twin.string(), "--threads", "1"});
  EXPECT_EQ(o.exit_code, 0) << o.output;
  return twin;
}

std::vector<int> ProcessesIn(const fs::path& dir, const std::string& comm = "") {
  std::vector<int> pids;
  const fs::path want = fs::canonical(dir);
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::error_code ec;
    const fs::path cwd = fs::read_symlink(e.path() / "cwd", ec);
    if (ec || cwd != want) continue;
    if (!comm.empty()) {
      std::string c;
      std::getline(std::ifstream(e.path() / "comm"), c);
      if (c != comm) continue;
    }
    pids.push_back(std::stoi(name));
  }
  return pids;
}

::testing::AssertionResult WaitUntilFree(const fs::path& dir) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    if (granary::RunDirectoryHolder(dir).empty()) return ::testing::AssertionSuccess();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return ::testing::AssertionFailure() << dir << " still locked after 60 s";
}

std::vector<Frame> ReadFrames(const fs::path& file) {
  std::vector<Frame> frames;
  FrameReader in(file);
  for (Frame f; in.Next(f);) frames.push_back(f);
  return frames;
}

std::vector<ContactFrame> ReadContactFrames(const fs::path& file) {
  std::vector<ContactFrame> frames;
  ContactReader in(file);
  for (ContactFrame f; in.Next(f);) frames.push_back(f);
  return frames;
}

// Each body's contact forces (rows with it as i, and as j with the force reversed) plus its
// weight: its mass times its acceleration.
std::map<std::int64_t, std::pair<double, double>> NetForces(const Frame& frame, const ContactFrame& contacts,
                                                            double gravity) {
  std::map<std::int64_t, std::pair<double, double>> net;
  for (const Disc& d : frame.discs) net[d.mol].second -= d.mass * gravity;
  for (const ContactRow& c : contacts.contacts) {
    net[c.body_i].first += c.fx;
    net[c.body_i].second += c.fy;
    if (c.body_j >= 0) {
      net[c.body_j].first -= c.fx;
      net[c.body_j].second -= c.fy;
    }
  }
  return net;
}

// Every body's discs keep their distances (rigid) and stay whole in every frame.
void ExpectRigid(const std::vector<Frame>& frames) {
  std::map<std::pair<std::int64_t, std::int64_t>, double> first;
  for (const Frame& f : frames) {
    std::map<std::int64_t, std::vector<const Disc*>> bodies;
    for (const Disc& d : f.discs) bodies[d.mol].push_back(&d);
    for (const auto& [mol, discs] : bodies)
      for (std::size_t i = 1; i < discs.size(); ++i) {
        const double dist = std::hypot(discs[i]->x - discs[0]->x, discs[i]->y - discs[0]->y);
        const auto [it, fresh] = first.emplace(std::make_pair(discs[0]->id, discs[i]->id), dist);
        if (!fresh) {
          ASSERT_NEAR(dist, it->second, 1e-6) << "body " << mol << " at t = " << f.time;
        }
      }
  }
}

TEST(LammpsBackend, DiscsLeaveAsOnTheNativeEngineFromTheSameBed) {
  const fs::path dir = MakeRun("discs_remove", {{"output", {{"frame_interval", 1.0}}}});
  const Outcome o = RunLammps(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const RunData run = ReadRun(dir);
  EXPECT_EQ(run.summary.engine, "lammps");
  EXPECT_NE(run.summary.engine_version.find("2021"), std::string::npos) << run.summary.engine_version;
  EXPECT_EQ(run.summary.tangential_cap, "lammps");
  EXPECT_EQ(run.summary.bodies, 80);
  EXPECT_EQ(run.summary.exited + run.summary.remaining, 80);
  ASSERT_GT(run.events.size(), 10u) << "a 5 d outlet lets discs out";
  const fs::path twin = NativeTwin(dir);
  const RunData native = ReadRun(twin);
  // The same bed, the same contact law: the first bodies out are the same ones, at the same
  // times: to the 0.01 at which the backend looks at the exit line, and the bed's contact
  // history, which LAMMPS does not get (docs/lammps.md).
  ASSERT_GE(native.events.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(run.events[i].body, native.events[i].body) << "exit " << i;
    EXPECT_NEAR(run.events[i].time, native.events[i].time, 0.03) << "exit " << i;
    EXPECT_NEAR(run.events[i].mass, native.events[i].mass, 1e-9);
    EXPECT_EQ(run.events[i].shape, "disc");
  }
  EXPECT_NEAR(static_cast<double>(run.events.size()), static_cast<double>(native.events.size()),
              0.15 * static_cast<double>(native.events.size()) + 2);
  // Frames: every frame of the native engine's times, the bed at t = 0 as the native one.
  const std::vector<Frame> frames = ReadFrames(dir / kFramesFile), nframes = ReadFrames(twin / kFramesFile);
  ASSERT_EQ(frames.size(), 5u);
  ASSERT_EQ(frames[0].discs.size(), nframes[0].discs.size());
  for (std::size_t i = 0; i < frames[0].discs.size(); ++i) {
    EXPECT_EQ(frames[0].discs[i].id, nframes[0].discs[i].id);
    EXPECT_EQ(frames[0].discs[i].mol, nframes[0].discs[i].mol);
    EXPECT_NEAR(frames[0].discs[i].x, nframes[0].discs[i].x, 1e-8);
    EXPECT_NEAR(frames[0].discs[i].mass, nframes[0].discs[i].mass, 1e-12);
  }
}

// contact/normal_model "hooke" is LAMMPS' gran/hooke/history, for the pairs and every wall: from
// the native engine's bed the same discs leave first, at the native Hooke run's times.
TEST(LammpsBackend, HookeDiscsLeaveAsOnTheNativeHookeEngineFromTheSameBed) {
  // The bed at the discharge's step: the default 8x step is unstable for this stiff linear
  // spring (omega dt ~1.8 at K_n 2e6).
  const fs::path dir =
      MakeRun("discs_hooke", {{"contact", {{"normal_model", "hooke"}}}, {"bed", {{"time_step", 1e-4}}}});
  const Outcome o = RunLammps(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  std::ifstream script_in(dir / "discharge.in");
  const std::string script((std::istreambuf_iterator<char>(script_in)), std::istreambuf_iterator<char>());
  EXPECT_NE(script.find("pair_style gran/hooke/history 2000000 2450000 1000 1000 0.5 1"), std::string::npos) << script;
  EXPECT_NE(script.find("wall/gran hooke/history"), std::string::npos) << script;
  EXPECT_EQ(script.find("hertz"), std::string::npos) << script;
  const RunData run = ReadRun(dir);
  ASSERT_GT(run.events.size(), 10u) << "a 5 d outlet lets discs out";
  const RunData native = ReadRun(NativeTwin(dir));
  // Matched by body: two exits 0.013 apart can swap at the backend's 0.01 look at the exit line.
  ASSERT_GE(native.events.size(), 7u);
  std::map<std::int64_t, double> lammps_exit;
  for (const auto& e : run.events) lammps_exit.emplace(e.body, e.time);
  for (std::size_t i = 0; i < 7; ++i) {
    const auto it = lammps_exit.find(native.events[i].body);
    ASSERT_NE(it, lammps_exit.end()) << "native exit " << i << ", body " << native.events[i].body;
    EXPECT_NEAR(it->second, native.events[i].time, 0.03) << "native exit " << i;
  }
  EXPECT_NEAR(static_cast<double>(run.events.size()), static_cast<double>(native.events.size()),
              0.15 * static_cast<double>(native.events.size()) + 2);
}

TEST(LammpsBackend, DumbbellsReinjectThroughThePeriodicBoxAndStayRigid) {
  const fs::path dir =
      MakeRun("dumbbells_reinject", {{"bodies", {{"count", 60}, {"species", {{{"shape", "dumbbell"}}}}}},
                                     {"silo", {{"base_outlets", {{{"center", 0}, {"width", 8}}}}}},
                                     {"discharge", {{"mode", "reinject"}, {"max_time", 8}, {"clog_window", 3}}},
                                     {"output", {{"frame_interval", 0.5}, {"contact_forces", true}}}});
  const Outcome o = RunLammps(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const RunData run = ReadRun(dir);
  EXPECT_EQ(run.summary.reinject_position, "periodic");
  ASSERT_GT(run.events.size(), 15u) << o.output;
  std::map<std::int64_t, int> exits;
  for (const auto& e : run.events) {
    EXPECT_EQ(e.shape, "dumbbell");
    EXPECT_NEAR(e.mass, 2 * std::numbers::pi / 4, 1e-9);
    ++exits[e.body];
  }
  int again = 0;
  for (const auto& [body, n] : exits) again += n > 1;
  if (run.summary.end_reason == "time_limit") {
    EXPECT_GT(again, 0) << "reinjected bodies leave again";
  }
  const std::vector<Frame> frames = ReadFrames(dir / kFramesFile);
  ASSERT_GE(frames.size(), 5u);
  for (const Frame& f : frames) EXPECT_EQ(f.discs.size(), 120u) << "nothing is lost at t = " << f.time;
  ExpectRigid(frames);
  // Contacts: no pair inside a dumbbell, every pair touching (pairs across the periodic
  // boundary put next to each other), the contact point on disc i's surface.
  const std::vector<ContactFrame> contacts = ReadContactFrames(dir / kContactsFile);
  ASSERT_EQ(contacts.size(), frames.size());
  std::size_t pairs = 0, walls = 0;
  for (const ContactFrame& f : contacts)
    for (const ContactRow& c : f.contacts) {
      ASSERT_NE(c.body_i, c.body_j) << "a pair inside a body at t = " << f.time;
      if (c.body_j < 0) {
        ++walls;
        continue;
      }
      ++pairs;
      ASSERT_LT(std::hypot(c.xj - c.xi, c.yj - c.yi), 1.0)
          << "bodies " << c.body_i << ", " << c.body_j << " at t = " << f.time;
      ASSERT_NEAR(std::hypot(c.cx - c.xi, c.cy - c.yi), 0.5, 1e-6);
    }
  EXPECT_GT(pairs, 100u);
  EXPECT_GT(walls, 10u);
}

TEST(LammpsBackend, EveryShapeWithASideOutletAndAnObstacleRuns) {
  const fs::path dir =
      MakeRun("shapes_side_obstacle", {{"silo",
                                        {{"width", 20},
                                         {"base_outlets", {{{"center", -3}, {"width", 5}}}},
                                         {"side_outlets", {{{"wall", "right"}, {"bottom", 1}, {"width", 5}}}},
                                         {"obstacles", {{{"x", -3}, {"y", 4}, {"diameter", 2}}}}}},
                                       {"bodies",
                                        {{"count", 80},
                                         {"species",
                                          {{{"shape", "disc"}, {"fraction", 0.25}, {"diameter", 1.2}},
                                           {{"shape", "dumbbell"}, {"fraction", 0.25}},
                                           {{"shape", "snowman"}, {"fraction", 0.25}, {"big_diameter", 1.5}},
                                           {{"shape", "rod"}, {"fraction", 0.25}, {"n", 3}}}}}},
                                       {"discharge", {{"max_time", 5}}},
                                       {"output", {{"frame_interval", 1.0}, {"contact_forces", true}}}});
  const Outcome o = RunLammps(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const RunData run = ReadRun(dir);
  ASSERT_EQ(run.summary.exits_per_outlet.size(), 2u);
  EXPECT_GT(run.summary.exits_per_outlet[0], 0) << o.output;
  EXPECT_GT(run.summary.exits_per_outlet[1], 0) << "bodies leave through the side outlet";
  std::set<std::string> shapes;
  for (const auto& e : run.events) shapes.insert(e.shape);
  EXPECT_GE(shapes.size(), 3u);
  const std::vector<Frame> frames = ReadFrames(dir / kFramesFile);
  ExpectRigid(frames);
  for (const Frame& f : frames)
    for (const Disc& d : f.discs)
      ASSERT_GT(std::hypot(d.x + 3, d.y - 4), 1.0 + d.radius - 0.05) << "a disc inside the obstacle at t = " << f.time;
  // Every wall contact point is on a wall: a side wall (x = ±10, the right one's pieces around
  // the side outlet included), the base (y = 0, the outlet's edges included) or the obstacle.
  int on_obstacle = 0;
  for (const ContactFrame& f : ReadContactFrames(dir / kContactsFile))
    for (const ContactRow& c : f.contacts) {
      if (c.body_j >= 0) continue;
      const bool obstacle = std::abs(std::hypot(c.cx + 3, c.cy - 4) - 1.0) < 1e-6;
      on_obstacle += obstacle;
      EXPECT_TRUE(obstacle || std::abs(std::abs(c.cx) - 10) < 1e-6 || std::abs(c.cy) < 1e-6)
          << "a wall contact at (" << c.cx << ", " << c.cy << ") at t = " << f.time;
    }
  EXPECT_GT(on_obstacle, 0) << "the obstacle's contacts are written";
}

TEST(LammpsBackend, AKilledBackendAndAKilledLmpContinueFromTheCheckpoint) {
  const fs::path dir = MakeRun(
      "killed", {{"bodies", {{"count", 60}, {"species", {{{"shape", "dumbbell"}}}}}},
                 {"silo", {{"base_outlets", {{{"center", 0}, {"width", 6}}}}}},
                 {"discharge", {{"mode", "reinject"}, {"max_time", 5}, {"clog_window", 3}}},
                 {"output", {{"checkpoint_interval", 1.0}, {"frame_interval", 0.5}, {"contact_forces", true}}}});
  const fs::path twin = kTmp / "killed-whole";
  fs::remove_all(twin);
  fs::create_directories(twin);
  fs::copy_file(dir / "run.json", twin / "run.json");
  ASSERT_EQ(RunLammps(twin).exit_code, 0);
  const std::vector<ExitEvent> whole = ReadRun(twin).events;

  // kill -9 of the backend once a checkpoint exists: LAMMPS dies with it.
  {
    bp::child c(GRANARY_LAMMPS_EXE, bp::args = {"run", dir.string()}, bp::std_out > bp::null, bp::std_err > bp::null);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    while (!fs::exists(dir / "checkpoint.20000.restart") && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_TRUE(fs::exists(dir / "checkpoint.20000.restart"));
    ::kill(c.id(), SIGKILL);
    c.wait();
  }
  ASSERT_TRUE(WaitUntilFree(dir));
  EXPECT_FALSE(fs::exists(dir / kDoneFile));
  // Continue, and kill -9 `lmp` itself once it has gone past the next checkpoint: the run fails
  // with the signal named, and the next start continues again.
  {
    bp::ipstream out;
    bp::child c(GRANARY_LAMMPS_EXE, bp::args = {"run", dir.string()}, (bp::std_out & bp::std_err) > out);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    while (!fs::exists(dir / "checkpoint.30000.restart") && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_TRUE(fs::exists(dir / "checkpoint.30000.restart"));
    for (int pid : ProcessesIn(dir, "lmp")) ::kill(pid, SIGKILL);
    std::string text;
    for (std::string line; std::getline(out, line);) text += line + "\n";
    c.wait();
    EXPECT_EQ(c.exit_code(), 1) << text;
    EXPECT_NE(text.find("LAMMPS killed by signal 9"), std::string::npos) << text;
  }
  ASSERT_TRUE(WaitUntilFree(dir));
  const Outcome o = RunLammps(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const RunData run = ReadRun(dir);
  EXPECT_TRUE(run.summary.continued_from_checkpoint);
  // Up to the first checkpoint the events are those of the uninterrupted run.
  std::vector<ExitEvent> a, b;
  for (const auto& e : whole)
    if (e.time <= 2.0) a.push_back(e);
  for (const auto& e : run.events)
    if (e.time <= 2.0) b.push_back(e);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].body, b[i].body);
    EXPECT_DOUBLE_EQ(a[i].time, b[i].time);
  }
  EXPECT_NEAR(static_cast<double>(run.events.size()), static_cast<double>(whole.size()),
              0.2 * static_cast<double>(whole.size()) + 3);
  // One frame and one contact frame every 0.5, none twice (LAMMPS writes a checkpoint step's
  // frame again when it continues from it); before the first checkpoint continued from, those
  // of the uninterrupted run.
  const std::vector<Frame> frames = ReadFrames(dir / kFramesFile), whole_frames = ReadFrames(twin / kFramesFile);
  const std::vector<ContactFrame> contacts = ReadContactFrames(dir / kContactsFile),
                                  whole_contacts = ReadContactFrames(twin / kContactsFile);
  ASSERT_EQ(frames.size(), 11u);
  ASSERT_EQ(contacts.size(), 11u);
  for (std::size_t k = 0; k < frames.size(); ++k) {
    EXPECT_EQ(frames[k].timestep, static_cast<std::int64_t>(k) * 5000);
    EXPECT_EQ(contacts[k].timestep, frames[k].timestep);
  }
  for (std::size_t k = 0; k < 4; ++k) {
    ASSERT_EQ(contacts[k].contacts.size(), whole_contacts[k].contacts.size()) << "t = " << contacts[k].time;
    for (std::size_t i = 0; i < contacts[k].contacts.size(); ++i) {
      EXPECT_EQ(contacts[k].contacts[i].body_i, whole_contacts[k].contacts[i].body_i);
      EXPECT_DOUBLE_EQ(contacts[k].contacts[i].fy, whole_contacts[k].contacts[i].fy);
    }
  }
}

// bed/settled_by "lammps": LAMMPS settles the loose placement (closed outlets) and discharges
// the settled bed: the start frame is no longer the loose one, at rest (kinetic energy per body
// below the threshold), below where the bodies were placed, no disc through the base, and the
// run goes on to exits as from a native bed. The native engine refuses the value.
TEST(LammpsBackend, ALammpsSettledBedSettlesThenDischarges) {
  const json overrides = {
      {"bodies",
       {{"count", 60},
        {"species", {{{"shape", "disc"}, {"fraction", 0.5}}, {{"shape", "dumbbell"}, {"fraction", 0.5}}}}}},
      {"bed", {{"settled_by", "lammps"}, {"settle_ke_per_body", 1e-4}, {"max_settle_time", 30}}},
      {"discharge", {{"max_time", 4}}},
      {"output", {{"frame_interval", 1.0}}}};
  const fs::path dir = MakeRun("lammps_settled", overrides);
  const Outcome o = RunLammps(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const json state = json::parse(std::ifstream(dir / "lammps_state.json"));
  ASSERT_EQ(state["bed"]["settled_by"], "lammps") << state.dump();
  EXPECT_TRUE(state["bed"]["settled"].get<bool>()) << "kinetic energy per body below 1e-4: " << state.dump();
  const double settle_time = state["bed"]["settle_time"].get<double>();
  EXPECT_GT(settle_time, 1.0);
  EXPECT_LT(settle_time, 30.0);
  // The loose placement LAMMPS started from, and the bed it settled into.
  Frame bed;
  {
    std::ifstream data(dir / "loose.data");
    ASSERT_TRUE(data.good());
  }
  const std::vector<Frame> start = ReadFrames(dir / "start.dump");
  ASSERT_EQ(start.size(), 1u);
  bed = start[0];
  ASSERT_EQ(bed.discs.size(), 90u) << "30 discs and 30 dumbbells";
  double top = 0, ke = 0;
  for (const Disc& d : bed.discs) {
    EXPECT_GT(d.y, d.radius - 0.05) << "disc " << d.id << " through the base";
    EXPECT_LT(std::abs(d.x), 8 - d.radius + 0.05) << "disc " << d.id << " through a wall";
    top = std::max(top, d.y + d.radius);
    ke += 0.5 * d.mass * (d.vx * d.vx + d.vy * d.vy);
  }
  EXPECT_LT(ke / 60, 1e-3) << "at rest";
  const RunData run = ReadRun(dir);
  EXPECT_NEAR(run.summary.bed.height, top, 1e-6);
  EXPECT_NEAR(run.summary.bed.settle_time, settle_time, 1e-9);
  EXPECT_TRUE(run.summary.bed.prepared_here);
  EXPECT_GT(run.events.size(), 3u) << "the settled bed discharges";
  const std::vector<Frame> frames = ReadFrames(dir / kFramesFile);
  ASSERT_GE(frames.size(), 2u);
  ExpectRigid(frames);
  // The same spec on the native engine is refused at plan time, with the path.
  const fs::path native = MakeRun("lammps_settled_native", overrides, "native");
  const Outcome n = RunProgram(GRANARY_ENGINE_EXE, {"run", native.string()});
  EXPECT_EQ(n.exit_code, 2) << n.output;
  EXPECT_NE(n.output.find("/bed/settled_by"), std::string::npos) << n.output;
}

// A wrapper around the real `lmp` that changes its input: `line` goes in before the first run.
fs::path LmpWrapper(const std::string& name, const std::string& line) {
  const fs::path w = kTmp / name;
  fs::create_directories(kTmp);
  std::ofstream(w) << "#!/bin/sh\n"
                   << "awk -v line=\"" << line << "\" '/^run 0 post no$/ { print line } { print }' discharge.in"
                   << " > discharge.changed.in\n"
                   << "exec lmp -in discharge.changed.in -log log.discharge -echo none -nocite\n";
  fs::permissions(w, fs::perms::owner_all);
  return w;
}

// A contact seen from the lower body id (pairs) or from its body (walls): the normal part of
// the force (along the line from the other disc's centre, or the wall's contact point, to the
// centre of disc i) and the overlap, for discs of radius r.
struct Seen {
  double fn, overlap;
};
std::map<std::tuple<std::int64_t, std::int64_t, long, long>, Seen> ByContact(const ContactFrame& f, double r) {
  std::map<std::tuple<std::int64_t, std::int64_t, long, long>, Seen> out;
  for (const ContactRow& c : f.contacts) {
    const double nx = c.xi - c.xj, ny = c.yi - c.yj, dist = std::hypot(nx, ny);
    const Seen seen{(c.fx * nx + c.fy * ny) / dist, (c.body_j < 0 ? r : 2 * r) - dist};
    // A body touches a wall at most once per wall piece: its contact point (to 1e-3) tells them apart.
    const auto key = c.body_j < 0
                         ? std::make_tuple(c.body_i, c.body_j, std::lround(c.cx * 1000), std::lround(c.cy * 1000))
                         : std::make_tuple(std::min(c.body_i, c.body_j), std::max(c.body_i, c.body_j), 0L, 0L);
    EXPECT_TRUE(out.emplace(key, seen).second) << "one row per contact at t = " << f.time;
  }
  return out;
}

// output/contact_forces on LAMMPS: a bed of discs over a base outlet narrower than a disc. At
// t = 0 LAMMPS' contacts are those of the native engine's contacts.dump of the same bed (the
// same pairs and wall contacts, the same normal forces); once the bed has come to rest again
// after the outlet opened under it, the walls carry its weight and every body's contact forces
// balance its weight.
TEST(LammpsBackend, ContactFramesBalanceGravityAndMatchTheNativeEngineAtTheStart) {
  const fs::path dir = MakeRun("contacts_at_rest", {{"silo", {{"base_outlets", {{{"center", 0.3}, {"width", 0.5}}}}}},
                                                    {"bodies", {{"count", 60}}},
                                                    {"discharge", {{"max_time", 10}, {"clog_window", 20}}},
                                                    {"output", {{"frame_interval", 1.0}, {"contact_forces", true}}}});
  const Outcome o = RunLammps(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const std::vector<Frame> frames = ReadFrames(dir / kFramesFile);
  const std::vector<ContactFrame> contacts = ReadContactFrames(dir / kContactsFile);
  ASSERT_EQ(frames.size(), 11u);
  ASSERT_EQ(contacts.size(), frames.size());
  for (std::size_t k = 0; k < frames.size(); ++k) {
    EXPECT_EQ(contacts[k].timestep, frames[k].timestep);
    ASSERT_EQ(frames[k].discs.size(), 60u) << "no disc passes an outlet half a diameter wide";
  }
  for (const Disc& d : frames[0].discs) ASSERT_DOUBLE_EQ(d.radius, 0.5);

  // t = 10. Each body's contact forces plus its weight are m a: the bed comes back to rest after
  // the outlet opened under it (measured: the largest |m a| is 0.1 m g at t = 3, 0.003 m g at
  // t = 10). A wall contact left out would leave the base short of about a twentieth of the
  // weight (19 wall contacts), a pair or a tangential force left out a body short of a
  // fraction of its weight.
  const Frame& rest = frames.back();
  const ContactFrame& rest_contacts = contacts.back();
  double weight = 0, wall_fy = 0, m = 0;
  int wall_rows = 0;
  for (const Disc& d : rest.discs) weight += d.mass * 1.0;
  m = rest.discs[0].mass;
  for (const ContactRow& c : rest_contacts.contacts)
    if (c.body_j < 0) {
      wall_fy += c.fy;
      ++wall_rows;
    }
  EXPECT_GT(wall_rows, 15);
  EXPECT_NEAR(wall_fy / weight, 1.0, 0.01) << "the base and walls carry the bed's weight";
  for (const auto& [body, f] : NetForces(rest, rest_contacts, 1.0))
    EXPECT_LT(std::hypot(f.first, f.second), 0.02 * m) << "body " << body << ": contact forces + weight";

  // t = 0 against the native engine's contacts of the same bed.
  const fs::path twin = NativeTwin(dir);
  const std::vector<ContactFrame> native = ReadContactFrames(twin / kContactsFile);
  ASSERT_FALSE(native.empty());
  EXPECT_EQ(native[0].timestep, 0);
  const auto lammps0 = ByContact(contacts[0], 0.5), native0 = ByContact(native[0], 0.5);
  ASSERT_GT(lammps0.size(), 100u);
  EXPECT_EQ(lammps0.size(), native0.size());
  int walls = 0;
  for (const auto& [key, l] : lammps0) {
    const auto n = native0.find(key);
    ASSERT_NE(n, native0.end()) << "a contact the native engine does not have: bodies " << std::get<0>(key) << ", "
                                << std::get<1>(key);
    walls += std::get<1>(key) < 0;
    // The same law on the same positions and velocities, except that LAMMPS starts from
    // start.dump, whose positions have 10 significant digits: overlaps differ by up to about
    // 4e-9, and the Hertz force (~ overlap^3/2) by 1.5 |F_n| 4e-9 / overlap (measured: up to
    // 1.2e-5 of F_n at overlaps of 1e-4). The tangential forces differ: the native engine keeps
    // the bed's shear springs, LAMMPS starts without (docs/lammps.md).
    EXPECT_NEAR(l.fn, n->second.fn, 1.5 * std::abs(n->second.fn) * 4e-9 / n->second.overlap + 1e-9)
        << "bodies " << std::get<0>(key) << ", " << std::get<1>(key) << " (overlap " << n->second.overlap << ")";
  }
  EXPECT_GT(walls, 15) << "wall contacts are compared too";
}

// A clog on LAMMPS keeps its contacts (clog_contacts.dump, whatever output asks), as on the
// native engine: the clogged bed's pairs and wall contacts; stalled for clog_window, the bed is
// at rest: its weight on the walls, each body's forces balanced (measured: |m a| < 0.05 m g).
TEST(LammpsBackend, AClogKeepsItsContacts) {
  const fs::path dir = MakeRun("clog_contacts", {{"silo", {{"base_outlets", {{{"center", 0}, {"width", 2.2}}}}}},
                                                 {"discharge", {{"max_time", 30}, {"clog_window", 3}}}});
  const Outcome o = RunLammps(dir);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const RunData run = ReadRun(dir);
  ASSERT_EQ(run.summary.end_reason, "clogged") << "an outlet 2.2 discs wide clogs";
  const std::vector<ClogState> clogs = ReadClogs(dir);
  ASSERT_EQ(clogs.size(), 1u);
  const ClogState& clog = clogs[0];
  EXPECT_EQ(clog.contacts.timestep, clog.frame.timestep);
  ASSERT_GT(clog.contacts.contacts.size(), clog.frame.discs.size()) << "a packed bed: more contacts than discs";
  double weight = 0, wall_fy = 0;
  for (const Disc& d : clog.frame.discs) weight += d.mass * 1.0;
  for (const ContactRow& c : clog.contacts.contacts) {
    ASSERT_NE(c.body_i, c.body_j);
    if (c.body_j < 0) wall_fy += c.fy;
  }
  EXPECT_NEAR(wall_fy / weight, 1.0, 0.02);
  const double m = clog.frame.discs[0].mass;
  for (const auto& [body, f] : NetForces(clog.frame, clog.contacts, 1.0))
    EXPECT_LT(std::hypot(f.first, f.second), 0.1 * m) << "body " << body;
}

TEST(LammpsBackend, ALammpsErrorLineFailsTheRunWithTheLogTail) {
  const fs::path dir = MakeRun("lammps_error", {});
  bp::environment env = boost::this_process::environment();
  env["GRANARY_LAMMPS"] = LmpWrapper("lmp-error.sh", "fix broken all no_such_style").string();
  const Outcome o = RunLammps(dir, env);
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_NE(o.output.find("LAMMPS failed during the discharge"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("ERROR: Unrecognized fix style"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("last lines of log.discharge"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(dir / kDoneFile));
}

TEST(LammpsBackend, AMissingLmpIsAClearError) {
  const fs::path dir = MakeRun("missing_lmp", {});
  bp::environment env = boost::this_process::environment();
  env["GRANARY_LAMMPS"] = (kTmp / "no-such-lmp").string();
  const Outcome o = RunLammps(dir, env);
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_NE(o.output.find("LAMMPS executable not found"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("Debian's package lammps"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(dir / kDoneFile));
}

TEST(LammpsBackend, AHungLmpIsEndedAndFailsTheRun) {
  const fs::path dir = MakeRun("hung_lmp", {});
  bp::environment env = boost::this_process::environment();
  env["GRANARY_LAMMPS"] = LmpWrapper("lmp-hung.sh", "print 'about to hang'\\nshell sleep 600").string();
  const auto t0 = std::chrono::steady_clock::now();
  const Outcome o = RunLammps(dir, env, {"--silence-limit", "3"});
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(60));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_NE(o.output.find("LAMMPS printed nothing for 3 s"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("about to hang"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(dir / kDoneFile));
  ASSERT_TRUE(WaitUntilFree(dir));
}

TEST(LammpsBackend, WhatLammpsCannotDoIsRefusedWithItsPath) {
  const fs::path dir = MakeRun("refused", {{"contact", {{"clip_normal", true}}}});
  const Outcome o = RunLammps(dir);
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("/contact/clip_normal"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(dir / "start.dump")) << "refused before anything runs";
}

TEST(LammpsCampaign, CompareRunsNativeAndLammpsOnTheSameBeds) {
  const fs::path dir = kTmp / "campaign";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const json spec = {{"name", "lammps-tiny"},
                     {"engine", {"native", "lammps"}},
                     {"replicas", 2},
                     {"base",
                      {{"silo", {{"width", 16}}},
                       {"bodies", {{"count", 60}, {"species", {{{"shape", "disc"}}}}}},
                       {"bed", {{"max_settle_time", 40}}},
                       {"discharge", {{"mode", "reinject"}, {"max_time", 3}, {"reinject_position", "periodic"}}},
                       {"output", {{"checkpoint_interval", 0}}}}},
                     {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {5}}}}}}};
  std::ofstream(dir / "spec.json") << spec.dump(2);
  const Outcome o =
      RunProgram(GRANARY_CAMPAIGN_EXE, {"compare", (dir / "spec.json").string(), "--db", (dir / "c.db").string(),
                                        "--jobs", "2", "--json", "--no-figures"});
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const std::size_t from = o.output.find("{\n"), to = o.output.find("\n}\n", from);
  ASSERT_NE(to, std::string::npos) << o.output;
  const json out = json::parse(o.output.substr(from, to + 3 - from));
  EXPECT_EQ(out["runs_used"], 4) << o.output;
  const json& c = out["comparison"];
  EXPECT_EQ(c["engine_a"], "native");
  EXPECT_EQ(c["engine_b"], "lammps");
  ASSERT_EQ(c["points"].size(), 1u);
}

// A tiny campaign on LAMMPS of every shape in both geometries (one base outlet; a base outlet,
// a side outlet and an obstacle), planned, run and reported through `campaign` as a user
// would: every run done on LAMMPS, with exits, and the report written.
TEST(LammpsCampaign, EveryShapeAndGeometryEndToEnd) {
  const fs::path dir = kTmp / "campaign_shapes";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const json spec = {{"name", "lammps-shapes"},
                     {"engine", "lammps"},
                     {"base",
                      {{"silo", {{"width", 16}, {"base_outlets", {{{"center", -2}, {"width", 5}}}}}},
                       {"bodies", {{"count", 40}}},
                       {"bed", {{"max_settle_time", 40}}},
                       // A body counts as gone half a diameter past a wall: from a bed this low, the side
                       // outlet's flow is slow, and three time units carry a body only about one d out.
                       {"discharge", {{"mode", "remove"}, {"max_time", 3}, {"clog_window", 3}, {"exit_distance", 0.5}}},
                       {"output", {{"checkpoint_interval", 0}, {"frame_interval", 1.0}}}}},
                     {"sweep",
                      {{"grid", {{"/bodies/species/0/shape", {"disc", "dumbbell", "snowman", "rod"}}}},
                       {"points",
                        {{{"/silo/side_outlets", json::array()}},
                         {{"/silo/side_outlets", {{{"wall", "right"}, {"bottom", 0.5}, {"width", 5}}}},
                          {"/silo/obstacles", {{{"x", -2}, {"y", 4}, {"diameter", 2}}}}}}}}}};
  std::ofstream(dir / "spec.json") << spec.dump(2);
  const std::string db = (dir / "c.db").string();
  const Outcome plan = RunProgram(GRANARY_CAMPAIGN_EXE, {"plan", (dir / "spec.json").string(), "--db", db});
  ASSERT_EQ(plan.exit_code, 0) << plan.output;
  const Outcome run = RunProgram(GRANARY_CAMPAIGN_EXE, {"run", "--db", db, "--jobs", "2"});
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const Outcome report = RunProgram(GRANARY_CAMPAIGN_EXE, {"report", "--db", db, "--no-figures"});
  ASSERT_EQ(report.exit_code, 0) << report.output;
  EXPECT_TRUE(fs::exists(dir / "report" / "report.html")) << report.output;
  int runs = 0, side_exits = 0;
  std::set<std::string> shapes;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.path().filename() != "summary.json") continue;
    const RunData r = ReadRun(e.path().parent_path());
    ++runs;
    EXPECT_EQ(r.summary.engine, "lammps");
    EXPECT_GT(r.summary.exited, 0) << e.path();
    for (const auto& ev : r.events) shapes.insert(ev.shape);
    if (r.summary.exits_per_outlet.size() == 2) side_exits += r.summary.exits_per_outlet[1];
  }
  EXPECT_EQ(runs, 8) << run.output;
  EXPECT_EQ(shapes.size(), 4u);
  EXPECT_GT(side_exits, 0) << "bodies leave through the side outlets";
}

}  // namespace
