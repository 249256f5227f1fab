// Tests of planning and leases on the database: planning twice changes nothing, an edited
// spec adds and retires runs without touching finished results, claims never hand the same
// run to two holders, and a dead holder's lease expires.
#include "runner/campaign_db.h"

#include <gtest/gtest.h>

#include <limits>

namespace granary::runner {
namespace {

using nlohmann::json;

CampaignSpec Spec(const std::string& widths) {
  return CampaignSpec::FromJson(json::parse(R"({"name": "t", "replicas": 2, "base": {"silo": {"width": 30}},
      "sweep": {"grid": {"/silo/base_outlets/0/width": )" +
                                            widths + "}}}"));
}

PlanSummary Plan(Store& store, const std::string& widths) {
  const CampaignSpec s = Spec(widths);
  return PlanCampaign(store, s, Expand(s, "/cache"), "/runs", false);
}

std::map<std::string, std::string> States(Store& store) {
  std::map<std::string, std::string> m;
  for (const auto& r : LoadRuns(store, false)) m[r.run_id] = ToString(r.state);
  return m;
}

TEST(PlanTest, PlanningTwiceChangesNothing) {
  Store store(":memory:");
  const PlanSummary first = Plan(store, "[4, 6, 8]");
  EXPECT_EQ(first.added, 6);
  EXPECT_EQ(first.points, 3);
  const auto before = LoadRuns(store, true);
  const PlanSummary again = Plan(store, "[4, 6, 8]");
  EXPECT_EQ(again.added, 0);
  EXPECT_EQ(again.unchanged, 6);
  EXPECT_EQ(again.retired, 0);
  const auto after = LoadRuns(store, true);
  ASSERT_EQ(before.size(), after.size());
  for (std::size_t i = 0; i < before.size(); ++i) {
    EXPECT_EQ(before[i].run_id, after[i].run_id);
    EXPECT_EQ(before[i].params, after[i].params);
    EXPECT_EQ(after[i].run_dir, "/runs/" + after[i].run_id);
  }
}

TEST(PlanTest, DryRunStoresNothing) {
  Store store(":memory:");
  const CampaignSpec s = Spec("[4, 6]");
  const PlanSummary sum = PlanCampaign(store, s, Expand(s, "/cache"), "/runs", true);
  EXPECT_EQ(sum.added, 4);
  EXPECT_TRUE(LoadRuns(store).empty());
  EXPECT_FALSE(LoadCampaign(store).has_value());
}

TEST(PlanTest, EditRetiresAndAddsButKeepsResults) {
  Store store(":memory:");
  Plan(store, "[4, 6]");
  // Finish one width-4 run with a result.
  const Holder me{"h:1:0", "h", 1};
  auto row = ClaimNext(store, me, 100.0, nullptr, {});
  ASSERT_TRUE(row);
  ASSERT_EQ(row->params["silo"]["base_outlets"][0]["width"], 4.0);
  ASSERT_TRUE(RecordDone(store, row->run_id, me.id, json{{"end_reason", "discharged"}, {"exited", 77}}, 110.0, 10.0));

  const PlanSummary edit = Plan(store, "[6, 8]");
  EXPECT_EQ(edit.added, 2);
  EXPECT_EQ(edit.unchanged, 2);
  EXPECT_EQ(edit.retired, 2);
  auto states = States(store);
  EXPECT_EQ(states[row->run_id], "retired");
  {
    Statement q = store.Prepare("SELECT value FROM results WHERE run_id = ?1 AND key = 'exited'");
    q.Bind(1, row->run_id);
    ASSERT_TRUE(q.Step());
    EXPECT_EQ(q.Real(0), 77.0);
  }
  // Back in the spec: the finished run is done again, not re-run.
  const PlanSummary back = Plan(store, "[4, 6, 8]");
  EXPECT_EQ(back.revived, 2);
  states = States(store);
  EXPECT_EQ(states[row->run_id], "done");
  int planned = 0;
  for (const auto& [id, st] : states) planned += st == "planned";
  EXPECT_EQ(planned, 5);
}

TEST(LeaseTest, ClaimsAreExclusiveAndInPlanOrder) {
  Store store(":memory:");
  Plan(store, "[4, 6]");
  const Holder a{"h:1:0", "h", 1}, b{"h:2:0", "h", 2};
  std::set<std::string> seen;
  for (int i = 0; i < 4; ++i) {
    auto r = ClaimNext(store, i % 2 ? a : b, 100.0, nullptr, {});
    ASSERT_TRUE(r);
    EXPECT_EQ(r->seq, i);
    EXPECT_TRUE(seen.insert(r->run_id).second);
  }
  EXPECT_FALSE(ClaimNext(store, a, 100.0, nullptr, {}));
}

TEST(LeaseTest, DeadOrSilentHolderLosesItsLease) {
  Store store(":memory:");
  Plan(store, "[4]");
  const Holder me = ThisProcessHolder();
  // A holder on this host whose pid does not exist (pid_max is far below this).
  const Holder dead{me.host + ":999999999:0", me.host, 999999999};
  const Holder remote{"elsewhere:5:0", "elsewhere", 5};
  auto r1 = ClaimNext(store, dead, NowSeconds(), nullptr, {});
  auto r2 = ClaimNext(store, remote, NowSeconds(), nullptr, {});
  ASSERT_TRUE(r1 && r2);
  EXPECT_EQ(RecoverExpiredLeases(store, me, NowSeconds()), 1);  // the remote one is fresh
  EXPECT_EQ(States(store)[r1->run_id], "interrupted");
  EXPECT_EQ(States(store)[r2->run_id], "running");
  EXPECT_EQ(RecoverExpiredLeases(store, me, NowSeconds() + LeaseStaleSeconds() + 1), 1);  // stale heartbeat
  EXPECT_EQ(States(store)[r2->run_id], "interrupted");
  // An interrupted run is claimed again, attempts counted.
  auto again = ClaimNext(store, me, NowSeconds(), nullptr, {});
  ASSERT_TRUE(again);
  EXPECT_EQ(again->run_id, r1->run_id);
  EXPECT_EQ(again->attempts, 2);
}

// The fault guarded against: a runner whose lease was taken over (it was stopped past the lease
// time) wrote its run's end by run id alone, over the new holder's claim.
TEST(LeaseTest, OnlyTheHolderRecordsAnEnd) {
  Store store(":memory:");
  Plan(store, "[4]");
  const Holder old_holder{"elsewhere:5:0", "elsewhere", 5}, new_holder{"h:2:0", "h", 2};
  auto first = ClaimNext(store, old_holder, 100.0, nullptr, {});
  ASSERT_TRUE(first);
  // The old holder goes silent; a new runner recovers the run and claims it.
  EXPECT_EQ(RecoverExpiredLeases(store, new_holder, 100.0 + LeaseStaleSeconds() + 1), 1);
  auto second = ClaimNext(store, new_holder, 200.0, nullptr, {});
  ASSERT_TRUE(second);
  ASSERT_EQ(second->run_id, first->run_id);
  // The old holder comes back: its heartbeat says it holds nothing, and neither its result
  // nor a failure is recorded.
  EXPECT_TRUE(Heartbeat(store, old_holder, 201.0, {{first->run_id, json{{"fraction", 0.9}}}}).empty());
  EXPECT_FALSE(
      RecordDone(store, first->run_id, old_holder.id, json{{"end_reason", "discharged"}, {"exited", 3}}, 202.0, 1.0));
  EXPECT_FALSE(RecordEnd(store, first->run_id, old_holder.id, RunState::kFailed, "late", 202.0, 1.0));
  const RunRow now_row = LoadRuns(store, false)[0];  // plan order: the claimed run first
  ASSERT_EQ(now_row.run_id, first->run_id);
  EXPECT_EQ(now_row.state, RunState::kRunning);
  EXPECT_EQ(now_row.lease_holder, new_holder.id);
  EXPECT_TRUE(now_row.progress.is_null());
  {
    Statement q = store.Prepare("SELECT COUNT(*) FROM results");
    q.Step();
    EXPECT_EQ(q.Integer(0), 0);
  }
  // The holder's own end is recorded.
  EXPECT_EQ(Heartbeat(store, new_holder, 203.0, {}), std::set<std::string>{first->run_id});
  EXPECT_TRUE(
      RecordDone(store, first->run_id, new_holder.id, json{{"end_reason", "discharged"}, {"exited", 3}}, 204.0, 1.0));
  EXPECT_EQ(LoadRuns(store, false)[0].state, RunState::kDone);
}

// A re-plan that retires a running run takes its lease with it: the runner learns it at its
// next heartbeat and cannot record the run done; revived, the run continues, it is not done.
TEST(LeaseTest, RetiringARunningRunTakesItsLease) {
  Store store(":memory:");
  Plan(store, "[4]");
  const Holder me{"h:1:0", "h", 1};
  auto row = ClaimNext(store, me, 100.0, nullptr, {});
  ASSERT_TRUE(row);
  Plan(store, "[6]");
  EXPECT_EQ(States(store)[row->run_id], "retired");
  EXPECT_TRUE(Heartbeat(store, me, 101.0, {}).empty());
  EXPECT_FALSE(RecordDone(store, row->run_id, me.id, json{{"end_reason", "discharged"}}, 102.0, 2.0));
  EXPECT_EQ(States(store)[row->run_id], "retired");
  Plan(store, "[4]");
  EXPECT_EQ(States(store)[row->run_id], "interrupted");
}

TEST(QueueTest, QueuedRunsAreAdoptedNotRecoveredAndKeepTheirHandle) {
  Store store(":memory:");
  Plan(store, "[4]");  // two runs
  const Holder me = ThisProcessHolder();
  const Holder dead{me.host + ":999999999:0", me.host, 999999999};
  auto r1 = ClaimNext(store, dead, NowSeconds(), nullptr, {});
  auto r2 = ClaimNext(store, dead, NowSeconds(), nullptr, {});
  ASSERT_TRUE(r1 && r2);
  JobArray array{"/db/slurm/t-0001", "/db/slurm/t-0001/job-1.sh", "granary-t-0001", "0%1", "", "", {{r1->run_id, 0}}};
  RecordJobArray(store, dead, array, NowSeconds());
  RecordJobId(store, array.script, "41");
  RecordJobStates(store, {{r1->run_id, "RUNNING"}});
  // The dead runner's local run is recovered; its queued run is not: its job holds it.
  EXPECT_EQ(RecoverExpiredLeases(store, me, NowSeconds()), 1);
  EXPECT_EQ(States(store)[r2->run_id], "interrupted");
  const auto adopted = AdoptQueuedRuns(store, me, NowSeconds());
  ASSERT_EQ(adopted.size(), 1u);
  EXPECT_EQ(adopted[0].run_id, r1->run_id);
  EXPECT_TRUE(adopted[0].Queued());
  EXPECT_EQ(adopted[0].job_id, "41");
  EXPECT_EQ(adopted[0].job_index, 0);
  EXPECT_EQ(adopted[0].job_dir, "/db/slurm/t-0001");
  EXPECT_EQ(adopted[0].job_name, "granary-t-0001");
  EXPECT_EQ(adopted[0].job_state, "RUNNING");
  EXPECT_EQ(adopted[0].lease_holder, me.id);
  // A live watcher keeps it; released, it is free to adopt again.
  const Holder other{"elsewhere:5:0", "elsewhere", 5};
  EXPECT_TRUE(AdoptQueuedRuns(store, other, NowSeconds()).empty());
  EXPECT_EQ(ReleaseQueuedRuns(store, me), 1);
  EXPECT_EQ(States(store)[r1->run_id], "running");
  EXPECT_EQ(AdoptQueuedRuns(store, other, NowSeconds()).size(), 1u);
  // Ended and claimed again, it leaves the queue but the claim still names its last place.
  EXPECT_TRUE(
      RecordEnd(store, r1->run_id, other.id, RunState::kInterrupted, "Slurm task 41_0 CANCELLED", NowSeconds(), 1));
  auto again = ClaimNext(store, me, NowSeconds(), [&](const RunRow& r) { return r.run_id == r1->run_id; }, {});
  ASSERT_TRUE(again);
  EXPECT_EQ(again->job_id, "41");
  EXPECT_EQ(again->job_index, 0);
  for (const auto& r : LoadRuns(store, false)) {
    if (r.run_id == r1->run_id) {
      EXPECT_FALSE(r.Queued());
    }
  }
}

TEST(IngestTest, FlattensScalarsSkippingSpec) {
  const auto m = FlattenScalars(json::parse(
      R"({"spec": {"seed": 1}, "exited": 5, "end_reason": "clogged", "timing": {"wall_s": 2.5}, "exits_per_outlet": [5]})"));
  EXPECT_EQ(m.size(), 3u);
  EXPECT_EQ(m.at("timing/wall_s"), 2.5);
  EXPECT_EQ(m.at("end_reason"), "clogged");
  EXPECT_EQ(m.count("spec/seed"), 0u);
}

TEST(MetricsTest, StoredPerRunAndAnalysisReplacedOnTheNextStore) {
  Store store(":memory:");
  Plan(store, "[10]");
  const std::vector<RunRow> runs = LoadRuns(store, false);
  ASSERT_EQ(runs.size(), 2u);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  StoreMetrics(
      store,
      {{runs[0].run_id, "flow", 1, {{"x", 1}}, {{"q_count", "bodies/sqrt(d/g)", 12.5, 0.5}, {"q_mass", "m", nan, nan}}},
       {runs[1].run_id, "flow", 1, nullptr, {{"q_count", "bodies/sqrt(d/g)", 11.5, nan}}}},
      100.0);
  // The query the database is for: Q of each run with its width.
  Statement q = store.Prepare(
      "SELECT json_extract(r.params, '$.silo.base_outlets[0].width'), m.value, m.se FROM metrics m "
      "JOIN runs r USING (run_id) WHERE m.metric = 'q_count' ORDER BY m.value");
  ASSERT_TRUE(q.Step());
  EXPECT_EQ(q.Real(0), 10.0);
  EXPECT_EQ(q.Real(1), 11.5);
  EXPECT_TRUE(q.IsNull(2));  // NaN is NULL
  ASSERT_TRUE(q.Step());
  EXPECT_EQ(q.Real(2), 0.5);
  // A second analysis replaces the run's rows of that analysis only.
  StoreMetrics(store, {{runs[0].run_id, "flow", 2, nullptr, {{"q_count", "bodies/sqrt(d/g)", 13.0, 0.4}}}}, 200.0);
  const auto all = LoadMetrics(store);
  ASSERT_EQ(all.at(runs[0].run_id).size(), 1u);
  EXPECT_EQ(all.at(runs[0].run_id)[0].version, 2);
  ASSERT_EQ(all.at(runs[0].run_id)[0].metrics.size(), 1u);  // q_mass gone with version 1
  EXPECT_EQ(all.at(runs[0].run_id)[0].metrics[0].value, 13.0);
  EXPECT_EQ(all.at(runs[1].run_id)[0].metrics[0].value, 11.5);
  Statement view = store.Prepare("SELECT COUNT(*) FROM run_metrics");  // runs not done: not in the view
  ASSERT_TRUE(view.Step());
  EXPECT_EQ(view.Integer(0), 0);
}

}  // namespace
}  // namespace granary::runner
