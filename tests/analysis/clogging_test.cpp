// Avalanches, t_f / t_c / N_u and the clogging index from constructed exit streams.
#include "analysis/clogging.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace granary::analysis {
namespace {

std::vector<rundir::ExitEvent> At(std::initializer_list<double> times, int outlet = 0) {
  std::vector<rundir::ExitEvent> ev;
  for (double t : times) ev.push_back({t, 0, "dumbbell", 1.0, outlet});
  return ev;
}

TEST(ClogSeries, StretchesAvalanchesAndTimes) {
  // Flow 1..3, clog 3 -> 10, flow 10..11, clog 11 -> 20, flow 20..23, clogged until the end (30).
  const auto ev = At({1, 2, 3, 10, 11, 20, 21, 22, 23});
  const ClogSeries s = ComputeClogSeries(ev, -1, 30.0, 5.0, RunEnd::kOther);
  ASSERT_EQ(s.flowing.size(), 3u);
  ASSERT_EQ(s.clogged.size(), 3u);
  EXPECT_EQ(s.AvalancheSizes(), (std::vector<double>{3, 2, 4}));
  EXPECT_EQ(s.FlowingTimes(), (std::vector<double>{3, 1, 3}));  // 0->3, 10->11, 20->23
  EXPECT_EQ(s.CloggedTimes(), (std::vector<double>{7, 9}));     // the last clog is censored
  EXPECT_FALSE(s.clogged.back().complete);
  EXPECT_EQ(s.Unclogs(), 2);

  const ClogSeries list[] = {s};
  const IntermittencyStats st = Intermittency(list);
  EXPECT_DOUBLE_EQ(st.t_flowing.mean, 7.0 / 3.0);
  EXPECT_EQ(st.t_flowing.n, 3);
  EXPECT_DOUBLE_EQ(st.t_clogged.mean, 8.0);
  EXPECT_DOUBLE_EQ(st.unclog_rate, 2.0 / 30.0);
}

TEST(ClogSeries, EndsFlowingOrStoppedOnClog) {
  const auto ev = At({1, 2, 3, 4});
  // Ended while flowing: the only stretch is incomplete, no avalanche.
  const ClogSeries flowing = ComputeClogSeries(ev, -1, 6.0, 5.0, RunEnd::kOther);
  EXPECT_TRUE(flowing.AvalancheSizes().empty());
  EXPECT_TRUE(flowing.clogged.empty());
  // The engine stopped on a clog: one avalanche of 4.
  const ClogSeries clogged = ComputeClogSeries(ev, -1, 6.0, 5.0, RunEnd::kClogged);
  EXPECT_EQ(clogged.AvalancheSizes(), std::vector<double>{4});
  // Stopped long after the last exit: a clog, unless the engine judged the stall a discharge
  // (the silo ran out of what can flow): then no avalanche and no clog, but an earlier gap stays one.
  EXPECT_EQ(ComputeClogSeries(ev, -1, 20.0, 5.0, RunEnd::kOther).AvalancheSizes(), std::vector<double>{4});
  const ClogSeries discharged = ComputeClogSeries(At({1, 2, 10, 11}), -1, 20.0, 5.0, RunEnd::kDischarged);
  EXPECT_EQ(discharged.AvalancheSizes(), std::vector<double>{2});
  EXPECT_EQ(discharged.clogged.size(), 1u);
  EXPECT_FALSE(discharged.flowing.back().complete);
  EXPECT_EQ(RunEndOf("discharged"), RunEnd::kDischarged);
  EXPECT_EQ(RunEndOf("clogged"), RunEnd::kClogged);
  EXPECT_EQ(RunEndOf("time_limit"), RunEnd::kOther);
  // An engine that stops on the first clog it judges did not stop at the gap and found the silo
  // discharged: not a clog for the silo as a whole, while one outlet's own stream keeps its gap.
  const ClogSeries trickle = ComputeClogSeries(At({1, 2, 10, 11}), -1, 20.0, 5.0, RunEnd::kDischarged, true);
  EXPECT_TRUE(trickle.clogged.empty());
  EXPECT_TRUE(trickle.AvalancheSizes().empty());
  EXPECT_EQ(ComputeClogSeries(At({1, 2, 10, 11}), -1, 20.0, 5.0, RunEnd::kClogged, true).AvalancheSizes(),
            (std::vector<double>{2, 2}));
  EXPECT_EQ(ComputeClogSeries(At({1, 2, 10, 11}), 0, 20.0, 5.0, RunEnd::kDischarged, true).clogged.size(), 1u);
}

TEST(ClogSeries, PerOutlet) {
  // Outlet 1 flows steadily; outlet 0 clogs between 2 and 12.
  auto ev = At({1, 2, 12, 13});
  for (double t = 0.5; t < 15; t += 1.0) ev.push_back({t, 0, "disc", 1.0, 1});
  std::sort(ev.begin(), ev.end(), [](auto& a, auto& b) { return a.time < b.time; });
  EXPECT_EQ(ComputeClogSeries(ev, 0, 15.0, 5.0, RunEnd::kOther).CloggedTimes(), std::vector<double>{10});
  EXPECT_TRUE(ComputeClogSeries(ev, 1, 15.0, 5.0, RunEnd::kOther).clogged.empty());
  EXPECT_TRUE(ComputeClogSeries(ev, -1, 15.0, 5.0, RunEnd::kOther).clogged.empty());  // the silo never stops
}

TEST(ClogSeries, StartUpDelayIsNotAClogButABlockedOutletIs) {
  // The first body needs 3 time units to leave (gap from the opening > clog_gap = 2): not a clog.
  const auto ev = At({3.0, 3.5, 4.0, 4.5});
  const ClogSeries s = ComputeClogSeries(ev, -1, 5.0, 2.0, RunEnd::kOther);
  EXPECT_TRUE(s.clogged.empty());
  // Outlet 0 stays blocked until t = 10 while outlet 1 flows from t = 3: a clog from 3 to 10.
  auto two = At({10.0, 10.5}, 0);
  for (double t = 3.0; t < 12.0; t += 0.5) two.push_back({t, 0, "disc", 1.0, 1});
  std::sort(two.begin(), two.end(), [](auto& a, auto& b) { return a.time < b.time; });
  const ClogSeries o0 = ComputeClogSeries(two, 0, 12.0, 2.0, RunEnd::kOther);
  EXPECT_EQ(o0.CloggedTimes(), std::vector<double>{7.0});
  EXPECT_EQ(o0.AvalancheSizes(), std::vector<double>{0.0});  // clogged before its first exit
}

TEST(Avalanches, MeanHistogramAndTail) {
  const std::vector<double> sizes = {10, 20, 30, 40};
  const AvalancheStats a = ComputeAvalancheStats(sizes, 4);
  EXPECT_DOUBLE_EQ(a.size.mean, 25.0);
  EXPECT_EQ(a.size.n, 4);
  EXPECT_NEAR(a.size.se, std::sqrt(500.0 / 3.0 / 4.0), 1e-12);
  EXPECT_DOUBLE_EQ(a.histogram.Total(), 4.0);
  EXPECT_DOUBLE_EQ(a.tail.s_min, 25.0);  // median
  EXPECT_EQ(a.tail.n_tail, 2);
  // Exponential avalanches with mean 50 (geometric, q = 50/51): tail decay recovered.
  std::mt19937_64 rng(3);
  std::geometric_distribution<int> geo(1.0 / 51.0);
  std::vector<double> s;
  for (int i = 0; i < 5000; ++i) s.push_back(geo(rng));
  const AvalancheStats b = ComputeAvalancheStats(s);
  const double decay = -1.0 / std::log(50.0 / 51.0);
  EXPECT_NEAR(b.tail.s_decay, decay, 4.0 * b.tail.s_decay_se);
  EXPECT_NEAR(b.size.mean, 50.0, 4.0 * b.size.se);
}

TEST(ClogIndex, Equation31WithDiscardRule) {
  constexpr RunEnd kC = RunEnd::kClogged, kD = RunEnd::kDischarged;
  const std::vector<ClogRun> runs = {
      {kD, 1000, 50, 950},                        // free: stagnant 50
      {kD, 1000, 70, 930},                        // free: stagnant 70 -> N_u = 60
      {kC, 1000, 560, 440}, {kC, 1000, 950, 50},  // clogged before 100 left: discarded
      {kC, 1000, 300, 700},
  };
  const ClogIndex ci = CloggingIndex(runs, 100);
  EXPECT_DOUBLE_EQ(ci.n_stagnant, 60.0);
  EXPECT_EQ(ci.discarded, 1);
  EXPECT_EQ(ci.clogged, 2);
  EXPECT_EQ(ci.discharged, 2);
  EXPECT_EQ(ci.unfinished, 0);
  EXPECT_EQ(ci.psi.n, 4);
  EXPECT_NEAR(ci.psi.mean, (500.0 - 10.0 + 10.0 + 240.0) / 940.0 / 4.0, 1e-14);
  EXPECT_TRUE(std::isnan(ci.psi_low));
  // All clogged and no stagnant count known: N_u and Psi are missing, and said so.
  const std::vector<ClogRun> all_clogged = {{kC, 100, 50, 50}, {kC, 100, 30, 70}};
  const ClogIndex c2 = CloggingIndex(all_clogged, 10);
  EXPECT_TRUE(std::isnan(c2.psi.mean));
  EXPECT_EQ(c2.psi.n, 0);
  EXPECT_TRUE(std::isnan(c2.n_stagnant));
  EXPECT_NE(c2.note.find("N_u missing"), std::string::npos);
  EXPECT_DOUBLE_EQ(CloggingIndex(all_clogged, 10, 20.0).psi.mean, (30.0 / 80.0 + 10.0 / 80.0) / 2.0);
}

// 8000 dumbbells, W = 11 with max_time 150. Two runs clogged (7000 and 7286
// left), one reached the time limit still flowing with 6080 inside; N_u = 860 from a full
// discharge at W = 14. The time-limited run is neither clogged nor discharged: it is left out
// and its 6080 is not N_u. Psi = ((7000 - 860) + (7286 - 860)) / 2 / 7140 = 0.88.
TEST(ClogIndex, ARunThatReachedItsTimeLimitIsNeither) {
  const std::vector<ClogRun> w11 = {
      {RunEnd::kClogged, 8000, 7000, 1000}, {RunEnd::kClogged, 8000, 7286, 714}, {RunEnd::kOther, 8000, 6080, 1920}};
  // Without a stagnant count the time-limited run must not stand in for one.
  const ClogIndex alone = CloggingIndex(w11, 100);
  EXPECT_TRUE(std::isnan(alone.n_stagnant));
  EXPECT_TRUE(std::isnan(alone.psi.mean));
  const ClogIndex ci = CloggingIndex(w11, 100, 860.0);
  EXPECT_EQ(ci.clogged, 2);
  EXPECT_EQ(ci.discharged, 0);
  EXPECT_EQ(ci.unfinished, 1);
  EXPECT_EQ(ci.psi.n, 2);
  EXPECT_NEAR(ci.psi.mean, 0.88, 1e-3);
  EXPECT_NEAR(ci.psi.mean, (6140.0 + 6426.0) / 2.0 / 7140.0, 1e-14);
  // The range had the left-out run finished: discharged afterwards (0) or clogged now.
  EXPECT_NEAR(ci.psi_low, (6140.0 + 6426.0) / 3.0 / 7140.0, 1e-14);
  EXPECT_NEAR(ci.psi_high, (6140.0 + 6426.0 + 5220.0) / 3.0 / 7140.0, 1e-14);
  // W = 13: every run reached the time limit: Psi over no run, not 0.
  const std::vector<ClogRun> w13 = {{RunEnd::kOther, 8000, 6080, 1920}, {RunEnd::kOther, 8000, 6100, 1900}};
  const ClogIndex c13 = CloggingIndex(w13, 100, 860.0);
  EXPECT_EQ(c13.psi.n, 0);
  EXPECT_TRUE(std::isnan(c13.psi.mean));
  EXPECT_EQ(c13.unfinished, 2);
  EXPECT_DOUBLE_EQ(c13.psi_low, 0.0);
  EXPECT_NEAR(c13.psi_high, (5220.0 + 5240.0) / 2.0 / 7140.0, 1e-14);
}

}  // namespace
}  // namespace granary::analysis

namespace granary::analysis {
namespace {

// Avalanches of a run whose engine broke its clogs: the exits between unclogs, whatever gaps
// the stream has; the stretch after the last unclog counts only when the run ended clogged.
TEST(Avalanches, BetweenUnclogs) {
  std::vector<rundir::ExitEvent> events;
  for (double t : {1.0, 2.0, 3.0, 20.0, 21.0, 40.0, 41.0, 42.0, 43.0})
    events.push_back({t, 0, "disc", 1.0, t < 30 ? 0 : 1});
  const std::vector<double> unclogs = {10.0, 35.0};  // the gap 3 -> 20 and 21 -> 40 were clogs
  EXPECT_EQ(AvalanchesBetweenUnclogs(events, -1, unclogs, RunEnd::kClogged), (std::vector<double>{3, 2, 4}));
  EXPECT_EQ(AvalanchesBetweenUnclogs(events, -1, unclogs, RunEnd::kOther), (std::vector<double>{3, 2}));
  EXPECT_EQ(AvalanchesBetweenUnclogs(events, 1, unclogs, RunEnd::kClogged), (std::vector<double>{0, 0, 4}));
  EXPECT_EQ(RunEndOf("max_clogs"), RunEnd::kClogged);
}

}  // namespace
}  // namespace granary::analysis
