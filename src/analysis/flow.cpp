// Implementation of flow.h.
#include "analysis/flow.h"

#include <algorithm>
#include <cmath>

namespace granary::analysis {

FlowWindow FindFlowWindow(const FlowInput& in, const FlowWindowRule& rule) {
  FlowWindow w;
  for (const auto& e : in.events) {
    if (in.outlet >= 0 && e.outlet != in.outlet) continue;
    w.times.push_back(e.time);
    w.masses.push_back(e.mass);
  }
  const std::size_t n = w.times.size();
  if (n == 0) {
    w.note = "no exits";
    return w;
  }
  // 1. End at the first clog.
  std::size_t last = n - 1;
  if (rule.stop_at_first_clog) {
    // The start-up delay (bodies must fall exit_distance before they count) is not a clog:
    // gaps are measured from the first exit through any outlet.
    double previous = in.events.front().time;
    // A run that stops at its first clog and clogged this early never flowed steadily.
    const auto startup_clog = [&](std::size_t exits, double t) {
      w.startup_clog = true;
      w.note = "clogged after " + std::to_string(exits) + " exits (t = " + std::to_string(t) + "), before its " +
               std::to_string(rule.min_exits_before_clog) +
               "th: a start-up clog, no steady flow (/report/window/min_exits_before_clog)";
      return w;
    };
    for (std::size_t i = 0; i < n; ++i) {
      if (w.times[i] - previous >= in.clog_gap) {
        if (i == 0) {
          w.note = "outlet clogged from the opening (its first exit at t = " + std::to_string(w.times[0]) + ")";
          return w;
        }
        if (in.stops_at_clog && static_cast<int>(i) < rule.min_exits_before_clog) return startup_clog(i, previous);
        last = i - 1;
        w.note = "window ends at the first clog (t = " + std::to_string(previous) + ")";
        break;
      }
      previous = w.times[i];
    }
    // A run that stopped at a clog (or stood clogged until its time limit) has its last gap
    // after its last exit.
    const bool ended_clogged = last == n - 1 && std::isfinite(in.t_end) && in.t_end - w.times[last] >= in.clog_gap;
    if (in.stops_at_clog && ended_clogged && static_cast<int>(n) < rule.min_exits_before_clog)
      return startup_clog(n, w.times[last]);
  }
  // 2. Remove mode: stop while enough bodies remain. Counts use every exit (all outlets).
  if (in.remove_mode && in.bodies > 0) {
    const double keep = (1.0 - rule.shallow_fraction) * in.bodies;
    std::size_t exited_all = 0;
    double t_shallow = kNaN;
    for (const auto& e : in.events) {
      ++exited_all;
      if (static_cast<double>(exited_all) > keep) {
        t_shallow = e.time;
        break;
      }
    }
    if (std::isfinite(t_shallow)) {
      std::size_t k = last + 1;
      while (k > 0 && w.times[k - 1] >= t_shallow) --k;
      if (k == 0) {
        w.note = "bed shallow before any exit of this outlet";
        return w;
      }
      if (k - 1 < last) {
        last = k - 1;
        w.note = "window ends when " + std::to_string(static_cast<int>(std::lround(rule.shallow_fraction * 100))) +
                 "% of the bodies remain (t = " + std::to_string(t_shallow) + ")";
      }
    }
  }
  // 3. Start-up transient.
  std::size_t first = static_cast<std::size_t>(std::ceil(rule.start_fraction * static_cast<double>(last + 1)));
  while (first <= last && w.times[first] < rule.start_time) ++first;
  w.first = first;
  w.last = last;
  if (first > last || static_cast<int>(last - first + 1) < rule.min_events) {
    w.note = "only " + std::to_string(first > last ? 0 : last - first + 1) + " exits in the steady window (need " +
             std::to_string(rule.min_events) + ")";
    return w;
  }
  w.ok = true;
  return w;
}

FlowRate MeasureFlowRate(const FlowInput& in, const FlowWindowRule& rule) {
  FlowRate q;
  const FlowWindow w = FindFlowWindow(in, rule);
  q.note = w.note;
  q.startup_clog = w.startup_clog;
  if (!w.ok) return q;
  std::vector<double> t, count, mass;
  double cumulative_mass = 0.0;
  bool have_mass = true;
  for (std::size_t i = 0; i <= w.last; ++i) {
    cumulative_mass += w.masses[i];
    if (!std::isfinite(w.masses[i])) have_mass = false;
    if (i < w.first) continue;
    t.push_back(w.times[i]);
    count.push_back(static_cast<double>(i + 1));
    mass.push_back(cumulative_mass);
  }
  q.t_start = t.front();
  q.t_end = t.back();
  q.n_events = static_cast<int>(t.size());
  const LineFit fc = FitLine(t, count);
  q.q_count = fc.slope;
  q.q_count_se_ols = fc.slope_se;
  q.count_intercept = fc.intercept;
  if (have_mass) q.q_mass = FitLine(t, mass).slope;
  // Batch means over equal time slices of the window.
  const int batches = std::min(10, q.n_events / 5);
  const double span = q.t_end - q.t_start;
  if (batches >= 2 && span > 0.0) {
    q.batches = batches;
    std::vector<double> n_rate(static_cast<std::size_t>(batches), 0.0), m_rate = n_rate;
    const double width = span / batches;
    for (std::size_t i = w.first; i <= w.last; ++i) {
      auto b = static_cast<std::size_t>((w.times[i] - q.t_start) / width);
      b = std::min(b, n_rate.size() - 1);
      n_rate[b] += 1.0 / width;
      m_rate[b] += w.masses[i] / width;
    }
    q.q_count_se = MeanAndSe(n_rate).se;
    if (have_mass) q.q_mass_se = MeanAndSe(m_rate).se;
  }
  q.ok = std::isfinite(q.q_count);
  if (!q.ok) q.note = "all exits of the window at one time";
  return q;
}

std::vector<FlowRate> FlowRatePerOutlet(const FlowInput& input, const FlowWindowRule& rule, int outlets) {
  std::vector<FlowRate> out(static_cast<std::size_t>(std::max(0, outlets)));
  FlowInput all = input;
  all.outlet = -1;
  const FlowWindow w = FindFlowWindow(all, rule);
  if (!w.ok) {
    for (int k = 0; k < outlets; ++k) {
      FlowInput one = input;
      one.outlet = k;
      out[static_cast<std::size_t>(k)] = MeasureFlowRate(one, rule);
    }
    return out;
  }
  // FindFlowWindow(all) keeps every event, so its indices are indices into input.events.
  std::vector<double> t;
  for (std::size_t i = w.first; i <= w.last; ++i) t.push_back(input.events[i].time);
  const int n_all = static_cast<int>(t.size());
  const int batches = std::min(10, n_all / 5);
  const double span = t.back() - t.front();
  for (int k = 0; k < outlets; ++k) {
    FlowRate& q = out[static_cast<std::size_t>(k)];
    std::vector<double> count, mass, n_rate(static_cast<std::size_t>(std::max(batches, 0)), 0.0), m_rate = n_rate;
    double cumulative = 0.0, cumulative_mass = 0.0;
    bool have_mass = true;
    for (std::size_t i = 0; i <= w.last; ++i) {
      const rundir::ExitEvent& e = input.events[i];
      if (e.outlet == k) {
        cumulative += 1.0;
        cumulative_mass += e.mass;
        if (!std::isfinite(e.mass)) have_mass = false;
        if (i >= w.first) {
          ++q.n_events;
          if (batches >= 2 && span > 0.0) {
            const double width = span / batches;
            const auto b = std::min(n_rate.size() - 1, static_cast<std::size_t>((e.time - t.front()) / width));
            n_rate[b] += 1.0 / width;
            m_rate[b] += e.mass / width;
          }
        }
      }
      if (i < w.first) continue;
      count.push_back(cumulative);
      mass.push_back(cumulative_mass);
    }
    q.t_start = t.front();
    q.t_end = t.back();
    const LineFit fc = FitLine(t, count);
    q.q_count = fc.slope;
    q.q_count_se_ols = fc.slope_se;
    q.count_intercept = fc.intercept;
    if (have_mass) q.q_mass = FitLine(t, mass).slope;
    if (batches >= 2 && span > 0.0) {
      q.batches = batches;
      q.q_count_se = MeanAndSe(n_rate).se;
      if (have_mass) q.q_mass_se = MeanAndSe(m_rate).se;
    }
    q.ok = std::isfinite(q.q_count);
    q.note = "over the steady window of all outlets together" + (w.note.empty() ? "" : " (" + w.note + ")");
  }
  return out;
}

VelocityProfileAccumulator::VelocityProfileAccumulator(double outlet_center, double outlet_width,
                                                       const ProfileOptions& options)
    : center_(outlet_center), width_(outlet_width), options_(options) {
  const auto bins = static_cast<std::size_t>(std::max(1, options.bins));
  sum_vx_.assign(bins, 0.0);
  sum_vy_.assign(bins, 0.0);
  count_.assign(bins, 0.0);
}

void VelocityProfileAccumulator::Add(std::span<const rundir::Body> bodies) {
  ++frames_;
  const double bins = static_cast<double>(count_.size());
  for (const rundir::Body& b : bodies) {
    if (b.y < options_.band_low || b.y > options_.band_high) continue;
    const double u = (b.x - center_) / width_ + 0.5;  // 0..1 across the outlet
    if (u < 0.0 || u >= 1.0) continue;
    const auto i = std::min(count_.size() - 1, static_cast<std::size_t>(u * bins));
    sum_vx_[i] += b.vx;
    sum_vy_[i] += b.vy;
    count_[i] += 1.0;
  }
}

VelocityProfile VelocityProfileAccumulator::Result() const {
  VelocityProfile p;
  p.frames = frames_;
  const std::size_t n = count_.size();
  double max_vx = 0.0, max_vy = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    p.x_over_w.push_back(-0.5 + (static_cast<double>(i) + 0.5) / static_cast<double>(n));
    p.samples.push_back(count_[i]);
    const double vx = count_[i] > 0 ? sum_vx_[i] / count_[i] : kNaN;
    const double vy = count_[i] > 0 ? sum_vy_[i] / count_[i] : kNaN;
    p.vx.push_back(vx);
    p.vy.push_back(vy);
    if (std::isfinite(vx)) max_vx = std::max(max_vx, std::abs(vx));
    if (std::isfinite(vy)) max_vy = std::max(max_vy, std::abs(vy));
  }
  for (std::size_t i = 0; i < n; ++i) {
    p.vx_norm.push_back(max_vx > 0 ? p.vx[i] / max_vx : kNaN);
    p.vy_norm.push_back(max_vy > 0 ? p.vy[i] / max_vy : kNaN);
  }
  if (max_vy > 0) p.v_max = max_vy;
  return p;
}

}  // namespace granary::analysis
