// End-to-end tests of the real `campaign` binary with a fake engine (fake_engine.cpp):
// exit codes, status --json, failures with the log tail, time limits, Ctrl-C, resume after
// `kill -9` of the runner, and two runners on one database never running a run twice.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mount.h>

#include <cerrno>
#include <cstring>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "runner/store.h"
#include "test_util.h"

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::CountLines;
using testing::ReadFile;
using testing::Sh;

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir();
    unsetenv("FAKE_ENGINE_FIRST_LAUNCH_STEP_MS");
    unsetenv("GRANARY_LEASE_SECONDS");
    setenv("GRANARY_CACHE_DIR", (dir_ / "beds").c_str(), 1);
    setenv("FAKE_ENGINE_STEPS", "10", 1);
    setenv("FAKE_ENGINE_STEP_MS", "20", 1);
  }
  void TearDown() override {
    for (const pid_t pid : spawned_) kill(pid, SIGKILL);  // a failed test leaves no runner behind
    fs::remove_all(dir_);
  }
  pid_t Spawn(const std::vector<std::string>& argv, const std::string& log) {
    spawned_.push_back(testing::Spawn(argv, log));
    return spawned_.back();
  }
  std::vector<pid_t> spawned_;

  // A campaign of `widths` x `replicas` runs; max_time 13 makes the fake engine fail.
  std::string WriteSpec(const std::string& widths, int replicas, double max_time = 20) {
    const fs::path p = dir_ / "c.json";
    std::ofstream(p) << json{
        {"name", "t"},
        {"replicas", replicas},
        {"base", {{"bodies", {{"count", 100}}}, {"silo", {{"width", 30}}}, {"discharge", {{"max_time", max_time}}}}},
        {"sweep", {{"grid", {{"/silo/base_outlets/0/width", json::parse(widths)}}}}}};
    return p.string();
  }
  std::string Db() const { return (dir_ / "g.db").string(); }
  std::string Cmd(const std::string& verb_and_flags) const {
    return testing::Campaign() + " " + verb_and_flags + " --db " + Db();
  }
  std::string RunCmd(const std::string& flags = "") const {
    return Cmd("run --engine " + testing::FakeEngine() + " " + flags);
  }
  json Status() const {
    const auto r = Sh(Cmd("status --json") + " 2>/dev/null");
    EXPECT_EQ(r.code, 0) << r.output;
    return json::parse(r.output);
  }
  fs::path dir_;
};

TEST_F(CliTest, HelpAndUnknownVerb) {
  auto r = Sh(testing::Campaign() + " --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.output.find("verbs:"), std::string::npos);
  for (const char* verb : {"plan", "run", "status", "report", "export", "compare"}) {
    r = Sh(testing::Campaign() + " " + verb + " --help");
    EXPECT_EQ(r.code, 0) << verb;
    EXPECT_EQ(r.output.rfind(std::string("usage: campaign ") + verb, 0), 0u) << r.output;
  }
  r = Sh(testing::Campaign() + " stauts");
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.output.rfind("campaign: unknown verb \"stauts\"; did you mean \"status\"?", 0), 0u) << r.output;
  r = Sh(testing::Campaign() + " run --jbos 2");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("unknown flag --jbos; did you mean --jobs?"), std::string::npos) << r.output;
}

TEST_F(CliTest, MissingEngineIsAUsageErrorAndTouchesNoRun) {
  Sh(Cmd("plan " + WriteSpec("[4]", 1)));
  const auto r = Sh(Cmd("run --engine /nonexistent/engine"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("error: engine executable not found: /nonexistent/engine"), std::string::npos) << r.output;
  EXPECT_EQ(Status()["counts"]["planned"], 1);
}

TEST_F(CliTest, SpecErrorExitsTwoWithPath) {
  const fs::path p = dir_ / "bad.json";
  std::ofstream(p) << R"({"name": "t", "base": {"silo": {"widht": 3}}})";
  const auto r = Sh(Cmd("plan " + p.string()));
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.output, "error: /base/silo/widht: unknown key; did you mean \"width\"? [" + p.string() + "]\n");
  EXPECT_FALSE(fs::exists(Db()) && Status()["total"] != 0);
}

// A spec nested 10^5 deep crashed `campaign plan` with SIGSEGV; a syntax error said
// only "not valid JSON"; a huge sweep ended in std::bad_alloc.
TEST_F(CliTest, BadSpecFilesAreUsageErrorsThatSayWhere) {
  const fs::path deep = dir_ / "deep.json";
  // (the error about /name dumped the value recursively: SIGSEGV)
  std::ofstream(deep) << "{\"name\": " << std::string(100000, '[') << std::string(100000, ']') << "}";
  auto r = Sh(Cmd("plan " + deep.string()));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_EQ(r.output,
            "error: " + deep.string() + ":1:73: nested deeper than 64 levels (a campaign spec needs fewer than 10)\n");
  const fs::path broken = dir_ / "broken.json";
  std::ofstream(broken) << "{\n  \"name\": \"t\",\n  \"replicas\": 2,,\n}\n";
  r = Sh(Cmd("plan " + broken.string()));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_EQ(r.output.rfind("error: " + broken.string() + ":3:17: not valid JSON: syntax error", 0), 0u) << r.output;
  // A number out of range exited 1 with nlohmann's out_of_range.406 text.
  const fs::path huge = dir_ / "huge.json";
  std::ofstream(huge) << "{\"name\": \"t\",\n \"seed\": 1e400}\n";
  r = Sh(Cmd("plan " + huge.string()));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_EQ(r.output, "error: " + huge.string() +
                          ":2:10: the number 1e400 is out of range (a JSON number must fit a "
                          "double, magnitude below 1.8e308)\n");
  const fs::path big = dir_ / "big.json";
  std::ofstream(big) << R"({"name": "t", "replicas": 1000, "base": {"silo": {"width": 30}},
    "sweep": {"grid": {"/silo/base_outlets/0/width": [3, 4, 5, 6], "/contact/mu": [0.1, 0.2, 0.3]}}})";
  r = Sh(Cmd("plan " + big.string() + " --dry-run --max-runs 11999"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find(
                "/sweep: expands to 12000 runs (3 x 4 x 1 engine(s) x 1000 replicas), more than the limit of 11999"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(Sh(Cmd("plan " + big.string() + " --dry-run --max-runs 12000")).code, 0);
}

// --only with a typo or a value not in the sweep ran nothing and exited 0.
TEST_F(CliTest, OnlyMustSelectSomething) {
  Sh(Cmd("plan " + WriteSpec("[4, 6]", 1)));
  auto r = Sh(RunCmd("--only /silo/base_outlet/0/width=4"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_EQ(r.output,
            "error: --only /silo/base_outlet/0/width=4: \"/silo/base_outlet/0/width\" is not a parameter of "
            "the runs; did you mean \"/silo/base_outlets/0/width\"? (axes: /silo/base_outlets/0/width)\n");
  r = Sh(RunCmd("--only /silo/base_outlets/0/width=5"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_EQ(r.output,
            "error: --only /silo/base_outlets/0/width=5: no run has /silo/base_outlets/0/width = 5 (its values: "
            "4.0, 6.0)\n");
  r = Sh(RunCmd("--only zzzz"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("error: --only zzzz: no run id starts with \"zzzz\""), std::string::npos) << r.output;
  EXPECT_EQ(Status()["counts"]["planned"], 2);
}

// A zero-length database was reported as an empty campaign; store errors exited 2
// ("usage"). They exit 3 with what happened.
TEST_F(CliTest, AZeroLengthDatabaseIsAStorageErrorNotAnEmptyCampaign) {
  Sh(Cmd("plan " + WriteSpec("[4]", 1)));
  fs::resize_file(Db(), 0);
  for (const char* verb : {"status", "run", "report --no-figures"}) {
    const auto r = Sh(Cmd(verb));
    EXPECT_EQ(r.code, 3) << verb << ": " << r.output;
    EXPECT_NE(r.output.find("error: database " + Db() + " is empty (0 bytes): whatever campaign it held is lost"),
              std::string::npos)
        << r.output;
  }
  std::ofstream(Db(), std::ios::trunc)
      << "this is not an SQLite file, but it is long enough to be looked at as one....";
  // A file that is not SQLite is the wrong --db, said without SQLite's words.
  const auto r = Sh(Cmd("status"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("is not a campaign database (not an SQLite file"), std::string::npos) << r.output;
}

// A finished run whose directory was deleted went unnoticed by status and run, and
// report counted it as failed.
TEST_F(CliTest, StatusRunAndReportSayWhichDoneRunsLostTheirDirectory) {
  Sh(Cmd("plan " + WriteSpec("[4, 6]", 1)));
  ASSERT_EQ(Sh(RunCmd()).code, 0);
  json s = Status();
  const std::string lost_id = s["runs"][0]["run_id"];
  fs::remove_all(s["runs"][0]["run_dir"].get<std::string>());
  s = Status();
  EXPECT_EQ(s["lost"], 1);
  EXPECT_EQ(s["runs"][0]["run_dir_missing"], true);
  EXPECT_FALSE(s["runs"][1].contains("run_dir_missing"));
  EXPECT_NE(Sh(Cmd("status")).output.find("lost: 1 done run(s) have no run directory"), std::string::npos);
  EXPECT_NE(Sh(RunCmd()).output.find("1 done run(s) have no run directory"), std::string::npos);
  // campaign scan agrees: the lost run stays done (its results are in the database), listed as lost.
  const auto scan = Sh(Cmd("scan --json"));
  ASSERT_EQ(scan.code, 0) << scan.output;
  const json scanned = json::parse(scan.output);
  EXPECT_EQ(scanned["agrees"], true) << scan.output;
  EXPECT_EQ(scanned["lost"], json::array({lost_id}));
  EXPECT_EQ(Status()["counts"]["done"], 2);
  EXPECT_NE(Sh(Cmd("scan")).output.find("1 done run(s) have no run directory (first " + lost_id + "): left done"),
            std::string::npos);
#ifdef GRANARY_HAVE_ANALYSIS
  const auto report = Sh(Cmd("report --no-figures"));
  ASSERT_EQ(report.code, 0) << report.output;
  EXPECT_NE(report.output.find("failed 0, lost 1 (done, run directory deleted"), std::string::npos) << report.output;
  const std::string md = ReadFile(dir_ / "report" / "report.md");
  EXPECT_NE(md.find("1 finished but their run directory was deleted"), std::string::npos) << md;
  EXPECT_NE(md.find("campaign run --rerun-lost runs it again"), std::string::npos) << md;
  // The export leaves the lost run out like an unfinished one.
  ASSERT_EQ(Sh(Cmd("export --format json --out " + (dir_ / "runs.json").string())).code, 0);
  const json rows = json::parse(ReadFile(dir_ / "runs.json"));
  ASSERT_EQ(rows.size(), 1u) << rows.dump();
  EXPECT_NE(rows[0]["run_id"], lost_id);
#endif
  ASSERT_EQ(Sh(RunCmd("--rerun-lost")).code, 0);
  EXPECT_EQ(Status()["lost"], 0);
  EXPECT_EQ(Status()["counts"]["done"], 2);
}

TEST_F(CliTest, PlanRunStatusReport) {
  const std::string spec = WriteSpec("[4, 6]", 2);
  auto r = Sh(Cmd("plan " + spec));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("points 2 x replicas 2 = 4 runs"), std::string::npos) << r.output;
  json s = Status();
  EXPECT_EQ(s["counts"]["planned"], 4);

  r = Sh(RunCmd("--jobs 2"));
  ASSERT_EQ(r.code, 0) << r.output;
  s = Status();
  EXPECT_EQ(s["counts"]["done"], 4);
  for (const auto& run : s["runs"]) {
    EXPECT_EQ(run["end_reason"], "discharged");
    EXPECT_EQ(run["attempts"], 1);
    EXPECT_TRUE(fs::exists(fs::path(run["run_dir"].get<std::string>()) / "engine.log"));
    EXPECT_EQ(fs::path(run["run_dir"].get<std::string>()).parent_path(), dir_ / "runs");
  }
  // Running again has nothing to do.
  r = Sh(RunCmd());
  EXPECT_EQ(r.code, 0);
  const json after = Status();  // (a range-for over Status()["runs"] would outlive the temporary)
  for (const auto& run : after["runs"]) {
    EXPECT_EQ(CountLines(ReadFile(fs::path(run["run_dir"].get<std::string>()) / "launches.txt"), "start"), 1);
  }
#ifdef GRANARY_HAVE_ANALYSIS
  r = Sh(Cmd("report --no-figures"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(dir_ / "report" / "report.md"));
  EXPECT_TRUE(fs::exists(dir_ / "report" / "report.html"));
#endif
}

TEST_F(CliTest, FailedRunExitsOneWithLogTail) {
  Sh(Cmd("plan " + WriteSpec("[4]", 1, 13)));
  const auto r = Sh(RunCmd("--retries 1"));
  EXPECT_EQ(r.code, 1) << r.output;
  const json s = Status();
  ASSERT_EQ(s["counts"]["failed"], 1);
  const json& run = s["runs"][0];
  EXPECT_EQ(run["attempts"], 2);  // one retry
  const std::string failure = run["failure"];
  EXPECT_EQ(failure.rfind("engine exited with status 3\n", 0), 0u) << failure;
  EXPECT_NE(failure.find("fake_engine: deliberate failure at step 5"), std::string::npos) << failure;
  const auto text = Sh(Cmd("status"));
  EXPECT_NE(text.output.find("failed:"), std::string::npos);
  EXPECT_NE(text.output.find("    | fake_engine: deliberate failure"), std::string::npos) << text.output;
}

TEST_F(CliTest, TimeLimitKillsAndFails) {
  Sh(Cmd("plan " + WriteSpec("[4]", 1, 666)));
  const auto r = Sh(RunCmd("--time-limit 0.5 --retries 0"));
  EXPECT_EQ(r.code, 1) << r.output;
  const json s = Status();
  EXPECT_EQ(std::string(s["runs"][0]["failure"]).rfind("wall-time limit of 0.5 s exceeded", 0), 0u) << s.dump();
}

// The end-to-end kill test: the runner is killed with -9 once both engines have written a
// checkpoint (a condition, not a number of milliseconds: the runs take 100 s each, so none
// can finish first). A new runner recovers the dead runner's leases, waits for the directory
// locks of the engines dying with their parent, and continues both from their checkpoints;
// every run finishes exactly once. (Stops, leases and time limits in-process:
// scheduler_test.cpp.)
TEST_F(CliTest, ResumesAfterKillMinusNineOfTheRunner) {
  setenv("FAKE_ENGINE_STEPS", "100", 1);
  setenv("FAKE_ENGINE_STEP_MS", "0", 1);
  setenv("FAKE_ENGINE_FIRST_LAUNCH_STEP_MS", "1000", 1);
  Sh(Cmd("plan " + WriteSpec("[4, 6, 8]", 1)));
  const std::string log = (dir_ / "runner.log").string();
  const pid_t pid =
      Spawn({testing::Campaign(), "run", "--db", Db(), "--jobs", "2", "--engine", testing::FakeEngine()}, log);
  std::vector<fs::path> dirs;
  const json planned = Status();
  for (const auto& run : planned["runs"]) dirs.push_back(run["run_dir"].get<std::string>());
  const auto checkpointed = [&] {
    int n = 0;
    for (const auto& d : dirs) n += fs::exists(d / "checkpoint.fake");
    return n;
  };
  ASSERT_TRUE(testing::WaitFor([&] { return checkpointed() == 2; }, 120)) << ReadFile(log);
  kill(pid, SIGKILL);
  testing::WaitExit(pid);
  json s = Status();
  EXPECT_EQ(s["counts"]["running"], 2) << s.dump();  // left behind by the dead runner
  for (const auto& run : s["runs"]) {
    if (run["state"] == "running") {
      EXPECT_EQ(run["lease_expired"], true);
    }
  }
  EXPECT_EQ(s["counts"]["planned"], 1);

  unsetenv("FAKE_ENGINE_FIRST_LAUNCH_STEP_MS");
  const auto r = Sh(RunCmd("--jobs 2"));
  ASSERT_EQ(r.code, 0) << r.output;
  s = Status();
  EXPECT_EQ(s["counts"]["done"], 3) << s.dump();
  int continued = 0;
  for (const auto& run : s["runs"]) {
    const std::string launches = ReadFile(fs::path(run["run_dir"].get<std::string>()) / "launches.txt");
    EXPECT_EQ(CountLines(launches, "finish"), 1) << launches;
    continued += CountLines(launches, "start") == 2;
  }
  EXPECT_EQ(continued, 2);
}

// End to end: runner A is stopped (kill -STOP, as Ctrl-Z does) while its engine
// runs on; once A's lease is stale, runner B recovers the run but starts no engine while A's
// engine holds the directory. When A continues (kill -CONT), its heartbeat finds the run
// taken: it stops its engine and records nothing; B then continues the run from its
// checkpoint. One writer at a time, the run done once (before: two engines wrote one
// events.csv and A recorded the run done).
TEST_F(CliTest, AStalledRunnerThatLostItsLeaseStopsItsEngineAndRecordsNothing) {
  setenv("GRANARY_LEASE_SECONDS", "3", 1);
  setenv("FAKE_ENGINE_STEPS", "100", 1);
  setenv("FAKE_ENGINE_STEP_MS", "0", 1);
  setenv("FAKE_ENGINE_FIRST_LAUNCH_STEP_MS", "1000", 1);
  Sh(Cmd("plan " + WriteSpec("[4]", 1)));
  const json planned = Status();
  const fs::path run_dir = planned["runs"][0]["run_dir"].get<std::string>();
  const std::string log_a = (dir_ / "a.log").string(), log_b = (dir_ / "b.log").string();
  const pid_t a =
      Spawn({testing::Campaign(), "run", "--db", Db(), "--jobs", "1", "--engine", testing::FakeEngine()}, log_a);
  ASSERT_TRUE(testing::WaitFor([&] { return fs::exists(run_dir / "checkpoint.fake"); }, 120)) << ReadFile(log_a);
  kill(a, SIGSTOP);
  ASSERT_TRUE(testing::WaitFor([&] { return Status()["runs"][0].value("lease_expired", false); }, 60));
  const pid_t b =
      Spawn({testing::Campaign(), "run", "--db", Db(), "--jobs", "1", "--engine", testing::FakeEngine()}, log_b);
  ASSERT_TRUE(testing::WaitFor([&] { return ReadFile(log_b).find("waiting") != std::string::npos; }, 60))
      << ReadFile(log_b);
  EXPECT_NE(ReadFile(log_b).find("its directory is locked by engine pid"), std::string::npos) << ReadFile(log_b);
  EXPECT_EQ(CountLines(ReadFile(run_dir / "launches.txt"), "start"), 1);  // B started nothing
  kill(a, SIGCONT);
  EXPECT_EQ(testing::WaitExit(a), 0) << ReadFile(log_a);
  EXPECT_EQ(testing::WaitExit(b), 0) << ReadFile(log_b);
  EXPECT_NE(ReadFile(log_a).find("lease lost"), std::string::npos) << ReadFile(log_a);
  const json s = Status();
  EXPECT_EQ(s["counts"]["done"], 1) << s.dump();
  EXPECT_EQ(s["runs"][0]["attempts"], 2);
  const std::string launches = ReadFile(run_dir / "launches.txt");
  EXPECT_EQ(CountLines(launches, "start"), 2) << launches;
  EXPECT_EQ(CountLines(launches, "finish"), 1) << launches;
  unsetenv("GRANARY_LEASE_SECONDS");
}

TEST_F(CliTest, EngineKilledMinusNineIsRelaunchedFromItsCheckpoint) {
  setenv("FAKE_ENGINE_STEPS", "100", 1);
  setenv("FAKE_ENGINE_STEP_MS", "0", 1);
  setenv("FAKE_ENGINE_FIRST_LAUNCH_STEP_MS", "1000", 1);
  Sh(Cmd("plan " + WriteSpec("[4]", 1)));
  const std::string log = (dir_ / "runner.log").string();
  const pid_t runner = Spawn(
      {testing::Campaign(), "run", "--db", Db(), "--jobs", "1", "--retries", "1", "--engine", testing::FakeEngine()},
      log);
  // Once the engine has passed a checkpoint, kill it (not the runner).
  const json plan = Status();
  const fs::path run_dir = plan["runs"][0]["run_dir"].get<std::string>();
  pid_t engine = 0;
  ASSERT_TRUE(testing::WaitFor([&] { return fs::exists(run_dir / "checkpoint.fake"); }, 120)) << ReadFile(log);
  std::istringstream in(ReadFile(run_dir / "launches.txt"));
  std::string word;
  in >> word >> engine;
  ASSERT_GT(engine, 0);
  kill(engine, SIGKILL);
  EXPECT_EQ(testing::WaitExit(runner), 0) << ReadFile(log);
  const json s = Status();
  EXPECT_EQ(s["counts"]["done"], 1);
  EXPECT_EQ(s["runs"][0]["attempts"], 2);
  const std::string launches = ReadFile(run_dir / "launches.txt");
  EXPECT_EQ(CountLines(launches, "start"), 2) << launches;
  EXPECT_EQ(CountLines(launches, "finish"), 1) << launches;
  EXPECT_NE(ReadFile(run_dir / "engine.log").find("continuing from checkpoint"), std::string::npos);
  EXPECT_NE(ReadFile(log).find("engine killed by signal 9"), std::string::npos) << ReadFile(log);
}

TEST_F(CliTest, TwoRunnersNeverRunTheSameRun) {
  setenv("FAKE_ENGINE_STEP_MS", "15", 1);
  Sh(Cmd("plan " + WriteSpec("[3, 4, 5, 6, 7, 8]", 1)));
  const std::vector<std::string> argv = {testing::Campaign(),  "run", "--db", Db(), "--jobs", "2", "--engine",
                                         testing::FakeEngine()};
  const pid_t a = Spawn(argv, (dir_ / "a.log").string());
  const pid_t b = Spawn(argv, (dir_ / "b.log").string());
  EXPECT_EQ(testing::WaitExit(a), 0) << ReadFile(dir_ / "a.log");
  EXPECT_EQ(testing::WaitExit(b), 0) << ReadFile(dir_ / "b.log");
  const json s = Status();
  EXPECT_EQ(s["counts"]["done"], 6);
  for (const auto& run : s["runs"]) {
    const std::string launches = ReadFile(fs::path(run["run_dir"].get<std::string>()) / "launches.txt");
    EXPECT_EQ(CountLines(launches, "start"), 1) << launches;
    EXPECT_EQ(run["attempts"], 1);
  }
}

TEST_F(CliTest, OnlyFilterSelectsRuns) {
  Sh(Cmd("plan " + WriteSpec("[4, 6]", 1)));
  ASSERT_EQ(Sh(RunCmd("--only /silo/base_outlets/0/width=6")).code, 0);
  const json s = Status();
  EXPECT_EQ(s["counts"]["done"], 1);
  for (const auto& run : s["runs"]) {
    EXPECT_EQ(run["state"], run["point"]["/silo/base_outlets/0/width"] == 6 ? "done" : "planned");
  }
}

}  // namespace
}  // namespace granary::runner

namespace granary::runner {
namespace {

// End to end on the real engine: a derived axis in --only and the export, and the
// reproduction table in export --expectations, status and report.
TEST_F(CliTest, RealEngineDerivedAxesAndExpectations) {
  const std::string engine = testing::BinDir() + "/granary-engine";
  if (!fs::exists(engine)) GTEST_SKIP() << "granary-engine not built";
  const fs::path p = dir_ / "expect.json";
  std::ofstream(p) << R"({"name": "expect", "seed": 2, "replicas": 1,
    "base": {"bodies": {"count": 60}, "silo": {"width": 12}, "discharge": {"mode": "remove", "max_time": 2}},
    "sweep": {"grid": {"/silo/base_outlets/0/width": [3, 4]}},
    "axes": {"W2": "2 * W"},
    "expect": [
      {"metric": "clogs", "at": {"W2": 8}, "value": 60, "tolerance": 60, "min_runs": 1, "source": "0 to 120 clogs"},
      {"metric": "clogs", "at": {"W": 4}, "value": -1000, "tolerance": 1, "min_runs": 1, "source": "no count is negative"},
      {"metric": "clogs", "at": {"W": 3}, "value": 60, "source": "two runs needed"}]})";
  ASSERT_EQ(Sh(Cmd("plan " + p.string())).code, 0);
  ASSERT_EQ(Sh(Cmd("run --jobs 2")).code, 0);
  const auto table = Sh(Cmd("export --expectations --format json") + " 2>/dev/null");
  ASSERT_EQ(table.code, 0) << table.output;
  const json t = json::parse(table.output);
  ASSERT_EQ(t.size(), 3u) << table.output;
  EXPECT_EQ(t[0]["verdict"], "agrees") << t.dump();
  EXPECT_EQ(t[0]["quantity"], "clogs at W2 = 8");
  EXPECT_EQ(t[1]["verdict"], "disagrees") << t.dump();
  EXPECT_EQ(t[2]["verdict"], "not enough runs") << t.dump();
  EXPECT_EQ(t[2]["runs"], 1);
  const auto status = Sh(Cmd("status") + " 2>/dev/null");
  EXPECT_NE(status.output.find("expectations: 1 agree, 1 disagrees, 1 not yet"), std::string::npos) << status.output;
  EXPECT_EQ(Status()["expectations"], "1 agree, 1 disagrees, 1 not yet");
  // The derived axis: a column of the export, and a filter.
  const auto only = Sh(Cmd("export --level point --format json --only W2=6") + " 2>/dev/null");
  ASSERT_EQ(only.code, 0) << only.output;
  const json rows = json::parse(only.output);
  ASSERT_EQ(rows.size(), 1u) << only.output;
  EXPECT_EQ(rows[0]["W"], 3);
  EXPECT_EQ(rows[0]["W2"], 6);
  const auto bad = Sh(Cmd("export --only W2=7") + " 2>&1");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.output.find("no run has W2 = 7 (its values: 6, 8)"), std::string::npos) << bad.output;
  const auto report = Sh(Cmd("report --no-figures") + " 2>/dev/null");
  ASSERT_EQ(report.code, 0) << report.output;
  EXPECT_NE(report.output.find("expectations: 1 agree, 1 disagrees, 1 not yet"), std::string::npos) << report.output;
  EXPECT_NE(ReadFile(dir_ / "report" / "report.md").find("## Key results"), std::string::npos);
  // Without /expect, --expectations is a usage error.
  EXPECT_EQ(Sh(Cmd("export --expectations --level run") + " 2>&1").code, 2);
}

// The real native engine on a tiny campaign: results are ingested from summary.json.
TEST_F(CliTest, RealEngineEndToEnd) {
  const std::string engine = testing::BinDir() + "/granary-engine";
  if (!fs::exists(engine)) GTEST_SKIP() << "granary-engine not built";
  const fs::path p = dir_ / "real.json";
  std::ofstream(p) << R"({"name": "real", "seed": 2, "replicas": 1,
    "base": {"bodies": {"count": 60}, "silo": {"width": 12},
             "discharge": {"mode": "remove", "max_time": 2}, "output": {"checkpoint_interval": 1}},
    "sweep": {"grid": {"/silo/base_outlets/0/width": [3, 4]}}})";
  ASSERT_EQ(Sh(Cmd("plan " + p.string())).code, 0);
  const auto r = Sh(Cmd("run --jobs 2"));
  ASSERT_EQ(r.code, 0) << r.output;
  const json s = Status();
  EXPECT_EQ(s["counts"]["done"], 2) << s.dump();
  for (const auto& run : s["runs"]) {
    const json summary = json::parse(ReadFile(fs::path(run["run_dir"].get<std::string>()) / "summary.json"));
    EXPECT_EQ(summary["run_id"], run["run_id"]);
    EXPECT_EQ(run["end_reason"], summary["end_reason"]);
    // The prepared bed is shared: both runs differ only in the outlet.
    EXPECT_EQ(fs::path(summary["bed"]["file"].get<std::string>()).parent_path(), dir_ / "beds");
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "beds"), fs::directory_iterator{}) >= 1, true);

  // The metrics as one table, one row per run: the swept width a numeric column, each metric
  // and its se numeric columns; and stored in the database.
  const auto csv = Sh(Cmd("export") + " 2>/dev/null");
  ASSERT_EQ(csv.code, 0) << csv.output;
  std::istringstream lines(csv.output);
  std::string header, row;
  std::getline(lines, header);
  EXPECT_EQ(header.rfind("run_id,point_id,replica,engine,end_reason,W,q_count,q_count_se,", 0), 0u) << header;
  int rows = 0;
  while (std::getline(lines, row)) ++rows;
  EXPECT_EQ(rows, 2);
  const auto points = Sh(Cmd("export --level point --format json --out " + (dir_ / "points.json").string()));
  ASSERT_EQ(points.code, 0) << points.output;
  const json p_json = json::parse(ReadFile(dir_ / "points.json"));
  ASSERT_EQ(p_json.size(), 2u);
  EXPECT_TRUE(p_json[0]["W"].is_number());
  EXPECT_EQ(p_json[0]["runs"], 1);
  EXPECT_TRUE(p_json[0].contains("q_count_n"));
  {
    Store store(Db());
    Statement q = store.Prepare(
        "SELECT json_extract(r.params, '$.silo.base_outlets[0].width'), m.unit FROM metrics m JOIN runs r USING (run_id) "
        "WHERE m.analysis = 'flow' AND m.metric = 'q_count' ORDER BY 1");
    std::vector<double> widths;
    while (q.Step()) {
      widths.push_back(q.Real(0));
      EXPECT_EQ(q.Text(1), "bodies/sqrt(d/g)");
    }
    EXPECT_EQ(widths, (std::vector<double>{3, 4}));
  }
  for (const auto& run : Status()["runs"]) EXPECT_TRUE(run["metrics"].contains("q_count")) << run.dump();
  // A report after the export reads every result from the runs' caches.
  const auto report = Sh(Cmd("report --no-figures"));
  ASSERT_EQ(report.code, 0) << report.output;
  EXPECT_NE(report.output.find(" from the runs' caches, 0 computed"), std::string::npos) << report.output;

  // docs/data.md: every python block runs on this campaign's export and database.
  if (Sh("/usr/bin/python3 -c 'import pandas' 2>&1").code != 0)
    GTEST_SKIP() << "python3-pandas is not installed (scripts/setup.sh installs it): docs/data.md not checked";
  ASSERT_EQ(Sh(Cmd("export --out " + (dir_ / "runs.csv").string())).code, 0);
  ASSERT_EQ(Sh(Cmd("export --level point --out " + (dir_ / "points.csv").string())).code, 0);
  fs::copy_file(Db(), dir_ / "study.db");
  const std::string doc = ReadFile(fs::path(GRANARY_SOURCE_DIR) / "docs" / "data.md");
  int blocks = 0;
  for (std::size_t at = doc.find("```python\n"); at != std::string::npos; at = doc.find("```python\n", at)) {
    at += 10;
    const std::size_t end = doc.find("```", at);
    ASSERT_NE(end, std::string::npos);
    const fs::path script = dir_ / ("doc" + std::to_string(++blocks) + ".py");
    std::ofstream(script) << doc.substr(at, end - at);
    const auto py = Sh("cd " + dir_.string() + " && /usr/bin/python3 " + script.string());
    EXPECT_EQ(py.code, 0) << "docs/data.md python block " << blocks << ":\n" << py.output;
    // The tables were printed: Q of the export, the analyses of the database.
    EXPECT_NE(py.output.find(blocks == 1 ? "q_count_se" : "flow"), std::string::npos) << py.output;
    at = end + 3;
  }
  EXPECT_EQ(blocks, 2);
}

// campaign fields on a real engine's run directory: CSV maps with n_frames, the JSON summary,
// a misspelt field, stress fields of a run without contacts, and the bench's output.
TEST_F(CliTest, FieldsWritesCsvMapsOfARun) {
  const std::string engine = testing::BinDir() + "/granary-engine";
  if (!fs::exists(engine)) GTEST_SKIP() << "granary-engine not built";
  auto make_run = [&](const std::string& name, bool contacts) {
    const fs::path run = dir_ / name;
    fs::create_directories(run);
    std::ofstream(run / "run.json") << json{
        {"seed", 2},
        {"bodies", {{"count", 60}}},
        {"silo", {{"width", 12}, {"base_outlets", {{{"center", 0}, {"width", 4}}}}}},
        {"discharge", {{"mode", "reinject"}, {"max_time", 1.0}}},
        {"output", {{"frame_interval", 0.25}, {"contact_forces", contacts}, {"checkpoint_interval", 0}}}};
    const auto r = Sh(engine + " run " + run.string() + " --threads 1");
    EXPECT_EQ(r.code, 0) << r.output;
    return run;
  };
  const fs::path run = make_run("with-contacts", true);
  const fs::path out = dir_ / "maps";
  auto r = Sh(testing::Campaign() + " fields " + run.string() + " --fields phi,pressure --from 0.5 --out " +
              out.string() + " --json");
  ASSERT_EQ(r.code, 0) << r.output;
  const json j = json::parse(r.output);
  EXPECT_EQ(j["frames"], 3);  // t = 0.5, 0.75, 1
  EXPECT_EQ(j["contact_frames"], 3);
  EXPECT_EQ(j["files"].size(), 2u);
  const std::string csv = ReadFile(out / "pressure.csv");
  EXPECT_EQ(csv.substr(0, csv.find('\n')), "x,y,pressure,n_frames");
  EXPECT_EQ(CountLines(csv, ""), 1 + j["nodes"].get<int>());
  EXPECT_NE(csv.find(",3\n"), std::string::npos);

  r = Sh(testing::Campaign() + " fields " + run.string() + " --fields presure");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("unknown field \"presure\"; did you mean \"pressure\"?"), std::string::npos) << r.output;

  const fs::path bare = make_run("without-contacts", false);
  r = Sh(testing::Campaign() + " fields " + bare.string() + " --fields pressure");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("pressure needs contacts.dump"), std::string::npos) << r.output;
  r = Sh(testing::Campaign() + " fields " + bare.string());  // every field its data supports
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(bare / "fields" / "tg.csv"));
  EXPECT_FALSE(fs::exists(bare / "fields" / "pressure.csv"));

  r = Sh(testing::Campaign() + " fields " + run.string() + " --bench --repeat 1 --threads-list 1,2 --max-frames 2");
  ASSERT_EQ(r.code, 0) << r.output;
  for (const char* line : {"round 1  read", "round 1  fields, 1 thread", "round 1  fields, 2 threads", "median"})
    EXPECT_NE(r.output.find(line), std::string::npos) << line << "\n" << r.output;
}

// A campaign that asks for coarse-grained fields: the plan turns contact output on (or names
// the path that turns it off), and the report has one map per field with a panel per point,
// its grids as CSV, the region table and the force chains.
TEST_F(CliTest, FieldsInTheReport) {
  const std::string engine = testing::BinDir() + "/granary-engine";
  if (!fs::exists(engine)) GTEST_SKIP() << "granary-engine not built";
  json spec = json::parse(R"({"name": "fields", "seed": 3, "replicas": 2,
    "base": {"bodies": {"count": 80}, "silo": {"width": 12},
             "discharge": {"mode": "reinject", "max_time": 3, "stop_on_clog": false},
             "output": {"frame_interval": 0.25, "contact_forces": false}},
    "sweep": {"grid": {"/silo/base_outlets/0/width": [4, 6]}},
    "report": {"window": {"start_time": 0.5, "min_events": 3},
               "fields": {"maps": ["phi", "speed", "pressure", "friction"], "frames": "split"}}})");
  const fs::path p = dir_ / "fields.json";
  std::ofstream(p) << spec.dump();
  auto r = Sh(Cmd("plan " + p.string()));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("/base/output/contact_forces"), std::string::npos) << r.output;
  spec["base"]["output"].erase("contact_forces");
  std::ofstream(p) << spec.dump();
  ASSERT_EQ(Sh(Cmd("plan " + p.string())).code, 0);
  r = Sh(Cmd("run --jobs 2"));
  ASSERT_EQ(r.code, 0) << r.output;
  const json s = Status();
  ASSERT_EQ(s["runs"].size(), 4u);
  for (const auto& run : s["runs"]) {
    const fs::path dir = run["run_dir"].get<std::string>();
    EXPECT_EQ(json::parse(ReadFile(dir / "run.json"))["output"]["contact_forces"], true);
    EXPECT_TRUE(fs::exists(dir / "contacts.dump"));
  }
  r = Sh(Cmd("report"));
  ASSERT_EQ(r.code, 0) << r.output;
  const fs::path report = dir_ / "report";
  const std::string md = ReadFile(report / "report.md");
  EXPECT_NE(md.find("## Coarse-grained fields"), std::string::npos);
  for (const char* map :
       {"field_phi_flowing", "field_speed_flowing", "field_pressure_flowing", "field_friction_flowing", "force_chains"})
    EXPECT_NE(md.find(std::string("](figures/") + map + ".svg)"), std::string::npos) << map;
  // One CSV per map and point: x, y, value, n_frames over the window's nodes.
  for (int k = 1; k <= 2; ++k) {
    const std::string csv = ReadFile(report / "data" / ("field_phi_flowing-" + std::to_string(k) + ".csv"));
    EXPECT_EQ(csv.substr(0, csv.find('\n')), "x,y,phi,n_frames");
    EXPECT_GT(CountLines(csv, ""), 50);
  }
  EXPECT_TRUE(fs::exists(report / "figures" / "field_pressure_flowing.svg"));
  EXPECT_TRUE(fs::exists(report / "data" / "force_chains-1-segments.csv"));
  EXPECT_TRUE(fs::exists(report / "data" / "field_speed_flowing-1-arrows.csv"));
  EXPECT_TRUE(fs::exists(report / "data" / "fields_region.csv"));
  // The region means are metrics of the export.
  const auto csv = Sh(Cmd("export") + " 2>/dev/null");
  ASSERT_EQ(csv.code, 0);
  EXPECT_NE(csv.output.find(",cg_phi,"), std::string::npos);
  EXPECT_NE(csv.output.find(",cg_pressure_clogged"), std::string::npos);
}

// campaign compare on a tiny campaign: both real engines (LIGGGHTS as installed by
// scripts/setup.sh), the comparison as JSON, the report; a second compare reuses every run.
TEST_F(CliTest, CompareRunsBothEnginesAndReportsThem) {
  const std::string native = testing::BinDir() + "/granary-engine";
  const std::string liggghts = testing::BinDir() + "/granary-liggghts";
  if (!fs::exists(native) || !fs::exists(liggghts)) GTEST_SKIP() << "engines not built";
  const fs::path p = dir_ / "cmp.json";
  std::ofstream(p) << R"({"name": "cmp", "seed": 4, "replicas": 2,
    "base": {"bodies": {"count": 60, "species": [{"shape": "disc"}]}, "silo": {"width": 12},
             "contact": {"tangential_cap": "liggghts"},
             "discharge": {"mode": "reinject", "reinject_position": "periodic", "max_time": 4, "stop_on_clog": false},
             "output": {"checkpoint_interval": 1, "frame_interval": 0.5}},
    "sweep": {"grid": {"/silo/base_outlets/0/width": [6]}},
    "report": {"fields": {"maps": ["phi", "speed", "pressure"], "force_chains": false}}})";
  // Progress goes to stderr; stdout is the JSON document.
  const auto r = Sh("(" + Cmd("compare " + p.string() + " --json --no-figures --jobs 2") + " 2>/dev/null)");
  ASSERT_EQ(r.code, 0) << r.output;
  const json out = json::parse(r.output);
  EXPECT_EQ(out["runs_used"], 4);
  const json& c = out["comparison"];
  EXPECT_EQ(c["engine_a"], "native");
  EXPECT_EQ(c["engine_b"], "liggghts");
  ASSERT_EQ(c["points"].size(), 1u);
  ASSERT_TRUE(c["points"][0]["metrics"].contains("q_count")) << c.dump();
  const json& q = c["points"][0]["metrics"]["q_count"];
  EXPECT_EQ(q["native"]["n"], 2);
  EXPECT_EQ(q["liggghts"]["n"], 2);
  EXPECT_GT(q["native"]["mean"].get<double>(), 0.0);
  EXPECT_GT(q["liggghts"]["mean"].get<double>(), 0.0);
  EXPECT_NEAR(q["ratio"].get<double>(), q["liggghts"]["mean"].get<double>() / q["native"]["mean"].get<double>(), 1e-12);
  for (const auto& e : c["costs"]) {
    EXPECT_EQ(e["runs"], 2);
    EXPECT_GT(e["disc_steps_per_s"]["mean"].get<double>(), 0.0);
  }
  // The coarse-grained fields of both engines' output (contacts.dump of each) agree within
  // their statistical error: the region means above the outlet, 2 replicas each.
  for (const char* name : {"cg_phi", "cg_speed", "cg_pressure"}) {
    ASSERT_TRUE(c["points"][0]["metrics"].contains(name)) << name << c.dump();
    const json& m = c["points"][0]["metrics"][name];
    ASSERT_EQ(m["native"]["n"], 2) << name;
    ASSERT_EQ(m["liggghts"]["n"], 2) << name;
    const double a = m["native"]["mean"].get<double>(), b = m["liggghts"]["mean"].get<double>();
    const double se = std::hypot(m["native"]["se"].get<double>(), m["liggghts"]["se"].get<double>());
    EXPECT_GT(a, 0.0) << name;
    EXPECT_LT(std::abs(a - b), std::max(4.0 * se, 0.1 * a))
        << name << ": native " << a << ", liggghts " << b << ", se " << se;
  }
  const std::string md = ReadFile(dir_ / "report" / "report.md");
  EXPECT_NE(md.find("Engine comparison: native and liggghts"), std::string::npos);
  std::map<std::string, int> engines;
  const json status = Status();
  for (const auto& run : status["runs"]) ++engines[run["engine"].get<std::string>()];
  EXPECT_EQ(engines["native"], 2);
  EXPECT_EQ(engines["liggghts"], 2);
  // Again: nothing to run, the same numbers.
  const auto again = Sh("(" + Cmd("compare " + p.string() + " --json --no-figures") + " 2>/dev/null)");
  ASSERT_EQ(again.code, 0) << again.output;
  EXPECT_EQ(json::parse(again.output)["comparison"]["points"], c["points"]);
  // The point by its sweep values (JSON paths, for scripts) and by the name the report gives it.
  EXPECT_TRUE(c["points"][0]["point"].contains("/silo/base_outlets/0/width")) << c["points"][0].dump();
  EXPECT_EQ(c["points"][0]["name"], "W = 6");
  // The printed table names it so too.
  const auto text = Sh("(" + Cmd("compare " + p.string() + " --no-run --no-figures") + " 2>/dev/null)");
  ASSERT_EQ(text.code, 0) << text.output;
  const std::string table = text.output.substr(std::min(text.output.size(), text.output.find("engine comparison:")));
  EXPECT_NE(table.find("\n  W = 6\n"), std::string::npos) << text.output;
  EXPECT_EQ(table.find("base_outlets"), std::string::npos) << text.output;
}

}  // namespace
}  // namespace granary::runner

namespace granary::runner {
namespace {

// A small tmpfs for the full-disk tests (root with CAP_SYS_ADMIN; otherwise the test skips
// and says so). Unmounted when the object goes.
class Tmpfs {
 public:
  Tmpfs(const fs::path& at, const std::string& size) : at_(at) {
    fs::create_directories(at);
    mounted_ = ::mount("tmpfs", at.c_str(), "tmpfs", 0, ("size=" + size).c_str()) == 0;
    if (!mounted_) why_ = std::strerror(errno);
  }
  ~Tmpfs() {
    if (mounted_) ::umount2(at_.c_str(), MNT_DETACH);
  }
  bool Mounted() const { return mounted_; }
  const std::string& Why() const { return why_; }
  // Writes zeros into `file` until the file system is full.
  void Fill(const fs::path& file) const {
    std::FILE* f = std::fopen(file.c_str(), "wb");
    const std::string block(4096, '\0');
    while (f && std::fwrite(block.data(), 1, block.size(), f) == block.size() && std::fflush(f) == 0) {
    }
    if (f) std::fclose(f);
  }

 private:
  fs::path at_;
  bool mounted_ = false;
  std::string why_;
};

// A full disk under the database aborted the runner and left runs `running`. Now
// the runner stops its engines (they checkpoint), exits 3 saying the disk is full and what it
// left, and the next runner (with room again) finishes every run exactly once.
TEST_F(CliTest, AFullDiskUnderTheDatabaseStopsTheRunnerCleanly) {
  const Tmpfs disk(dir_ / "dbfs", "2m");
  if (!disk.Mounted()) GTEST_SKIP() << "cannot mount a tmpfs to fill (needs root with CAP_SYS_ADMIN): " << disk.Why();
  const std::string db = (dir_ / "dbfs" / "g.db").string();
  fs::create_directories(dir_ / "runs-elsewhere");
  fs::create_directory_symlink(dir_ / "runs-elsewhere", dir_ / "dbfs" / "runs");  // only the database is full
  setenv("FAKE_ENGINE_STEPS", "100", 1);
  setenv("FAKE_ENGINE_STEP_MS", "0", 1);
  setenv("FAKE_ENGINE_FIRST_LAUNCH_STEP_MS", "1000", 1);
  ASSERT_EQ(Sh(testing::Campaign() + " plan " + WriteSpec("[4, 6]", 1) + " --db " + db).code, 0);
  const std::string log = (dir_ / "runner.log").string();
  const pid_t runner =
      Spawn({testing::Campaign(), "run", "--db", db, "--jobs", "2", "--engine", testing::FakeEngine()}, log);
  const auto checkpointed = [&] {
    int n = 0;
    for (const auto& e : fs::directory_iterator(dir_ / "runs-elsewhere")) n += fs::exists(e.path() / "checkpoint.fake");
    return n;
  };
  ASSERT_TRUE(testing::WaitFor([&] { return checkpointed() == 2; }, 120)) << ReadFile(log);
  disk.Fill(dir_ / "dbfs" / "filler");
  EXPECT_EQ(testing::WaitExit(runner), 3) << ReadFile(log);
  const std::string out = ReadFile(log);
  EXPECT_NE(out.find("database or disk is full"), std::string::npos) << out;
  // And where the full disk is.
  EXPECT_NE(out.find("the file system of " + (dir_ / "dbfs").string() + " is full ("), std::string::npos) << out;
  EXPECT_NE(out.find("campaign run stopped its engines (they continue from their checkpoints)"), std::string::npos)
      << out;
  fs::remove(dir_ / "dbfs" / "filler");
  unsetenv("FAKE_ENGINE_FIRST_LAUNCH_STEP_MS");
  const auto r = Sh(testing::Campaign() + " run --db " + db + " --engine " + testing::FakeEngine());
  ASSERT_EQ(r.code, 0) << r.output;
  const json s = json::parse(Sh(testing::Campaign() + " status --json --db " + db + " 2>/dev/null").output);
  EXPECT_EQ(s["counts"]["done"], 2) << s.dump();
  for (const auto& run : s["runs"]) {
    const std::string launches = ReadFile(fs::path(run["run_dir"].get<std::string>()) / "launches.txt");
    EXPECT_EQ(CountLines(launches, "finish"), 1) << launches;
    EXPECT_NE(ReadFile(fs::path(run["run_dir"].get<std::string>()) / "engine.log").find("continuing from checkpoint"),
              std::string::npos);
  }
}

// A full disk under runs/ showed "engine exited with status 1" with no reason. The
// real engine fills a small file system with frames: its run is interrupted (not failed)
// with the reason, no further run starts, and the runner exits 3.
TEST_F(CliTest, AFullDiskUnderTheRunsIsSaidAndInterruptsTheRun) {
  const std::string engine = testing::BinDir() + "/granary-engine";
  if (!fs::exists(engine)) GTEST_SKIP() << "granary-engine not built";
  const Tmpfs disk(dir_ / "runs", "1m");
  if (!disk.Mounted()) GTEST_SKIP() << "cannot mount a tmpfs to fill (needs root with CAP_SYS_ADMIN): " << disk.Why();
  const fs::path p = dir_ / "frames.json";
  std::ofstream(p) << R"({"name": "full", "seed": 2, "replicas": 2,
    "base": {"bodies": {"count": 60}, "silo": {"width": 12}, "discharge": {"mode": "reinject", "max_time": 50,
             "stop_on_clog": false}, "output": {"checkpoint_interval": 1, "frame_interval": 0.01}},
    "sweep": {"grid": {"/silo/base_outlets/0/width": [4]}}})";
  ASSERT_EQ(Sh(Cmd("plan " + p.string())).code, 0);
  const auto r = Sh(Cmd("run --jobs 1 --retries 1"));
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find("is full ("), std::string::npos) << r.output;
  const json s = Status();
  EXPECT_EQ(s["counts"]["interrupted"], 1) << s.dump();
  EXPECT_EQ(s["counts"]["planned"], 1) << s.dump();  // not started on a full disk
  EXPECT_EQ(s["counts"]["failed"], 0) << s.dump();
  for (const auto& run : s["runs"]) {
    if (run["state"] != "interrupted") continue;
    const std::string failure = run["failure"];
    EXPECT_EQ(failure.rfind("engine exited with status 1; the file system of " + (dir_ / "runs").string() + "/", 0), 0u)
        << failure;
    EXPECT_NE(failure.find(" is full ("), std::string::npos) << failure;
    EXPECT_EQ(run["attempts"], 1);
  }
}

// A database in a read-only directory failed even `status` with "unable to open
// database file (SQLite code 14)". status, show, report and export now read it read-only;
// a verb that must write says the directory is read-only.
TEST_F(CliTest, AReadOnlyDatabaseDirectoryIsReadAndSaidSo) {
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4, 6]", 1))).code, 0);
  ASSERT_EQ(Sh(RunCmd()).code, 0);
  const Tmpfs disk(dir_ / "ro", "8m");
  if (!disk.Mounted()) GTEST_SKIP() << "cannot mount a tmpfs (needs root with CAP_SYS_ADMIN): " << disk.Why();
  fs::copy_file(Db(), dir_ / "ro" / "g.db");
  fs::create_directory_symlink(dir_ / "runs", dir_ / "ro" / "runs");
  ASSERT_EQ(::mount("tmpfs", (dir_ / "ro").c_str(), "tmpfs", MS_REMOUNT | MS_RDONLY, nullptr), 0)
      << std::strerror(errno);
  const std::string db = (dir_ / "ro" / "g.db").string();
  const auto status = Sh(testing::Campaign() + " status --db " + db);
  EXPECT_EQ(status.code, 0) << status.output;
  EXPECT_NE(status.output.find("done 2"), std::string::npos) << status.output;
  const auto report = Sh(testing::Campaign() + " report --no-figures --out " + (dir_ / "rep").string() + " --db " + db);
  EXPECT_EQ(report.code, 0) << report.output;
  EXPECT_NE(report.output.find("cannot be written here (read-only): the metrics are not stored in it"),
            std::string::npos)
      << report.output;
  EXPECT_TRUE(fs::exists(dir_ / "rep" / "report.md"));
  const auto exported = Sh(testing::Campaign() + " export --out " + (dir_ / "runs.csv").string() + " --db " + db);
  EXPECT_EQ(exported.code, 0) << exported.output;
  EXPECT_NE(exported.output.find("export: the database " + db + " cannot be written here (read-only)"),
            std::string::npos)
      << exported.output;
  EXPECT_EQ(CountLines(ReadFile(dir_ / "runs.csv"), ""), 3);  // header and 2 runs
  const auto run = Sh(testing::Campaign() + " run --engine " + testing::FakeEngine() + " --db " + db);
  EXPECT_EQ(run.code, 3) << run.output;
  EXPECT_NE(run.output.find((dir_ / "ro").string() + " is read-only ("), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("campaign status, show, report and export work read-only"), std::string::npos)
      << run.output;
}

// Campaign report with nothing finished exited 0 without a word.
TEST_F(CliTest, AReportWithNothingFinishedSaysSoAndExitsFive) {
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4, 6]", 1))).code, 0);
  const auto report = Sh(Cmd("report --no-figures --out " + (dir_ / "rep").string()));
  EXPECT_EQ(report.code, 5) << report.output;
  EXPECT_NE(report.output.find("report: no finished run to analyse"), std::string::npos) << report.output;
  const auto exported = Sh(Cmd("export"));
  EXPECT_EQ(exported.code, 5) << exported.output;
  EXPECT_NE(exported.output.find("export: no finished run to analyse"), std::string::npos) << exported.output;
}

// A run directory deleted while its engine ran failed with only "engine exited with
// status 1" (engine.log went with the directory). The runner keeps the log open and tells
// what the engine last said.
TEST_F(CliTest, ARunDirectoryDeletedMidRunSaysWhatTheEngineLastSaid) {
  const std::string engine = testing::BinDir() + "/granary-engine";
  if (!fs::exists(engine)) GTEST_SKIP() << "granary-engine not built";
  const fs::path p = dir_ / "long.json";
  std::ofstream(p) << R"({"name": "gone", "seed": 2, "replicas": 1,
    "base": {"bodies": {"count": 60}, "silo": {"width": 12}, "discharge": {"mode": "reinject", "max_time": 100000,
             "stop_on_clog": false}, "output": {"checkpoint_interval": 0.5, "frame_interval": 0.5}},
    "sweep": {"grid": {"/silo/base_outlets/0/width": [4]}}})";
  ASSERT_EQ(Sh(Cmd("plan " + p.string())).code, 0);
  const fs::path run_dir = fs::path(Status()["runs"][0]["run_dir"].get<std::string>());
  const std::string log = (dir_ / "runner.log").string();
  const pid_t runner = Spawn({testing::Campaign(), "run", "--db", Db(), "--retries", "0"}, log);
  // Deleted once the engine is in its discharge (it has written a checkpoint there).
  ASSERT_TRUE(testing::WaitFor([&] { return fs::exists(run_dir / "checkpoint.bin"); }, 300)) << ReadFile(log);
  fs::remove_all(run_dir);
  EXPECT_EQ(testing::WaitExit(runner), 1) << ReadFile(log);
  const json s = Status();
  ASSERT_EQ(s["counts"]["failed"], 1) << s.dump();
  const std::string failure = s["runs"][0]["failure"];
  EXPECT_EQ(failure.rfind("engine exited with status 1; its run directory " + run_dir.string() +
                              " was deleted while it ran; it last said:\n",
                          0),
            0u)
      << failure;
  EXPECT_NE(failure.find("No such file or directory"), std::string::npos) << failure;
}

}  // namespace
}  // namespace granary::runner
