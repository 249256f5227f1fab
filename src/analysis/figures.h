// The figure layer: figures a campaign spec asks for under /report/figures, drawn the way the
// thesis draws them. A figure is y (a metric, or an expression over metrics and axes) against
// x (a sweep axis, a derived axis of /axes, or the view's x such as the gap L), one curve per
// group, on a subset of the points (only), with points pooled over some axes (pool), and
// optionally a model over one or several axes fitted across every point of the figure at
// once (fit), drawn as curves or as a collapse (the data divided by the fitted law). Knows no
// metric by name: any metric an analysis returns can be asked for. Pure: an analysed campaign
// in, report blocks and fit results out.
#pragma once

#include <array>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/axes.h"
#include "analysis/campaign_analysis.h"
#include "analysis/fit.h"
#include "analysis/report_document.h"

namespace granary::analysis {

struct FigureFitSpec {
  std::string model;                      // "a * W^(1.5 + X_db/2) / (1.43 + 17 * X_db^2)"
  std::vector<std::string> over;          // its variables (axes); default: the axis names it uses
  std::map<std::string, double> initial;  // parameters' start values (missing: 1)
  bool collapse = false;                  // also draw y / law against x (should lie on 1)
};

// A mark a pictures figure asks for (/report/figures/k/annotate/i); PictureMarksOf places it
// on each run.
struct MarkSpec {
  // Rectangles: "region" (the region analysis' rectangle next to an outlet, /report/region) or
  // "fields" (the maps' window, /report/fields/window or each run's default). Dimensions from
  // the run spec: "outlet_width" (W), "obstacle_height" (H: base to the obstacle's centre),
  // "obstacle_offset" (L: the silo's axis to the obstacle's centre), "outlet_gap" (L: edge to
  // edge of base outlets 0 and 1); from the frame: "disc_diameters" (each disc size of the body
  // nearest `at`: a snowman's D_s and D_b, thesis fig. 6.1). A point: "origin".
  std::string what;
  int index = -1;  // the outlet or obstacle (event order); -1: every outlet (rectangles), 0 (dimensions)
  std::string label;
  bool shade = false;
  std::optional<std::array<double, 2>> at = {};  // disc_diameters: default the zoom window's centre, else mid-bed
  std::vector<std::string> labels = {};          // disc_diameters: one per disc size, smallest first
};

struct FigureSpec {
  std::string path;  // "/report/figures/3", for messages
  std::string name;  // file stem, and what expectations name ("fit": name)
  // "points" (with error bars), "distribution" (a histogram per chosen point), "curves" (a curve
  // an analysis offers, per chosen point), "maps" (a field's map per chosen point), "profile" (a
  // field along a line, a curve per chosen point) or "pictures" (of the chosen points)
  std::string kind = "points";
  std::string picture = "end";     // pictures: "end" (the last frame: clogged, discharged), "bed" or "clog"
  std::vector<MarkSpec> annotate;  // pictures: regions and dimensions drawn over them
  std::optional<std::array<double, 4>> window;  // pictures: a zoom (x_lo, x_hi, y_lo, y_hi in d) besides the whole
  bool colour_by_disc = false;                  // pictures: "colour": "disc" (a snowman's head and body apart)
  std::string of;  // distribution: an offered distribution or a per-run metric; curves: an offered curve
  int bins = 30;   // distribution
  double range_lo = kNaN, range_hi = kNaN;  // distribution: the bins' range (NaN: the data's, common to every curve)
  std::string field;                        // maps, profile: an offered field
  std::string along;                        // profile: "x" or "y"
  double at = kNaN;                         // profile: the line's other coordinate (d)
  double width = 1.0;                       // profile: the band across the line averaged (d)
  int origin_outlet = -1;                   // profile along x: x from this base outlet's centre (-1: the silo's x)
  bool one_run = false;                     // maps, profile: the lowest replica with the field, not the runs merged
  // points: one or several metric names or expressions over metrics and axes, each a curve per
  // group (thesis fig. 6.8: the s-s, l-s and l-l fractions in one figure)
  std::vector<std::string> y;
  bool y_list = false;              // given as a list: /y/<k> in messages, and each curve's label names it
  std::vector<std::string> labels;  // the legend label of each y (default: the y itself)
  std::string ylabel;               // default: the y (joined when several)
  std::string x;                    // an axis name; "" = the report's x axis
  std::vector<std::string> group;   // axes making one curve each
  bool group_given = false;         // false: every sweep axis but x and the pooled ones
  std::vector<std::string> pool;    // axes pooled over (points differing only there are one)
  std::vector<std::pair<std::string, std::vector<nlohmann::json>>> only;  // axis -> accepted values
  // points: each curve divided by its own value at the point whose axes take these values, the
  // curve's other axes (x, group) the same ({"L": 0}: Q/Q_0 with Q_0 at L = 0, thesis fig. 5.13a)
  std::vector<std::pair<std::string, nlohmann::json>> normalize;
  std::optional<FigureFitSpec> fit;
  std::string title, caption, reference;
  bool logx = false, logy = false;
};

// The parts of polylines (the silo's walls over a map) inside box {x0, x1, y0, y1}: a line
// leaving and re-entering it becomes two.
std::vector<std::vector<std::array<double, 2>>> ClipPolylines(
    const std::vector<std::vector<std::array<double, 2>>>& lines, const std::array<double, 4>& box);

// Reads /report/figures of a campaign spec (absent: none). Every error is an OptionError naming
// the JSON path, the value and what is allowed; axis names are checked against the spec's
// sweep and /axes.
std::vector<FigureSpec> ReadFigureSpecs(const nlohmann::json& campaign_spec);

// The marks of a pictures figure on one run, in silo coordinates: from its run spec, the
// campaign spec (/report/region, /report/fields) and its bed's top (the maps' default window).
// A mark the run has nothing for (no obstacle, one outlet) is left out and said in `problems`.
std::vector<PictureMark> PictureMarksOf(const FigureSpec& figure, const nlohmann::json& campaign_spec,
                                        const nlohmann::json& run_spec, double bed_top,
                                        std::vector<std::string>& problems);

// One data point of a figure: a set of sweep points (pooled), its axes' values, y ± se (n).
struct FigureDatum {
  std::vector<std::size_t> points;     // indices into CampaignView::points
  std::map<std::string, double> axes;  // every axis by name (sweep short names, derived, L)
  double x = kNaN, y = kNaN, se = kNaN;
  int n = 0;
  std::string group;       // "X_db = 0.5" (the group axes' values)
  std::size_t series = 0;  // which of the figure's y
};

struct FigureOutcome {
  const FigureSpec* spec = nullptr;
  std::vector<FigureDatum> data;
  std::optional<FitResult> fit;  // when the figure has a fit (perhaps not good)
  std::vector<Block> blocks;     // the figure(s), fit table and notes
};

// The axes of a point of the view by name: CampaignAxes::values plus the report's x symbol
// when x is not a sweep axis (the gap L between two outlets).
std::map<std::string, double> PointAxes(const CampaignView& view, const Point& point);

// Does the value of axis `name` at a point equal `want` (numbers as numbers, to 6 significant
// digits as the report prints them; strings as strings)?
bool AxisValueMatches(const CampaignView& view, const Point& point, const std::string& name,
                      const nlohmann::json& want);

// Point metrics of several points pooled: means weighted by n, standard errors combined
// (one point: its metrics as they are).
std::map<std::string, MeanSe> PooledMetrics(const CampaignAnalysis& analysis, const std::vector<std::size_t>& points);
// y (a metric name, or an expression over metrics and axes) from such metrics and a point's
// axes: a metric as it is; an expression with its metrics' standard errors propagated to first
// order and n the fewest of theirs. Sets `problem` (and returns NaN) for a name that is neither.
MeanSe YValue(const std::string& y, const std::map<std::string, MeanSe>& metrics,
              const std::map<std::string, double>& axes, std::string& problem);

// y / y_0 with y_0 the reference's value: se propagated as from independent values; the
// reference itself (`same`) is 1 exactly with se 0.
MeanSe NormalisedValue(const MeanSe& y, const MeanSe& y0, bool same);

// The data of a figure (only, pool, y per point, normalize) and, with a fit, the fit across them.
FigureOutcome MakeFigure(const CampaignAnalysis& analysis, const FigureSpec& spec);

// A field along a line: the mean over the grid nodes whose other coordinate lies within
// width/2 of `at` (the nearest row or column when the band holds none) at each position along
// it. `along` is 'x' or 'y'.
struct FieldProfile {
  std::vector<double> position, value;    // value NaN where no node of the band is defined
  std::vector<int> nodes;                 // defined nodes averaged at each position
  double band_lo = kNaN, band_hi = kNaN;  // the rows (columns) averaged: their coordinates
};
FieldProfile ComputeFieldProfile(const FieldMap& map, char along, double at, double width);

// A histogram of weighted values as a probability density over `bins` equal bins of [lo, hi]
// (equal in log when `log`; each bin [a, b) but the last, which holds hi, as numpy's): counts,
// and density = count / (total weight * bin width), the total counting the values outside the
// range too.
struct Density {
  std::vector<double> center, density, count;
  double total = 0.0;
};
Density DensityHistogram(const Samples& samples, int bins, double lo, double hi, bool log);

// The "Figures" section of the report: every figure of /report/figures; nullopt when none.
std::optional<Section> FiguresSection(const std::vector<FigureOutcome>& figures);

}  // namespace granary::analysis
