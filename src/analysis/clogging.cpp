// Implementation of clogging.h.
#include "analysis/clogging.h"

#include <algorithm>
#include <cmath>

namespace granary::analysis {

int ClogSeries::Unclogs() const {
  int n = 0;
  for (const auto& c : clogged) n += c.complete ? 1 : 0;
  return n;
}

std::vector<double> ClogSeries::AvalancheSizes() const {
  std::vector<double> s;
  for (const auto& f : flowing)
    if (f.complete) s.push_back(f.exits);
  return s;
}

std::vector<double> ClogSeries::FlowingTimes() const {
  std::vector<double> t;
  for (const auto& f : flowing)
    if (f.complete) t.push_back(f.Duration());
  return t;
}

std::vector<double> ClogSeries::CloggedTimes() const {
  std::vector<double> t;
  for (const auto& c : clogged)
    if (c.complete) t.push_back(c.Duration());
  return t;
}

RunEnd RunEndOf(const std::string& end_reason) {
  if (end_reason == "clogged" || end_reason == "max_clogs") return RunEnd::kClogged;
  if (end_reason == "discharged") return RunEnd::kDischarged;
  return RunEnd::kOther;
}

ClogSeries ComputeClogSeries(std::span<const rundir::ExitEvent> events, int outlet, double t_end, double clog_gap,
                             RunEnd end, bool engine_stops_on_clog) {
  const bool gaps_are_clogs = !(engine_stops_on_clog && end == RunEnd::kDischarged && outlet < 0);
  ClogSeries s;
  std::vector<double> times;
  for (const auto& e : events)
    if (outlet < 0 || e.outlet == outlet) times.push_back(e.time);
  std::sort(times.begin(), times.end());
  s.t_end = std::max(t_end, times.empty() ? 0.0 : times.back());
  Stretch current{0.0, 0.0, 0, true};
  // Gaps count from the first exit through any outlet, not from the opening: the start-up
  // delay is not a clog, but an outlet that stays blocked while another one flows is.
  double previous = 0.0;
  for (const auto& e : events) previous = previous == 0.0 ? e.time : std::min(previous, e.time);
  for (double t : times) {
    if (gaps_are_clogs && t - previous >= clog_gap) {
      current.end = previous;
      s.flowing.push_back(current);
      s.clogged.push_back({previous, t, 0, true});
      current = Stretch{t, t, 0, true};
    }
    ++current.exits;
    previous = t;
  }
  current.end = previous;
  const bool final_clog =
      end == RunEnd::kClogged || (gaps_are_clogs && end != RunEnd::kDischarged && s.t_end - previous >= clog_gap);
  current.complete = final_clog;
  s.flowing.push_back(current);
  if (final_clog) s.clogged.push_back({previous, s.t_end, 0, false});
  return s;
}

std::vector<double> AvalanchesBetweenUnclogs(std::span<const rundir::ExitEvent> events, int outlet,
                                             std::span<const double> unclog_times, RunEnd end) {
  std::vector<double> sizes(unclog_times.size() + 1, 0.0);
  for (const auto& e : events) {
    if (outlet >= 0 && e.outlet != outlet) continue;
    const auto k = std::upper_bound(unclog_times.begin(), unclog_times.end(), e.time) - unclog_times.begin();
    sizes[static_cast<std::size_t>(k)] += 1.0;
  }
  if (end != RunEnd::kClogged) sizes.pop_back();
  return sizes;
}

IntermittencyStats Intermittency(std::span<const ClogSeries> runs) {
  IntermittencyStats st;
  std::vector<double> tf, tc;
  for (const auto& r : runs) {
    for (double t : r.FlowingTimes()) tf.push_back(t);
    for (double t : r.CloggedTimes()) tc.push_back(t);
    st.unclogs += r.Unclogs();
    st.observed_time += r.t_end;
  }
  st.t_flowing = MeanAndSe(tf);
  st.t_clogged = MeanAndSe(tc);
  if (st.observed_time > 0.0) st.unclog_rate = st.unclogs / st.observed_time;
  return st;
}

AvalancheStats ComputeAvalancheStats(std::span<const double> sizes, int bins, double tail_from) {
  AvalancheStats a;
  a.sizes.assign(sizes.begin(), sizes.end());
  a.size = MeanAndSe(sizes);
  if (sizes.empty()) return a;
  double hi = 0.0;
  for (double s : sizes) hi = std::max(hi, s);
  a.histogram = MakeHistogram(sizes, bins, 0.0, hi + std::max(1.0, hi / bins));
  const double from = tail_from >= 0.0 ? tail_from : Median(a.sizes);
  a.tail = FitExponentialTail(sizes, from);
  return a;
}

ClogIndex CloggingIndex(std::span<const ClogRun> runs, int min_exits, double stagnant) {
  ClogIndex ci;
  std::vector<const ClogRun*> used, unfinished;
  std::vector<double> free_remaining;
  for (const auto& r : runs) {
    if (r.end == RunEnd::kOther) {
      unfinished.push_back(&r);
    } else if (r.end == RunEnd::kClogged && r.exited < min_exits) {
      ++ci.discarded;
    } else if (r.end == RunEnd::kClogged) {
      used.push_back(&r);
      ++ci.clogged;
    } else {
      used.push_back(&r);
      ++ci.discharged;
      free_remaining.push_back(r.undischarged);
    }
  }
  ci.unfinished = static_cast<int>(unfinished.size());
  if (stagnant >= 0.0) {
    ci.n_stagnant = stagnant;
  } else if (!free_remaining.empty()) {
    ci.n_stagnant = MeanAndSe(free_remaining).mean;
  } else {
    ci.note = "N_u missing: no run discharged, so Psi is not defined";
    return ci;
  }
  auto term = [&](const ClogRun& r) {
    const double denominator = r.bodies - ci.n_stagnant;
    return denominator > 0.0 ? (r.undischarged - ci.n_stagnant) / denominator : kNaN;
  };
  std::vector<double> psi;
  for (const ClogRun* r : used)
    if (const double x = term(*r); std::isfinite(x)) psi.push_back(x);
  ci.psi = MeanAndSe(psi);
  if (!unfinished.empty()) {
    std::vector<double> low = psi, high = psi;
    for (const ClogRun* r : unfinished) {
      if (const double x = term(*r); std::isfinite(x)) {
        low.push_back(0.0);
        high.push_back(std::max(0.0, x));
      }
    }
    if (!low.empty()) {
      ci.psi_low = MeanAndSe(low).mean;
      ci.psi_high = MeanAndSe(high).mean;
    }
  }
  return ci;
}

}  // namespace granary::analysis
