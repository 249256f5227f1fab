// The scheduler with a batch-queue executor, in-process and without Slurm (a fake queue, as
// ninja tests its builder with a fake command runner): the places of the runs are in the
// database before the queue sees a job, an interrupted runner detaches and leaves the jobs
// to a runner that adopts them without starting anything, and --detach submits and returns.
#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <memory>
#include <filesystem>
#include <map>
#include <set>

#include "rundir/files.h"
#include "rundir/run_directory.h"
#include "rundir/summary.h"
#include "runner/campaign_db.h"
#include "runner/scheduler.h"
#include "test_util.h"

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class NullObserver : public RunObserver {
 public:
  void OnBegin(int, int, int) override {}
  void OnEvent(const std::string&, const std::string& state, const std::string&) override { events.push_back(state); }
  void OnTick(const std::vector<ActiveRun>&, int, int, int) override {}
  void OnEnd(int, int, int) override {}
  std::vector<std::string> events;
};

// A queue whose jobs end when the test says so; an ended job with `done` leaves DONE and a
// summary in its run directory, as an engine would.
class FakeQueue : public Executor {
 public:
  std::function<void()> before_submit;   // runs inside Submit(), before any job "exists"
  std::function<void()> on_poll;         // runs at the start of every Poll()
  std::map<std::string, int> exit_once;  // runs whose next job ends with this engine exit status
  std::set<std::string> finish;          // runs whose jobs end at the next poll, done
  std::vector<std::string> started, attached;
  int submissions = 0;

  bool CanStartMore() const override { return true; }
  void Start(const Launch& l) override {
    started.push_back(l.run_id);
    pending_.push_back(l);
  }
  std::vector<JobArray> Place() override {
    if (pending_.empty()) return {};
    JobArray a;
    a.dir = "/queue/a" + std::to_string(arrays_);
    a.script = a.dir + "/job-1.sh";
    a.name = "fake-" + std::to_string(arrays_);
    for (std::size_t i = 0; i < pending_.size(); ++i) {
      a.runs.emplace_back(pending_[i].run_id, static_cast<int>(i));
      queued_[pending_[i].run_id] = pending_[i];
    }
    a.array = "0-" + std::to_string(pending_.size() - 1);
    ++arrays_;
    pending_.clear();
    placed_.push_back(a);
    return {a};
  }
  std::vector<JobArray> Submit() override {
    if (before_submit) before_submit();
    std::vector<JobArray> out;
    for (auto& a : placed_) {
      a.job_id = std::to_string(100 + submissions++);
      out.push_back(a);
    }
    placed_.clear();
    return out;
  }
  QueuePlace Attach(const Launch& l) override {
    attached.push_back(l.run_id);
    queued_[l.run_id] = l;
    return l.place;
  }
  std::vector<Finished> Poll() override {
    if (on_poll) on_poll();
    std::vector<Finished> out = std::move(ready_);
    ready_.clear();
    for (auto it = queued_.begin(); it != queued_.end();) {
      if (auto e = exit_once.find(it->first); e != exit_once.end()) {
        Finished f;
        f.run_id = it->first;
        f.exit_code = e->second;
        out.push_back(f);
        exit_once.erase(e);
        it = queued_.erase(it);
        continue;
      }
      if (!finish.count(it->first)) {
        ++it;
        continue;
      }
      rundir::Summary s;
      s.engine = "fake";
      s.run_id = it->first;
      s.end_reason = "discharged";
      rundir::WriteSummary(it->second.run_dir, s);
      rundir::WriteDone(it->second.run_dir, "discharged");
      Finished f;
      f.run_id = it->first;
      out.push_back(f);
      it = queued_.erase(it);
    }
    return out;
  }
  // As the Slurm executor: a run another runner watches now is let go (its job runs on).
  void Stop(const std::string& id, StopReason reason) override {
    if (reason != StopReason::kLeaseLost || !queued_.erase(id)) return;
    let_go.push_back(id);
    Finished f;
    f.run_id = id;
    f.signal = 15;
    ready_.push_back(f);
  }
  void StopAll(StopReason) override {}
  std::size_t Active() const override { return pending_.size() + queued_.size() + ready_.size(); }
  std::vector<std::string> let_go;
  bool OutlivesRunner() const override { return true; }
  bool LimitsTime() const override { return true; }

 private:
  std::vector<Launch> pending_;
  std::vector<JobArray> placed_;
  std::map<std::string, Launch> queued_;
  std::vector<Finished> ready_;
  int arrays_ = 0;
};

class BatchSchedulerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir();
    store_ = std::make_unique<Store>((dir_ / "g.db").string());
    const CampaignSpec spec = CampaignSpec::FromJson(json::parse(
        R"({"name": "t", "replicas": 3, "base": {"silo": {"width": 30}}, "sweep": {"grid": {"/silo/base_outlets/0/width": [4]}}})"));
    PlanCampaign(*store_, spec, Expand(spec, (dir_ / "beds").string()), (dir_ / "runs").string(), false);
    options_.engine = "/bin/true";  // never run: the fake queue only pretends
    options_.poll_interval = 0;
  }
  void TearDown() override {
    store_.reset();
    fs::remove_all(dir_);
  }
  std::map<std::string, RunRow> Rows() {
    std::map<std::string, RunRow> m;
    for (auto& r : LoadRuns(*store_, false)) m[r.run_id] = r;
    return m;
  }
  fs::path dir_;
  std::unique_ptr<Store> store_;
  CampaignRunOptions options_;
  NullObserver observer_;
};

TEST_F(BatchSchedulerTest, PlacesAreRecordedBeforeTheQueueSeesAJob) {
  FakeQueue queue;
  int checked = 0;
  queue.before_submit = [&] {
    for (const auto& [id, r] : Rows()) {
      EXPECT_TRUE(r.Queued()) << id;  // its place is in the database...
      EXPECT_EQ(r.job_id, "") << id;  // ...and the job does not exist yet
      EXPECT_GE(r.job_index, 0);
      ++checked;
    }
    for (const auto& [id, r] : Rows()) queue.finish.insert(id);
  };
  EXPECT_EQ(RunCampaign(*store_, options_, queue, observer_, nullptr), ExitCode::kOk);
  EXPECT_EQ(checked, 3);
  for (const auto& [id, r] : Rows()) {
    EXPECT_EQ(r.state, RunState::kDone);
    EXPECT_EQ(r.job_id, "100");  // recorded once sbatch answered
    EXPECT_EQ(r.job_dir, "/queue/a0");
  }
  EXPECT_EQ(queue.started.size(), 3u);
}

TEST_F(BatchSchedulerTest, AnInterruptedRunnerDetachesAndTheNextOneAdoptsWithoutStarting) {
  volatile std::sig_atomic_t stop = 0;
  {
    FakeQueue queue;
    queue.before_submit = [&] { stop = 1; };  // Ctrl-C while the jobs are queued
    EXPECT_EQ(RunCampaign(*store_, options_, queue, observer_, &stop), ExitCode::kInterrupted);
    EXPECT_EQ(queue.started.size(), 3u);
  }
  for (const auto& [id, r] : Rows()) {
    EXPECT_TRUE(r.Queued()) << id;  // still in the queue, with nobody watching
    EXPECT_EQ(r.lease_holder, "");
    EXPECT_EQ(r.job_id, "100");
  }
  FakeQueue next;
  for (const auto& [id, r] : Rows()) next.finish.insert(id);
  EXPECT_EQ(RunCampaign(*store_, options_, next, observer_, nullptr), ExitCode::kOk);
  EXPECT_TRUE(next.started.empty());  // nothing started twice
  EXPECT_EQ(next.attached.size(), 3u);
  for (const auto& [id, r] : Rows()) {
    EXPECT_EQ(r.state, RunState::kDone);
    EXPECT_EQ(r.attempts, 1);
  }
}

// The lease guarantee with a batch queue: a runner stalled past its lease, whose queued runs
// another runner adopted, lets their jobs go and records nothing, not even the results its
// jobs left; the adopter records them.
TEST_F(BatchSchedulerTest, ARunnerThatLostItsLeaseLetsTheJobsGoAndRecordsNothing) {
  const Holder stalled{"elsewhere:5:0", "elsewhere", 5};
  const Holder me = ThisProcessHolder();
  const Holder adopter{me.host + ":999999999:0", me.host, 999999999};  // dead by the time we look
  options_.holder = stalled;
  options_.tick_interval = 0;
  options_.heartbeat_interval = 0;
  FakeQueue queue;
  bool taken = false;
  queue.on_poll = [&] {
    if (taken || Rows().begin()->second.job_id.empty()) return;
    taken = true;
    // The stalled runner's lease has expired: the adopter takes its queued runs, and the
    // jobs finish (DONE and summary.json in their directories).
    ASSERT_EQ(AdoptQueuedRuns(*store_, adopter, NowSeconds() + LeaseStaleSeconds() + 1).size(), 3u);
    for (const auto& [id, r] : Rows()) {
      fs::create_directories(r.run_dir);
      rundir::Summary summary;
      summary.engine = "fake";
      summary.run_id = id;
      summary.end_reason = "discharged";
      rundir::WriteSummary(r.run_dir, summary);
      rundir::WriteDone(r.run_dir, "discharged");
    }
  };
  // At its next heartbeat the stalled runner finds that it holds nothing.
  EXPECT_EQ(RunCampaign(*store_, options_, queue, observer_, nullptr), ExitCode::kOk);
  EXPECT_TRUE(taken);
  EXPECT_EQ(queue.let_go.size(), 3u);  // let go, not cancelled: the adopter watches the jobs
  for (const auto& [id, r] : Rows()) {
    EXPECT_EQ(r.state, RunState::kRunning) << id;  // nothing recorded by the stalled runner
    EXPECT_EQ(r.lease_holder, adopter.id);
    EXPECT_TRUE(r.Queued());
  }
  EXPECT_EQ(std::count(observer_.events.begin(), observer_.events.end(), "lease lost"), 3);
  // A later runner (the adopter is gone) attaches and ingests, starting nothing.
  options_.holder.reset();
  FakeQueue next;
  for (const auto& [id, r] : Rows()) next.finish.insert(id);
  EXPECT_EQ(RunCampaign(*store_, options_, next, observer_, nullptr), ExitCode::kOk);
  EXPECT_TRUE(next.started.empty());
  for (const auto& [id, r] : Rows()) {
    EXPECT_EQ(r.state, RunState::kDone) << id;
    EXPECT_EQ(r.attempts, 1);
  }
}

// A task whose engine found its run directory locked by another engine (engine.lock; exit
// 75) touched nothing: the run waits while the lock is held and is queued again once it is
// free, never marked failed.
TEST_F(BatchSchedulerTest, ATaskThatFoundItsDirectoryLockedIsQueuedAgainOnceFree) {
  const std::string busy_run = Rows().begin()->first;
  const fs::path busy_dir = Rows().begin()->second.run_dir;
  fs::create_directories(busy_dir);
  std::unique_ptr<RunDirectoryLock> lock;
  FakeQueue queue;
  // Another engine (a stray task of an earlier attempt) takes the directory once the run is
  // queued: the run's own task finds it locked.
  queue.before_submit = [&] {
    if (queue.submissions == 0) lock = std::make_unique<RunDirectoryLock>(busy_dir);
  };
  queue.exit_once[busy_run] = kExitRunDirectoryBusy;
  int polls_while_waiting = 0;
  queue.on_poll = [&] {
    for (const auto& [id, r] : Rows()) {
      if (id != busy_run) queue.finish.insert(id);
    }
    if (!queue.exit_once.empty() || !lock) return;
    // Its task has ended busy: while the lock is held, it is not queued again.
    EXPECT_EQ(std::count(queue.started.begin(), queue.started.end(), busy_run), 1);
    EXPECT_EQ(Rows()[busy_run].state, RunState::kRunning);  // claimed, waiting; not failed
    if (++polls_while_waiting == 3) {
      lock.reset();  // the other engine ends
      queue.finish.insert(busy_run);
    }
  };
  EXPECT_EQ(RunCampaign(*store_, options_, queue, observer_, nullptr), ExitCode::kOk);
  EXPECT_EQ(polls_while_waiting, 3);
  EXPECT_EQ(std::count(queue.started.begin(), queue.started.end(), busy_run),
            2);  // queued again once the lock was free
  EXPECT_EQ(queue.started.size(), 4u);
  for (const auto& [id, r] : Rows()) {
    EXPECT_EQ(r.state, RunState::kDone) << id;
    EXPECT_EQ(r.attempts, 1) << id;
  }
}

TEST_F(BatchSchedulerTest, DetachSubmitsAndReturns) {
  FakeQueue queue;
  options_.detach = true;
  EXPECT_EQ(RunCampaign(*store_, options_, queue, observer_, nullptr), ExitCode::kOk);
  EXPECT_EQ(queue.submissions, 1);
  for (const auto& [id, r] : Rows()) {
    EXPECT_TRUE(r.Queued());
    EXPECT_EQ(r.lease_holder, "");
  }
}

}  // namespace
}  // namespace granary::runner
