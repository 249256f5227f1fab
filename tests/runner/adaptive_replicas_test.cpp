// Adaptive replicas end to end (docs/campaign-spec.md "Replicas"): the real `campaign` with
// the fake engine, whose flow rate differs between replicas by a known amount
// (/discharge/max_time 21; fake_engine.cpp), and the real analyses. The runner stops each
// point at its target (or at max), a re-plan keeps what it added, status and the report show
// it, and kill -9 of the runner while it adds replicas loses and repeats nothing.
#include <signal.h>
#include <sys/wait.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "rundir/replica_rule.h"
#include "test_util.h"

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::CountLines;
using testing::ReadFile;
using testing::Sh;

class AdaptiveReplicas : public ::testing::Test {
 protected:
  void SetUp() override {
#ifndef GRANARY_HAVE_ANALYSIS
    GTEST_SKIP() << "built without the analysis library: no metrics to judge";
#endif
    dir_ = testing::MakeTempDir();
    unsetenv("FAKE_ENGINE_FIRST_LAUNCH_STEP_MS");
    unsetenv("GRANARY_LEASE_SECONDS");
    unsetenv("GRANARY_TEST_HOLD_REPLICAS");
    setenv("GRANARY_CACHE_DIR", (dir_ / "beds").c_str(), 1);
    setenv("FAKE_ENGINE_STEPS", "10", 1);
    setenv("FAKE_ENGINE_STEP_MS", "5", 1);
  }
  void TearDown() override {
    unsetenv("GRANARY_TEST_HOLD_REPLICAS");
    for (const pid_t pid : spawned_) kill(pid, SIGKILL);
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  // Two points: max_time 20 (every replica the same flow rate: se 0, met at min) and 21 (the
  // rate differs by seed).
  std::string WriteSpec(const fs::path& folder, const json& replicas) const {
    fs::create_directories(folder);
    const fs::path p = folder / "c.json";
    std::ofstream(p) << json{{"name", "adaptive"},
                             {"seed", 3},
                             {"replicas", replicas},
                             {"base", {{"bodies", {{"count", 100}}}, {"silo", {{"width", 30}}}}},
                             {"sweep", {{"grid", {{"/discharge/max_time", {20, 21}}}}}},
                             // the fake engine's 10 exits are all steady flow
                             {"report", {{"window", {{"min_events", 4}, {"start_time", 0}, {"start_fraction", 0}}}}}};
    return p.string();
  }
  static std::string Cmd(const fs::path& db, const std::string& verb) {
    return testing::Campaign() + " " + verb + " --db " + db.string();
  }
  static json Status(const fs::path& db) {
    const auto r = Sh(Cmd(db, "status --json") + " 2>/dev/null");
    EXPECT_EQ(r.code, 0) << r.output;
    return json::parse(r.output);
  }
  // Replica progress of the point with this max_time.
  static json PointOf(const json& status, int max_time) {
    for (const json& p : status["replicas"]["points"])
      if (p["point"]["/discharge/max_time"] == max_time) return p;
    return json();
  }
  static std::set<std::string> RunIds(const json& status) {
    std::set<std::string> ids;
    for (const json& r : status["runs"])
      if (r["state"] != "retired") ids.insert(r["run_id"].get<std::string>());
    return ids;
  }
  pid_t Spawn(const std::vector<std::string>& argv, const std::string& log) {
    spawned_.push_back(testing::Spawn(argv, log));
    return spawned_.back();
  }
  fs::path dir_;
  std::vector<pid_t> spawned_;
};

const json kRule = json::parse(R"({"min": 2, "max": 12, "until": {"metric": "q_count", "rel_se": 0.08}})");

TEST_F(AdaptiveReplicas, StopAtTheTargetAndAPlanKeepsWhatWasAdded) {
  const fs::path db = dir_ / "a" / "g.db";
  const std::string spec = WriteSpec(dir_ / "a", kRule);
  const auto plan = Sh(Cmd(db, "plan " + spec));
  ASSERT_EQ(plan.code, 0) << plan.output;
  EXPECT_NE(
      plan.output.find("adaptive replicas: 2 replicas per point, then more until se/|q_count| <= 0.08, at most 12"),
      std::string::npos)
      << plan.output;
  const auto run = Sh(Cmd(db, "run --jobs 2 --engine " + testing::FakeEngine()));
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("more planned"), std::string::npos) << run.output;

  const json s = Status(db);
  ASSERT_TRUE(s.contains("replicas")) << s.dump();
  const json same = PointOf(s, 20), spread = PointOf(s, 21);
  // Every replica alike: se 0 after min, no more.
  EXPECT_EQ(same["runs"], 2) << same.dump();
  EXPECT_EQ(same["verdict"], "met") << same.dump();
  // The spread point grew, and stopped where the rule says: met, or at max.
  EXPECT_GT(spread["runs"].get<int>(), 2) << spread.dump();
  EXPECT_LE(spread["runs"].get<int>(), 12);
  EXPECT_EQ(spread["done"], spread["runs"]);
  const json& t = spread["targets"][0];
  EXPECT_EQ(t["metric"], "q_count");
  ReplicaRule rule = ReplicaRule::FromJson(kRule);
  PointReplicas final_state{spread["runs"].get<int>(),
                            0,
                            {{"q_count", {t["value"].get<double>(), t["se"].get<double>(), t["n"].get<int>()}}}};
  const ReplicaDecision d = DecideReplicas(rule, final_state);
  EXPECT_TRUE(d.verdict == ReplicaVerdict::kMet || d.verdict == ReplicaVerdict::kAtMax) << ToString(d.verdict);
  EXPECT_EQ(spread["verdict"], ToString(d.verdict));
  const int runs = static_cast<int>(RunIds(s).size());
  EXPECT_EQ(runs, 2 + spread["runs"].get<int>());

  // Each run ran once.
  for (const json& r : s["runs"]) {
    const std::string launches = ReadFile(fs::path(r["run_dir"].get<std::string>()) / "launches.txt");
    EXPECT_EQ(CountLines(launches, "finish"), 1) << launches;
  }
  // The same plan again keeps the added replicas (idempotent), and a second run adds nothing.
  const auto again = Sh(Cmd(db, "plan " + spec + " --json") + " 2>/dev/null");
  ASSERT_EQ(again.code, 0) << again.output;
  const json j = json::parse(again.output);
  EXPECT_EQ(j["runs"], runs);
  EXPECT_EQ(j["added"], 0);
  EXPECT_EQ(j["retired"], 0);
  EXPECT_EQ(Sh(Cmd(db, "run --engine " + testing::FakeEngine())).code, 0);
  EXPECT_EQ(RunIds(Status(db)), RunIds(s));

  // The report states the rule and the verdict per point.
  const auto report = Sh(Cmd(db, "report --no-figures"));
  ASSERT_EQ(report.code, 0) << report.output;
  const std::string md = ReadFile(db.parent_path() / "report" / "report.md");
  EXPECT_NE(
      md.find("Replicas were added adaptively: 2 replicas per point, then more until se/|q_count| <= 0.08, at most 12"),
      std::string::npos);
  EXPECT_NE(md.find("Adaptive replicas per point"), std::string::npos);
}

TEST_F(AdaptiveReplicas, APointAtMaxIsMarked) {
  const fs::path db = dir_ / "m" / "g.db";
  ASSERT_EQ(
      Sh(Cmd(db, "plan " +
                     WriteSpec(dir_ / "m",
                               json::parse(R"({"min": 2, "max": 3, "until": {"metric": "q_count", "rel_se": 1e-6}})"))))
          .code,
      0);
  const auto run = Sh(Cmd(db, "run --jobs 2 --engine " + testing::FakeEngine()));
  ASSERT_EQ(run.code, 0) << run.output;
  const json spread = PointOf(Status(db), 21);
  EXPECT_EQ(spread["runs"], 3) << spread.dump();
  EXPECT_EQ(spread["verdict"], "at max") << spread.dump();
  EXPECT_NE(run.output.find("at max (3) without reaching the target"), std::string::npos) << run.output;
  const auto text = Sh(Cmd(db, "status"));
  EXPECT_NE(text.output.find("AT MAX without reaching the target"), std::string::npos) << text.output;
  ASSERT_EQ(Sh(Cmd(db, "report --no-figures")).code, 0);
  EXPECT_NE(ReadFile(db.parent_path() / "report" / "report.md").find("max reached, target not met"), std::string::npos);

  // A name that is no metric at all: refused by the plan, naming the path.
  const fs::path db0 = dir_ / "n" / "g.db";
  const auto refused = Sh(
      Cmd(db0,
          "plan " + WriteSpec(dir_ / "n",
                              json::parse(R"({"min": 2, "max": 9, "until": {"metric": "no_such_metric", "se": 1}})"))));
  EXPECT_EQ(refused.code, 2) << refused.output;
  EXPECT_NE(refused.output.find("/replicas/until/metric: \"no_such_metric\" names no metric"), std::string::npos)
      << refused.output;
  // A metric of the analyses that no run of this campaign returns (a third outlet's): said at
  // run time, and nothing added.
  const fs::path db2 = dir_ / "u" / "g.db";
  ASSERT_EQ(
      Sh(Cmd(db2,
             "plan " +
                 WriteSpec(
                     dir_ / "u",
                     json::parse(R"({"min": 2, "max": 9, "until": {"metric": "avalanche_size_outlet3", "se": 1}})"))))
          .code,
      0);
  const auto r2 = Sh(Cmd(db2, "run --jobs 2 --engine " + testing::FakeEngine()));
  EXPECT_EQ(r2.code, 0) << r2.output;
  EXPECT_NE(r2.output.find("se(avalanche_size_outlet3) = not a metric of this campaign"), std::string::npos)
      << r2.output;
  EXPECT_EQ(RunIds(Status(db2)).size(), 4u);
}

// kill -9 of the runner after it decided which replicas to add and before it wrote them, twice;
// then a runner to the end: the same runs as a campaign never killed, each finished once.
TEST_F(AdaptiveReplicas, KillMinusNineWhileAddingLosesAndRepeatsNothing) {
  const fs::path control = dir_ / "control" / "g.db";
  ASSERT_EQ(Sh(Cmd(control, "plan " + WriteSpec(dir_ / "control", kRule))).code, 0);
  ASSERT_EQ(Sh(Cmd(control, "run --jobs 2 --engine " + testing::FakeEngine())).code, 0);
  const std::set<std::string> expected = RunIds(Status(control));
  ASSERT_GT(expected.size(), 4u);

  const fs::path db = dir_ / "killed" / "g.db";
  ASSERT_EQ(Sh(Cmd(db, "plan " + WriteSpec(dir_ / "killed", kRule))).code, 0);
  for (int k = 0; k < 2; ++k) {
    const fs::path hold = dir_ / ("hold" + std::to_string(k));
    setenv("GRANARY_TEST_HOLD_REPLICAS", hold.c_str(), 1);
    const std::string log = (dir_ / ("runner" + std::to_string(k) + ".log")).string();
    const pid_t runner =
        Spawn({testing::Campaign(), "run", "--db", db.string(), "--jobs", "2", "--engine", testing::FakeEngine()}, log);
    ASSERT_TRUE(testing::WaitFor([&] { return fs::exists(hold.string() + ".reached"); }, 120)) << ReadFile(log);
    kill(runner, SIGKILL);
    EXPECT_EQ(testing::WaitExit(runner), 128 + SIGKILL);
  }
  unsetenv("GRANARY_TEST_HOLD_REPLICAS");
  const auto last = Sh(Cmd(db, "run --jobs 2 --engine " + testing::FakeEngine()));
  ASSERT_EQ(last.code, 0) << last.output;
  const json s = Status(db);
  EXPECT_EQ(RunIds(s), expected);
  for (const json& r : s["runs"]) {
    EXPECT_EQ(r["state"], "done");
    const std::string launches = ReadFile(fs::path(r["run_dir"].get<std::string>()) / "launches.txt");
    EXPECT_EQ(CountLines(launches, "finish"), 1) << r["run_dir"] << "\n" << launches;
  }
}

// The same on a tiny real campaign: granary-engine's unclog protocol (remove_arch, at most 3
// clogs per run) in a silo of 200 discs 16 d wide, and the avalanche statistics of the real
// analyses. Over an outlet of 3 d the runs clog, so each adds avalanches and the point meets a
// loose target (se/<s> <= 0.5); over 8 d the discs drain without a clog (the clogging
// probability of discs at W/d = 8 is negligible): no avalanche, no se, so the point asks for one
// more run each time until max, where it is marked. The campaign is then planned again in a
// second directory and its runner killed -9 twice after it decided which replicas to add and
// before it wrote them: the last runner ends with the same runs, each run once, with the same
// exits, as the campaign never killed.
TEST_F(AdaptiveReplicas, ARealUnclogCampaignStopsAtItsTargetOrAtMaxAndAKillLosesNothing) {
  const std::string engine = testing::BinDir() + "/granary-engine";
  if (!fs::exists(engine)) GTEST_SKIP() << "granary-engine not built";
  const json rule = json::parse(R"({"min": 2, "max": 4, "until": {"metric": "avalanche_size", "rel_se": 0.5}})");
  const auto write_spec = [&](const fs::path& folder) {
    fs::create_directories(folder);
    const fs::path p = folder / "c.json";
    std::ofstream(p) << json{{"name", "adaptive-real"},
                             {"seed", 3},
                             {"replicas", rule},
                             {"base",
                              {{"bodies", {{"count", 200}, {"species", {{{"shape", "disc"}}}}}},
                               {"silo", {{"width", 16}, {"base_outlets", {{{"center", 0}, {"width", 3}}}}}},
                               {"bed", {{"batch_size", 200}, {"settle_ke_per_body", 1e-4}, {"max_settle_time", 10}}},
                               {"discharge",
                                {{"mode", "remove"},
                                 {"max_time", 30},
                                 {"clog_window", 2},
                                 {"on_clog", "unclog"},
                                 {"unclog", {{"method", "remove_arch"}, {"max_clogs", 3}}}}},
                               {"output", {{"checkpoint_interval", 2}, {"frame_interval", 0}}}}},
                             {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {3, 8}}}}}}};
    return p.string();
  };
  const auto point_of = [](const json& status, int width) {
    for (const json& p : status["replicas"]["points"])
      if (p["point"]["/silo/base_outlets/0/width"] == width) return p;
    return json();
  };
  // One engine at a time: the test stays on one core (both campaigns share the prepared beds).
  const fs::path control = dir_ / "control" / "g.db";
  ASSERT_EQ(Sh(Cmd(control, "plan " + write_spec(dir_ / "control"))).code, 0);
  const auto run = Sh(Cmd(control, "run --jobs 1"));
  ASSERT_EQ(run.code, 0) << run.output;
  const json s = Status(control);
  const json clogging = point_of(s, 3), draining = point_of(s, 8);
  ASSERT_FALSE(clogging.is_null() || draining.is_null()) << s.dump();
  // The clogging point stopped at its target, as decide_replicas judges its final state.
  EXPECT_EQ(clogging["verdict"], "met") << clogging.dump();
  EXPECT_GE(clogging["runs"].get<int>(), 2);
  EXPECT_LE(clogging["runs"].get<int>(), 4);
  const json& t = clogging["targets"][0];
  EXPECT_EQ(t["metric"], "avalanche_size");
  EXPECT_LE(t["achieved"].get<double>(), 0.5);
  const PointReplicas state{clogging["runs"].get<int>(),
                            0,
                            {{"avalanche_size", {t["value"].get<double>(), t["se"].get<double>(), t["n"].get<int>()}}}};
  EXPECT_EQ(ToString(DecideReplicas(ReplicaRule::FromJson(rule), state).verdict), std::string("met"));
  // The runner said so when it stopped adding.
  EXPECT_NE(run.output.find("width=3: se/|avalanche_size| = "), std::string::npos) << run.output;
  EXPECT_NE(
      run.output.find("(target 0.5, met) after " + std::to_string(clogging["runs"].get<int>()) + " runs: target met"),
      std::string::npos)
      << run.output;
  // The draining point: no avalanche, so it ran to max and is marked there.
  EXPECT_EQ(draining["runs"], 4) << draining.dump();
  EXPECT_EQ(draining["verdict"], "at max") << draining.dump();
  EXPECT_EQ(draining["targets"][0]["n"], 0) << draining.dump();
  EXPECT_NE(run.output.find(
                "width=8: se/|avalanche_size| = n/a (target 0.5) after 4 runs: at max (4) without reaching the target"),
            std::string::npos)
      << run.output;
  EXPECT_NE(Sh(Cmd(control, "status")).output.find("AT MAX without reaching the target"), std::string::npos);
  ASSERT_EQ(Sh(Cmd(control, "report --no-figures")).code, 0);
  EXPECT_NE(ReadFile(control.parent_path() / "report" / "report.md").find("max reached, target not met"),
            std::string::npos);
  const std::set<std::string> expected = RunIds(s);
  EXPECT_EQ(static_cast<int>(expected.size()), clogging["runs"].get<int>() + 4);
  std::map<std::string, std::string> exits;  // run id -> events.csv
  for (const json& r : s["runs"]) {
    EXPECT_EQ(r["state"], "done");
    EXPECT_EQ(r["attempts"], 1) << r.dump();
    exits[r["run_id"]] = ReadFile(fs::path(r["run_dir"].get<std::string>()) / "events.csv");
  }

  const fs::path db = dir_ / "killed" / "g.db";
  ASSERT_EQ(Sh(Cmd(db, "plan " + write_spec(dir_ / "killed"))).code, 0);
  for (int k = 0; k < 2; ++k) {
    const fs::path hold = dir_ / ("hold" + std::to_string(k));
    setenv("GRANARY_TEST_HOLD_REPLICAS", hold.c_str(), 1);
    const std::string log = (dir_ / ("runner" + std::to_string(k) + ".log")).string();
    const pid_t runner = Spawn({testing::Campaign(), "run", "--db", db.string(), "--jobs", "1"}, log);
    ASSERT_TRUE(testing::WaitFor([&] { return fs::exists(hold.string() + ".reached"); }, 600)) << ReadFile(log);
    kill(runner, SIGKILL);
    EXPECT_EQ(testing::WaitExit(runner), 128 + SIGKILL);
  }
  unsetenv("GRANARY_TEST_HOLD_REPLICAS");
  const auto last = Sh(Cmd(db, "run --jobs 1"));
  ASSERT_EQ(last.code, 0) << last.output;
  const json k = Status(db);
  EXPECT_EQ(RunIds(k), expected);
  for (const json& r : k["runs"]) {
    EXPECT_EQ(r["state"], "done");
    EXPECT_EQ(r["attempts"], 1) << r.dump();
    EXPECT_TRUE(ReadFile(fs::path(r["run_dir"].get<std::string>()) / "events.csv") == exits[r["run_id"]])
        << r["run_id"];
  }
  EXPECT_EQ(point_of(k, 3)["verdict"], "met");
  EXPECT_EQ(point_of(k, 8)["verdict"], "at max");
}

}  // namespace
}  // namespace granary::runner
