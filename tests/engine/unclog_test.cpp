// The unclog protocol (discharge/on_clog "unclog") on a small disc silo: clog, unclog, clog
// again; what the engine took out is the arch the arches analysis finds in the same clog; the
// avalanches between unclogs, the clog frames and unclogs.csv agree; the same bits at 1 and 2
// threads and after a kill and continue.
#include <algorithm>
#include <cmath>
#include <map>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "analysis/arches.h"
#include "analysis/registry.h"
#include "analysis/run_pass.h"
#include "engine/bed.h"
#include "engine/run.h"
#include "rundir/clogs.h"
#include "rundir/events.h"
#include "rundir/layout.h"
#include "rundir/unclogs.h"
#include "run_helpers.h"

namespace granary::engine {
namespace {

// 200 discs in a silo 16 d wide over an outlet 3 d wide: a clog every few tens of exits.
nlohmann::json UnclogSpec(const std::string& mode, const std::string& method, int max_clogs) {
  nlohmann::json spec = SmallSpec(3.0, 150.0, 11, "disc");
  spec["bodies"]["count"] = 200;
  spec["bed"]["batch_size"] = 200;
  spec["bed"]["cache_file"] = BedCache(11, "disc200");
  spec["discharge"]["mode"] = mode;
  spec["discharge"]["on_clog"] = "unclog";
  spec["discharge"]["unclog"] = {{"method", method}, {"max_clogs", max_clogs}};
  if (method == "kick") spec["discharge"]["unclog"]["kick_speed"] = 1.5;
  spec["output"] = {{"checkpoint_interval", 2.0}, {"frame_interval", 0.0}};
  return spec;
}

struct Outcome {
  nlohmann::json summary;
  std::vector<rundir::ExitEvent> events;
  std::vector<rundir::UnclogEvent> unclogs;
  std::vector<rundir::ClogState> clogs;
};

Outcome Read(const fs::path& dir) {
  return {ReadJson(dir / rundir::kSummaryFile), rundir::ReadEvents(dir / rundir::kEventsFile),
          rundir::ReadUnclogs(dir / rundir::kUnclogsFile), rundir::ReadClogs(dir)};
}

// The per-run results of the registered analyses on `dir` (no cache).
std::map<std::string, nlohmann::json> Analyse(const fs::path& dir) {
  const analysis::AnalysisSetup setup = analysis::SetupAnalyses(nlohmann::json::object());
  const std::vector<const analysis::Analysis*> list = setup.List();
  const analysis::RunPassResult r = analysis::AnalyseRun(dir, list, setup.pass, {1, false, false});
  std::map<std::string, nlohmann::json> out;
  for (std::size_t k = 0; k < list.size(); ++k) out[list[k]->Key()] = r.results[k];
  return out;
}

// Each clog k has its frame in clog_frames.dump at the step of its first unclog attempt; the
// avalanches are the exits between those steps, the last one up to the final clog.
void ExpectConsistent(const fs::path& dir, const Outcome& o, int max_clogs) {
  EXPECT_EQ(o.summary["end_reason"], "max_clogs");
  EXPECT_EQ(o.summary["clogs"].get<int>(), max_clogs);
  ASSERT_EQ(static_cast<int>(o.clogs.size()), max_clogs);
  std::vector<double> cuts;
  int clog = 0;
  for (const rundir::UnclogEvent& u : o.unclogs) {
    EXPECT_FALSE(u.bodies.empty());
    if (u.clog == clog) continue;  // a further attempt on the same clog
    ++clog;
    EXPECT_EQ(u.clog, clog);
    EXPECT_EQ(u.attempt, 1);
    EXPECT_EQ(u.step, o.clogs[static_cast<std::size_t>(clog - 1)].frame.timestep);
    cuts.push_back(u.time);
  }
  EXPECT_EQ(clog, max_clogs - 1);  // the last clog ends the run unbroken
  EXPECT_EQ(o.summary["unclogs"].get<int>(), max_clogs - 1);
  std::vector<double> expected(cuts.size() + 1, 0.0);
  for (const rundir::ExitEvent& e : o.events)
    expected[static_cast<std::size_t>(std::upper_bound(cuts.begin(), cuts.end(), e.time) - cuts.begin())] += 1;
  for (double s : expected) EXPECT_GT(s, 0.0);
  const std::map<std::string, nlohmann::json> a = Analyse(dir);
  EXPECT_EQ(a.at("avalanches")["sizes"].get<std::vector<double>>(), expected);
  EXPECT_EQ(a.at("avalanches")["clogs"].get<int>(), max_clogs);
  EXPECT_EQ(a.at("arches")["clogs"].size(), static_cast<std::size_t>(max_clogs));
  EXPECT_TRUE(a.at("clogging_index").value("unclog", false) || a.at("clogging_index")["remove_mode"] == false);
}

TEST(Unclog, RemoveArchTakesOutTheArchTheAnalysisFindsAndTheFlowGoesOn) {
  const fs::path dir = FreshDir("unclog-remove-arch");
  WriteSpec(dir, UnclogSpec("reinject", "remove_arch", 3));
  RunQuiet(dir);
  const Outcome o = Read(dir);
  ExpectConsistent(dir, o, 3);
  // What the engine took out at each clog's first attempt is the arch of that clog as the
  // arches analysis reads it from clog_frames.dump.
  const nlohmann::json spec = ReadJson(dir / rundir::kRunSpecFile);
  int checked = 0;
  for (const rundir::UnclogEvent& u : o.unclogs) {
    if (u.attempt != 1) continue;
    const analysis::ClogArches arches = analysis::AnalyseClog(o.clogs[static_cast<std::size_t>(u.clog - 1)], spec);
    ASSERT_FALSE(arches.arches.empty());
    std::vector<std::int64_t> ids;
    for (const analysis::Arch& arch : arches.arches)
      for (const analysis::ArchBody& b : arch.bodies) ids.push_back(b.id);
    std::sort(ids.begin(), ids.end());
    EXPECT_EQ(u.bodies, ids) << "clog " << u.clog;
    ++checked;
  }
  EXPECT_EQ(checked, 2);
  // Reinject mode: the arch went back on top, nothing is lost.
  EXPECT_EQ(o.summary["remaining"].get<int>(), 200);
}

TEST(Unclog, KickBlowsTheBodiesOverTheOutletUntilTheFlowResumes) {
  const fs::path dir = FreshDir("unclog-kick");
  WriteSpec(dir, UnclogSpec("remove", "kick", 3));
  RunQuiet(dir);
  const Outcome o = Read(dir);
  ExpectConsistent(dir, o, 3);
  // Every kicked body was within the outlet's width (3 d) of its centre at the clog, and a kick
  // takes nothing out.
  for (const rundir::UnclogEvent& u : o.unclogs) {
    EXPECT_EQ(u.method, "kick");
    if (u.attempt != 1) continue;
    const rundir::ClogState& c = o.clogs[static_cast<std::size_t>(u.clog - 1)];
    for (std::int64_t b : u.bodies) {
      const auto bodies = rundir::BodiesOf(c.frame.discs);
      const auto it = std::find_if(bodies.begin(), bodies.end(), [&](const rundir::Body& x) { return x.id == b; });
      ASSERT_NE(it, bodies.end());
      EXPECT_LE(std::hypot(it->x, it->y), 3.0 + 1e-12);
    }
  }
  EXPECT_EQ(o.summary["exited"].get<int>() + o.summary["remaining"].get<int>(), 200);
  EXPECT_FALSE(o.summary.contains("unclog_removed") && o.summary["unclog_removed"].get<int>() != 0);
}

// remove_arch in remove mode: the arch bodies are counted apart from the exits.
TEST(Unclog, RemovedArchBodiesAreNotExits) {
  const fs::path dir = FreshDir("unclog-remove-mode");
  WriteSpec(dir, UnclogSpec("remove", "remove_arch", 3));
  RunQuiet(dir);
  const Outcome o = Read(dir);
  ExpectConsistent(dir, o, 3);
  int removed = 0;
  for (const rundir::UnclogEvent& u : o.unclogs) removed += static_cast<int>(u.bodies.size());
  EXPECT_EQ(o.summary["unclog_removed"].get<int>(), removed);
  EXPECT_EQ(static_cast<int>(o.events.size()), o.summary["exited"].get<int>());
  EXPECT_EQ(o.summary["exited"].get<int>() + o.summary["remaining"].get<int>() + removed, 200);
}

// The files a clog and its unclog write, and the run's end time, the same bytes in `other` as in `reference`.
void ExpectSameClogOutputs(const fs::path& reference, const fs::path& other) {
  SCOPED_TRACE(other.filename().string());
  for (const char* f : {rundir::kEventsFile, rundir::kUnclogsFile, rundir::kClogFramesFile, rundir::kClogContactsFile})
    EXPECT_TRUE(Slurp(reference / f) == Slurp(other / f)) << f;
  EXPECT_EQ(ReadJson(reference / rundir::kSummaryFile)["t_end"], ReadJson(other / rundir::kSummaryFile)["t_end"]);
}

// The same bits at 1 and 2 threads and after a kill and continue (the checkpoint carries the
// unclog state, the kicks' random numbers and the offset of unclogs.csv).
void ExpectSameBits(const std::string& method) {
  const fs::path one = FreshDir("unclog-bits-1-" + method), two = FreshDir("unclog-bits-2-" + method),
                 cont = FreshDir("unclog-bits-c-" + method);
  // Up to t = 16: the first clog at t = 8.7 and the first attempts to break it (kicks every 2
  // time units), so that the kill below falls among unclog attempts; short, since forced
  // parallel loops at two threads are slow when the suite runs two tests on two cores.
  nlohmann::json spec = UnclogSpec("remove", method, 2);
  spec["discharge"]["max_time"] = 16.0;
  for (const fs::path& d : {one, two, cont}) WriteSpec(d, spec);
  RunQuiet(one, 1, -1, 32);
  RunQuiet(two, 2, -1, 32);
  const Outcome o = Read(one);
  ASSERT_GE(o.unclogs.size(), 1u);
  // Killed after the first unclog, past a checkpoint (every 2 time units), and continued with
  // the same force blocks (their size sets the order of the force sums, the threads do not).
  const std::int64_t kill_at = o.unclogs.front().step + 25000;
  EXPECT_EQ(RunQuiet(cont, 1, kill_at, 32).end_reason, "aborted");
  EXPECT_TRUE(RunQuiet(cont, 1, -1, 32).continued);
  for (const fs::path& d : {two, cont}) ExpectSameClogOutputs(one, d);
}

// A run that ended at max_clogs, planned again with a larger max_clogs (granary::extends),
// continues from the checkpoint its end wrote (there is no other: no periodic checkpoints) and
// gives the bits of a run planned with the larger limit from the start, frames included.
TEST(Unclog, ARaisedMaxClogsContinuesFromTheLastClogWithTheSameBits) {
  const fs::path extended = FreshDir("unclog-extend"), fresh = FreshDir("unclog-extend-fresh");
  nlohmann::json spec = UnclogSpec("reinject", "remove_arch", 2);
  spec["output"] = {{"checkpoint_interval", 0.0}, {"frame_interval", 0.05}};
  WriteSpec(extended, spec);
  ASSERT_EQ(RunQuiet(extended).end_reason, "max_clogs");
  const std::string short_events = Slurp(extended / rundir::kEventsFile);
  spec["discharge"]["unclog"]["max_clogs"] = 3;
  WriteSpec(fresh, spec);
  ASSERT_EQ(RunQuiet(fresh).end_reason, "max_clogs");
  EXPECT_TRUE(granary::Extends(ReadJson(extended / rundir::kRunSpecFile), ReadJson(fresh / rundir::kRunSpecFile)));
  // As the runner moves a run it extends: its run.json replaced, without DONE.
  WriteSpec(extended, spec);
  fs::remove(extended / rundir::kDoneFile);
  const RunResult r = RunQuiet(extended);
  EXPECT_TRUE(r.continued);
  EXPECT_EQ(r.end_reason, "max_clogs");
  EXPECT_EQ(ReadJson(extended / rundir::kSummaryFile)["clogs"], 3);
  EXPECT_GT(Slurp(extended / rundir::kEventsFile).size(), short_events.size());
  for (const char* f : {rundir::kEventsFile, rundir::kUnclogsFile, rundir::kClogFramesFile, rundir::kClogContactsFile,
                        rundir::kFramesFile})
    EXPECT_TRUE(Slurp(fresh / f) == Slurp(extended / f)) << f;
  EXPECT_EQ(ReadJson(fresh / rundir::kSummaryFile)["t_end"], ReadJson(extended / rundir::kSummaryFile)["t_end"]);
}

// A stall that no arch seals, so that remove_arch finds nothing to take out (as snowmen that hang
// into the opening from its edge onto a body below leave it): a bed placed by hand, 8 discs
// (d = 1) at rest in a row on the floor beside the 3 d outlet, 4 on each side, none near it.
// Reinject mode judges every stall a clog (remove mode would call this one discharged), so the
// first clog comes at clog_window, before any exit, and nothing but a kick moves the discs.
// The kick radius reaches the whole floor (the silo is 16 d wide).
nlohmann::json NoArchSpec(const fs::path& dir, const std::string& fallback) {
  nlohmann::json spec = SmallSpec(3.0, 150.0, 13, "disc");
  spec["bodies"]["count"] = 8;
  spec["bed"]["batch_size"] = 8;
  // In the run's directory: a file shared by tests that ctest runs at once could be read torn.
  spec["bed"]["cache_file"] = (dir / "bed.json").string();
  spec["discharge"]["mode"] = "reinject";
  spec["discharge"]["on_clog"] = "unclog";
  spec["discharge"]["unclog"] = {{"method", "remove_arch"}, {"max_clogs", 3}, {"kick_radius", 8.0}};
  if (!fallback.empty()) spec["discharge"]["unclog"]["fallback"] = fallback;
  spec["output"] = {{"checkpoint_interval", 2.0}, {"frame_interval", 0.0}};
  BedState bed;
  for (const double x : {-7.0, -6.0, -5.0, -4.0, 4.0, 5.0, 6.0, 7.0}) {
    bed.species.push_back(0);
    bed.x.push_back(x);
    bed.y.push_back(0.5);
    bed.theta.push_back(0.0);
    bed.vx.push_back(0.0);
    bed.vy.push_back(0.0);
    bed.omega.push_back(0.0);
    bed.height = std::max(bed.height, bed.y.back() + 0.5);
  }
  std::ofstream(spec["bed"]["cache_file"].get<std::string>()) << BedToJson(bed, RunSpec::FromJson(spec)).dump();
  return spec;
}

TEST(Unclog, WithoutAFallbackARemoveArchThatFindsNoArchEndsTheRunClogged) {
  const fs::path dir = FreshDir("unclog-no-arch-none");
  WriteSpec(dir, NoArchSpec(dir, ""));
  EXPECT_EQ(RunQuiet(dir).end_reason, "clogged");
  const Outcome o = Read(dir);
  EXPECT_EQ(o.summary["clogs"].get<int>(), 1);
  EXPECT_TRUE(o.events.empty());
  // max_attempts (10) attempts that took out nothing.
  ASSERT_EQ(o.unclogs.size(), 10u);
  for (const rundir::UnclogEvent& u : o.unclogs) {
    EXPECT_EQ(u.method, "remove_arch");
    EXPECT_TRUE(u.bodies.empty());
  }
}

TEST(Unclog, AKickFallbackBreaksAStallNoArchSealsAndTheRunGoesOnToMaxClogs) {
  const fs::path dir = FreshDir("unclog-no-arch-kick");
  WriteSpec(dir, NoArchSpec(dir, "kick"));
  EXPECT_EQ(RunQuiet(dir).end_reason, "max_clogs");
  const Outcome o = Read(dir);
  EXPECT_EQ(o.summary["clogs"].get<int>(), 3);
  EXPECT_EQ(o.summary["unclogs"].get<int>(), 2);
  ASSERT_EQ(o.clogs.size(), 3u);
  // Each attempt found no arch and kicked instead: a "kick" row with the bodies within the kick
  // radius (all of them: the radius reaches the whole floor and nothing is above 8 d).
  std::vector<double> cuts;
  for (const rundir::UnclogEvent& u : o.unclogs) {
    EXPECT_EQ(u.method, "kick");
    EXPECT_EQ(u.bodies.size(), 8u);
    if (u.attempt == 1) cuts.push_back(u.time);
  }
  ASSERT_EQ(cuts.size(), 2u);
  // The avalanche after each fallback kick is the exits up to the next clog, as for any unclog.
  std::vector<double> expected(3, 0.0);
  for (const rundir::ExitEvent& e : o.events)
    expected[static_cast<std::size_t>(std::upper_bound(cuts.begin(), cuts.end(), e.time) - cuts.begin())] += 1;
  EXPECT_EQ(expected[0], 0.0);  // the bed never flowed before its first stall
  EXPECT_GT(expected[1], 0.0);
  EXPECT_GT(expected[2], 0.0);
  const std::map<std::string, nlohmann::json> a = Analyse(dir);
  EXPECT_EQ(a.at("avalanches")["sizes"].get<std::vector<double>>(), expected);
  EXPECT_EQ(a.at("avalanches")["clogs"].get<int>(), 3);
  EXPECT_EQ(a.at("avalanches")["unclogs"].get<int>(), 2);
  // The arches analysis sees the three clogs, none of them with an arch.
  ASSERT_EQ(a.at("arches")["clogs"].size(), 3u);
  const nlohmann::json spec = ReadJson(dir / rundir::kRunSpecFile);
  for (const rundir::ClogState& c : o.clogs) EXPECT_TRUE(analysis::AnalyseClog(c, spec).arches.empty());
}

// The fallback's kicks draw the kicks' random numbers: the same bits at 1 and 2 threads and
// after a kill after a fallback kick and a continue.
TEST(Unclog, AKickFallbackGivesTheSameBitsAtAnyThreadCountAndAfterAContinue) {
  const fs::path one = FreshDir("unclog-no-arch-1"), two = FreshDir("unclog-no-arch-2"),
                 cont = FreshDir("unclog-no-arch-c");
  // To the second clog (t = 28.4): short, since forced parallel loops at two threads are slow
  // when the suite runs two tests on two cores.
  for (const fs::path& d : {one, two, cont}) {
    nlohmann::json spec = NoArchSpec(d, "kick");
    spec["discharge"]["unclog"]["max_clogs"] = 2;
    WriteSpec(d, spec);
  }
  EXPECT_EQ(RunQuiet(one, 1, -1, 32).end_reason, "max_clogs");
  RunQuiet(two, 2, -1, 32);
  const Outcome o = Read(one);
  ASSERT_EQ(o.unclogs.size(), 1u);
  ASSERT_EQ(o.unclogs[0].method, "kick");
  // Killed after the fallback kick, past a checkpoint (every 2 time units).
  const std::int64_t kill_at = o.unclogs[0].step + 25000;
  EXPECT_EQ(RunQuiet(cont, 1, kill_at, 32).end_reason, "aborted");
  EXPECT_TRUE(RunQuiet(cont, 1, -1, 32).continued);
  for (const fs::path& d : {two, cont}) ExpectSameClogOutputs(one, d);
}

// A run that ended at max_clogs on a clog with no arch, planned again with a larger max_clogs,
// continues with the fallback kick a run planned with the larger limit gives there (the arch is
// looked for again from the checkpoint's bodies: none, as at the clog).
TEST(Unclog, ARaisedMaxClogsContinuesFromAClogWithNoArchWithTheFallbackKick) {
  const fs::path extended = FreshDir("unclog-no-arch-extend"), fresh = FreshDir("unclog-no-arch-extend-fresh");
  nlohmann::json spec = NoArchSpec(extended, "kick");
  spec["discharge"]["unclog"]["max_clogs"] = 1;
  WriteSpec(extended, spec);
  ASSERT_EQ(RunQuiet(extended).end_reason, "max_clogs");
  spec["discharge"]["unclog"]["max_clogs"] = 3;
  WriteSpec(fresh, spec);
  ASSERT_EQ(RunQuiet(fresh).end_reason, "max_clogs");
  WriteSpec(extended, spec);
  fs::remove(extended / rundir::kDoneFile);
  const RunResult r = RunQuiet(extended);
  EXPECT_TRUE(r.continued);
  EXPECT_EQ(r.end_reason, "max_clogs");
  const Outcome o = Read(extended);
  ASSERT_FALSE(o.unclogs.empty());
  EXPECT_EQ(o.unclogs.front().method, "kick");
  ExpectSameClogOutputs(fresh, extended);
}

TEST(Unclog, KicksGiveTheSameBitsAtAnyThreadCountAndAfterAContinue) { ExpectSameBits("kick"); }
TEST(Unclog, ArchRemovalsGiveTheSameBitsAtAnyThreadCountAndAfterAContinue) { ExpectSameBits("remove_arch"); }

}  // namespace
}  // namespace granary::engine
