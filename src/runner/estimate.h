// What a campaign will cost before it runs (docs/cli.md "The estimate"): core-hours, wall
// time on J concurrent runs and disk, per sweep point and in total, from the resolved run
// specs and a calibration of the engine's speed. Pure: no file, no process; the calibration
// is measured elsewhere (calibration.h) and the bytes of a frame come from the run-directory
// writers themselves (rundir::FrameBytes, ContactBytes) on a frame of the run's size.
#pragma once

#include <map>
#include <set>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "rundir/run_spec.h"
#include "runner/campaign_spec.h"

namespace granary::runner {

// Disc-steps per second of one engine thread. A body of several discs costs more per disc
// than a lone disc (more contacts per disc), so the two are measured apart; a mixture costs
// the harmonic mean weighted by its discs.
struct Calibration {
  double disc_rate = 0.0;   // bodies of one disc
  double clump_rate = 0.0;  // bodies of several discs (dumbbells, snowmen, rods)
  // Measured / estimated core time of the campaign's finished runs (1 = none finished).
  double scale = 1.0;
  int scaled_from_runs = 0;
  std::string source;  // how the rates were obtained, in words
  bool Valid() const { return disc_rate > 0.0 && clump_rate > 0.0; }
};

// One run's cost. Remove-mode runs (and any run that stops at a clog) end when the silo has
// discharged or clogged, which is not known before: they get a range, from "clogs as soon as
// a clog can be judged" (clog_window after opening) to "flows until the silo is empty at
// Beverloo's rate, or until max_time".
struct RunEstimate {
  double bodies = 0.0;
  double discs = 0.0;
  bool open_end = false;  // the end cannot be known: low < high
  double sim_low = 0.0;   // simulated discharge time
  double sim_high = 0.0;
  double bed_disc_steps = 0.0;  // 0 when a run before it in the campaign prepares the same bed
  double disc_steps_low = 0.0;  // discharge
  double disc_steps_high = 0.0;
  double core_s_low = 0.0;  // bed + discharge, at Calibration's rates and scale
  double core_s_high = 0.0;
  double bytes_low = 0.0;  // frames, contact frames, checkpoints, events
  double bytes_high = 0.0;
  double frame_bytes = 0.0;  // one frame (with its contact frame when written)
};

// The constants of the model (docs/cli.md says where each comes from).
struct EstimateModel {
  double beverloo_c = 0.67;       // 2-D Beverloo Q = C n sqrt(g) (W - k b)^1.5 (bodies per time)
  double beverloo_k = 1.5;        // k, in units of the body's largest disc diameter
  double packing_fraction = 0.8;  // area fraction of a bed (a random loose packing of discs: 0.78-0.85)
  // Contact rows per disc in a frame of a flowing silo (measured: 1.1 in the ch. 4 mixture and
  // in docs/run-directory.md's dumbbell bed; 0.91 in a tiny dumbbell silo, whose two discs of a
  // body touch each other without a row).
  double contacts_per_lone_disc = 1.1;
  double contacts_per_clump_disc = 0.91;
  double bed_insert_fraction = 0.3;  // area fraction of a batch's insertion region (bed.cpp)
  double bed_final_settle = 10.0;    // simulated settling after the last batch
  double run_overhead_s = 0.5;       // per run: engine start, bed file, silo.vtk, the runner's polls
};

// bed_prepared: this run prepares its bed (the first run of its bed key); otherwise the bed
// comes from the cache and costs nothing.
RunEstimate EstimateRun(const RunSpec& spec, const Calibration& cal, bool prepares_bed,
                        const EstimateModel& model = {});

struct PointEstimate {
  std::string point_id;
  nlohmann::json point;
  std::string engine;
  int runs = 0;
  bool open_end = false;
  double core_s_low = 0.0, core_s_high = 0.0;
  double bytes_low = 0.0, bytes_high = 0.0;
  double run_core_s_high = 0.0;  // the costliest run of the point
};

struct CampaignEstimate {
  std::vector<PointEstimate> points;        // in plan order
  std::map<std::string, RunEstimate> runs;  // by run id
  int run_count = 0;
  int open_end_runs = 0;
  int beds = 0;  // distinct prepared beds
  double core_s_low = 0.0, core_s_high = 0.0;
  double bytes_low = 0.0, bytes_high = 0.0;
  int jobs = 1;  // concurrent runs of the wall-time estimate
  double wall_s_low = 0.0, wall_s_high = 0.0;
  Calibration calibration;
  std::string method;  // how it was estimated, in words
};

// The cost of `runs` (in plan order: the first run of a bed key prepares it) on `jobs`
// concurrent one-thread runs (wall time: each run goes to the slot that frees first).
// Runs whose bed.cache_file is in `beds_ready` take their bed from the cache.
CampaignEstimate EstimateCampaign(const std::vector<PlannedRun>& runs, const Calibration& cal, int jobs,
                                  const std::set<std::string>& beds_ready = {}, const EstimateModel& model = {});

// What the finished runs measured against what the calibration predicts for what they did
// (their own simulated time and exits, from summary.json): sets cal.scale and
// cal.scaled_from_runs. `finished` holds (resolved run spec, summary.json) of done runs.
// Without a valid calibration the rates themselves come from the runs' disc-steps per second.
void ScaleFromFinished(Calibration& cal, const std::vector<std::pair<nlohmann::json, nlohmann::json>>& finished,
                       const EstimateModel& model = {});

// Greedy list schedule: each duration, in order, to the slot that frees first; the makespan.
double Makespan(const std::vector<double>& durations, int slots);

nlohmann::json to_json(const CampaignEstimate& e);

// "12.3 core-hours", "3.1-14.2 core-hours"; "1.2 GB", "0.4-1.7 GB".
std::string CoreHoursText(double low_s, double high_s);
std::string BytesText(double low, double high);

}  // namespace granary::runner
