// End-to-end tests of the real `campaign` binary with a fake engine (fake_engine.cpp):
// exit codes, status --json, failures with the log tail, time limits, Ctrl-C, resume after
// `kill -9` of the runner, and two runners on one database never running a run twice.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
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
    setenv("GRANARY_CACHE_DIR", (dir_ / "beds").c_str(), 1);
    setenv("FAKE_ENGINE_STEPS", "10", 1);
    setenv("FAKE_ENGINE_STEP_MS", "20", 1);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A campaign of `widths` x `replicas` runs; max_time 13 makes the fake engine fail.
  std::string WriteSpec(const std::string& widths, int replicas, double max_time = 20) {
    const fs::path p = dir_ / "c.json";
    std::ofstream(p) << json{{"name", "t"},
                             {"replicas", replicas},
                             {"base", {{"bodies", {{"count", 100}}}, {"silo", {{"width", 30}}},
                                       {"discharge", {{"max_time", max_time}}}}},
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
  for (const auto& run : Status()["runs"]) {
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
  const auto t0 = std::chrono::steady_clock::now();
  const auto r = Sh(RunCmd("--time-limit 0.5 --retries 0"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  const json s = Status();
  EXPECT_EQ(std::string(s["runs"][0]["failure"]).rfind("wall-time limit of 0.5 s exceeded", 0), 0u) << s.dump();
}

TEST_F(CliTest, SigintStopsCleanlyAndResumes) {
  setenv("FAKE_ENGINE_STEP_MS", "100", 1);
  Sh(Cmd("plan " + WriteSpec("[4, 6]", 1)));
  const std::string log = (dir_ / "runner.log").string();
  const pid_t pid = testing::Spawn({testing::Campaign(), "run", "--db", Db(), "--jobs", "2", "--engine",
                                    testing::FakeEngine()}, log);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  kill(pid, SIGINT);
  EXPECT_EQ(testing::WaitExit(pid), 130) << ReadFile(log);
  json s = Status();
  EXPECT_EQ(s["counts"]["interrupted"], 2) << s.dump();
  setenv("FAKE_ENGINE_STEP_MS", "20", 1);
  ASSERT_EQ(Sh(RunCmd()).code, 0);
  s = Status();
  EXPECT_EQ(s["counts"]["done"], 2);
  for (const auto& run : s["runs"]) {
    const std::string dir = run["run_dir"];
    EXPECT_EQ(CountLines(ReadFile(fs::path(dir) / "launches.txt"), "finish"), 1);
    EXPECT_NE(ReadFile(fs::path(dir) / "engine.log").find("continuing from checkpoint"), std::string::npos);
  }
}

TEST_F(CliTest, ResumesAfterKillMinusNineOfTheRunner) {
  setenv("FAKE_ENGINE_STEP_MS", "100", 1);  // 1 s per run
  Sh(Cmd("plan " + WriteSpec("[4, 6, 8]", 1)));
  const std::string log = (dir_ / "runner.log").string();
  const pid_t pid = testing::Spawn({testing::Campaign(), "run", "--db", Db(), "--jobs", "2", "--engine",
                                    testing::FakeEngine()}, log);
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
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
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // engines die with their parent

  setenv("FAKE_ENGINE_STEP_MS", "20", 1);
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

TEST_F(CliTest, EngineKilledMinusNineIsRelaunchedFromItsCheckpoint) {
  setenv("FAKE_ENGINE_STEP_MS", "100", 1);
  Sh(Cmd("plan " + WriteSpec("[4]", 1)));
  const std::string log = (dir_ / "runner.log").string();
  const pid_t runner = testing::Spawn({testing::Campaign(), "run", "--db", Db(), "--jobs", "1", "--retries", "1",
                                       "--engine", testing::FakeEngine()}, log);
  // Wait for the engine to start and pass a checkpoint, then kill it (not the runner).
  const json plan = Status();
  const fs::path run_dir = plan["runs"][0]["run_dir"].get<std::string>();
  pid_t engine = 0;
  for (int i = 0; i < 100 && engine == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::istringstream in(ReadFile(run_dir / "launches.txt"));
    std::string word;
    in >> word >> engine;
    if (!fs::exists(run_dir / "checkpoint.fake")) engine = 0;
  }
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
  const std::vector<std::string> argv = {testing::Campaign(), "run", "--db", Db(), "--jobs", "2", "--engine",
                                         testing::FakeEngine()};
  const pid_t a = testing::Spawn(argv, (dir_ / "a.log").string());
  const pid_t b = testing::Spawn(argv, (dir_ / "b.log").string());
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
  EXPECT_EQ(header.rfind("run_id,point_id,replica,engine,end_reason,base_outlets.0.width,q_count,q_count_se,", 0), 0u)
      << header;
  int rows = 0;
  while (std::getline(lines, row)) ++rows;
  EXPECT_EQ(rows, 2);
  const auto points = Sh(Cmd("export --level point --format json --out " + (dir_ / "points.json").string()));
  ASSERT_EQ(points.code, 0) << points.output;
  const json p_json = json::parse(ReadFile(dir_ / "points.json"));
  ASSERT_EQ(p_json.size(), 2u);
  EXPECT_TRUE(p_json[0]["base_outlets.0.width"].is_number());
  EXPECT_EQ(p_json[0]["runs"], 1);
  EXPECT_TRUE(p_json[0].contains("q_count_n"));
  {
    Store store(Db());
    Statement q = store.prepare(
        "SELECT json_extract(r.params, '$.silo.base_outlets[0].width'), m.unit FROM metrics m JOIN runs r USING (run_id) "
        "WHERE m.analysis = 'flow' AND m.metric = 'q_count' ORDER BY 1");
    std::vector<double> widths;
    while (q.step()) {
      widths.push_back(q.real(0));
      EXPECT_EQ(q.text(1), "bodies/sqrt(d/g)");
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
    "sweep": {"grid": {"/silo/base_outlets/0/width": [6]}}})";
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
}

}  // namespace
}  // namespace granary::runner
