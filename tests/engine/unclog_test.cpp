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
  for (const fs::path& d : {two, cont}) {
    SCOPED_TRACE(d.filename().string());
    for (const char* f :
         {rundir::kEventsFile, rundir::kUnclogsFile, rundir::kClogFramesFile, rundir::kClogContactsFile})
      EXPECT_TRUE(Slurp(one / f) == Slurp(d / f)) << f;
    EXPECT_EQ(ReadJson(one / rundir::kSummaryFile)["t_end"], ReadJson(d / rundir::kSummaryFile)["t_end"]);
  }
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

TEST(Unclog, KicksGiveTheSameBitsAtAnyThreadCountAndAfterAContinue) { ExpectSameBits("kick"); }
TEST(Unclog, ArchRemovalsGiveTheSameBitsAtAnyThreadCountAndAfterAContinue) { ExpectSameBits("remove_arch"); }

}  // namespace
}  // namespace granary::engine
