// What a registered analysis is (docs/architecture.md, "Adding an analysis"): a key and a
// version, options read from the campaign spec's /report/<key>, an accumulator that one pass
// over a run directory feeds (events up front, then the frames and contact frames of the time
// windows it asks for), a per-run result as JSON (cached in the run directory), the per-run
// metrics derived from that result, their aggregation per sweep point, and a report section.
// Analyses are pure: everything they see comes through these types; the pass, the cache, the
// report, the export and the database are the framework's.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "analysis/axes.h"
#include "analysis/flow.h"
#include "analysis/outlets.h"
#include "analysis/report_document.h"
#include "analysis/json_numbers.h"
#include "analysis/stats.h"
#include "rundir/contacts.h"
#include "rundir/frames.h"
#include "rundir/run_directory.h"

namespace granary::analysis {

struct CampaignView;

// One number of one run. `name` is a column of the export and a key of the database
// ([a-z0-9_]); per-outlet variants end in OutletSuffix(k).
struct Metric {
  std::string name;
  std::string unit;       // reduced units of docs/model.md: "bodies/sqrt(d/g)", "1", ...
  double value = kNaN;    // NaN: not defined for this run
  double se = kNaN;       // NaN: no error estimate
  std::string title;      // for tables and print-outs
  bool headline = false;  // shown in the per-run table, `campaign compare`, the engine-ratio figure
};

// One number of one sweep point: over its replicas, or pooled over what they contain (the
// analysis says which, and `n` counts it).
struct PointMetric {
  std::string name;
  std::string unit;
  double mean = kNaN;
  double se = kNaN;
  int n = 0;
  std::string title;
  bool headline = false;
  std::string note;
  bool compare = true;  // compared across engines (counts of runs are not)
  MeanSe Estimate() const { return {mean, se, n}; }
};

// Options of the pass that several analyses share (/report/window, clog_gap, frame_stride,
// max_frames): what a steady window and a clog are, and how densely frames are sampled.
struct PassOptions {
  FlowWindowRule window;
  double clog_gap = -1.0;  // < 0: each run's /discharge/clog_window
  int frame_stride = 1;    // every n-th frame of an analysis' windows
  int max_frames = 0;      // 0: all of them
};

// Which of the pass options an analysis' per-run results depend on (its cache key holds them).
struct PassUse {
  bool window = false;
  bool clog_gap = false;
  bool frames = false;  // frame_stride, max_frames
};

// A closed interval [start, end] of simulated time since the opening; end may be +inf.
struct TimeWindow {
  double start = -std::numeric_limits<double>::infinity();
  double end = std::numeric_limits<double>::infinity();
  bool Contains(double t) const { return t >= start && t <= end; }
};

// What the pass knows of a run before any analysis starts: the run directory's summary, spec
// and exit events, plus facts several analyses share.
struct RunView {
  const rundir::RunData* data = nullptr;
  std::string run_id;
  std::string engine;
  std::string end_reason;
  bool remove_mode = true;
  bool stop_on_clog = true;      // the spec's /discharge/stop_on_clog
  std::string on_clog = "stop";  // the spec's /discharge/on_clog: "stop", "wait" or "unclog"
  int bodies = 0;                // in the silo at the opening
  int exited = 0;
  int undischarged = 0;  // left in the silo at the end
  double t_end = 0.0;
  double clog_gap = 5.0;  // the effective one (PassOptions or the run's clog_window)
  double density = 1.0;   // areal density of the bodies
  std::vector<OutletGeometry> outlets;
  FlowRate flow;  // all outlets together over the steady window
  // The frames of steady flow: the flow window of all outlets; without one, from
  // /report/window/start_time up to the first clog; none after a start-up clog (flow.startup_clog).
  TimeWindow steady;
  // The clogged states: each clog of the exit stream of all outlets, from the last exit
  // before it to the first after it (to the end of the run if it never ended).
  std::vector<TimeWindow> clogged;
  const PassOptions* options = nullptr;
};

// One frame as the pass hands it to every analysis that asked for it: parsed once, its bodies
// rebuilt once, and its contact frame when asked for and written at the same time step.
struct FrameView {
  const rundir::Frame& frame;
  const std::vector<rundir::Body>& bodies;
  const rundir::ContactFrame* contacts = nullptr;
};

struct FrameRequest {
  std::vector<TimeWindow> windows;  // frames whose time lies in any of these (none: no frames)
  bool contacts = false;            // also the contact frame at each selected frame
};

// A per-run result with this key set to true is cached (so `campaign show` sees it) but never
// read back: a failure that may not happen again (a Python script's timeout, an interpreter
// that died), which the next report computes again.
inline constexpr char kRecompute[] = "recompute";

// One analysis on one run: made by Analysis::start, fed by the pass, finished once.
class RunAccumulator {
 public:
  virtual ~RunAccumulator() = default;
  // Asked once, before the first frame. The pass applies frame_stride and max_frames per
  // accumulator, counting the frames inside its windows.
  virtual FrameRequest Frames() const { return {}; }
  virtual void AddFrame(const FrameView& frame) { (void)frame; }
  // The per-run result. A key "notes" (array of strings) is shown beside the run in the report;
  // kRecompute: true has the next pass compute it again instead of reading the cache.
  virtual nlohmann::json Finish() = 0;
};

// One analysis' per-run results over the used runs of a campaign (CampaignView::used order;
// null where the run had no result).
struct AnalysisResults {
  const CampaignView* view = nullptr;
  std::vector<nlohmann::json> runs;
  PassOptions pass = {};  // the pass options the runs were analysed with
  // The results of the used runs of point p (CampaignView::points order).
  std::vector<const nlohmann::json*> OfPoint(std::size_t p) const;
};

// What a picture shows besides the bodies and the silo (a figure of kind "pictures",
// figures.h): a rectangle outlined (and shaded), a dimension line with its label, the discs of
// the body nearest a point measured (the renderer finds the body in the frame), or the origin
// with x and y arrows; in silo coordinates (d, x from the silo's centre, y up from the base).
struct PictureMark {
  enum class Kind { kRect, kDimension, kDiscs, kOrigin } kind = Kind::kRect;
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // the rectangle's corners, the dimension's ends, or the point (x0, y0)
  std::string label;                      // "A", "W = 11 d"; drawn at the rectangle's top left or the line's middle
  bool shade = false;                     // rectangles: filled translucent, not only outlined
  std::vector<std::string> labels = {};   // kDiscs: one per disc size, smallest first (empty: the renderer's)
};

// A clog an engine kept (clog_frames.dump) drawn to scale around its outlet, the bodies in
// `highlight` outlined: what a section asks the renderer for (the runner sets it from
// src/render; analyses never draw).
struct ClogPicture {
  int clog = 1;  // 1-based, in the run's clog files
  std::set<std::int64_t> highlight;
  double x_lo = 0, x_hi = 0, y_lo = 0, y_hi = 0;  // the part of the silo shown
  std::vector<PictureMark> marks;
  bool colour_by_disc = false;  // each disc of a body by its place in the body (a snowman's head and body)
};
// Draws `picture` of the run into `png`; returns "" or why it could not.
using DrawClog = std::function<std::string(const std::filesystem::path& run_dir, const ClogPicture& picture,
                                           const std::filesystem::path& png)>;

// What an analysis' report section is made from.
struct SectionInput {
  const CampaignView& view;
  const AnalysisResults& results;
  const std::vector<std::vector<PointMetric>>& points;  // this analysis' point metrics, per point
  const PassOptions& pass;
  std::filesystem::path out_dir = {};  // the report folder (pictures go below it)
  DrawClog draw_clog = {};             // unset: no pictures (the section says so)
};

// A per-run distribution an analysis offers figures of kind "distribution" (/report/figures,
// figures.h): what it is called there, and its title and unit for the axis.
struct DistributionInfo {
  std::string name;   // "vx", "avalanche_size": what a figure's "of" names
  std::string title;  // "v_x in the region above the outlet"
  std::string unit;   // "sqrt(g d)"; "" for a pure number
};
// Its values in one run: samples of weight 1 (avalanche sizes), or a histogram the run kept on
// a fine grid as its bin centres with their counts as weights (velocities). The figure bins
// them as it is asked; the replicas of a point pool by adding their weights.
struct Samples {
  std::vector<double> values;
  std::vector<double> weights;  // empty: 1 each
};

// A curve an analysis offers figures of kind "curves": y against x from the runs behind a
// chosen point, merged (the arch bodies' pressure against their angular position, thesis fig.
// 6.7): its name there, the axes' labels with their units, and whether the line y = x belongs
// to it (fig. 6.6: the axis' mode against theta beside mode = theta).
struct CurveInfo {
  std::string name;    // "arch_pressure_theta": what a figure's "of" names
  std::string title;   // "pressure of arch bodies against their angular position"
  std::string xlabel;  // "theta (degrees)"
  std::string ylabel;  // "P (rho g d)"
  bool diagonal = false;
};
// One point of such a curve: se NaN where the curve has none, n what stands behind y.
struct CurvePoint {
  double x = 0.0, y = 0.0, se = 0.0, n = 0.0;
};
// A field over the silo an analysis offers figures of kind "maps" and "profile": its name
// there, title, unit, and whether it is signed (a diverging colour scale).
struct FieldInfo {
  std::string name;   // "pressure", "speed_clogged"
  std::string title;  // "pressure P (contact)"
  std::string unit;   // "rho g d"; "" for a pure number
  bool diverging = false;
};
// The field on a regular grid (nodes (x0 + i h, y0 + j h), node j nx + i) from the runs given,
// merged, with the silo's walls and obstacles to draw over it.
struct FieldMap {
  double x0 = 0.0, y0 = 0.0, spacing = 1.0;
  int nx = 0, ny = 0;
  std::vector<double> values;                             // NaN: not defined at that node
  std::vector<double> n_frames;                           // frames behind each node's value
  int runs = 0;                                           // runs merged
  int frames = 0;                                         // frames of those runs behind the map
  std::vector<std::vector<std::array<double, 2>>> lines;  // walls, as polylines
  std::vector<std::array<double, 3>> circles;             // obstacles: x, y, radius
  // A vector field's arrows (the velocity over |v|): x, y and the vector in the field's units,
  // every `arrow_spacing` d; the figure scales them to that spacing.
  std::vector<std::array<double, 4>> arrows;
  double arrow_spacing = 0.0;
  double X(int i) const { return x0 + i * spacing; }
  double Y(int j) const { return y0 + j * spacing; }
  double At(int i, int j) const {
    return values[static_cast<std::size_t>(j) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(i)];
  }
};

class Analysis {
 public:
  virtual ~Analysis() = default;
  virtual std::string Key() const = 0;
  // Bump when the per-run results of the same inputs change: cached results become stale.
  virtual int Version() const = 0;
  // The options the per-run results depend on (canonical JSON); part of the cache key. Options
  // that only change aggregation or the section (fit models, discard rules) stay out of it.
  virtual nlohmann::json RunOptions() const { return nullptr; }
  virtual PassUse PassOptionsUsed() const { return {}; }
  // The campaign's axes, handed over by SetupAnalyses once every analysis is made: options
  // that name axes (an orientation region's bound "W_s - 5", evaluated per run from its spec)
  // are checked here, at plan time. Throws OptionError naming the option's path.
  virtual void UseAxes(const CampaignAxes& axes) { (void)axes; }
  virtual std::unique_ptr<RunAccumulator> Start(const RunView& run) const = 0;
  virtual std::vector<Metric> RunMetrics(const nlohmann::json& result) const = 0;
  // Default: every per-run metric as mean ± standard error over the point's runs where it is
  // finite (n = those runs).
  virtual std::vector<PointMetric> PointMetrics(const AnalysisResults& results, std::size_t point) const;
  virtual std::optional<Section> BuildSection(const SectionInput& input) const {
    (void)input;
    return std::nullopt;
  }
  // Distributions, curves and fields any figure of /report/figures may ask for by name (figures.h);
  // an analysis that offers some overrides these pairs, in its own file pair only.
  virtual std::vector<DistributionInfo> DistributionNames() const { return {}; }
  // The distribution `name` (one of DistributionNames()) of one run's result; empty if the
  // run has none.
  virtual Samples Distribution(const std::string& name, const nlohmann::json& result) const {
    (void)name;
    (void)result;
    return {};
  }
  virtual std::vector<CurveInfo> CurveNames() const { return {}; }
  // The curve `name` (one of CurveNames()) from these runs' results merged; empty if they have
  // none of it.
  virtual std::vector<CurvePoint> Curve(const std::string& name,
                                        const std::vector<const nlohmann::json*>& results) const {
    (void)name;
    (void)results;
    return {};
  }
  virtual std::vector<FieldInfo> FieldNames() const { return {}; }
  // The field `name` (one of FieldNames()) from these runs' results merged (the replicas of a
  // point, or several points pooled); `run_spec` a run spec of them (the silo drawn over it).
  // nullopt if none of them has it, or their grids differ.
  virtual std::optional<FieldMap> Field(const std::string& name, const std::vector<const nlohmann::json*>& results,
                                        const nlohmann::json& run_spec) const {
    (void)name;
    (void)results;
    (void)run_spec;
    return std::nullopt;
  }
};

// Mean ± se over runs of each metric name, in first-appearance order (the default aggregation).
std::vector<PointMetric> MeanOverRuns(const Analysis& analysis, const std::vector<const nlohmann::json*>& runs);

// The metric called `name` of a list, or nullptr.
const Metric* FindMetric(const std::vector<Metric>& metrics, const std::string& name);
const PointMetric* FindMetric(const std::vector<PointMetric>& metrics, const std::string& name);

nlohmann::json to_json(const MeanSe& m);
MeanSe MeanSeOf(const nlohmann::json& j);
std::vector<double> NumbersOf(const nlohmann::json& array);
nlohmann::json JsonNumbers(const std::vector<double>& values);
// The k-th string of a JSON array, or "" (outlet labels of a result).
std::string StringAt(const nlohmann::json& array, std::size_t k);

}  // namespace granary::analysis
