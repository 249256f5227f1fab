// The single pass over a run directory with every registered analysis: region and profiles
// beside a side outlet, the frame window without a steady flow, notes, frames parsed once and
// handed to every analysis that asked, read-ahead on a second thread with the same results,
// and the cache (a changed option re-analyses only its analysis; a run run again, all).
#include "analysis/run_pass.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <string>

#include "analysis/registry.h"
#include "rundir/analysis_cache.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::TempDir;
using testing::WriteFile;

const nlohmann::json kSpec = {
    {"silo",
     {{"width", 100},
      {"base_outlets", {{{"center", -20.0}, {"width", 8.0}}}},
      {"side_outlets",
       {{{"wall", "right"}, {"bottom", 3.5}, {"width", 25.0}}, {{"wall", "left"}, {"bottom", 0.0}, {"width", 10.0}}}}}},
    {"discharge", {{"mode", "reinject"}, {"clog_window", 3.0}}},
    {"bodies", {{"count", 10}}}};

// Every metric of every analysis of one pass, by name.
std::map<std::string, Metric> MetricsOf(const AnalysisSetup& setup, const RunPassResult& pass) {
  std::map<std::string, Metric> out;
  for (std::size_t k = 0; k < setup.analyses.size(); ++k)
    for (const Metric& m : setup.analyses[k]->RunMetrics(pass.results[k])) out[m.name] = m;
  return out;
}

RunPassOptions NoCache() {
  RunPassOptions o;
  o.read_cache = o.write_cache = false;
  return o;
}

TEST(RunPass, RegionBesideASideOutlet) {
  TempDir dir;
  WriteFile(dir.Path() / "run.json", kSpec.dump());
  WriteFile(dir.Path() / "summary.json", R"({"engine":"native","bodies":10,"exited":0,"remaining":10,"t_end":10})");
  WriteFile(dir.Path() / "events.csv", "time,body,shape,mass,outlet\n");
  // One disc (r = 1) against the right wall next to the side outlet, one next to the base
  // outlet, moving out of each.
  WriteFile(dir.Path() / "frames.dump",
            "ITEM: TIMESTEP\n30000\nITEM: TIME\n3.0\nITEM: NUMBER OF ATOMS\n2\n"
            "ITEM: ATOMS id mol x y radius vx vy omegaz\n"
            "1 0 48.5 16 1 3 0 0\n"
            "2 1 -20 1.5 1 0 -4 0\n");
  const AnalysisSetup setup = SetupAnalyses(nlohmann::json::object());
  const RunPassResult r = AnalyseRun(dir.Path(), setup.List(), setup.pass, NoCache());
  EXPECT_EQ(r.frames_parsed, 1);
  auto m = MetricsOf(setup, r);
  // ch. 4 region of W = 25 beside the right wall: (25 + 2 sqrt2) x 5 sqrt2, holds the whole disc.
  const double area_side = (25.0 + 2.0 * std::numbers::sqrt2) * 5.0 * std::numbers::sqrt2;
  EXPECT_NEAR(m["phi_outlet1"].value, std::numbers::pi / area_side, 1e-12);
  const double area_base = (8.0 + 2.0 * std::numbers::sqrt2) * 5.0 * std::numbers::sqrt2;
  EXPECT_NEAR(m["phi"].value, std::numbers::pi / area_base, 1e-12);
  EXPECT_NEAR(m["phi_outlet2"].value, 0.0, 1e-15);
  EXPECT_DOUBLE_EQ(m["v_max_outlet1"].value, 3.0);  // |v_n| of the disc leaving sideways
  EXPECT_DOUBLE_EQ(m["v_max"].value, 4.0);
  EXPECT_TRUE(std::isnan(m["q_count"].value));  // no exits: no flow rate
  EXPECT_EQ(m.count("clogged"), 0u);            // reinject mode: no clogging index
}

// A run of 10 bodies (on_clog "stop" by default) with 5 exits, then a clog from t = 2.5 to its
// end at t = 20; frames at t = 2.2 (flowing) and t = 15 (clogged).
void WriteRunThatClogsAfterFiveExits(const std::filesystem::path& dir) {
  WriteFile(dir / "run.json", kSpec.dump());
  WriteFile(dir / "summary.json",
            R"({"bodies":10,"exited":5,"remaining":10,"t_end":20,"end_reason":"time_limit","clogs":1})");
  WriteFile(
      dir / "events.csv",
      "time,body,shape,mass,outlet\n2.1,0,disc,1,0\n2.2,1,disc,1,0\n2.3,2,disc,1,0\n2.4,3,disc,1,0\n2.5,4,disc,1,0\n");
  std::string frames;
  for (double t : {2.2, 15.0})
    frames += "ITEM: TIMESTEP\n1\nITEM: TIME\n" + std::to_string(t) +
              "\nITEM: NUMBER OF ATOMS\n1\nITEM: ATOMS id mol x y radius vx vy omegaz\n1 0 -20 1 0.5 0 -1 0\n";
  WriteFile(dir / "frames.dump", frames);
}

TEST(RunPass, WithoutAFlowWindowFramesStopAtTheFirstClog) {
  // 5 exits (too few for a flow rate), then a clog from t = 2.5 on; frames at t = 2.2
  // (flowing) and t = 15 (clogged): only the first may enter the region statistics, and the
  // pass stops reading after it. (min_exits_before_clog 3: the clog is not a start-up clog.)
  TempDir dir;
  WriteRunThatClogsAfterFiveExits(dir.Path());
  const AnalysisSetup setup =
      SetupAnalyses({{"report", {{"window", {{"start_time", 1.0}, {"min_exits_before_clog", 3}}}}}});
  const RunPassResult r = AnalyseRun(dir.Path(), setup.List(), setup.pass, NoCache());
  EXPECT_EQ(r.frames_parsed, 1);
  auto m = MetricsOf(setup, r);
  EXPECT_TRUE(std::isnan(m["q_count"].value));
  EXPECT_EQ(m["clogs"].value, 1.0);  // in the exit stream
  // The clogged state an analysis of arches would ask for: from the last exit to the end.
  const rundir::RunData data = rundir::ReadRun(dir.Path());
  const RunView view = MakeRunView(data, setup.pass);
  ASSERT_EQ(view.clogged.size(), 1u);
  EXPECT_DOUBLE_EQ(view.clogged[0].start, 2.5);
  EXPECT_DOUBLE_EQ(view.clogged[0].end, 20.0);
  EXPECT_DOUBLE_EQ(view.steady.start, 1.0);
  EXPECT_DOUBLE_EQ(view.steady.end, 2.5);
  for (std::size_t k = 0; k < setup.analyses.size(); ++k) {
    if (setup.analyses[k]->Key() == "region") {
      ASSERT_TRUE(r.results[k].contains("regions"));
      EXPECT_EQ(r.results[k]["regions"][0]["frames"], 1);
    }
  }
}

TEST(RunPass, AStartUpClogGivesNoFramesOfSteadyFlow) {
  // The same run under the default rule (100 exits before a first clog): its 5 exits are a
  // start-up clog, so no frame is steady flow and the region analysis says why.
  TempDir dir;
  WriteRunThatClogsAfterFiveExits(dir.Path());
  const AnalysisSetup setup = SetupAnalyses({{"report", {{"window", {{"start_time", 1.0}}}}}});
  const RunPassResult r = AnalyseRun(dir.Path(), setup.List(), setup.pass, NoCache());
  EXPECT_EQ(r.frames_parsed, 0);
  const rundir::RunData data = rundir::ReadRun(dir.Path());
  const RunView view = MakeRunView(data, setup.pass);
  EXPECT_TRUE(view.flow.startup_clog);
  EXPECT_FALSE(view.steady.Contains(2.2));
  ASSERT_EQ(view.clogged.size(), 1u);  // the clog itself is still a clogged state
  bool noted = false;
  for (std::size_t k = 0; k < setup.analyses.size(); ++k) {
    if (setup.analyses[k]->Key() != "region") continue;
    ASSERT_TRUE(r.results[k].contains("notes"));
    for (const auto& note : r.results[k]["notes"])
      noted = noted || note.get<std::string>().find("start-up clog") != std::string::npos;
  }
  EXPECT_TRUE(noted);
}

TEST(RunPass, SummaryAndEventsDisagree) {
  TempDir dir;
  WriteFile(dir.Path() / "summary.json",
            R"({"bodies":10,"exited":5,"remaining":5,"t_end":3,"end_reason":"time_limit"})");
  WriteFile(dir.Path() / "events.csv", "time,body,shape,mass,outlet\n1,0,disc,1,0\n2,1,disc,1,0\n2.5,2,disc,1,0\n");
  const AnalysisSetup setup = SetupAnalyses(nlohmann::json::object());
  const RunPassResult r = AnalyseRun(dir.Path(), setup.List(), setup.pass, NoCache());
  const nlohmann::json& flow = r.results[0];
  ASSERT_EQ(setup.analyses[0]->Key(), "flow");
  bool found = false;
  for (const auto& n : flow["notes"]) found = found || n == "events.csv has 3 exits but summary.json says 5";
  EXPECT_TRUE(found) << flow["notes"].dump();
  EXPECT_EQ(flow["cumulative"]["n"], (nlohmann::json{1, 2, 3}));
  auto m = MetricsOf(setup, r);
  EXPECT_EQ(m["clogged"].value, 0.0);  // remove mode (the run-spec default without run.json)
  EXPECT_EQ(m["undischarged"].value, 5.0);
}

// A run of `frames` frames of one disc at t = 1, 2, ..., with contact frames at every other step.
void WriteFrameRun(const std::filesystem::path& dir, int frames) {
  WriteFile(dir / "run.json", R"({"discharge":{"mode":"reinject"},"bodies":{"count":1}})");
  WriteFile(dir / "summary.json", R"({"bodies":1,"exited":0,"remaining":1,"t_end":100,"end_reason":"time_limit"})");
  WriteFile(dir / "events.csv", "time,body,shape,mass,outlet\n");
  std::string f, c;
  for (int k = 1; k <= frames; ++k) {
    const std::string step = std::to_string(1000 * k);
    f += "ITEM: TIMESTEP\n" + step + "\nITEM: TIME\n" + std::to_string(k) + "\nITEM: NUMBER OF ATOMS\n1\n" +
         "ITEM: ATOMS id mol x y radius vx vy omegaz\n1 0 0 " + std::to_string(k) + " 0.5 0 -1 0\n";
    if (k % 2 == 0)
      c += "ITEM: TIMESTEP\n" + step + "\nITEM: TIME\n" + std::to_string(k) + "\nITEM: NUMBER OF ENTRIES\n1\n" +
           "ITEM: ENTRIES body_i body_j xi yi xj yj cx cy fx fy\n0 -1 0 0 0 0 0 0 0 " + std::to_string(k) + "\n";
  }
  WriteFile(dir / "frames.dump", f);
  WriteFile(dir / "contacts.dump", c);
}

// An analysis that records the frames (time, y of the disc, contact force) it is handed.
class Recorder : public Analysis {
 public:
  Recorder(std::string key, std::vector<TimeWindow> windows, bool contacts)
      : key_(std::move(key)), windows_(std::move(windows)), contacts_(contacts) {}
  std::string Key() const override { return key_; }
  int Version() const override { return 1; }
  PassUse PassOptionsUsed() const override { return {.window = false, .clog_gap = false, .frames = true}; }
  std::unique_ptr<RunAccumulator> Start(const RunView&) const override {
    class Acc : public RunAccumulator {
     public:
      Acc(const Recorder& r) : r_(r) {}
      FrameRequest Frames() const override { return {r_.windows_, r_.contacts_}; }
      void AddFrame(const FrameView& f) override {
        ASSERT_EQ(f.bodies.size(), 1u);
        seen_.push_back({f.frame.time, f.frame.discs.at(0).y, f.contacts ? f.contacts->contacts.at(0).fy : -1.0});
      }
      nlohmann::json Finish() override { return seen_; }

     private:
      const Recorder& r_;
      nlohmann::json seen_ = nlohmann::json::array();
    };
    return std::make_unique<Acc>(*this);
  }
  std::vector<Metric> RunMetrics(const nlohmann::json& r) const override {
    return {{"frames_seen", "1", static_cast<double>(r.size()), kNaN, "", false}};
  }

 private:
  std::string key_;
  std::vector<TimeWindow> windows_;
  bool contacts_;
};

TEST(RunPass, EachAnalysisGetsItsWindowsFromOneReadingAtAnyThreadCount) {
  TempDir dir;
  WriteFrameRun(dir.Path(), 12);
  const Recorder early("early", {{0.0, 3.5}}, false), late("late", {{6.0, 9.0}, {11.0, 11.0}}, true);
  PassOptions pass;
  for (int threads : {1, 2}) {
    RunPassOptions o = NoCache();
    o.threads = threads;
    const RunPassResult r = AnalyseRun(dir.Path(), {&early, &late}, pass, o);
    EXPECT_EQ(r.results[0], (nlohmann::json{{1.0, 1.0, -1.0}, {2.0, 2.0, -1.0}, {3.0, 3.0, -1.0}})) << threads;
    // Contact frames exist at even steps only; the late one stops after t = 11.
    EXPECT_EQ(
        r.results[1],
        (nlohmann::json{{6.0, 6.0, 6.0}, {7.0, 7.0, -1.0}, {8.0, 8.0, 8.0}, {9.0, 9.0, -1.0}, {11.0, 11.0, -1.0}}))
        << threads;
    EXPECT_EQ(r.frames_parsed, 8) << threads;  // frames 1-3, 6-9 and 11; 4, 5, 10 and 12 skipped unparsed
  }
  pass.frame_stride = 2;
  pass.max_frames = 2;
  const RunPassResult r = AnalyseRun(dir.Path(), {&early, &late}, pass, NoCache());
  EXPECT_EQ(r.results[0], (nlohmann::json{{1.0, 1.0, -1.0}, {3.0, 3.0, -1.0}}));
  EXPECT_EQ(r.results[1], (nlohmann::json{{6.0, 6.0, 6.0}, {8.0, 8.0, 8.0}}));
}

TEST(RunPass, ResultsAreCachedAndAChangedOptionReanalysesOnlyItsAnalysis) {
  TempDir dir;
  WriteFrameRun(dir.Path(), 6);
  AnalysisSetup setup = SetupAnalyses(nlohmann::json::object());
  const RunPassResult cold = AnalyseRun(dir.Path(), setup.List(), setup.pass);
  EXPECT_EQ(cold.from_cache, 0);
  EXPECT_TRUE(std::filesystem::exists(dir.Path() / "analyses" / "flow.json"));
  const RunPassResult warm = AnalyseRun(dir.Path(), setup.List(), setup.pass);
  EXPECT_EQ(warm.from_cache, static_cast<int>(setup.analyses.size()));
  EXPECT_EQ(warm.frames_parsed, 0);
  EXPECT_EQ(warm.results, cold.results);
  // Another region size: only the region analysis runs again (and reads the frames).
  setup = SetupAnalyses({{"report", {{"region", "ch3"}}}});
  const RunPassResult region = AnalyseRun(dir.Path(), setup.List(), setup.pass);
  EXPECT_EQ(region.from_cache, static_cast<int>(setup.analyses.size()) - 1);
  // A window option changes the steady window: every analysis that uses it runs again.
  setup = SetupAnalyses({{"report", {{"window", {{"start_time", 0.5}}}}}});
  const RunPassResult window = AnalyseRun(dir.Path(), setup.List(), setup.pass);
  // The clogging index, avalanches, intermittency, arches and contacts do not use it.
  EXPECT_EQ(window.from_cache, 5);
  // The run run again (a new summary.json): nothing of the cache is used.
  WriteFile(dir.Path() / "summary.json",
            R"({"bodies":1,"exited":0,"remaining":1,"t_end":101,"end_reason":"time_limit"})");
  EXPECT_EQ(AnalyseRun(dir.Path(), setup.List(), setup.pass).from_cache, 0);
}

}  // namespace
}  // namespace granary::analysis
