// The campaign as the report, the export and the comparison see it: its runs sorted into
// used / missing / failed / unreadable / lost / retired, its sweep points in order with their x value
// on the report's x axis and their group (the other axes' values), and the helpers that turn
// point metrics into figure series. Knows nothing of any particular analysis.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "analysis/axes.h"
#include "analysis/report_document.h"
#include "analysis/stats.h"
#include "rundir/manifest.h"
#include "rundir/summary.h"

namespace granary::analysis {

struct PointMetric;

// One run of the campaign as the runner knows it.
struct RunRecord {
  std::string run_id;
  std::string state;     // planned, running, done, failed, interrupted, retired
  std::string engine;    // native or liggghts
  std::string point_id;  // id of the sweep point (runs differing only by replica share it)
  int replica = 0;
  nlohmann::json point;           // the sweep-axis values of this point, e.g. {"/silo/base_outlets/0/width": 10}
  nlohmann::json spec;            // the resolved run spec (run.json)
  std::filesystem::path run_dir;  // absolute
  std::string failure;            // failed runs: reason and log tail
};

struct CampaignInfo {
  std::string name;
  std::string spec_hash;
  nlohmann::json spec;            // the campaign spec as planned
  std::vector<std::string> axes;  // sweep axes (JSON pointers into the run spec), in spec order
  std::string granary_version;
  std::string git_commit;
};

// What each engine cost on a run (summary.json "timing").
struct RunTiming {
  double wall_s = kNaN;  // bed + discharge
  double discharge_wall_s = kNaN;
  double disc_steps_per_s = kNaN;
  int threads = 0;
};

struct UsedRun {
  const RunRecord* record = nullptr;
  rundir::Summary summary;
  nlohmann::json spec;         // run.json as the engine saw it (the record's if absent)
  std::string tangential_cap;  // the cap the engine applied (LIGGGHTS says which)
  std::string reinjection;     // reinject mode: "random" or "periodic"; "" in remove mode
  RunTiming timing;
  std::size_t outlets = 1;
};

struct Point {
  std::string id;
  nlohmann::json point;           // sweep-axis values
  double x = kNaN;                // value on the report's x axis
  std::string group;              // the other axes' values, short: "X_db = 0.5" (groups points; keys)
  std::string group_title;        // the same in words: "dumbbell fraction X_db = 0.5" (captions)
  std::string shared_group;       // `group` without the engine (points matched across engines)
  std::string engine;             // campaigns on several engines: this point's engine
  nlohmann::json spec;            // a run spec of this point (for axis values)
  std::vector<std::size_t> runs;  // indices into CampaignView::used
};

struct CampaignView {
  const CampaignInfo* campaign = nullptr;
  std::vector<std::string> axes;     // the campaign's axes, plus /engine when runs come from several engines
  std::vector<std::string> engines;  // in first-appearance order
  std::vector<UsedRun> used;
  std::vector<const RunRecord*> missing, failed, retired;
  std::vector<const RunRecord*> lost;  // done, but the run directory was deleted afterwards
  std::vector<std::pair<const RunRecord*, std::string>> unreadable;
  // done, but a file differs from what the engine recorded (rundir/manifest.h): kept out of
  // every number, listed with what differs
  std::vector<std::pair<const RunRecord*, std::vector<rundir::FileProblem>>> damaged;
  std::vector<const RunRecord*> unverifiable;  // used, but written before manifests: not verifiable
  std::vector<Point> points;                   // sorted by group, then x
  std::string x_axis;                          // JSON pointer of the x axis ("" = none)
  std::set<std::string> x_axes;                // the sweep axes that make x (left out of the groups)
  std::string x_label;
  std::string x_name;    // short name of x in CSV headers
  std::string x_title;   // x in words, as "The system" names it ("outlet width W"), for point titles
  std::string x_symbol;  // x's symbol ("W"), for point names
  std::map<std::string, std::string> axis_symbols;  // axis -> its one short name (axes.h), everywhere
  CampaignAxes named;                               // the axes by name, with the campaign's derived axes (/axes)
  bool x_is_width = false;
  bool x_is_gap = false;                   // x = gap L between base outlets 0 and 1 (ch. 5b, 7)
  int x_outlet = -1;                       // the outlet (event order) whose width is x; -1: none
  std::size_t outlets = 1;                 // most outlets of any used run
  std::vector<std::string> outlet_labels;  // of a used run with that many ("base 0", "side 1 (right)")
};

// The check of each done run against its manifest (rundir::VerifyRun), by run id; a run
// not in it counts as not checked (whole).
using RunChecks = std::map<std::string, rundir::Verification>;

// Sorts `runs` (which must outlive the view): a done run is used unless its summary.json
// cannot be read, `unreadable` names it (run id -> reason, e.g. from the analysis pass) or
// `checks` found it damaged.
CampaignView MakeCampaignView(const CampaignInfo& campaign, const std::vector<RunRecord>& runs,
                              const std::map<std::string, std::string>& unreadable = {}, const RunChecks& checks = {});

// "/silo/base_outlets/0/width" -> "base_outlets.0.width".
std::string ShortAxis(const std::string& pointer);
// A sweep value as text: numbers to 6 significant digits, strings as they are.
std::string ValueText(const nlohmann::json& value);
// The value of a sweep axis for a point: from the point record, else from the run spec.
std::optional<nlohmann::json> AxisValue(const std::string& axis, const nlohmann::json& point,
                                        const nlohmann::json& spec);
// Point names come in two forms: short, the symbols alone ("W = 10, X_db = 0.5"), in tables'
// point columns, figure keys and the data/ file names made from them; long, in words ("outlet
// width W = 10, dumbbell fraction X_db = 0.5"), in captions (The system explains the symbols).
enum class NameForm { kShort, kLong };
// An axis' name in that form (CampaignView::axis_symbols; axis_name for the long one).
std::string AxisText(const CampaignView& view, const std::string& axis, const nlohmann::json& spec, NameForm form);
// "W = 10, X_db = 0.5" or "outlet width W = 10, dumbbell fraction X_db = 0.5" (axes in `skip` left out).
std::string PointLabel(const CampaignView& view, const nlohmann::json& point, const nlohmann::json& spec, NameForm form,
                       const std::set<std::string>& skip_axes = {});
// "W = 6 d, D_b = 1.5 d": the short form with each value's unit (system.h axis_unit), for
// titles that stand alone (map panels).
std::string PointLabelWithUnits(const CampaignView& view, const nlohmann::json& point, const nlohmann::json& spec);
// "W = 10" or "outlet width W = 10": x and its value; "" if the view has no x.
std::string XText(const CampaignView& view, double x, NameForm form);
// The report's name of a point (short form): x first, then its group; the id if it has neither.
std::string PointName(const CampaignView& view, const Point& point);
// The same in the long form, for captions.
std::string PointTitle(const CampaignView& view, const Point& point);
std::vector<std::string> GroupsOf(const CampaignView& view);
// At least two points have an x value: figures against x make sense.
bool HasX(const CampaignView& view);
// The sweep axis that names the groups with one number per group, different in every group
// (fitted parameters are drawn against it); "" if none.
std::string GroupAxis(const CampaignView& view);

// Up to `most` indices of points for which `has` holds, spread evenly over them (figures that
// draw one curve per point; every point is in the CSVs).
std::vector<std::size_t> SpreadPoints(const CampaignView& view, const std::function<bool(std::size_t)>& has,
                                      std::size_t most = 6);

// Point metrics of one analysis, per point in CampaignView::points order.
using PointMetricTable = std::vector<std::vector<PointMetric>>;
// One series per group of (x, mean, se, n) of the point metric `name`.
std::vector<Series> PointSeries(const CampaignView& view, const PointMetricTable& metrics, const std::string& name,
                                const std::string& column);
// One series per (outlet, group) of the metric `name_of(k)` of outlet k, labelled with the
// outlet's label; for runs with several outlets.
std::vector<Series> OutletSeries(const CampaignView& view, const PointMetricTable& metrics,
                                 const std::function<std::string(std::size_t)>& name_of,
                                 const std::vector<std::string>& outlet_labels, const std::string& column);

}  // namespace granary::analysis
