// The report as a document: sections of text, tables and figures, rendered to report.md and
// a self-contained report.html (inline CSS, figures as inline SVG made by gnuplot). Every
// table and every figure series is also written as a CSV next to the report. Analyses never
// format; they fill Tables and Figures, and this layer renders them.
#pragma once

#include <array>
#include <filesystem>
#include <limits>
#include <string>
#include <variant>
#include <vector>

#include "analysis/stats.h"

namespace granary::analysis {

// A table cell: text, a number, or an estimate "mean ± se (n)". Markdown and HTML show
// numbers to a few significant digits; the CSV has them to full precision, an estimate in
// three columns (<key>, <key>_se, <key>_n; no _n column when no cell of it has an n).
struct Cell {
  enum class Kind { kText, kNumber, kEstimate };
  Kind kind = Kind::kText;
  std::string text;
  double value = kNaN;
  double se = kNaN;
  int n = -1;      // estimates: < 0 = no n
  int digits = 4;  // significant digits shown

  Cell() = default;
  Cell(std::string t) : text(std::move(t)) {}  // NOLINT: text cells read naturally in row lists
  Cell(const char* t) : text(t) {}             // NOLINT
  static Cell Number(double value, int digits = 4);
  static Cell Count(long long value);
  static Cell Estimate(double mean, double se, int n, int digits = 4);
  static Cell Estimate(const MeanSe& m, int digits = 4) { return Estimate(m.mean, m.se, m.n, digits); }
  // What markdown and HTML show.
  std::string Shown() const;
};

struct Table {
  std::string name;  // file stem of its CSV (unique in the report)
  std::string caption;
  std::vector<std::string> header;  // what markdown and HTML show
  std::vector<std::vector<Cell>> rows;
  std::vector<std::string> keys;  // CSV column names (empty: the header)
};

// One curve of a figure: columns of numbers (NaN = missing). Its CSV is named after the
// figure and the curve's label (or file_label): <figure>--<label as a file name>.csv.
struct Series {
  std::string label;
  std::vector<std::string> columns;  // names, e.g. {"W", "Q", "Q_se"}
  std::vector<std::vector<double>> rows;
  enum class Style { kPoints, kErrorBars, kLines, kLinesPoints, kSteps } style = Style::kPoints;
  // Columns plotted (0-based); err < 0: none (kErrorBars needs it; kLinesPoints draws error
  // bars when it is set).
  int x = 0, y = 1, err = -1;
  int color = -1;  // palette index (0-based); -1: next in turn
  // kData: measured values; the axes are fitted to them, and points of several curves at the
  // same x are drawn side by side. kFit: a model curve over the data (its data's colour; the
  // axes do not stretch for it). kReference: a reference line (black, its own dash pattern).
  enum class Role { kData, kFit, kReference } role = Role::kData;
  // Names the CSV instead of `label` when set: what may change from one report to the next (a
  // fit's quality, a count) goes in the key, not in the file name scripts read.
  std::string file_label{};
};

// The report's palette: 12 colours that stay apart (and from the black of reference lines);
// curve k takes colour k mod 12 and point shape k mod 6, so 24 curves differ in something.
inline constexpr int kPaletteSize = 12;
extern const char* const kPalette[kPaletteSize];

// Report folder layout: tables' and curves' CSVs in data/, SVGs and their gnuplot scripts in
// figures/, next to report.md and report.html.
inline constexpr char kDataDir[] = "data";
inline constexpr char kFiguresDir[] = "figures";

struct Figure {
  std::string name;  // file stem: <name>.svg, <name>--<curve>.csv
  std::string title;
  std::string xlabel, ylabel;  // with units
  std::vector<Series> series;
  bool logx = false, logy = false;
  std::string caption;
};

struct Text {
  std::string markdown;  // plain text with `code` and **bold**; paragraphs by blank lines
};

// Pictures already drawn (PNG files in the report folder), side by side: in report.html as
// data URIs, so it stays self-contained.
struct Picture {
  std::string file;  // relative to the report folder
  std::string caption;
};
struct Pictures {
  std::string caption;
  std::vector<Picture> pictures;
};

// A map over the silo (gnuplot SVG): a field on a regular grid in panels side by side (one per
// sweep point), one colour scale across the panels, the silo's walls and outlets as lines and
// its obstacles as circles drawn over it, axes in d; optionally arrows (a vector field) and
// segments drawn with widths in proportion to a weight (a contact-force network). Each panel's
// grid is its CSV <name>-<k>.csv: columns x, y, <value_key>, n_frames.
struct MapPanel {
  std::string title;
  std::vector<std::array<double, 4>> grid;                // x, y, value (NaN: none), n_frames; empty: no colour map
  std::vector<std::vector<std::array<double, 2>>> lines;  // polylines (walls)
  std::vector<std::array<double, 3>> circles;             // x, y, radius (obstacles)
  std::vector<std::array<double, 4>> arrows;              // x, y, dx, dy (in d, already scaled)
  std::vector<std::array<double, 5>> segments;            // x1, y1, x2, y2, weight (width in proportion)
};

struct MapFigure {
  std::string name;  // file stem
  std::string title;
  std::string value_name;           // colour-bar label, e.g. "pressure P (contact) (m g / d)"
  std::string value_key = "value";  // its CSV column, e.g. "pressure"
  std::vector<MapPanel> panels;
  double x_lo = 0, x_hi = 1, y_lo = 0, y_hi = 1;           // the view, in d
  double c_lo = std::numeric_limits<double>::quiet_NaN();  // colour scale; NaN: the panels' finite range
  double c_hi = std::numeric_limits<double>::quiet_NaN();
  bool diverging = false;  // a signed field: range symmetric about 0, blue-white-red
  std::string caption;
};

// Text shown as it is, in a monospaced block (the campaign spec in the provenance).
struct Code {
  std::string text;
};

using Block = std::variant<Text, Table, Figure, Pictures, MapFigure, Code>;

struct Section {
  std::string id;  // html anchor
  std::string title;
  std::vector<Block> blocks;
};

// Why pictures of a section could not be drawn (no renderer, a run directory gone): the first
// few reasons, said once at the end of the section as "Not drawn: ...".
class NotDrawn {
 public:
  void Add(std::string problem) {
    if (problems_.size() < kKept) problems_.push_back(std::move(problem));
  }
  void AppendTo(Section& s) const;

 private:
  static constexpr std::size_t kKept = 5;
  std::vector<std::string> problems_;
};

struct RenderOptions {
  bool figures = true;
  std::string gnuplot = "gnuplot";
};

struct RenderResult {
  std::filesystem::path markdown, html;
  int figures_drawn = 0;
  std::vector<std::string> problems;  // e.g. "gnuplot not found: figures omitted"
};

// The gnuplot script that draws `figure` from its series' CSV files; run in the report folder,
// it reads data/<curve files> and writes figures/<name>.svg.
std::string GnuplotScript(const Figure& figure);

// Writes report.md and report.html into out_dir, every CSV into out_dir/data and (with
// figures) every SVG into out_dir/figures.
RenderResult RenderReport(const std::string& title, const std::vector<Section>& sections,
                          const std::filesystem::path& out_dir, const RenderOptions& options);

// Helpers for filling tables: numbers with a fixed number of significant digits, NaN as "".
std::string FormatNumber(double value, int significant = 4);
// "mean ± se (n)" in markdown/html cells; se NaN -> "mean (n)"; n < 0 -> no "(n)".
std::string FormatMeanSe(double mean, double se, int n, int significant = 4);
// Full precision (the shortest text that reads back as the same double); NaN as "nan".
std::string CsvNumber(double value);
// A figure's canvas and its key below the plot: two columns when two of the longest title fit
// across, else one; a title wider than 800 px widens the canvas (report.html scales the SVG to
// the page), so the key is never cut or wrapped past the plot's edge.
struct KeyLayout {
  int width = 800, height = 440;  // SVG size, px
  int columns = 2;                // of the key
};
KeyLayout ComputeKeyLayout(const Figure& figure);

// The CSV files of a figure's curves, in series order: <figure>--<label>.csv, unique.
std::vector<std::string> SeriesFiles(const Figure& figure);
std::string CsvEscape(const std::string& field);
std::string HtmlEscape(const std::string& text);

}  // namespace granary::analysis
