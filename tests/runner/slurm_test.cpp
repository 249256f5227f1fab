// Tests against a real one-node Slurm (slurm_cluster.h): the cluster itself, then campaigns
// submitted as job arrays by `campaign run --executor slurm` with the fake engine: to done,
// a cancelled task resubmitted from its checkpoint, the runner killed -9 and re-attached,
// arrays split at MaxArraySize, a failing engine, the time limit from the task's start,
// `campaign scan`, and a runner stalled past its lease. Waits are bounded polls on conditions (WaitFor), never timed sleeps; the
// fake engine's FAKE_ENGINE_HOLD keeps runs mid-way until a test lets them go.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>

#include "rundir/progress.h"
#include "rundir/run_directory.h"
#include "runner/campaign_db.h"
#include "runner/slurm_executor.h"
#include "runner/slurm.h"
#include "slurm_cluster.h"
#include "test_util.h"

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::ReadFile;
using testing::Sh;
using testing::SlurmCluster;
using testing::WaitFor;

TEST(SlurmClusterTest, RunsAnArrayAndReportsAFailedTask) {
  SlurmCluster cluster;
  const fs::path dir = testing::MakeTempDir();
  const fs::path script = dir / "task.sh";
  std::ofstream(script) << "#!/bin/bash\necho \"$SLURM_ARRAY_TASK_ID\" > " << dir.string()
                        << "/out.$SLURM_ARRAY_TASK_ID\nexit $((SLURM_ARRAY_TASK_ID == 2 ? 7 : 0))\n";
  const auto submitted = Sh("sbatch --parsable --array=0-2%2 -o /dev/null " + script.string());
  ASSERT_EQ(submitted.code, 0) << submitted.output << cluster.LogTails();
  const std::string job = submitted.output.substr(0, submitted.output.find_first_of(";\n"));
  const auto states = [&] { return Sh("squeue -h -r -t all -j " + job + " -o '%i %T' | sort").output; };
  EXPECT_TRUE(
      WaitFor([&] { return states() == job + "_0 COMPLETED\n" + job + "_1 COMPLETED\n" + job + "_2 FAILED\n"; }, 60))
      << states() << cluster.LogTails();
  for (int i = 0; i < 3; ++i) EXPECT_EQ(ReadFile(dir / ("out." + std::to_string(i))), std::to_string(i) + "\n");
  EXPECT_NE(Sh("scontrol show job " + job + "_2").output.find("ExitCode=7:0"), std::string::npos);
  fs::remove_all(dir);
}

// A campaign on the test cluster: spec, database and runner commands in a private directory.
class SlurmCampaignTest : public ::testing::Test {
 protected:
  void SetUp() override { Start({}); }
  void Start(const SlurmCluster::Options& options) {
    cluster_ = std::make_unique<SlurmCluster>(options);
    dir_ = testing::MakeTempDir();
    chmod(dir_.c_str(), 0755);
    setenv("GRANARY_CACHE_DIR", (dir_ / "beds").c_str(), 1);
    setenv("FAKE_ENGINE_STEPS", "10", 1);
    setenv("FAKE_ENGINE_STEP_MS", "20", 1);
    unsetenv("FAKE_ENGINE_HOLD");
    unsetenv("GRANARY_LEASE_SECONDS");
  }
  void TearDown() override {
    cluster_.reset();  // cancels what is left before the directories go
    fs::remove_all(dir_);
  }
  // `widths` x `replicas` runs; a width listed in `failing` makes the fake engine fail (exit 3),
  // one in `hanging` makes it hang.
  void Plan(const std::vector<int>& widths, int replicas, const std::set<int>& failing = {},
            const std::set<int>& hanging = {}) {
    json points = json::array();
    for (int w : widths) {
      const double max_time = failing.count(w) ? 13 : hanging.count(w) ? 666 : 20;
      points.push_back({{"/silo/base_outlets/0/width", w}, {"/discharge/max_time", max_time}});
    }
    const fs::path p = dir_ / "c.json";
    std::ofstream(p) << json{{"name", "t"},
                             {"replicas", replicas},
                             {"base", {{"bodies", {{"count", 100}}}, {"silo", {{"width", 30}}}}},
                             {"sweep", {{"points", points}}}};
    const auto r = Sh(Cmd("plan " + p.string()));
    ASSERT_EQ(r.code, 0) << r.output;
  }
  std::string Db() const { return (dir_ / "g.db").string(); }
  std::string Cmd(const std::string& verb_and_flags) const {
    return testing::Campaign() + " " + verb_and_flags + " --db " + Db();
  }
  std::vector<std::string> RunArgv(const std::vector<std::string>& flags) const {
    std::vector<std::string> argv = {testing::Campaign(), "run",   "--db",     Db(),
                                     "--executor",        "slurm", "--engine", testing::FakeEngine(),
                                     "--poll-interval",   "0.3"};
    argv.insert(argv.end(), flags.begin(), flags.end());
    return argv;
  }
  std::string RunCmd(const std::string& flags = "") const {
    std::string line;
    for (const auto& a : RunArgv({})) line += a + " ";
    return line + flags;
  }
  json Status() const {
    const auto r = Sh(Cmd("status --json"));
    EXPECT_EQ(r.code, 0) << r.output;
    const json j = json::parse(r.output, nullptr, false);
    EXPECT_FALSE(j.is_discarded()) << r.output;
    return j.is_discarded() ? json::object() : j;
  }
  std::map<std::string, json> RunsById() const {
    std::map<std::string, json> m;
    const json s = Status();
    for (const auto& run : s["runs"]) m[run["run_id"]] = run;
    return m;
  }
  static std::string Launches(const json& run) {
    return ReadFile(fs::path(run["run_dir"].get<std::string>()) / "launches.txt");
  }
  std::string Log(const std::string& name) const { return ReadFile(dir_ / name); }
  // Job handles of every run, once all are recorded ("JOB_TASK").
  std::map<std::string, std::string> JobsOnceSubmitted() const {
    std::map<std::string, std::string> jobs;
    EXPECT_TRUE(WaitFor(
        [&] {
          jobs.clear();
          const json s = Status();
          if (!s.contains("runs") || s["runs"].empty()) return false;
          for (const auto& run : s["runs"]) {
            if (!run.contains("job") || !run["job"].is_string()) return false;
            jobs[run["run_id"]] = run["job"];
          }
          return true;
        },
        60))
        << cluster_->LogTails();
    return jobs;
  }
  std::unique_ptr<SlurmCluster> cluster_;
  fs::path dir_;
};

TEST_F(SlurmCampaignTest, SmallCampaignRunsToDoneAsArrays) {
  Plan({4, 6}, 2);
  const auto r = Sh(RunCmd("--array-max 2"));
  ASSERT_EQ(r.code, 0) << r.output << cluster_->LogTails();
  EXPECT_EQ(testing::CountLines(r.output, "submitted"), 1) << r.output;  // one array
  const json s = Status();
  EXPECT_EQ(s["counts"]["done"], 4) << s.dump(2);
  std::set<std::string> arrays;
  for (const auto& run : s["runs"]) {
    EXPECT_EQ(run["attempts"], 1);
    EXPECT_EQ(run["end_reason"], "discharged");
    EXPECT_EQ(testing::CountLines(Launches(run), "start"), 1);
    const std::string job = run["job"];
    arrays.insert(job.substr(0, job.find('_')));
    // The task recorded itself in the run directory, and Slurm agrees it completed.
    const auto record = ParseTaskRecord(ReadFile(fs::path(run["run_dir"].get<std::string>()) / "slurm-task.json"));
    ASSERT_TRUE(record && record->exit_code);
    EXPECT_EQ(record->job, job);
    EXPECT_EQ(*record->exit_code, 0);
    EXPECT_EQ(Sh("squeue -h -t all -j " + job + " -o %T").output, "COMPLETED\n");
  }
  EXPECT_EQ(arrays.size(), 1u);
  EXPECT_TRUE(fs::exists(dir_ / "slurm" / "t-0001" / "manifest.tsv"));
  EXPECT_NE(ReadFile(dir_ / "slurm" / "t-0001" / "job-1.sh").find("#SBATCH --array=0-3%2\n"), std::string::npos);
  // Nothing left to do: a second run submits nothing.
  const auto again = Sh(RunCmd());
  EXPECT_EQ(again.code, 0) << again.output;
  EXPECT_EQ(testing::CountLines(again.output, "submitted"), 0) << again.output;
}

// Adaptive replicas on Slurm (docs/campaign-spec.md "Adaptive replicas"): the replicas the
// runner adds after the first array's runs end go out as new array jobs. The fake engine's
// flow rate is the same for every replica at max_time 20 and differs by seed at 21
// (fake_engine.cpp), so the first point stops at min and the second grows.
TEST_F(SlurmCampaignTest, AdaptiveReplicasGoOutAsNewArrayJobs) {
#ifndef GRANARY_HAVE_ANALYSIS
  GTEST_SKIP() << "built without the analysis library: no metrics to judge";
#endif
  const json rule = json::parse(R"({"min": 2, "max": 8, "until": {"metric": "q_count", "rel_se": 0.08}})");
  const fs::path p = dir_ / "c.json";
  std::ofstream(p) << json{{"name", "t"},
                           {"seed", 3},
                           {"replicas", rule},
                           {"base", {{"bodies", {{"count", 100}}}, {"silo", {{"width", 30}}}}},
                           {"sweep", {{"grid", {{"/discharge/max_time", {20, 21}}}}}},
                           // the fake engine's 10 exits are all steady flow
                           {"report", {{"window", {{"min_events", 4}, {"start_time", 0}, {"start_fraction", 0}}}}}};
  ASSERT_EQ(Sh(Cmd("plan " + p.string())).code, 0);
  const auto r = Sh(RunCmd());
  ASSERT_EQ(r.code, 0) << r.output << cluster_->LogTails();
  const json s = Status();
  ASSERT_TRUE(s.contains("replicas")) << s.dump(2);
  std::map<int, json> points;  // max_time -> replica progress
  for (const json& point : s["replicas"]["points"]) points[point["point"]["/discharge/max_time"].get<int>()] = point;
  EXPECT_EQ(points[20]["runs"], 2) << points[20].dump();
  EXPECT_EQ(points[20]["verdict"], "met");
  const int grown = points[21]["runs"].get<int>();
  EXPECT_GT(grown, 2) << points[21].dump();
  EXPECT_LE(grown, 8);
  EXPECT_TRUE(points[21]["verdict"] == "met" || points[21]["verdict"] == "at max") << points[21].dump();
  // The first array held the 4 planned runs; every added replica went out in a later array.
  std::map<long long, std::set<int>> arrays;  // job id -> replicas
  for (const json& run : s["runs"]) {
    EXPECT_EQ(run["state"], "done") << run.dump(2);
    EXPECT_EQ(run["attempts"], 1);
    EXPECT_EQ(testing::CountLines(Launches(run), "start"), 1) << Launches(run);
    ASSERT_TRUE(run.contains("job") && run["job"].is_string()) << run.dump(2);
    const std::string job = run["job"];
    arrays[std::stoll(job.substr(0, job.find('_')))].insert(run["replica"].get<int>());
  }
  EXPECT_EQ(static_cast<int>(s["runs"].size()), 2 + grown);
  EXPECT_GE(arrays.size(), 2u);
  EXPECT_EQ(testing::CountLines(r.output, "submitted"), static_cast<int>(arrays.size())) << r.output;
  const std::set<int>& first = arrays.begin()->second;  // job ids grow with submission
  EXPECT_EQ(first, (std::set<int>{0, 1})) << r.output;
  for (auto it = std::next(arrays.begin()); it != arrays.end(); ++it)
    for (int replica : it->second) EXPECT_GE(replica, 2) << it->first;
}

TEST_F(SlurmCampaignTest, CancelledTaskIsResubmittedAndContinuesFromItsCheckpoint) {
  const fs::path hold = dir_ / "go";
  setenv("FAKE_ENGINE_HOLD", hold.c_str(), 1);
  Plan({4, 6}, 1);
  const pid_t runner = testing::Spawn(RunArgv({"--retries", "1"}), (dir_ / "runner.log").string());
  const auto jobs = JobsOnceSubmitted();
  ASSERT_EQ(jobs.size(), 2u);
  const auto runs = RunsById();
  const std::string victim = jobs.begin()->first;
  const fs::path victim_dir = runs.at(victim)["run_dir"].get<std::string>();
  // Mid-run: held after its fifth step's checkpoint.
  ASSERT_TRUE(WaitFor(
      [&] {
        const auto p = rundir::ReadProgress(victim_dir);
        return p && p->fraction >= 0.5;
      },
      60))
      << cluster_->LogTails();
  const std::string task = jobs.at(victim);
  ASSERT_EQ(Sh("scancel " + task).code, 0);
  ASSERT_TRUE(WaitFor([&] { return Sh("squeue -h -t all -j " + task + " -o %T").output == "CANCELLED\n"; }, 60));
  std::ofstream(hold) << "";
  EXPECT_EQ(testing::WaitExit(runner), 0) << Log("runner.log");
  const auto after = RunsById();
  for (const auto& [id, run] : after) {
    EXPECT_EQ(run["state"], "done") << run.dump(2);
    const std::string launches = Launches(run);
    EXPECT_EQ(testing::CountLines(launches, "finish"), 1) << launches;
    EXPECT_EQ(testing::CountLines(launches, "start"), id == victim ? 2 : 1) << launches;
    EXPECT_EQ(run["attempts"], id == victim ? 2 : 1);
  }
  EXPECT_NE(ReadFile(victim_dir / "engine.log").find("continuing from checkpoint at step 5"), std::string::npos)
      << ReadFile(victim_dir / "engine.log");
  EXPECT_NE(Log("runner.log").find("Slurm task " + task + " CANCELLED while its engine ran"), std::string::npos)
      << Log("runner.log");
  // Resubmitted by index into its own submission, as a new array job.
  const std::string index = task.substr(task.find('_') + 1);
  EXPECT_NE(ReadFile(dir_ / "slurm" / "t-0001" / "job-2.sh").find("#SBATCH --array=" + index + "\n"),
            std::string::npos);
  EXPECT_NE(after.at(victim)["job"], task);
}

TEST_F(SlurmCampaignTest, RunnerKilledMinusNineReattachesWithZeroDoubleExecutions) {
  const fs::path hold = dir_ / "go";
  setenv("FAKE_ENGINE_HOLD", hold.c_str(), 1);
  Plan({4, 6, 8}, 1);
  const pid_t first = testing::Spawn(RunArgv({}), (dir_ / "first.log").string());
  const auto jobs = JobsOnceSubmitted();
  ASSERT_EQ(jobs.size(), 3u);
  // Some tasks are at work (held mid-run) when the runner dies.
  ASSERT_TRUE(WaitFor([&] { return Sh("squeue -h -t running -o %i").output.size() > 0; }, 60));
  kill(first, SIGKILL);
  testing::WaitExit(first);
  json s = Status();
  EXPECT_EQ(s["counts"]["running"], 3) << s.dump(2);
  ASSERT_TRUE(s.contains("queue")) << s.dump(2);
  EXPECT_EQ(s["queue"]["live"], true);
  int queued = 0;
  for (const auto& [state, n] : s["queue"]["arrays"][0]["states"].items()) {
    EXPECT_TRUE(state == "PENDING" || state == "RUNNING") << state;
    queued += n.get<int>();
  }
  EXPECT_EQ(queued, 3);
  const auto text = Sh(Cmd("status"));
  EXPECT_NE(text.output.find("Slurm queue (live):"), std::string::npos) << text.output;

  const pid_t second = testing::Spawn(RunArgv({}), (dir_ / "second.log").string());
  ASSERT_TRUE(WaitFor([&] { return Log("second.log").find("watching them again") != std::string::npos; }, 60))
      << Log("second.log");
  std::ofstream(hold) << "";
  EXPECT_EQ(testing::WaitExit(second), 0) << Log("second.log");
  EXPECT_NE(Log("second.log").find("3 run(s) already in the queue: watching them again"), std::string::npos);
  EXPECT_EQ(testing::CountLines(Log("second.log"), "submitted"), 0) << Log("second.log");
  for (const auto& [id, run] : RunsById()) {
    EXPECT_EQ(run["state"], "done");
    EXPECT_EQ(run["attempts"], 1);
    EXPECT_EQ(run["job"], jobs.at(id));
    EXPECT_EQ(testing::CountLines(Launches(run), "start"), 1);
    EXPECT_EQ(testing::CountLines(Launches(run), "finish"), 1);
  }
}

// The lease guarantee on Slurm: a runner stopped past its lease (kill -STOP) while its jobs
// run; a second runner adopts them and collects them; the first, continued, lets them go —
// it records nothing and cancels nothing. Every run ran once.
TEST_F(SlurmCampaignTest, AStalledRunnerThatLostItsLeaseRecordsNothingAndCancelsNothing) {
  setenv("GRANARY_LEASE_SECONDS", "3", 1);
  const fs::path hold = dir_ / "go";
  setenv("FAKE_ENGINE_HOLD", hold.c_str(), 1);
  Plan({4, 6}, 1);
  const pid_t stalled = testing::Spawn(RunArgv({}), (dir_ / "stalled.log").string());
  // Whatever happens below, the stalled runner is continued and reaped.
  struct Reap {
    pid_t pid;
    bool reaped = false;
    ~Reap() {
      if (reaped) return;
      kill(pid, SIGCONT);
      kill(pid, SIGKILL);
      testing::WaitExit(pid);
    }
  } reap{stalled};
  const auto jobs = JobsOnceSubmitted();
  ASSERT_EQ(jobs.size(), 2u);
  ASSERT_TRUE(WaitFor([&] { return Sh("squeue -h -t running -o %i").output.size() > 0; }, 60)) << cluster_->LogTails();
  kill(stalled, SIGSTOP);
  ASSERT_TRUE(WaitFor(
      [&] {
        for (const auto& [id, run] : RunsById())
          if (!run.value("lease_expired", false)) return false;
        return true;
      },
      60));
  const pid_t adopter = testing::Spawn(RunArgv({}), (dir_ / "adopter.log").string());
  ASSERT_TRUE(WaitFor([&] { return Log("adopter.log").find("watching them again") != std::string::npos; }, 60))
      << Log("adopter.log");
  std::ofstream(hold) << "";
  EXPECT_EQ(testing::WaitExit(adopter), 0) << Log("adopter.log");
  kill(stalled, SIGCONT);
  EXPECT_EQ(testing::WaitExit(stalled), 0) << Log("stalled.log");
  reap.reaped = true;
  EXPECT_NE(Log("stalled.log").find("lease lost"), std::string::npos) << Log("stalled.log");
  EXPECT_EQ(testing::CountLines(Log("adopter.log"), "submitted"), 0) << Log("adopter.log");
  for (const auto& [id, run] : RunsById()) {
    EXPECT_EQ(run["state"], "done") << run.dump(2);
    EXPECT_EQ(run["attempts"], 1);
    EXPECT_EQ(testing::CountLines(Launches(run), "start"), 1);
    EXPECT_EQ(testing::CountLines(Launches(run), "finish"), 1);
    // Not cancelled by the runner that lost it.
    EXPECT_EQ(Sh("squeue -h -t all -j " + jobs.at(id) + " -o %T").output, "COMPLETED\n");
  }
}

TEST_F(SlurmCampaignTest, NativeRunsUseThreadsAndLiggghtsRunsMpiRanksUnderSrun) {
  const fs::path p = dir_ / "real.json";
  std::ofstream(p) << json{{"name", "real"},
                           {"seed", 2},
                           {"engine", {"native", "liggghts"}},
                           {"base",
                            {{"bodies", {{"count", 20}, {"species", {{{"shape", "dumbbell"}}}}}},
                             {"silo", {{"width", 12}, {"base_outlets", {{{"center", 0}, {"width", 6}}}}}},
                             {"bed", {{"max_settle_time", 5}, {"settle_ke_per_body", 1e-3}}},
                             {"discharge", {{"mode", "reinject"}, {"max_time", 1}, {"stop_on_clog", false}}}}}};
  ASSERT_EQ(Sh(Cmd("plan " + p.string())).code, 0);
  const auto r =
      Sh(testing::Campaign() + " run --db " + Db() + " --executor slurm --cpus-per-run 2 --poll-interval 0.3");
  ASSERT_EQ(r.code, 0) << r.output << cluster_->LogTails();
  const json s = Status();
  ASSERT_EQ(s["counts"]["done"], 2) << s.dump(2);
  for (const auto& run : s["runs"]) {
    const fs::path dir = run["run_dir"].get<std::string>();
    const json summary = json::parse(ReadFile(dir / "summary.json"));
    EXPECT_EQ(summary["timing"]["threads"], 2) << run["engine"];
    if (run["engine"] == "liggghts") {
      // Two MPI ranks started by srun inside the task.
      EXPECT_NE(ReadFile(dir / "engine.log").find("srun --mpi=pmix --ntasks=2 "), std::string::npos)
          << ReadFile(dir / "engine.log");
      EXPECT_NE(ReadFile(dir / "log.discharge").find("2 by 1 by 1 MPI processor grid"), std::string::npos);
    }
  }
}

// A runner killed inside sbatch: the places of its runs are recorded, the job id is not. The
// next runner finds a submitted job by its name and script and watches it; an array that was
// never submitted is submitted again. Either way each run runs once.
TEST_F(SlurmCampaignTest, RunnerDeadInsideSbatchLeavesNothingToRunTwice) {
  Plan({4, 6}, 1);
  {
    Store store(Db());
    const Holder me = ThisProcessHolder();
    const Holder dead{me.host + ":999999999:0", me.host, 999999999};  // a pid that does not exist
    SlurmSettings settings;
    settings.root = (dir_ / "slurm").string();
    settings.campaign = "t";
    auto executor = MakeSlurmExecutor(settings);
    for (int i = 0; i < 2; ++i) {
      auto row = ClaimNext(store, dead, NowSeconds(), nullptr, {});
      ASSERT_TRUE(row);
      rundir::WriteRunSpec(row->run_dir, row->params);
      Launch l;
      l.run_id = row->run_id;
      l.argv = {testing::FakeEngine(), "run", row->run_dir, "--threads", "1"};
      l.engine = row->engine;
      l.run_dir = row->run_dir;
      executor->Start(l);
      // The first run goes into an array that is submitted, the second into one that is not.
      const auto placed = executor->Place();
      ASSERT_EQ(placed.size(), 1u);
      RecordJobArray(store, dead, placed[0], NowSeconds());
      if (i == 0) {
        const auto submitted = executor->Submit();
        ASSERT_EQ(submitted.size(), 1u);
        ASSERT_TRUE(submitted[0].error.empty()) << submitted[0].error;
      }
    }
  }
  const auto r = Sh(RunCmd());
  ASSERT_EQ(r.code, 0) << r.output << cluster_->LogTails();
  EXPECT_NE(r.output.find("2 run(s) already in the queue: watching them again"), std::string::npos) << r.output;
  EXPECT_EQ(testing::CountLines(r.output, "submitted"), 1) << r.output;  // only the one that never was
  for (const auto& [id, run] : RunsById()) {
    EXPECT_EQ(run["state"], "done") << run.dump(2);
    EXPECT_EQ(testing::CountLines(Launches(run), "start"), 1) << Launches(run);
  }
}

TEST_F(SlurmCampaignTest, ArrayRefusedBySbatchLeavesItsRunsInterruptedWithSbatchsWords) {
  Plan({4, 6}, 1);
  const auto refused = Sh(RunCmd("--partition nosuchpartition"));
  EXPECT_EQ(refused.code, 1) << refused.output;
  EXPECT_NE(refused.output.find("not submitted"), std::string::npos) << refused.output;
  for (const auto& [id, run] : RunsById()) {
    EXPECT_EQ(run["state"], "interrupted");
    EXPECT_NE(run["failure"].get<std::string>().find("Invalid partition name specified"), std::string::npos)
        << run.dump(2);
    EXPECT_FALSE(fs::exists(fs::path(run["run_dir"].get<std::string>()) / "launches.txt"));
  }
  // Nothing is lost: with a partition that exists, they run.
  const auto r = Sh(RunCmd());
  ASSERT_EQ(r.code, 0) << r.output;
  for (const auto& [id, run] : RunsById()) EXPECT_EQ(run["state"], "done");
}

class SlurmSmallArraysTest : public SlurmCampaignTest {
 protected:
  void SetUp() override {
    SlurmCluster::Options o;
    o.max_array_size = 3;
    Start(o);
  }
};

TEST_F(SlurmSmallArraysTest, ArrayLargerThanMaxArraySizeIsSplit) {
  Plan({3, 4, 5, 6, 7, 8, 9}, 1);
  const auto dry = Sh(RunCmd("--array-max 2 --dry-run"));
  ASSERT_EQ(dry.code, 0) << dry.output;
  EXPECT_NE(dry.output.find("7 runs in 3 array(s); MaxArraySize 3;"), std::string::npos) << dry.output;
  EXPECT_FALSE(fs::exists(dir_ / "slurm"));  // a dry run writes nothing
  const auto r = Sh(RunCmd("--array-max 2"));
  ASSERT_EQ(r.code, 0) << r.output << cluster_->LogTails();
  EXPECT_EQ(testing::CountLines(r.output, "submitted"), 3) << r.output;
  std::map<std::string, int> runs_per_array;
  const json s = Status();
  for (const auto& run : s["runs"]) {
    EXPECT_EQ(run["state"], "done");
    EXPECT_EQ(run["attempts"], 1);
    const std::string job = run["job"];
    EXPECT_LT(std::stoi(job.substr(job.find('_') + 1)), 3);  // indices below MaxArraySize
    ++runs_per_array[job.substr(0, job.find('_'))];
  }
  EXPECT_EQ(runs_per_array.size(), 3u);
  std::multiset<int> sizes;
  for (const auto& [job, n] : runs_per_array) sizes.insert(n);
  EXPECT_EQ(sizes, (std::multiset<int>{1, 3, 3}));
  // The throttle holds for the campaign: each array after the first waits for the one before.
  EXPECT_NE(r.output.find("(3 runs, --array=0-2%2)"), std::string::npos) << r.output;
  EXPECT_EQ(ParseManifest(ReadFile(dir_ / "slurm" / "t-0003" / "manifest.tsv")).size(), 1u);
}

TEST_F(SlurmCampaignTest, FailingEngineMarksItsRunFailedWithItsLogTail) {
  Plan({4, 6}, 1, {6});
  const auto r = Sh(RunCmd("--retries 0"));
  EXPECT_EQ(r.code, 1) << r.output;
  const json s = Status();
  for (const auto& run : s["runs"]) {
    if (run["point"]["/silo/base_outlets/0/width"] == 4) {
      EXPECT_EQ(run["state"], "done");
      continue;
    }
    EXPECT_EQ(run["state"], "failed");
    const std::string failure = run["failure"];
    EXPECT_EQ(
        failure.rfind("Slurm task " + run["job"].get<std::string>() + " FAILED: engine exited with status 3\n", 0), 0u)
        << failure;
    EXPECT_NE(failure.find("fake_engine: deliberate failure at step 5"), std::string::npos) << failure;
  }
}

TEST_F(SlurmCampaignTest, TimeLimitCountsFromTheTasksStartNotFromSubmission) {
  // One task at a time: the second waits in the queue while the first hangs until its limit.
  Plan({4, 6}, 1, {}, {4});
  const auto r = Sh(RunCmd("--array-max 1 --time-limit 2 --retries 0"));
  EXPECT_EQ(r.code, 1) << r.output;
  std::map<int, json> by_width;
  const json s = Status();
  for (const auto& run : s["runs"]) by_width[run["point"]["/silo/base_outlets/0/width"]] = run;
  EXPECT_EQ(by_width[4]["state"], "failed");
  EXPECT_EQ(by_width[4]["failure"].get<std::string>().rfind("wall-time limit of 2 s exceeded", 0), 0u)
      << by_width[4].dump(2);
  EXPECT_EQ(by_width[6]["state"], "done") << by_width[6].dump(2);
  const auto first = ParseTaskRecord(ReadFile(fs::path(by_width[4]["run_dir"].get<std::string>()) / "slurm-task.json"));
  const auto second =
      ParseTaskRecord(ReadFile(fs::path(by_width[6]["run_dir"].get<std::string>()) / "slurm-task.json"));
  ASSERT_TRUE(first && second);
  // The second run was submitted with the first yet started after the first's limit.
  EXPECT_GE(second->started_at - first->started_at, 2);
}

// Each array's --time is the estimate of its longest run (what `campaign plan --json` says of
// the point, calibrated by granary-engine bench on this machine) times 2 plus 10 minutes,
// rounded up to a minute: in the submitted script and in Slurm's TimeLimit. --time set by the
// user wins. The runs are of full size (20,000 discs, 100 time units: a core-quarter-hour and more, so that the
// factor 2 shows beside the 10 minutes); the fake engine runs them in a moment.
TEST_F(SlurmCampaignTest, EachArraysTimeIsTheEstimateWithItsMarginUnlessSet) {
  const fs::path spec = dir_ / "big.json";
  auto plan_widths = [&](const std::vector<int>& widths) {
    std::ofstream(spec) << json{{"name", "t"},
                                {"replicas", 1},
                                {"base",
                                 {{"bodies", {{"count", 20000}}},
                                  {"silo", {{"width", 100}}},
                                  {"discharge", {{"mode", "reinject"}, {"max_time", 100}}}}},
                                {"sweep", {{"grid", {{"/silo/base_outlets/0/width", widths}}}}}};
    const auto r = Sh(Cmd("plan " + spec.string()));
    ASSERT_EQ(r.code, 0) << r.output;
  };
  plan_widths({20});
  const auto plan = Sh(Cmd("plan " + spec.string() + " --dry-run --json"));
  ASSERT_EQ(plan.code, 0) << plan.output;
  const json e = json::parse(plan.output.substr(plan.output.find('{')))["estimate"];
  ASSERT_TRUE(e["core_hours"].is_array()) << "no calibration: " << e.dump();
  const double core_s = e["points"][0]["core_hours"][1].get<double>() * 3600;
  ASSERT_GT(core_s, 900) << e.dump();
  const long want_minutes = static_cast<long>(std::ceil((2 * core_s + 600) / 60));
  char want[32];
  std::snprintf(want, sizeof want, "%02ld:%02ld:00", want_minutes / 60, want_minutes % 60);
  auto time_limit = [&](const std::string& job) {
    const std::string out = Sh("scontrol show job " + job.substr(0, job.find('_'))).output;
    const auto at = out.find("TimeLimit=");
    return at == std::string::npos ? out : out.substr(at + 10, out.find_first_of(" \n", at) - at - 10);
  };
  const auto r = Sh(RunCmd());
  ASSERT_EQ(r.code, 0) << r.output << cluster_->LogTails();
  const std::string script = ReadFile(dir_ / "slurm" / "t-0001" / "job-1.sh");
  EXPECT_NE(script.find("#SBATCH --time=0-" + std::string(want) + "\n"), std::string::npos) << want << "\n" << script;
  const json s = Status();
  ASSERT_EQ(s["runs"].size(), 1u);
  EXPECT_EQ(time_limit(s["runs"][0]["job"]), want);
  // Set by the user: that time, whatever the estimate.
  plan_widths({20, 30});
  const auto set = Sh(RunCmd("--time 7:00"));
  ASSERT_EQ(set.code, 0) << set.output << cluster_->LogTails();
  EXPECT_NE(ReadFile(dir_ / "slurm" / "t-0002" / "job-1.sh").find("#SBATCH --time=7:00\n"), std::string::npos);
  int checked = 0;
  const json after = Status();
  for (const auto& run : after["runs"]) {
    if (run["point"]["/silo/base_outlets/0/width"] == 30) {
      EXPECT_EQ(time_limit(run["job"]), "00:07:00");
      ++checked;
    }
  }
  EXPECT_EQ(checked, 1) << after.dump();
}

TEST_F(SlurmCampaignTest, ScanAgreesWithTheDatabaseAndCollectsADetachedCampaign) {
  Plan({4, 6}, 2);
  const auto detached = Sh(RunCmd("--detach"));
  ASSERT_EQ(detached.code, 0) << detached.output;
  EXPECT_NE(detached.output.find("detached"), std::string::npos) << detached.output;
  json s = Status();
  EXPECT_EQ(s["counts"]["running"], 4) << s.dump(2);
  // Every task records its end in its run directory; nothing watches the jobs meanwhile.
  ASSERT_TRUE(WaitFor(
      [&] {
        for (const auto& run : s["runs"]) {
          const auto rec = ParseTaskRecord(ReadFile(fs::path(run["run_dir"].get<std::string>()) / "slurm-task.json"));
          if (!rec || !rec->exit_code) return false;
        }
        return true;
      },
      60))
      << cluster_->LogTails();
  EXPECT_EQ(Status()["counts"]["running"], 4);  // the database does not know yet
  auto scan = Sh(Cmd("scan --json"));
  ASSERT_EQ(scan.code, 0) << scan.output;
  json report = json::parse(scan.output);
  EXPECT_EQ(report["changes"].size(), 4u) << report.dump(2);
  for (const auto& c : report["changes"]) {
    EXPECT_EQ(c["from"], "running");
    EXPECT_EQ(c["to"], "done");
    EXPECT_EQ(c["written"], true);
  }
  s = Status();
  EXPECT_EQ(s["counts"]["done"], 4);
  for (const auto& run : s["runs"]) EXPECT_EQ(run["end_reason"], "discharged");
  // Now the database and the directories agree, and a scan changes nothing.
  scan = Sh(Cmd("scan --json"));
  report = json::parse(scan.output);
  EXPECT_EQ(report["agrees"], true) << report.dump(2);
  EXPECT_EQ(report["counts"]["done"], 4);
  EXPECT_NE(Sh(Cmd("scan")).output.find("the database agrees with the run directories"), std::string::npos);
}

}  // namespace
}  // namespace granary::runner
