// Flow analyses of ch. 4-6: the flow rate Q from the exit stream over an explicit steady
// window, and velocity profiles across an outlet from frames. Pure functions over the
// reader's values.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "rundir/events.h"
#include "rundir/frames.h"
#include "analysis/stats.h"

namespace granary::analysis {

// The steady window of a discharge (shared analyses.md "Flow rate"). Applied in this order:
//  1. end: the last exit before the first clog, i.e. before the first gap of at least
//     `clog_gap` in the exit stream, when `stop_at_first_clog`; otherwise the last exit.
//     Gaps count from the first exit through any outlet: the start-up delay (bodies fall
//     exit_distance before they count) is not a clog;
//  2. remove mode only: the end moves earlier to the last exit after which at least
//     `shallow_fraction` of the bodies are still in the silo (the bed is then too shallow
//     for a steady flow);
//  3. start: exits before `start_time` and the first `start_fraction` of the exits up to
//     the end are dropped (start-up transient).
// At least `min_events` exits must remain.
struct FlowWindowRule {
  double start_time = 2.0;  // sqrt(d/g)
  double start_fraction = 0.1;
  double shallow_fraction = 0.3;
  bool stop_at_first_clog = true;
  int min_events = 10;
  // A run whose first clog comes before this many exits never flowed steadily: its start-up
  // clog gives no window (ch. 3's discard rule; the clogging index applies it too).
  int min_exits_before_clog = 100;
};

struct FlowInput {
  std::span<const rundir::ExitEvent> events;  // sorted by time
  bool remove_mode = true;
  int bodies = 0;         // bodies in the bed at the opening
  double clog_gap = 5.0;  // a gap this long in the exit stream is a clog
  int outlet = -1;        // -1: all outlets together
  double t_end = kNaN;    // the run's end, when known: a last gap to it of at least clog_gap is a clog too
  // The run's protocol ends it at its first clog (on_clog "stop", ch. 3): only then is a clog
  // before min_exits_before_clog exits a start-up clog. Runs that wait or unclog go on, and
  // their first avalanche is often shorter than that (ch. 4, 6).
  bool stops_at_clog = true;
};

struct FlowRate {
  bool ok = false;
  std::string note;           // why not ok, or what limited the window
  bool startup_clog = false;  // not ok: the run clogged before min_exits_before_clog exits (FlowWindow)
  double t_start = kNaN, t_end = kNaN;
  int n_events = 0;
  double q_count = kNaN, q_count_se = kNaN;  // bodies per sqrt(d/g); se by batch means
  double q_mass = kNaN, q_mass_se = kNaN;    // mass per sqrt(d/g) (NaN without masses)
  double q_count_se_ols = kNaN;              // OLS error of the slope (optimistic, see below)
  double count_intercept = kNaN;             // the line: cumulative count = intercept + q_count t
  int batches = 0;
};

// Q = slope of the least-squares line through the cumulative count (mass) against time over
// the window. Cumulative counts are strongly correlated, so the OLS error of the slope
// understates the uncertainty badly; the se reported is by batch means instead: the window
// is cut into B = min(10, n/5) equal time batches, the rate of each is count (mass) / length,
// and se = sd(rates) / sqrt(B) (NaN when B < 2). For a Poisson stream this is ~sqrt(Q/T).
FlowRate MeasureFlowRate(const FlowInput& input, const FlowWindowRule& rule);

// Q through each of `outlets` outlets over the steady window of all outlets together: the
// least-squares slope of the outlet's cumulative count sampled at every exit time of that
// window. A slope is linear in the counts, so the outlets' rates add up to the total exactly,
// and an outlet that clogs and unclogs inside the window (ch. 7) gets its mean throughput
// rather than no rate. se by batch means over the same time slices as the total. If the
// window of all outlets is undefined, each outlet falls back to its own window (flow_rate).
std::vector<FlowRate> FlowRatePerOutlet(const FlowInput& input, const FlowWindowRule& rule, int outlets);

// The window alone, as indices [first, last] into the events of the outlet (all outlets if -1).
struct FlowWindow {
  bool ok = false;
  std::string note;
  std::vector<double> times;  // exit times of the selected outlet(s), all of them
  std::vector<double> masses;
  std::size_t first = 0, last = 0;  // inclusive
  bool startup_clog = false;        // no window: the run clogged before min_exits_before_clog exits
};
FlowWindow FindFlowWindow(const FlowInput& input, const FlowWindowRule& rule);

// Velocity profile across a base outlet (ch. 4, 5): body centre-of-mass velocities of the
// bodies with centre in the band y in [band_low, band_high] and x inside the outlet, binned
// in x/W over [-1/2, 1/2], averaged over frames. Normalised profiles divide by max |v| of
// the profile; V_max = max |v_y|.
struct ProfileOptions {
  int bins = 16;
  double band_low = 0.0;
  double band_high = 2.0;
};

struct VelocityProfile {
  std::vector<double> x_over_w;  // bin centres
  std::vector<double> vx, vy;    // mean per bin (NaN if empty)
  std::vector<double> vx_norm, vy_norm;
  std::vector<double> samples;  // body samples per bin
  double v_max = kNaN;
  int frames = 0;
};

class VelocityProfileAccumulator {
 public:
  VelocityProfileAccumulator(double outlet_center, double outlet_width, const ProfileOptions& options);
  void Add(std::span<const rundir::Body> bodies);
  VelocityProfile Result() const;

 private:
  double center_, width_;
  ProfileOptions options_;
  std::vector<double> sum_vx_, sum_vy_, count_;
  int frames_ = 0;
};

}  // namespace granary::analysis
