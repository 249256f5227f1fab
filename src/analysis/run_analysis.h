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
#include "analysis/run_reader.h"

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
  std::string label;                  // "base 0", "side 0 (right)"
};
// Outlets of a resolved run spec in event order: base outlets, then side outlets. Missing
// keys take the run-spec defaults (one base outlet of width 10 at x = 0).
std::vector<OutletGeometry> outlets_of(const nlohmann::json& spec);

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
  std::vector<FlowRate> flow_per_outlet;
  ClogRun clog;                       // for Psi
  ClogSeries series;                  // all outlets together (avalanches)
  std::vector<ClogSeries> series_per_outlet;  // t_f, t_c per outlet
  bool has_region = false;
  RegionStats region;                 // above base outlet 0
  bool has_profile = false;
  VelocityProfile profile;            // across base outlet 0
  std::vector<std::string> notes;
};

// Everything that needs only summary.json, run.json and events.csv. Pure.
RunAnalysis analyse_events(const RunData& data, const AnalysisOptions& options);
// Streams frames.dump (if present and options.read_frames) and fills region and profile.
// Frames inside the flow window are used (all frames after window.start_time if the flow
// window is not defined). Throws ReadError on a malformed dump.
void analyse_frames(const RunData& data, const AnalysisOptions& options, RunAnalysis& analysis);
// read_run + analyse_events + analyse_frames.
RunAnalysis analyse_run(const std::filesystem::path& dir, const AnalysisOptions& options);

}  // namespace granary::analysis
