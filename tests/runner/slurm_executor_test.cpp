// The Slurm executor's watching logic against a stand-in `squeue` on PATH (a shell script
// whose answers the test sets): a squeue that does not answer proves nothing, a job whose id
// a dead runner never recorded is found by its name and script, and only a job squeue no
// longer knows is decided from the run directory. The real thing is in slurm_test.cpp.
#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "rundir/files.h"
#include "rundir/layout.h"
#include "runner/scheduler.h"
#include "runner/slurm_executor.h"
#include "test_util.h"

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using testing::WaitFor;

class FakeSqueueTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir();
    fs::create_directories(dir_ / "bin");
    fs::create_directories(dir_ / "run");
    // Answers from DIR/answer: "fail" (controller unreachable), "gone" (no such job), or
    // "running" (job 77 task 0 runs, found by name with script DIR/job-1.sh).
    std::ofstream(dir_ / "bin" / "squeue")
        << "#!/bin/bash\n"
        << "answer=$(cat " << (dir_ / "answer").string() << ")\n"
        << "echo \"$*\" >> " << (dir_ / "calls").string() << "\n"
        << "case $answer in\n"
        << "  fail) echo 'slurm_load_jobs error: Unable to contact slurm controller' >&2; exit 1;;\n"
        << "  gone) case \"$*\" in *--name=*) exit 0;; esac\n"
        << "        echo 'slurm_load_jobs error: Invalid job id specified' >&2; exit 1;;\n"
        << "  running) case \"$*\" in *--name=*) echo '77|" << (dir_ / "job-1.sh").string() << "'; exit 0;; esac\n"
        << "        echo '77|0|RUNNING|1795468828|granary-t-0001-1|None'; exit 0;;\n"
        << "esac\n";
    fs::permissions(dir_ / "bin" / "squeue", fs::perms::owner_all);
    old_path_ = std::getenv("PATH");
    setenv("PATH", ((dir_ / "bin").string() + ":" + old_path_).c_str(), 1);
  }
  void TearDown() override {
    setenv("PATH", old_path_.c_str(), 1);
    fs::remove_all(dir_);
  }
  void Answer(const std::string& a) { std::ofstream(dir_ / "answer") << a; }
  int Calls() const { return testing::CountLines(testing::ReadFile(dir_ / "calls"), ""); }
  std::unique_ptr<Executor> Make() {
    SlurmSettings s;
    s.root = (dir_ / "slurm").string();
    s.campaign = std::string(1, 't');
    s.max_array_size = 10;
    s.options.poll_interval = 0.01;
    return MakeSlurmExecutor(s);
  }
  Launch Adopted(const std::string& job_id) {
    Launch l;
    l.run_id = "r1";
    l.argv = {"/bin/true"};
    l.engine = "native";
    l.run_dir = (dir_ / "run").string();
    l.place = QueuePlace{dir_.string(), (dir_ / "job-1.sh").string(), "granary-t-0001-1", 0, job_id, "PENDING"};
    return l;
  }
  fs::path dir_;
  std::string old_path_;
};

TEST_F(FakeSqueueTest, AQueueThatDoesNotAnswerProvesNothing) {
  Answer("fail");
  auto executor = Make();
  executor->Attach(Adopted("77"));
  // Many polls, squeue failing each time: the run is neither ended nor forgotten.
  ASSERT_TRUE(WaitFor(
      [&] {
        EXPECT_TRUE(executor->Poll().empty());
        return Calls() >= 5;
      },
      30));
  EXPECT_EQ(executor->Active(), 1u);
  // Once squeue says the job is gone, the run directory decides: no task record, so its task
  // never started, and the run continues elsewhere.
  Answer("gone");
  std::vector<Finished> ended;
  ASSERT_TRUE(WaitFor(
      [&] {
        ended = executor->Poll();
        return !ended.empty();
      },
      30));
  ASSERT_EQ(ended.size(), 1u);
  EXPECT_NE(ended[0].signal, 0);
  EXPECT_EQ(ended[0].how, "Slurm task 77_0 left the queue before its engine started; it continues from its checkpoint");
  EXPECT_EQ(executor->Active(), 0u);
}

TEST_F(FakeSqueueTest, AJobWhoseIdWasNeverRecordedIsFoundByItsNameOnceSqueueAnswers) {
  Answer("fail");
  auto executor = Make();
  EXPECT_EQ(executor->Attach(Adopted("")).job_id, "");  // not found yet: squeue did not answer
  ASSERT_TRUE(WaitFor(
      [&] {
        EXPECT_TRUE(executor->Poll().empty());
        return Calls() >= 3;
      },
      30));
  EXPECT_TRUE(executor->QueueChanges().empty());
  Answer("running");
  ASSERT_TRUE(WaitFor(
      [&] {
        executor->Poll();
        const auto changes = executor->QueueChanges();
        return changes.count("r1") && changes.at("r1").job_id == "77";
      },
      30));
  // RUNNING: watched, not ended.
  const int calls = Calls();
  ASSERT_TRUE(WaitFor(
      [&] {
        EXPECT_TRUE(executor->Poll().empty());
        return Calls() >= calls + 3;
      },
      30));
  EXPECT_EQ(executor->Active(), 1u);
}

// How a task that left the queue ended, from its state and its run directory.
TEST(SlurmTaskEnd, EveryVerdictFromTheStateAndTheRunDirectory) {
  const fs::path dir = testing::MakeTempDir();
  const QueuePlace place{dir.string(), (dir / "job-1.sh").string(), "granary-t-0001-1", 2, "7", "RUNNING"};
  const auto record = [&](const std::string& job, const std::string& end) {
    std::ofstream(dir / rundir::kSlurmTaskFile)
        << R"({"job": ")" << job << R"(", "node": "n1", "started_at": 100)" << end << "}";
  };
  const auto end = [&](const std::string& state, double time_limit = 0) {
    return SlurmTaskEnd("r", dir.string(), place, state, time_limit, "1:00:00");
  };
  record("7_2", R"(, "exit_code": 3, "ended_at": 110)");
  Finished f = end("FAILED");
  EXPECT_EQ(f.exit_code, 3);
  EXPECT_EQ(f.how, "Slurm task 7_2 FAILED: engine exited with status 3");
  EXPECT_EQ(f.wall_s, 10);
  // Its engine found the directory locked by another engine (engine.lock): it touched
  // nothing, and the run is queued again once the lock is free, not failed.
  record("7_2", R"(, "exit_code": 75, "ended_at": 101)");
  f = end("FAILED");
  EXPECT_EQ(f.exit_code, kExitRunDirectoryBusy);
  EXPECT_EQ(f.signal, 0);
  EXPECT_EQ(EndStateOf(f, false, 0, (dir / "engine.log").string()).first, RunState::kInterrupted);
  record("7_2", R"(, "exit_code": 124, "ended_at": 160)");
  f = end("FAILED", 60);
  EXPECT_TRUE(f.timed_out);
  EXPECT_EQ(f.how, "");  // the scheduler says "wall-time limit of 60 s exceeded"
  record("7_2", R"(, "exit_code": 137, "ended_at": 110)");
  f = end("");
  EXPECT_EQ(f.signal, 9);  // killed from outside before any limit: continues from its checkpoint
  f = end("OUT_OF_MEMORY");
  EXPECT_EQ(f.signal, 0);
  EXPECT_EQ(f.exit_code, 1);
  EXPECT_EQ(f.how.rfind("Slurm task 7_2 OUT_OF_MEMORY: the engine ran out of memory", 0), 0u) << f.how;
  record("7_2", "");
  f = end("TIMEOUT");
  EXPECT_TRUE(f.timed_out);
  EXPECT_EQ(f.how.rfind("Slurm task 7_2 TIMEOUT: Slurm's time limit for the task ran out (--time 1:00:00)", 0), 0u)
      << f.how;
  f = end("CANCELLED");
  EXPECT_EQ(f.signal, SIGTERM);
  EXPECT_EQ(f.how, "Slurm task 7_2 CANCELLED while its engine ran; it continues from its checkpoint");
  f = end("");
  EXPECT_EQ(f.how, "Slurm task 7_2 left the queue while its engine ran; it continues from its checkpoint");
  record("5_2", R"(, "exit_code": 3, "ended_at": 110)");  // an earlier attempt's record
  f = end("PREEMPTED");
  EXPECT_EQ(f.how, "Slurm task 7_2 PREEMPTED before its engine started; it continues from its checkpoint");
  std::ofstream(dir / rundir::kDoneFile) << "discharged\n";
  f = end("FAILED");  // DONE decides
  EXPECT_EQ(f.exit_code, 0);
  EXPECT_EQ(f.signal, 0);
  EXPECT_FALSE(f.timed_out);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace granary::runner
