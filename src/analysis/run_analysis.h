// All analyses of one run, computed once: the flow rate (all outlets and per outlet), the
// clog series, the numbers for the clogging index and, when frames exist, region statistics
// and the velocity profile above the first base outlet. The report and the `compare` verb
// both start from these values.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/clogging.h"
#include "analysis/flow.h"
#include "analysis/region.h"
#include "rundir/frames.h"
#include "rundir/run_directory.h"

namespace granary::analysis {

struct AnalysisOptions {
  FlowWindowRule window;
  double clog_gap = -1.0;             // < 0: the run's /discharge/clog_window (default 5)
  int min_exits_before_clog = 100;    // ch. 3 discard rule for Psi
  RegionSize region = chapter4_region();
  ProfileOptions profile;
  bool read_frames = true;
  int frame_stride = 1;               // analyse every n-th frame
  int max_frames = 0;                 // 0 = all frames in the window
};

struct OutletGeometry {
  bool base = true;                   // base outlet (x centre, width) or side outlet
  double center = 0.0;                // base: x of the centre; side: y of the centre
  double width = 10.0;
  bool right_wall = true;             // side outlets: in the right (x = +silo/2) or left wall
  double wall_x = 50.0;               // side outlets: x of that wall
  std::string label;                  // "base 0", "side 1 (right)"
};
// Outlets of a resolved run spec in event order: base outlets, then side outlets. Missing
// keys take the run-spec defaults (one base outlet of width 10 at x = 0, silo width 100).
std::vector<OutletGeometry> outlets_of(const nlohmann::json& spec);

// Positions and velocities in the outlet's own frame, so that one region / profile code
// serves base and lateral outlets (ch. 5a): x = along the outlet from its centre, y = distance
// from the outlet's wall into the silo, v likewise (outflow has v_y < 0). The map is a rigid
// rotation or reflection, so packing fractions and temperatures are unchanged by it.
void to_outlet_frame(const OutletGeometry& outlet, std::vector<rundir::Disc>& discs, std::vector<rundir::Body>& bodies);

struct RunAnalysis {
  std::string run_id;
  std::string engine;
  std::string end_reason;
  bool remove_mode = true;
  int bodies = 0;
  int exited = 0;
  double t_end = 0.0;
  double clog_gap = 5.0;
  std::vector<OutletGeometry> outlets;
  FlowRate flow;                      // all outlets together
  std::vector<FlowRate> flow_per_outlet;  // over the window of `flow` (flow_rate_per_outlet): they add up to it
  ClogRun clog;                       // for Psi
  ClogSeries series;                  // all outlets together (avalanches)
  int engine_clogs = -1;              // summary.json "clogs" if the engine counted them (KE-confirmed), else -1
  std::vector<ClogSeries> series_per_outlet;  // t_f, t_c per outlet
  bool has_region = false;
  RegionStats region;                 // next to outlet 0 (= region_per_outlet[0])
  bool has_profile = false;
  VelocityProfile profile;            // across outlet 0 (= profile_per_outlet[0])
  std::vector<RegionStats> region_per_outlet;     // in outlet coordinates (to_outlet_frame)
  std::vector<VelocityProfile> profile_per_outlet;
  std::vector<double> cumulative_t, cumulative_n;  // cumulative exits (all outlets), thinned to <= 201 samples
  std::vector<std::string> notes;
};

// Everything that needs only summary.json, run.json and events.csv. Pure.
RunAnalysis analyse_events(const rundir::RunData& data, const AnalysisOptions& options);
// Streams frames.dump (if present and options.read_frames) and fills the region statistics
// and velocity profiles of every outlet, from the frames of the flow window; without one,
// from the frames after window.start_time up to the first clog.
// Throws ReadError on a malformed dump.
void analyse_frames(const rundir::RunData& data, const AnalysisOptions& options, RunAnalysis& analysis);
// read_run + analyse_events + analyse_frames.
RunAnalysis analyse_run(const std::filesystem::path& dir, const AnalysisOptions& options);

}  // namespace granary::analysis
