// The scheduler in-process against a fake executor (as ninja tests its builder with a
// FakeCommandRunner): no engine processes, no sleeps, a fake clock. Each poll of the fake
// executor is one step of a scripted world: engines finish, a stop is requested, another
// runner takes a lease over, a re-plan retires a run, another engine holds a directory.
#include "runner/scheduler.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "rundir/files.h"
#include "runner/campaign_db.h"
#include "runner/campaign_spec.h"
#include "test_util.h"

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// An engine that exists only as a promise: it ends `polls` polls after its start (done:
// DONE and summary.json written, as the engine would; or with an exit code), or when stopped.
struct FakeRun {
  Launch launch;
  int ends_at_poll = 0;
  int exit_code = 0;
  bool writes_done = true;
  std::optional<StopReason> stopped;
};

class FakeExecutor : public Executor {
 public:
  explicit FakeExecutor(int slots) : slots_(slots) {}
  bool CanStartMore() const override { return static_cast<int>(running_.size()) < slots_; }
  void Start(const Launch& launch) override {
    FakeRun r;
    r.launch = launch;
    r.ends_at_poll = polls + run_polls;
    r.exit_code = next_exit_code;
    r.writes_done = next_exit_code == 0;
    if (on_start) on_start(r);
    started.push_back(launch.run_id);
    running_[launch.run_id] = r;
  }
  std::vector<Finished> Poll() override {
    ++polls;
    clock += 1.0;
    if (on_poll) on_poll(polls);
    std::vector<Finished> out;
    for (auto it = running_.begin(); it != running_.end();) {
      FakeRun& r = it->second;
      Finished f;
      f.run_id = it->first;
      if (r.stopped) {
        f.signal = *r.stopped == StopReason::kLeaseLost ? 9 : 15;
      } else if (polls >= r.ends_at_poll) {
        f.exit_code = r.exit_code;
        if (r.writes_done) WriteDone(fs::path(r.launch.argv.at(2)), it->first);
      } else {
        ++it;
        continue;
      }
      out.push_back(f);
      it = running_.erase(it);
    }
    return out;
  }
  void Stop(const std::string& run_id, StopReason reason) override {
    stops.emplace_back(run_id, reason);
    if (auto it = running_.find(run_id); it != running_.end()) it->second.stopped = reason;
  }
  void StopAll(StopReason reason) override {
    for (auto& [id, r] : running_) Stop(id, reason);
  }
  std::size_t Active() const override { return running_.size(); }

  static void WriteDone(const fs::path& dir, const std::string& run_id) {
    std::ofstream(dir / "summary.json") << json{{"run_id", run_id}, {"end_reason", "discharged"}, {"exited", 7}}.dump();
    std::ofstream(dir / "DONE") << "discharged\n";
  }

  int run_polls = 3;
  int next_exit_code = 0;
  int polls = 0;
  double clock = 0;
  std::function<void(int)> on_poll;
  std::function<void(FakeRun&)> on_start;
  std::vector<std::string> started;
  std::vector<std::pair<std::string, StopReason>> stops;

 private:
  int slots_;
  std::map<std::string, FakeRun> running_;
};

class RecordingObserver : public RunObserver {
 public:
  void OnBegin(int, int, int) override {}
  void OnEvent(const std::string& run_id, const std::string& state, const std::string& message) override {
    events.push_back(run_id + " " + state + ": " + message);
  }
  void OnTick(const std::vector<ActiveRun>&, int, int, int) override {}
  void OnEnd(int, int, int) override {}
  int Count(const std::string& what) const {
    int n = 0;
    for (const auto& e : events) n += e.find(what) != std::string::npos;
    return n;
  }
  std::string All() const {
    std::string s;
    for (const auto& e : events) s += e + "\n";
    return s;
  }
  std::vector<std::string> events;
};

class SchedulerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir();
    store_ = std::make_unique<Store>((dir_ / "g.db").string());
    Plan("[4, 6]");
    options_.jobs = 2;
    options_.engine = testing::FakeEngine();  // must exist; the fake executor never runs it
    options_.poll_interval = 0;
    options_.tick_interval = 0;
    options_.heartbeat_interval = 2;
    options_.holder = Holder{"test-runner:1:0", ThisProcessHolder().host, static_cast<int>(getpid())};
    options_.clock = [this] { return executor_.clock; };
  }
  void TearDown() override { fs::remove_all(dir_); }

  void Plan(const std::string& widths) {
    const CampaignSpec spec = CampaignSpec::FromJson(json::parse(
        R"({"name": "t", "base": {"silo": {"width": 30}}, "sweep": {"grid": {"/silo/base_outlets/0/width": )" + widths +
        "}}}"));
    PlanCampaign(*store_, spec, Expand(spec, (dir_ / "beds").string()), (dir_ / "runs").string(), false);
  }
  ExitCode Run() { return RunCampaign(*store_, options_, executor_, observer_, &stop_); }
  std::map<std::string, RunRow> Rows() {
    std::map<std::string, RunRow> m;
    for (auto& r : LoadRuns(*store_, false)) m[r.run_id] = r;
    return m;
  }
  std::vector<std::string> Ids() {
    std::vector<std::string> ids;
    for (const auto& r : LoadRuns(*store_, false)) ids.push_back(r.run_id);
    return ids;
  }
  int ResultCount(const std::string& run_id) {
    Statement q = store_->Prepare("SELECT COUNT(*) FROM results WHERE run_id = ?1");
    q.Bind(1, run_id);
    q.Step();
    return static_cast<int>(q.Integer(0));
  }

  fs::path dir_;
  std::unique_ptr<Store> store_;
  CampaignRunOptions options_;
  FakeExecutor executor_{2};
  RecordingObserver observer_;
  volatile std::sig_atomic_t stop_ = 0;
};

TEST_F(SchedulerTest, RunsEveryRunOnceAndRecordsItDone) {
  EXPECT_EQ(Run(), ExitCode::kOk);
  EXPECT_EQ(executor_.started.size(), 2u);
  for (const auto& [id, row] : Rows()) {
    EXPECT_EQ(row.state, RunState::kDone) << id;
    EXPECT_EQ(row.attempts, 1);
    EXPECT_EQ(ResultCount(id), 3);  // run_id, end_reason, exited
    EXPECT_TRUE(fs::exists(fs::path(row.run_dir) / "run.json"));
  }
  // Again: nothing to do.
  EXPECT_EQ(Run(), ExitCode::kOk);
  EXPECT_EQ(executor_.started.size(), 2u);
}

// Replaces the CLI test that sent SIGINT after 500 ms and expected exactly two interrupted
// runs (it failed under load): the stop is requested once both engines have started.
TEST_F(SchedulerTest, AStopRequestInterruptsTheRunsInFlightAndTheyResume) {
  executor_.run_polls = 100;
  executor_.on_poll = [&](int) {
    if (executor_.Active() == 2) stop_ = 1;
  };
  EXPECT_EQ(Run(), ExitCode::kInterrupted);
  ASSERT_EQ(executor_.stops.size(), 2u);
  for (const auto& [id, reason] : executor_.stops) EXPECT_EQ(reason, StopReason::kInterrupt);
  for (const auto& [id, row] : Rows()) {
    EXPECT_EQ(row.state, RunState::kInterrupted) << id;
    EXPECT_EQ(row.failure, "interrupted by the user (runner stopped)");
    EXPECT_TRUE(row.lease_holder.empty());
  }
  stop_ = 0;
  executor_.run_polls = 2;
  executor_.on_poll = nullptr;
  EXPECT_EQ(Run(), ExitCode::kOk);
  for (const auto& [id, row] : Rows()) {
    EXPECT_EQ(row.state, RunState::kDone) << id;
    EXPECT_EQ(row.attempts, 2);
  }
}

TEST_F(SchedulerTest, ARunOverItsTimeLimitIsStoppedAndFails) {
  options_.time_limit = 5;
  options_.retries = 0;
  executor_.run_polls = 1000;
  EXPECT_EQ(Run(), ExitCode::kRunsFailed);
  ASSERT_EQ(executor_.stops.size(), 2u);
  for (const auto& [id, reason] : executor_.stops) EXPECT_EQ(reason, StopReason::kTimeLimit);
  for (const auto& [id, row] : Rows()) {
    EXPECT_EQ(row.state, RunState::kFailed);
    EXPECT_EQ(row.failure.rfind("wall-time limit of 5 s exceeded\n", 0), 0u) << row.failure;
  }
  EXPECT_LT(executor_.polls, 10);
}

TEST_F(SchedulerTest, AFailedRunIsRetriedThenReported) {
  options_.retries = 1;
  executor_.next_exit_code = 3;
  EXPECT_EQ(Run(), ExitCode::kRunsFailed);
  EXPECT_EQ(executor_.started.size(), 4u);  // two runs, two attempts each
  for (const auto& [id, row] : Rows()) {
    EXPECT_EQ(row.state, RunState::kFailed);
    EXPECT_EQ(row.attempts, 2);
    EXPECT_EQ(row.failure.rfind("engine exited with status 3\n", 0), 0u) << row.failure;
  }
}

// Runner A is stopped (kill -STOP) past its lease; runner B takes the run over.
// When A comes back, its heartbeat finds the run is not its own: it stops its engine at once
// and records nothing (before: A wrote `done` by run id over B's claim).
TEST_F(SchedulerTest, ALeaseTakenOverStopsTheEngineAndRecordsNothing) {
  options_.jobs = 1;
  const std::string first = Ids()[0];
  const Holder other{"other:2:0", "elsewhere", 2};
  executor_.run_polls = 100;
  executor_.on_poll = [&](int poll) {
    if (poll == 1) {
      // Runner B: A's heartbeat is stale, B recovers the run and claims it.
      ASSERT_EQ(RecoverExpiredLeases(*store_, other, NowSeconds() + LeaseStaleSeconds() + 1), 1);
      ASSERT_EQ(ClaimNext(*store_, other, NowSeconds(), nullptr, {})->run_id, first);
    }
  };
  options_.only = {first};
  EXPECT_EQ(Run(), ExitCode::kOk);
  ASSERT_EQ(executor_.stops.size(), 1u);
  EXPECT_EQ(executor_.stops[0], std::make_pair(first, StopReason::kLeaseLost));
  const RunRow row = Rows()[first];
  EXPECT_EQ(row.state, RunState::kRunning);
  EXPECT_EQ(row.lease_holder, other.id);
  EXPECT_EQ(ResultCount(first), 0);
  EXPECT_EQ(observer_.Count("lease lost"), 1) << observer_.All();
}

// The same, but A's engine finished while A was stopped: its result is not recorded either.
TEST_F(SchedulerTest, AResultSeenAfterTheLeaseWasTakenOverIsNotRecorded) {
  const std::string first = Ids()[0];
  const Holder other{"other:2:0", "elsewhere", 2};
  options_.only = {first};
  options_.heartbeat_interval = 1000;  // the engine ends before the next heartbeat
  executor_.run_polls = 2;
  executor_.on_poll = [&](int poll) {
    if (poll == 1) {
      ASSERT_EQ(RecoverExpiredLeases(*store_, other, NowSeconds() + LeaseStaleSeconds() + 1), 1);
      ASSERT_TRUE(ClaimNext(*store_, other, NowSeconds(), nullptr, {}));
    }
  };
  EXPECT_EQ(Run(), ExitCode::kOk);
  const RunRow row = Rows()[first];
  EXPECT_EQ(row.state, RunState::kRunning);
  EXPECT_EQ(row.lease_holder, other.id);
  EXPECT_EQ(ResultCount(first), 0);
  EXPECT_EQ(observer_.Count("its result is not recorded"), 1) << observer_.All();
}

// A run retired by a re-plan while it runs came back `done`.
TEST_F(SchedulerTest, ARunRetiredWhileItRunsIsStoppedAndStaysRetired) {
  executor_.run_polls = 100;
  executor_.on_poll = [&](int poll) {
    if (poll == 1) Plan("[6]");
  };
  EXPECT_EQ(Run(), ExitCode::kOk);
  int retired_runs = 0;
  for (const auto& [id, row] : Rows()) {
    if (row.point["/silo/base_outlets/0/width"] == 4) {
      ++retired_runs;
      EXPECT_EQ(row.state, RunState::kRetired);
      EXPECT_EQ(ResultCount(id), 0);
      ASSERT_EQ(executor_.stops.size(), 1u);
      EXPECT_EQ(executor_.stops[0], std::make_pair(id, StopReason::kLeaseLost));
    } else {
      EXPECT_EQ(row.state, RunState::kDone);
    }
  }
  EXPECT_EQ(retired_runs, 1);
  Plan("[4, 6]");  // back in the spec: it continues, it is not done
  for (const auto& [id, row] : Rows()) {
    if (row.point["/silo/base_outlets/0/width"] == 4) {
      EXPECT_EQ(row.state, RunState::kInterrupted);
    }
  }
}

// An engine of a lost runner still holds the directory (its lock): no second engine starts on
// it; the run waits, then starts when the lock is free.
TEST_F(SchedulerTest, NoEngineStartsOnADirectoryAnotherEngineHolds) {
  const std::string first = Ids()[0];
  const fs::path run_dir = Rows()[first].run_dir;
  fs::create_directories(run_dir);
  auto lock = std::make_unique<RunDirectoryLock>(run_dir);
  int released_at = 0;
  executor_.on_poll = [&](int poll) {
    if (poll == 4) {
      lock.reset();
      released_at = poll;
    }
  };
  executor_.on_start = [&](FakeRun& r) {
    if (r.launch.run_id == first) {
      EXPECT_GT(released_at, 0) << "started while the directory was locked";
    }
  };
  EXPECT_EQ(Run(), ExitCode::kOk);
  EXPECT_EQ(observer_.Count(first + " waiting: its directory is locked by engine pid " + std::to_string(getpid())), 1)
      << observer_.All();
  for (const auto& [id, row] : Rows()) EXPECT_EQ(row.state, RunState::kDone);
  EXPECT_EQ(executor_.started.size(), 2u);
}

// The other engine finished the run while this runner waited: it is ingested, not run again.
TEST_F(SchedulerTest, ARunFinishedByTheEngineThatHeldItsDirectoryIsIngested) {
  const std::string first = Ids()[0];
  const fs::path run_dir = Rows()[first].run_dir;
  fs::create_directories(run_dir);
  auto lock = std::make_unique<RunDirectoryLock>(run_dir);
  executor_.on_poll = [&](int poll) {
    if (poll == 2) {
      FakeExecutor::WriteDone(run_dir, first);
      lock.reset();
    }
  };
  EXPECT_EQ(Run(), ExitCode::kOk);
  EXPECT_EQ(Rows()[first].state, RunState::kDone);
  EXPECT_EQ(ResultCount(first), 3);
  EXPECT_EQ(executor_.started, std::vector<std::string>{Ids()[1]});
}

// An engine that found its directory locked (exit 75) after the runner looked: the run waits
// and starts again; it is not a failure.
TEST_F(SchedulerTest, AnEngineThatFoundItsDirectoryBusyIsStartedAgain) {
  options_.retries = 0;
  int busy = 1;
  executor_.on_start = [&](FakeRun& r) {
    if (busy-- > 0) {
      r.exit_code = kExitRunDirectoryBusy;
      r.writes_done = false;
    }
  };
  EXPECT_EQ(Run(), ExitCode::kOk);
  EXPECT_EQ(executor_.started.size(), 3u);
  for (const auto& [id, row] : Rows()) EXPECT_EQ(row.state, RunState::kDone);
}

// The database stops taking writes while engines run (a full disk, a read-only file): the
// runner stops its engines (they checkpoint) and says what it could not record, instead of
// aborting with its engines killed and its runs left `running` without a word.
TEST_F(SchedulerTest, ADatabaseThatCannotBeWrittenStopsTheEngines) {
  executor_.run_polls = 100;
  executor_.on_poll = [&](int poll) {
    if (poll == 1) store_->Exec("PRAGMA query_only = ON");  // every write now fails
  };
  try {
    Run();
    FAIL() << "expected a StoreError";
  } catch (const StoreError& e) {
    const std::string what = e.what();
    EXPECT_NE(
        what.find("campaign run stopped its engines (they continue from their checkpoints); runs it could not mark "
                  "interrupted show as running with their runner gone"),
        std::string::npos)
        << what;
  }
  ASSERT_EQ(executor_.stops.size(), 2u);
  for (const auto& [id, reason] : executor_.stops) EXPECT_EQ(reason, StopReason::kInterrupt);
  EXPECT_EQ(executor_.Active(), 0u);
  store_->Exec("PRAGMA query_only = OFF");
  for (const auto& [id, row] : Rows()) EXPECT_EQ(row.state, RunState::kRunning);  // as the next runner will find them
}

// A done run whose directory was deleted went unnoticed by `run`. It is reported at
// every start, and run again on request (--rerun-lost).
TEST_F(SchedulerTest, DoneRunsWhoseDirectoryWasDeletedAreReportedAndRunAgainOnRequest) {
  EXPECT_EQ(Run(), ExitCode::kOk);
  const std::string first = Ids()[0];
  fs::remove_all(Rows()[first].run_dir);
  EXPECT_EQ(Run(), ExitCode::kOk);
  EXPECT_EQ(executor_.started.size(), 2u);
  EXPECT_EQ(observer_.Count(" lost: 1 done run(s) have no run directory (deleted after they finished; first " + first),
            1)
      << observer_.All();
  options_.rerun_lost = true;
  EXPECT_EQ(Run(), ExitCode::kOk);
  ASSERT_EQ(executor_.started.size(), 3u);
  EXPECT_EQ(executor_.started.back(), first);
  EXPECT_EQ(Rows()[first].state, RunState::kDone);
  EXPECT_EQ(Rows()[first].attempts, 2);
  EXPECT_TRUE(fs::exists(fs::path(Rows()[first].run_dir) / "DONE"));
}

}  // namespace
}  // namespace granary::runner
