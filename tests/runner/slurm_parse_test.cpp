// The Slurm executor's pure parts (slurm.h): options, the manifest, --array values, the batch
// script (run by bash with the variables Slurm would set, no Slurm needed), squeue and
// scontrol output, and what each job state means for a run.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "rundir/run_spec.h"
#include "runner/campaign_spec.h"
#include "runner/slurm.h"
#include "test_util.h"

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

TEST(SlurmArraySpec, RangesWhereConsecutiveAndTheThrottle) {
  EXPECT_EQ(ArraySpec({0, 1, 2, 5, 7, 8}, 0), "0-2,5,7-8");
  EXPECT_EQ(ArraySpec({0, 1, 2, 3}, 2), "0-3%2");
  EXPECT_EQ(ArraySpec({4}, 0), "4");
  EXPECT_EQ(ArraySpec({3, 17}, 8), "3,17%8");
}

TEST(SlurmManifest, RoundTripsAndRefusesTabsInFields) {
  const std::vector<ManifestEntry> entries = {{0, "aa11", "native", "/opt/g/granary-engine", "/data/c/runs/aa11"},
                                              {1, "bb22", "liggghts", "/opt/g/granary-liggghts", "/data/my runs/bb22"}};
  const std::string text = ManifestText(entries);
  EXPECT_EQ(text,
            "# index\trun_id\tengine\texecutable\trun_dir\n"
            "0\taa11\tnative\t/opt/g/granary-engine\t/data/c/runs/aa11\n"
            "1\tbb22\tliggghts\t/opt/g/granary-liggghts\t/data/my runs/bb22\n");
  const auto back = ParseManifest(text);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[1].run_dir, "/data/my runs/bb22");
  EXPECT_EQ(back[1].engine, "liggghts");
  EXPECT_THROW(ManifestText({{0, "x", "native", "/a", "/b\tc"}}), std::invalid_argument);
  EXPECT_THROW(ParseManifest("0\tx\tnative\n"), std::invalid_argument);
}

TEST(SlurmSqueue, ParsesArrayTasksPlainJobsAndSkipsNoise) {
  const auto entries = ParseSqueue(
      "12|3|PENDING|0|granary-t-0001|JobArrayTaskLimit\n"
      "12|0|RUNNING|1795468828|granary-t-0001|None\n"
      "15|N/A|COMPLETED|1795468830|other|None\n"
      "squeue: warning: something\n"
      "12|1|CANCELLED|1795468828|granary-t-0001|reason|with|bars\n");
  ASSERT_EQ(entries.size(), 4u);
  EXPECT_EQ(entries[0].job_id, "12");
  EXPECT_EQ(entries[0].task, 3);
  EXPECT_EQ(entries[0].state, "PENDING");
  EXPECT_EQ(entries[0].started_at, 0);
  EXPECT_EQ(entries[0].reason, "JobArrayTaskLimit");
  EXPECT_EQ(entries[1].started_at, 1795468828);
  EXPECT_EQ(entries[2].task, -1);
  EXPECT_EQ(entries[3].name, "granary-t-0001");
  EXPECT_EQ(entries[3].reason, "reason|with|bars");
}

TEST(SlurmConfig, MaxArraySizeFromShowConfig) {
  EXPECT_EQ(ParseMaxArraySize("Configuration data as of 2026-11-23T21:20:11\n"
                              "MailType                = (null)\n"
                              "MaxArraySize            = 4\n"
                              "MaxJobCount             = 10000\n"),
            4);
  EXPECT_EQ(ParseMaxArraySize("MaxJobCount = 10000\n"), 1001);
}

TEST(SlurmStates, EveryStateTheIssueNamesMapsOntoARunState) {
  EXPECT_EQ(FateOf("PENDING"), TaskFate::kQueued);
  EXPECT_EQ(FateOf("REQUEUED"), TaskFate::kQueued);
  EXPECT_EQ(FateOf("CONFIGURING"), TaskFate::kQueued);
  EXPECT_EQ(FateOf("RUNNING"), TaskFate::kRunning);
  EXPECT_EQ(FateOf("COMPLETING"), TaskFate::kRunning);
  EXPECT_EQ(FateOf("SUSPENDED"), TaskFate::kRunning);
  EXPECT_EQ(FateOf("COMPLETED"), TaskFate::kCompleted);
  EXPECT_EQ(FateOf("FAILED"), TaskFate::kFailed);
  EXPECT_EQ(FateOf("OUT_OF_MEMORY"), TaskFate::kFailed);
  EXPECT_EQ(FateOf("TIMEOUT"), TaskFate::kTimedOut);
  EXPECT_EQ(FateOf("PREEMPTED"), TaskFate::kLost);
  EXPECT_EQ(FateOf("NODE_FAIL"), TaskFate::kLost);
  EXPECT_EQ(FateOf("CANCELLED"), TaskFate::kLost);
  EXPECT_EQ(FateOf("CANCELLED+"), TaskFate::kLost);
  EXPECT_EQ(FateOf("BOOT_FAIL"), TaskFate::kLost);
  EXPECT_EQ(FateOf("SOMETHING_NEW"), TaskFate::kRunning);  // never resubmit what we do not understand
  EXPECT_TRUE(IsQueuedOrRunning(FateOf("PENDING")));
  EXPECT_FALSE(IsQueuedOrRunning(FateOf("TIMEOUT")));
}

TEST(SlurmTime, FormatsAndRecognisesSlurmTimes) {
  EXPECT_EQ(SlurmTime(3600), "0-01:00:00");
  EXPECT_EQ(SlurmTime(61), "0-00:02:00");
  EXPECT_EQ(SlurmTime(0.5), "0-00:01:00");
  EXPECT_EQ(SlurmTime(90000), "1-01:00:00");
  for (const char* good : {"30", "30:00", "4:00:00", "1-12", "1-12:30", "2-00:00:00", "UNLIMITED"}) {
    EXPECT_TRUE(IsSlurmTime(good)) << good;
  }
  for (const char* bad : {"", "1h", "4:00:00:00", "-1", "1-", "abc"}) EXPECT_FALSE(IsSlurmTime(bad)) << bad;
}

TEST(SlurmOptions, ExecutorBlockErrorsNameThePath) {
  SlurmOptions o;
  EXPECT_EQ(ParseExecutorBlock(json{{"type", "slurm"},
                                    {"partition", "short"},
                                    {"time", "2:00:00"},
                                    {"cpus_per_run", 4},
                                    {"array_max", 50},
                                    {"sbatch_args", {"--qos=long"}}},
                               "/executor", o),
            "slurm");
  EXPECT_EQ(o.partition, "short");
  EXPECT_EQ(o.time, "2:00:00");
  EXPECT_EQ(o.cpus_per_run, 4);
  EXPECT_EQ(o.array_max, 50);
  EXPECT_EQ(o.sbatch_args, std::vector<std::string>{"--qos=long"});
  const auto error = [](const json& block) {
    SlurmOptions unused;
    try {
      ParseExecutorBlock(block, "/executor", unused);
    } catch (const SpecError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error(json{{"partition", "x"}}), "/executor/type: must be \"local\" or \"slurm\" (got nothing)");
  EXPECT_EQ(error(json{{"type", "slurm"}, {"partiton", "x"}}),
            "/executor/partiton: unknown key; did you mean \"partition\"?");
  EXPECT_EQ(error(json{{"type", "slurm"}, {"time", "2h"}}),
            "/executor/time: must be a Slurm time such as \"30\", \"4:00:00\" or \"1-12:00:00\" (got \"2h\")");
  EXPECT_EQ(error(json{{"type", "slurm"}, {"cpus_per_run", 0}}),
            "/executor/cpus_per_run: must be an integer >= 1 (got 0)");
  EXPECT_EQ(error(json{{"type", "slurm"}, {"sbatch_args", {"qos=long"}}}),
            "/executor/sbatch_args/0: must be one sbatch option such as \"--qos=long\" (got \"qos=long\")");
}

TEST(SlurmOptions, CampaignSpecCarriesAValidatedExecutorBlock) {
  const json block = {{"type", "slurm"}, {"array_max", 8}};
  EXPECT_EQ(CampaignSpec::FromJson(json{{"name", "t"}, {"executor", block}}).executor, block);
  EXPECT_TRUE(CampaignSpec::FromJson(json{{"name", "t"}}).executor.is_null());
  try {
    CampaignSpec::FromJson(json{{"name", "t"}, {"executor", {{"type", "pbs"}}}});
    ADD_FAILURE() << "no error";
  } catch (const SpecError& e) {
    EXPECT_EQ(std::string(e.what()), "/executor/type: must be \"local\" or \"slurm\" (got \"pbs\")");
  }
}

TEST(SlurmTaskRecord, ParsesStartAndEnd) {
  auto r = ParseTaskRecord(R"({"job": "12_3", "run_id": "ab", "node": "n1", "started_at": 100})");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->job, "12_3");
  EXPECT_FALSE(r->exit_code);
  r = ParseTaskRecord(R"({"job": "12_3", "node": "n1", "started_at": 100, "exit_code": 124, "ended_at": 160})");
  ASSERT_TRUE(r);
  EXPECT_EQ(*r->exit_code, 124);
  EXPECT_TRUE(EndedByTimeLimit(*r, 60));
  EXPECT_FALSE(EndedByTimeLimit(*r, 0));
  r->exit_code = 137;
  EXPECT_TRUE(EndedByTimeLimit(*r, 60));
  EXPECT_FALSE(EndedByTimeLimit(*r, 600));  // killed by something else before the limit
  EXPECT_FALSE(ParseTaskRecord("{\"job\": "));
}

class SlurmScriptTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir();
    run_dir_ = dir_ / "runs" / "r1";
    fs::create_directories(run_dir_);
    fs::create_directories(dir_ / "logs");
    setenv("FAKE_ENGINE_STEPS", "3", 1);
    setenv("FAKE_ENGINE_STEP_MS", "10", 1);
  }
  void TearDown() override { fs::remove_all(dir_); }
  void WriteRun(double max_time) {
    std::ofstream(run_dir_ / "run.json") << json{
        {"run_id", "r1"},
        {"bodies", {{"count", 10}}},
        {"discharge", {{"max_time", max_time}}}}.dump();
  }
  // Writes the manifest and the script, then runs the script as Slurm would run task 1.
  testing::Result RunTask(double time_limit) {
    std::ofstream(dir_ / "manifest.tsv") << ManifestText(
        {{0, "r0", "native", "/nonexistent", "/nonexistent"},
         {1, "r1", "native", testing::FakeEngine(), run_dir_.string()}});
    BatchJob job;
    job.job_name = "granary-t-0001";
    job.array = "0-1%1";
    job.manifest = (dir_ / "manifest.tsv").string();
    job.log_dir = (dir_ / "logs").string();
    job.engine = "native";
    job.time_limit = time_limit;
    job.options.cpus_per_run = 2;
    std::ofstream(dir_ / "job.sh") << BatchScript(job);
    return testing::Sh("env SLURM_ARRAY_JOB_ID=77 SLURM_ARRAY_TASK_ID=1 SLURM_CPUS_PER_TASK=2 bash " +
                       (dir_ / "job.sh").string());
  }
  fs::path dir_, run_dir_;
};

TEST_F(SlurmScriptTest, HeaderCarriesTheOptions) {
  BatchJob job;
  job.job_name = "granary-t-0002";
  job.array = "3,17%8";
  job.manifest = "/data/c/slurm/t-0002/manifest.tsv";
  job.log_dir = "/data/c/slurm/t-0002/logs";
  job.engine = "liggghts";
  job.dependency = "afterany:41";
  job.time_limit = 3600;
  job.options.partition = "short";
  job.options.account = "proj7";
  job.options.cpus_per_run = 4;
  job.options.sbatch_args = {"--qos=long", "--mem-per-cpu=2G"};
  const std::string s = BatchScript(job);
  const std::string header =
      "#SBATCH --job-name=granary-t-0002\n#SBATCH --array=3,17%8\n#SBATCH --ntasks=4\n#SBATCH --cpus-per-task=1\n"
      "#SBATCH --output=/data/c/slurm/t-0002/logs/%A_%a.out\n#SBATCH --partition=short\n#SBATCH --account=proj7\n"
      "#SBATCH --time=0-01:02:00\n#SBATCH --dependency=afterany:41\n#SBATCH --qos=long\n#SBATCH --mem-per-cpu=2G\n";
  EXPECT_NE(s.find(header), std::string::npos) << s;
  EXPECT_NE(s.find("manifest='/data/c/slurm/t-0002/manifest.tsv'\ntime_limit=3600 "), std::string::npos) << s;
  EXPECT_NE(s.find("srun --mpi=pmix"), std::string::npos);
  job.options.time = "4:00:00";
  job.engine = "native";
  EXPECT_NE(BatchScript(job).find("#SBATCH --ntasks=1\n#SBATCH --cpus-per-task=4\n"), std::string::npos);
  EXPECT_NE(BatchScript(job).find("#SBATCH --time=4:00:00\n"), std::string::npos);
}

TEST_F(SlurmScriptTest, TaskRunsItsRunAndRecordsTheExit) {
  WriteRun(20);
  const auto r = RunTask(0);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(run_dir_ / "DONE"));
  EXPECT_NE(testing::ReadFile(run_dir_ / "engine.log").find("progress phase=discharge fraction=1"), std::string::npos);
  const auto record = ParseTaskRecord(testing::ReadFile(run_dir_ / "slurm-task.json"));
  ASSERT_TRUE(record);
  EXPECT_EQ(record->job, "77_1");
  ASSERT_TRUE(record->exit_code);
  EXPECT_EQ(*record->exit_code, 0);
  EXPECT_GE(record->ended_at, record->started_at);
}

TEST_F(SlurmScriptTest, FailingEngineExitStatusIsRecorded) {
  WriteRun(13);  // the fake engine fails with status 3
  const auto r = RunTask(0);
  EXPECT_EQ(r.code, 3) << r.output;
  const auto record = ParseTaskRecord(testing::ReadFile(run_dir_ / "slurm-task.json"));
  ASSERT_TRUE(record && record->exit_code);
  EXPECT_EQ(*record->exit_code, 3);
  EXPECT_NE(testing::ReadFile(run_dir_ / "engine.log").find("deliberate failure"), std::string::npos);
}

TEST_F(SlurmScriptTest, TimeLimitCountsFromTheTaskStart) {
  WriteRun(666);  // the fake engine hangs
  const auto r = RunTask(0.3);
  EXPECT_EQ(r.code, 124) << r.output;
  const auto record = ParseTaskRecord(testing::ReadFile(run_dir_ / "slurm-task.json"));
  ASSERT_TRUE(record);
  EXPECT_TRUE(EndedByTimeLimit(*record, 0.3));
}

TEST_F(SlurmScriptTest, UnknownIndexFailsWithAMessage) {
  WriteRun(20);
  std::ofstream(dir_ / "manifest.tsv") << ManifestText({});
  BatchJob job;
  job.array = "0";
  job.manifest = (dir_ / "manifest.tsv").string();
  job.log_dir = (dir_ / "logs").string();
  job.engine = "native";
  std::ofstream(dir_ / "job.sh") << BatchScript(job);
  const auto r = testing::Sh("env SLURM_ARRAY_JOB_ID=77 SLURM_ARRAY_TASK_ID=5 bash " + (dir_ / "job.sh").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("granary: array index 5 is not in " + job.manifest), std::string::npos) << r.output;
}

}  // namespace
}  // namespace granary::runner
