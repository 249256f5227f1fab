// Clogging analyses: the clogging index Psi (ch. 3, eq. 3.1), avalanche sizes (ch. 4, 6)
// and the flowing / clogged durations t_f, t_c with the unclogging rate N_u (ch. 7), all
// from the exit stream. Pure functions.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "rundir/events.h"
#include "analysis/stats.h"

namespace granary::analysis {

// The exit stream of one outlet (or all) cut into flowing and clogged stretches.
// Rule: a gap of at least `clog_gap` between two consecutive exits is a clog lasting from
// the earlier exit to the later one (t_c), and the flowing stretch before it runs from the
// opening (t = 0) or the unclog to the last exit before the gap (t_f). The first exit
// through any outlet stands in for the opening when measuring gaps, so the start-up delay
// (bodies fall exit_distance before they count) is not a clog, while an outlet that stays
// blocked while another flows is (from that first exit on). After the last exit the stream is clogged
// if the run ended because it clogged, or if t_end - t_last >= clog_gap unless the engine judged
// the final stall a discharge (every outlet open to the top: the silo ran out of what can flow,
// docs/engine.md); that last clog has no end (censored): it counts for the avalanche but not for <t_c>.
enum class RunEnd { kOther, kClogged, kDischarged };
RunEnd RunEndOf(const std::string& end_reason);
struct Stretch {
  double start = 0.0;
  double end = 0.0;
  int exits = 0;         // exits in a flowing stretch; 0 for a clog
  bool complete = true;  // a flowing stretch ending in a clog / a clog ending in an unclog
  double Duration() const { return end - start; }
};

struct ClogSeries {
  std::vector<Stretch> flowing;  // in time order; the last one may be incomplete (run ended flowing)
  std::vector<Stretch> clogged;  // the last one may be incomplete (run ended clogged)
  double t_end = 0.0;
  int Unclogs() const;                         // number of complete clogs
  std::vector<double> AvalancheSizes() const;  // exits of each flowing stretch that ended in a clog
  std::vector<double> FlowingTimes() const;    // durations of complete flowing stretches
  std::vector<double> CloggedTimes() const;    // durations of complete clogs
};

// `engine_stops_on_clog` (spec stop_on_clog) with a run the engine ended `discharged`: the
// engine judged every stall of the whole silo it met and stopped at the first, finding every
// outlet open, so the stream of all outlets (`outlet` < 0) has no clog at all: its gaps were the
// slow trickle off the dead zones at the end of a discharge, bodies still moving, not arches.
ClogSeries ComputeClogSeries(std::span<const rundir::ExitEvent> events, int outlet, double t_end, double clog_gap,
                             RunEnd end, bool engine_stops_on_clog = false);

// Avalanche sizes of a run whose engine broke its clogs (discharge/on_clog "unclog"): the exits
// (of outlet `outlet`, or all when < 0) between one unclog and the next, cut at `unclog_times`
// (the first attempt on each clog, in time order), the first from the opening. The stretch
// after the last unclog is an avalanche when the run ended in a clog (`end` kClogged: its last
// clog, max_clogs, or one the protocol could not break), else it was cut short and is not.
std::vector<double> AvalanchesBetweenUnclogs(std::span<const rundir::ExitEvent> events, int outlet,
                                             std::span<const double> unclog_times, RunEnd end);

// t_f, t_c and N_u of one outlet, pooled over several runs (each run's series).
struct IntermittencyStats {
  MeanSe t_flowing;           // <t_f> over complete flowing stretches
  MeanSe t_clogged;           // <t_c> over complete clogs
  double unclog_rate = kNaN;  // N_u = unclogs / observed time (sum of t_end)
  int unclogs = 0;
  double observed_time = 0.0;
};
IntermittencyStats Intermittency(std::span<const ClogSeries> runs);

struct AvalancheStats {
  MeanSe size;          // <s>, its standard error and the number of avalanches
  Histogram histogram;  // of s
  ExpTailFit tail;
  std::vector<double> sizes;
};
// tail_from < 0: the tail starts at the median size.
AvalancheStats ComputeAvalancheStats(std::span<const double> sizes, int bins = 20, double tail_from = -1.0);

// One run's numbers for eq. 3.1. `end` is how the run ended for the index: kClogged (an
// arch sealed an outlet for good), kDischarged (the silo ran out of what can flow: what is left
// is the stagnant zones), or kOther: neither (it reached its time limit while flowing, or was
// cut short), which says nothing of either count and is left out.
struct ClogRun {
  RunEnd end = RunEnd::kOther;
  int bodies = 0;        // N_total
  int undischarged = 0;  // N_undis (remaining)
  int exited = 0;
};

// Psi = (1/n) sum_i (N_undis,i - N_u) / (N_total - N_u) over the runs that clogged or
// discharged, N_u the mean N_undis of the runs that discharged (`stagnant` if given, i.e.
// >= 0; else from `runs`). Runs that clogged with fewer than `min_exits` exits are discarded
// (ch. 3). Runs that did neither are left out: their N_undis is only an upper bound of what
// they would have left. Without a discharged run and without `stagnant`, N_u is missing and so
// is Psi (the note says so; N_u = 0 would make every clogged run count as if the stagnant
// zones had flowed out).
struct ClogIndex {
  MeanSe psi;                // over the used runs; se is the replica standard error; NaN without N_u
  double n_stagnant = kNaN;  // N_u used; NaN: missing
  int clogged = 0;           // clogged runs used
  int discharged = 0;        // discharged runs used
  int discarded = 0;         // clogged before min_exits
  int unfinished = 0;        // neither clogged nor discharged: left out
  // With the left-out runs counted too, each between having discharged afterwards (0) and
  // having clogged at its end (its N_undis now): the range Psi could take had they finished.
  double psi_low = kNaN;
  double psi_high = kNaN;
  std::string note;
};
ClogIndex CloggingIndex(std::span<const ClogRun> runs, int min_exits = 100, double stagnant = -1.0);

}  // namespace granary::analysis
