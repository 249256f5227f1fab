// Implementation of report_document.h: markdown, html, CSV and gnuplot SVG rendering.
#include "analysis/report_document.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <regex>
#include <set>
#include <sstream>

namespace granary::analysis {

namespace fs = std::filesystem;

std::string FormatNumber(double v, int significant) {
  if (!std::isfinite(v)) return "";
  if (v == std::floor(v) && std::abs(v) < 1e9) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.0f", v);
    return buf;
  }
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", significant, v);
  return buf;
}

std::string FormatMeanSe(double mean, double se, int n, int significant) {
  if (!std::isfinite(mean)) return "";
  if (std::isfinite(se) && std::abs(mean) < 1e-9 * se) mean = 0.0;  // rounding noise of an exact zero
  std::string s = FormatNumber(mean, significant);
  if (std::isfinite(se)) s += " ± " + FormatNumber(se, 2);
  return n < 0 ? s : s + " (" + std::to_string(n) + ")";
}

Cell Cell::Number(double value, int digits) {
  Cell c;
  c.kind = Kind::kNumber;
  c.value = value;
  c.digits = digits;
  return c;
}

Cell Cell::Count(long long value) { return Number(static_cast<double>(value)); }

Cell Cell::Estimate(double mean, double se, int n, int digits) {
  Cell c;
  c.kind = Kind::kEstimate;
  c.value = mean;
  c.se = se;
  c.n = n;
  c.digits = digits;
  return c;
}

std::string Cell::Shown() const {
  switch (kind) {
    case Kind::kNumber: return FormatNumber(value, digits);
    case Kind::kEstimate: return FormatMeanSe(value, se, n, digits);
    case Kind::kText: break;
  }
  return text;
}

std::string CsvNumber(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return ec == std::errc() ? std::string(buf, end) : std::string("nan");
}

std::vector<std::string> SeriesFiles(const Figure& f) {
  std::vector<std::string> names;
  for (std::size_t k = 0; k < f.series.size(); ++k) {
    // The label as a file name: letters, digits, '.', '-' and '_' kept, runs of others -> '_'.
    std::string slug;
    const Series& se = f.series[k];
    for (char ch : se.file_label.empty() ? se.label : se.file_label) {
      const bool keep = std::isalnum(static_cast<unsigned char>(ch)) || ch == '.' || ch == '-' || ch == '_';
      if (keep) {
        slug += ch;
      } else if (!slug.empty() && slug.back() != '_') {
        slug += '_';
      }
    }
    while (!slug.empty() && slug.back() == '_') slug.pop_back();
    if (slug.size() > 80) slug.resize(80);
    if (slug.empty()) slug = "curve" + std::to_string(k + 1);
    std::string name = f.name + "--" + slug;
    for (int i = 2; std::find(names.begin(), names.end(), name + ".csv") != names.end(); ++i)
      name = f.name + "--" + slug + "-" + std::to_string(i);
    names.push_back(name + ".csv");
  }
  return names;
}

std::string CsvEscape(const std::string& f) {
  if (f.find_first_of(",\"\n") == std::string::npos) return f;
  std::string out = "\"";
  for (char c : f) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

std::string HtmlEscape(const std::string& t) {
  std::string out;
  for (char c : t) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

namespace {

constexpr double kNaNValue = std::numeric_limits<double>::quiet_NaN();

void WriteText(const fs::path& file, const std::string& text) {
  std::ofstream out(file);
  out << text;
  if (!out) throw std::runtime_error(file.string() + ": cannot write");
}

// Numbers to full precision and missing ones as "nan" (read as NaN by numpy and pandas), so
// that the numbers can be re-analysed; an estimate column becomes <key>, <key>_se, <key>_n.
void WriteTableCsv(const fs::path& file, const Table& t) {
  const std::size_t columns = t.header.size();
  std::vector<bool> estimate(columns, false), with_n(columns, false);
  for (const auto& row : t.rows)
    for (std::size_t i = 0; i < row.size() && i < columns; ++i)
      if (row[i].kind == Cell::Kind::kEstimate) {
        estimate[i] = true;
        with_n[i] = with_n[i] || row[i].n >= 0;
      }
  std::ostringstream s;
  for (std::size_t i = 0; i < columns; ++i) {
    const std::string key = i < t.keys.size() ? t.keys[i] : t.header[i];
    s << (i ? "," : "") << CsvEscape(key);
    if (estimate[i]) s << "," << CsvEscape(key + "_se") << (with_n[i] ? "," + CsvEscape(key + "_n") : "");
  }
  s << "\n";
  for (const auto& row : t.rows) {
    for (std::size_t i = 0; i < columns; ++i) {
      if (i) s << ",";
      const Cell empty;
      const Cell& c = i < row.size() ? row[i] : empty;
      if (estimate[i]) {
        const bool is_estimate = c.kind == Cell::Kind::kEstimate;
        s << (c.kind == Cell::Kind::kText ? CsvEscape(c.text) : CsvNumber(c.value)) << ","
          << CsvNumber(is_estimate ? c.se : kNaNValue);
        if (with_n[i]) s << "," << (is_estimate && c.n >= 0 ? std::to_string(c.n) : std::string("nan"));
      } else if (c.kind == Cell::Kind::kText) {
        s << CsvEscape(c.text);
      } else {
        s << CsvNumber(c.value);
      }
    }
    s << "\n";
  }
  WriteText(file, s.str());
}

void WriteSeriesCsv(const fs::path& file, const Series& se) {
  std::ostringstream s;
  for (std::size_t i = 0; i < se.columns.size(); ++i) s << (i ? "," : "") << CsvEscape(se.columns[i]);
  s << "\n";
  for (const auto& row : se.rows) {
    for (std::size_t i = 0; i < row.size(); ++i) s << (i ? "," : "") << CsvNumber(row[i]);
    s << "\n";
  }
  WriteText(file, s.str());
}

bool HasFinitePoint(const Figure& f) {
  for (const Series& se : f.series)
    for (const auto& row : se.rows) {
      const auto x = static_cast<std::size_t>(se.x), y = static_cast<std::size_t>(se.y);
      if (x < row.size() && y < row.size() && std::isfinite(row[x]) && std::isfinite(row[y])) return true;
    }
  return false;
}

std::string GpQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

}  // namespace

const char* const kPalette[kPaletteSize] = {"#0072b2", "#d55e00", "#009e73", "#cc79a7", "#e69f00", "#56b4e9",
                                            "#9467bd", "#8c564b", "#bcbd22", "#2f4f4f", "#e41a1c", "#1b1b8f"};

namespace {

// Point shapes of gnuplot's svg terminal, in turn: filled circle, square, up triangle, diamond,
// down triangle, pentagon.
constexpr int kPointTypes[] = {7, 5, 9, 13, 11, 15};

struct Range {
  double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();
  double lowest_value = std::numeric_limits<double>::infinity();  // of the values alone (no error bars)
  void Add(double v, double err, bool log) {
    if (!std::isfinite(v) || (log && v <= 0)) return;
    lowest_value = std::min(lowest_value, v);
    const double e = std::isfinite(err) ? std::abs(err) : 0.0;
    lo = std::min(lo, log && v - e <= 0 ? v : v - e);
    hi = std::max(hi, v + e);
  }
  bool empty() const { return !(lo <= hi); }
};

// "[lo:hi]" that holds the range with a margin; a quantity whose values are all >= 0 does not
// get a negative axis for its error bars' sake. Log axes get a factor as margin.
std::string RangeText(const Range& r, bool log) {
  double lo = r.lo, hi = r.hi;
  if (log) {
    const double f = hi > lo ? std::pow(hi / lo, 0.05) : 2.0;
    lo /= f;
    hi *= f;
  } else {
    const double span = hi - lo;
    const double pad =
        span > 1e-12 * std::max(1.0, std::abs(lo)) ? 0.05 * span : (lo != 0.0 ? 0.1 * std::abs(lo) : 1.0);
    lo = r.lowest_value >= 0 ? std::max(0.0, lo - pad) : lo - pad;
    hi += pad;
  }
  return "[" + CsvNumber(lo) + ":" + CsvNumber(hi) + "]";
}

double FormatCell(const std::vector<double>& row, int col) {
  return col >= 0 && col < static_cast<int>(row.size()) ? row[static_cast<std::size_t>(col)] : kNaNValue;
}

}  // namespace

KeyLayout ComputeKeyLayout(const Figure& f) {
  // Gnuplot's svg terminal sizes a key entry as its title's characters at 0.7 font sizes each
  // plus the sample line: at 13 pt, 9.1 px a character and the sample line about 10 characters
  // more (measured: titles of 30 characters go in two columns on 800 px, of 36 in one; a pair
  // of 32-character titles in two columns ended 10 px from the edge).
  constexpr double kCharPx = 9.1;
  constexpr int kMargin = 40;
  std::size_t longest = 0;
  for (const Series& se : f.series) longest = std::max(longest, se.label.size());
  KeyLayout k;
  const int entry = static_cast<int>(std::ceil((static_cast<double>(longest) + 10) * kCharPx));
  k.width = std::max(k.width, entry + kMargin);
  // The title is centred over the plot, which the y label's margin moves right: at most
  // 7.5 px a character (measured 6.6) and that margin on both sides.
  constexpr double kTitleCharPx = 7.5;
  constexpr int kTitleMargin = 2 * 70;
  k.width =
      std::max(k.width, static_cast<int>(std::ceil(static_cast<double>(f.title.size()) * kTitleCharPx)) + kTitleMargin);
  k.columns = 2 * entry + kMargin <= k.width ? 2 : 1;
  const int rows = static_cast<int>((f.series.size() + static_cast<std::size_t>(k.columns) - 1) /
                                    static_cast<std::size_t>(k.columns));
  k.height = 440 + 20 * rows;
  return k;
}

std::string GnuplotScript(const Figure& f) {
  std::ostringstream s;
  const std::vector<std::string> files = SeriesFiles(f);
  const KeyLayout key = ComputeKeyLayout(f);
  s << "set terminal svg size " << key.width << "," << key.height << " font 'Helvetica,13' background rgb 'white'\n"
    << "set output " << GpQuote(std::string(kFiguresDir) + "/" + f.name + ".svg") << "\n"
    << "set datafile separator ','\n"
    << "set title " << GpQuote(f.title) << " noenhanced\n"
    << "set xlabel " << GpQuote(f.xlabel) << " noenhanced\n"
    << "set ylabel " << GpQuote(f.ylabel) << " noenhanced\n"
    << "set grid\nset key below maxcols " << key.columns << " noenhanced\n";
  for (int k = 0; k < 2 * kPaletteSize; ++k)
    s << "set linetype " << k + 1 << " lc rgb '" << kPalette[k % kPaletteSize] << "' lw 1.5 pt "
      << kPointTypes[k % std::size(kPointTypes)] << " dt " << (k < kPaletteSize ? 1 : 2) << "\n";
  if (f.logx) s << "set logscale x\n";
  if (f.logy) s << "set logscale y\nset format y '%g'\n";
  // Axes fitted to the data (and reference lines), not stretched by fitted curves or tics.
  Range xr, yr;
  for (const Series& se : f.series) {
    if (se.role == Series::Role::kFit) continue;
    for (const auto& row : se.rows) {
      if (!std::isfinite(FormatCell(row, se.x)) || !std::isfinite(FormatCell(row, se.y))) continue;
      xr.Add(FormatCell(row, se.x), kNaNValue, f.logx);
      const bool bars =
          se.err >= 0 && (se.style == Series::Style::kErrorBars || se.style == Series::Style::kLinesPoints);
      yr.Add(FormatCell(row, se.y), bars ? FormatCell(row, se.err) : kNaNValue, f.logy);
    }
  }
  if (!xr.empty()) s << "set xrange " << RangeText(xr, f.logx) << "\n";
  if (!yr.empty()) s << "set yrange " << RangeText(yr, f.logy) << "\n";
  // Every point at its true x: curves that share an x tell apart by colour and marker shape,
  // never by a shifted coordinate (a shift reads as another x and left the outermost points
  // outside the range).
  s << "plot ";
  int next_colour = 0, reference = 0;
  for (std::size_t k = 0; k < f.series.size(); ++k) {
    const Series& se = f.series[k];
    const std::string x = "($" + std::to_string(se.x + 1) + ")";
    const std::string y = "($" + std::to_string(se.y + 1) + ")";
    s << (k ? ", \\\n     " : "") << GpQuote(std::string(kDataDir) + "/" + files[k]) << " skip 1 using " << x << ":"
      << y;
    // An unknown se (nan in the CSV) is no bar: gnuplot reads "nan" as an invalid column,
    // which `$n == $n` alone does not catch (it drew the bar's caps at the axis).
    const std::string e = std::string("$").append(std::to_string(se.err + 1));
    const std::string err = ":(valid(" + std::to_string(se.err + 1) + ") && " + e + " == " + e + " ? " + e + " : 0)";
    switch (se.style) {
      case Series::Style::kErrorBars: s << err << " with yerrorbars ps 0.7"; break;
      case Series::Style::kLines: s << " with lines"; break;
      case Series::Style::kLinesPoints:
        if (se.err >= 0)
          s << err << " with yerrorlines ps 0.6";  // a curve of means with their standard errors
        else
          s << " with linespoints ps 0.6";
        break;
      case Series::Style::kSteps: s << " with histeps"; break;
      case Series::Style::kPoints: s << " with points ps 0.7"; break;
    }
    if (se.role == Series::Role::kReference) {
      // Black (grey after the first), each its own dash pattern: told apart in the key.
      s << " lc rgb '" << (reference == 0 ? "#000000" : "#555555") << "' dt " << 1 + reference % 5;
      ++reference;
    } else {
      const int colour = se.color >= 0 ? se.color : next_colour++;
      s << " lt " << colour % (2 * kPaletteSize) + 1;
      if (se.role == Series::Role::kFit) s << " dt 2";  // dashed: a model, not data
    }
    const bool line = se.style == Series::Style::kLines || se.style == Series::Style::kSteps;
    s << " lw " << (se.role == Series::Role::kReference ? "1.5" : line ? "2" : "1.5");
    s << " title " << GpQuote(se.label);
    // The end of a measured curve gets a point of its colour, so that a short curve hidden
    // under longer ones (a stream that clogged at once) is still seen, and where it ends.
    if (se.role == Series::Role::kData && line && !se.rows.empty() && se.style == Series::Style::kLines) {
      const std::size_t last = se.rows.size() - 1;
      s << ", \\\n     " << GpQuote(std::string(kDataDir) + "/" + files[k]) << " skip 1 every ::" << last
        << "::" << last << " using " << x << ":" << y << " with points ps 0.8 lt "
        << (se.color >= 0 ? se.color : next_colour - 1) % (2 * kPaletteSize) + 1 << " notitle";
    }
  }
  s << "\n";
  return s.str();
}

namespace {

// SVG for inlining: no XML prolog, ids made unique per figure so several SVGs share a page.
std::string InlineSvg(const std::string& svg, const std::string& prefix) {
  std::string s = svg;
  const auto start = s.find("<svg");
  if (start != std::string::npos) s = s.substr(start);
  s = std::regex_replace(s, std::regex("id='"), "id='" + prefix);
  s = std::regex_replace(s, std::regex("id=\""), "id=\"" + prefix);
  s = std::regex_replace(s, std::regex("href='#"), "href='#" + prefix);
  s = std::regex_replace(s, std::regex("href=\"#"), "href=\"#" + prefix);
  s = std::regex_replace(s, std::regex("url\\(#"), "url(#" + prefix);
  return s;
}

// POSIX shell single quoting: ' -> '\''.
std::string ShellQuote(const std::string& s) {
  std::string out = "'";
  for (char ch : s) out += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
  return out + "'";
}

bool HaveGnuplot(const std::string& exe) {
  const std::string cmd = "command -v " + ShellQuote(exe) + " > /dev/null 2>&1";
  return std::system(cmd.c_str()) == 0;
}

// Runs gnuplot in the report directory; returns "" or the problem.
std::string RunGnuplot(const std::string& exe, const fs::path& dir, const std::string& script) {
  const std::string cmd = "cd " + ShellQuote(dir.string()) + " && " + ShellQuote(exe) + " " + ShellQuote(script) +
                          " > " + ShellQuote(script + ".log") + " 2>&1";
  const int rc = std::system(cmd.c_str());
  if (rc == 0) {
    std::error_code ec;
    fs::remove(dir / (script + ".log"), ec);  // nothing to keep: the figure is there
  } else {
    std::ifstream in(dir / (script + ".log"));
    std::string log((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (log.size() > 400) log = log.substr(log.size() - 400);
    return "gnuplot failed on " + script + " (status " + std::to_string(rc) + "): " + log;
  }
  return "";
}

std::string ReadText(const fs::path& file) {
  std::ifstream in(file);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Inline markup of Text: `code` and **bold** only.
std::string HtmlInline(const std::string& text) {
  std::string e = HtmlEscape(text);
  e = std::regex_replace(e, std::regex("\\*\\*([^*]+)\\*\\*"), "<b>$1</b>");
  e = std::regex_replace(e, std::regex("`([^`]+)`"), "<code>$1</code>");
  // Links within the report only: an anchor or a file beside report.html (relative, so the
  // folder can be moved); anything with a scheme or a quote stays text.
  e = std::regex_replace(e, std::regex("\\[([^\\]]+)\\]\\((#[A-Za-z0-9_.-]+|[A-Za-z0-9_][A-Za-z0-9_./-]*)\\)"),
                         "<a href=\"$2\">$1</a>");
  return e;
}

// A link to a file next to report.html (relative: the report folder can be moved or mailed).
std::string LocalLink(const std::string& file) {
  const std::string f = HtmlEscape(file);
  return std::string("<a href=\"").append(f).append("\">").append(f).append("</a>");
}

// Numbers (and "mean ± se (n)") align right, words left.
bool LooksNumeric(const Cell& cell) {
  if (cell.kind != Cell::Kind::kText) return true;
  const std::string& c = cell.text;
  if (c.empty()) return true;
  const char first = c.front();
  return std::isdigit(static_cast<unsigned char>(first)) ||
         ((first == '-' || first == '.' || first == '[') && c.size() > 1);
}

std::string MdCell(const std::string& s) {
  std::string out;
  for (char c : s) out += c == '|' ? std::string("\\|") : c == '\n' ? std::string(" ") : std::string(1, c);
  return out;
}

const char* kCss =
    "body{font-family:Helvetica,Arial,sans-serif;max-width:1300px;margin:2em auto;padding:0 1em;color:#222}"
    "h1{border-bottom:2px solid #446}h2{border-bottom:1px solid #ccd;margin-top:2em}"
    // Tables fit the page: headers and text wrap, numbers stay whole; no sideways scrolling.
    "table{border-collapse:collapse;margin:1em 0;font-size:0.85em;max-width:100%}"
    "th,td{border:1px solid #ccd;padding:3px 6px;text-align:right}th{background:#eef;white-space:normal}"
    "td{white-space:nowrap}td.t{text-align:left;white-space:normal;max-width:24em}"
    "table.wide{font-size:0.75em}table.wide th,table.wide td{padding:2px 4px}"
    "caption{text-align:left;font-weight:bold;padding:4px 0}"
    "figure{margin:1em 0}figcaption{font-size:0.9em;color:#444}code{background:#f4f4f8;padding:0 3px}pre{background:#f4f4f8;padding:0.5em;font-size:0.8em;max-height:30em;overflow:auto}"
    ".csv{font-size:0.8em;color:#666}nav a{margin-right:1em}svg{max-width:100%;height:auto}"
    ".pics{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-end}.pics figure{margin:0}.pics img{width:320px;border:1px solid #ddd}";

// RFC 4648 base64, for the pictures' data URIs.
std::string Base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = static_cast<unsigned char>(bytes[i]) << 16 | static_cast<unsigned char>(bytes[i + 1]) << 8 |
                       static_cast<unsigned char>(bytes[i + 2]);
    out += {k[v >> 18], k[(v >> 12) & 63], k[(v >> 6) & 63], k[v & 63]};
  }
  if (i + 1 == bytes.size()) {
    const unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    out += {k[v >> 18], k[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == bytes.size()) {
    const unsigned v = static_cast<unsigned char>(bytes[i]) << 16 | static_cast<unsigned char>(bytes[i + 1]) << 8;
    out += {k[v >> 18], k[(v >> 12) & 63], k[(v >> 6) & 63], '='};
  }
  return out;
}

// A table cell in HTML: escaped, and a "name = value" pair (a point name's "W = 12") held on
// one line with no-break spaces, so a narrow column breaks only between the pairs.
std::string HtmlCellText(const std::string& text) {
  std::string out = HtmlEscape(text);
  for (std::size_t at = out.find(" = "); at != std::string::npos; at = out.find(" = ", at))
    out.replace(at, 3, "&#160;=&#160;");
  return out;
}

std::string PanelFile(const MapFigure& f, std::size_t k, const char* layer) {
  std::string file = std::string(kDataDir) + "/" + f.name + "-" + std::to_string(k + 1);
  if (layer[0] != '\0') file.append("-").append(layer);
  return file.append(".csv");
}

// The colour range of a map: the figure's, or the panels' finite range (symmetric about 0
// for a diverging field), widened when flat.
std::pair<double, double> MapRange(const MapFigure& f) {
  double lo = f.c_lo, hi = f.c_hi;
  if (!std::isfinite(lo) || !std::isfinite(hi)) {
    lo = std::numeric_limits<double>::infinity();
    hi = -lo;
    for (const MapPanel& p : f.panels)
      for (const auto& row : p.grid)
        if (std::isfinite(row[2])) {
          lo = std::min(lo, row[2]);
          hi = std::max(hi, row[2]);
        }
    if (!std::isfinite(lo)) return {0.0, 1.0};
    if (f.diverging) {
      hi = std::max(std::abs(lo), std::abs(hi));
      lo = -hi;
    }
  }
  if (hi - lo <= 1e-12 * std::max(1.0, std::abs(lo))) {
    const double pad = lo != 0.0 ? 0.1 * std::abs(lo) : 1.0;
    lo -= pad;
    hi += pad;
  }
  return {lo, hi};
}

// Writes the CSV layers of every panel; returns the gnuplot script.
// A tic step of about a quarter of `range`: 1, 2 or 5 times a power of ten.
double TicStep(double range) {
  const double raw = std::max(1e-9, range / 4.0), decade = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (m * decade >= raw) return m * decade;
  return 10.0 * decade;
}

std::string MapScript(const MapFigure& f, const fs::path& dir) {
  // Panels in rows of up to four (three for 5, 6 or 9 panels), each about 330 px wide; the
  // colour bar, the same for every panel, beside the last panel of each row.
  const std::size_t n = std::max<std::size_t>(1, f.panels.size());
  const std::size_t cols = n <= 4 ? n : (n % 3 == 0 && n <= 9) || n == 5 ? 3 : 4, rows = (n + cols - 1) / cols;
  const double aspect = (f.y_hi - f.y_lo) / std::max(1e-9, f.x_hi - f.x_lo);
  const int panel_w = cols == 1 ? 520 : 330;
  const int width = static_cast<int>(cols) * panel_w + 90;
  const int panel_h = std::clamp(static_cast<int>((panel_w - 90) * aspect) + 80, 160, 1100);
  const int height = static_cast<int>(rows) * panel_h + 40;
  const auto [lo, hi] = MapRange(f);
  double max_weight = 0.0;
  for (const MapPanel& p : f.panels)
    for (const auto& s : p.segments) max_weight = std::max(max_weight, s[4]);
  std::ostringstream s;
  s << "set terminal svg size " << width << "," << height << " font 'Helvetica,10' background rgb 'white'\n"
    << "set output " << GpQuote(std::string(kFiguresDir) + "/" + f.name + ".svg") << "\n"
    << "set datafile separator ','\n"
    << "set multiplot title " << GpQuote(f.title) << " noenhanced\n"
    << "set size ratio -1\nset xrange [" << CsvNumber(f.x_lo) << ":" << CsvNumber(f.x_hi) << "]\n"
    << "set yrange [" << CsvNumber(f.y_lo) << ":" << CsvNumber(f.y_hi) << "]\n"
    << "set xtics " << CsvNumber(TicStep(f.x_hi - f.x_lo)) << "\nset ytics " << CsvNumber(TicStep(f.y_hi - f.y_lo))
    << "\nset format cb '%g'\nset xlabel 'x/d'\nset ylabel 'y/d'\nset tics out nomirror\n"
    << "set cbrange [" << CsvNumber(lo) << ":" << CsvNumber(hi) << "]\n"
    << "set cblabel " << GpQuote(f.value_name) << " noenhanced\n";
  if (f.diverging)
    s << "set palette defined (0 '#2166ac', 0.25 '#67a9cf', 0.5 '#f7f7f7', 0.75 '#ef8a62', 1 '#b2182b')\n";
  else
    s << "set palette defined (0 '#440154', 0.25 '#3b528b', 0.5 '#21918c', 0.75 '#5ec962', 1 '#fde725')\n";
  // Placement in screen fractions: each panel's cell, the last of a row wider by the bar.
  const double cell_w = static_cast<double>(panel_w) / width,
               cell_h = (1.0 - 40.0 / height) / static_cast<double>(rows);
  for (std::size_t k = 0; k < f.panels.size(); ++k) {
    const MapPanel& p = f.panels[k];
    {
      std::ostringstream csv;
      csv << "x,y," << CsvEscape(f.value_key) << ",n_frames\n";
      for (const auto& r : p.grid)
        csv << CsvNumber(r[0]) << "," << CsvNumber(r[1]) << "," << CsvNumber(r[2]) << "," << CsvNumber(r[3]) << "\n";
      WriteText(dir / PanelFile(f, k, ""), csv.str());
    }
    std::vector<std::string> layers;
    bool any_value = false;
    for (const auto& r : p.grid) any_value = any_value || std::isfinite(r[2]);
    if (any_value) layers.push_back(GpQuote(PanelFile(f, k, "")) + " skip 1 using 1:2:3 with image notitle");
    if (!p.segments.empty() && max_weight > 0.0) {
      std::ostringstream csv;
      csv << "x1,y1,x2,y2,weight\n";
      for (const auto& g : p.segments)
        csv << CsvNumber(g[0]) << "," << CsvNumber(g[1]) << "," << CsvNumber(g[2]) << "," << CsvNumber(g[3]) << ","
            << CsvNumber(g[4]) << "\n";
      WriteText(dir / PanelFile(f, k, "segments"), csv.str());
      // gnuplot 5.4 has no variable width for vectors: six classes of width.
      constexpr int kClasses = 6;
      for (int c = 1; c <= kClasses; ++c) {
        const double a = max_weight * (c - 1) / kClasses,
                     b = c == kClasses ? 2.0 * max_weight : max_weight * c / kClasses;
        layers.push_back(GpQuote(PanelFile(f, k, "segments")) + " skip 1 using 1:2:(($5 >= " + CsvNumber(a) +
                         " && $5 < " + CsvNumber(b) + ") ? $3 - $1 : 1/0):($4 - $2) with vectors nohead lw " +
                         CsvNumber(0.5 * c) + " lc rgb '#202020' notitle");
      }
    }
    if (!p.arrows.empty()) {
      std::ostringstream csv;
      csv << "x,y,dx,dy\n";
      for (const auto& g : p.arrows)
        csv << CsvNumber(g[0]) << "," << CsvNumber(g[1]) << "," << CsvNumber(g[2]) << "," << CsvNumber(g[3]) << "\n";
      WriteText(dir / PanelFile(f, k, "arrows"), csv.str());
      layers.push_back(
          GpQuote(PanelFile(f, k, "arrows")) +
          " skip 1 using 1:2:3:4 with vectors head size screen 0.006,20 filled lw 1 lc rgb '#101010' notitle");
    }
    if (!p.lines.empty()) {
      std::ostringstream csv;
      csv << "x,y\n";
      for (const auto& line : p.lines) {
        for (const auto& pt : line) csv << CsvNumber(pt[0]) << "," << CsvNumber(pt[1]) << "\n";
        csv << "\n";
      }
      WriteText(dir / PanelFile(f, k, "walls"), csv.str());
      layers.push_back(GpQuote(PanelFile(f, k, "walls")) +
                       " skip 1 using 1:2 with lines lw 2.5 lc rgb 'black' notitle");
    }
    if (!p.circles.empty()) {
      std::ostringstream csv;
      csv << "x,y,r\n";
      for (const auto& c : p.circles)
        csv << CsvNumber(c[0]) << "," << CsvNumber(c[1]) << "," << CsvNumber(c[2]) << "\n";
      WriteText(dir / PanelFile(f, k, "obstacles"), csv.str());
      layers.push_back(GpQuote(PanelFile(f, k, "obstacles")) +
                       " skip 1 using 1:2:3 with circles fill solid 1.0 lc rgb '#808080' notitle");
    }
    const double row = static_cast<double>(k / cols), col = static_cast<double>(k % cols);
    const bool last_in_row = k % cols + 1 == cols || k + 1 == f.panels.size();
    s << "set origin " << CsvNumber(col * cell_w) << "," << CsvNumber(1.0 - 40.0 / height - (row + 1) * cell_h) << "\n"
      << "set size ratio -1 " << CsvNumber(last_in_row ? cell_w + 90.0 / width : cell_w) << "," << CsvNumber(cell_h)
      << "\n"
      << (last_in_row ? "set colorbox\n" : "unset colorbox\n");
    s << "set title " << GpQuote(p.title) << " noenhanced\n";
    if (layers.empty()) {
      s << "set label 1 'no data' at graph 0.5, graph 0.5 center\nplot 1/0 notitle\nunset label 1\n";
      continue;
    }
    s << "plot ";
    for (std::size_t i = 0; i < layers.size(); ++i) s << (i ? ", \\\n     " : "") << layers[i];
    s << "\n";
  }
  s << "unset multiplot\n";
  return s.str();
}

}  // namespace

RenderResult RenderReport(const std::string& title, const std::vector<Section>& sections, const fs::path& out_dir,
                          const RenderOptions& options) {
  fs::create_directories(out_dir / kDataDir);
  RenderResult result;
  bool figures = options.figures;
  if (figures && !HaveGnuplot(options.gnuplot)) {
    figures = false;
    result.problems.push_back("gnuplot ('" + options.gnuplot +
                              "') was not found: figures are omitted; every figure's numbers are in its CSV files");
  } else if (!figures) {
    result.problems.push_back("figures were switched off: every figure's numbers are in its CSV files");
  }
  std::ostringstream md, html;
  md << "# " << title << "\n\n";
  html << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" << HtmlEscape(title)
       << "</title><style>" << kCss << "</style></head><body>\n<h1>" << HtmlEscape(title) << "</h1>\n<nav>";
  for (const auto& s : sections) html << "<a href=\"#" << s.id << "\">" << HtmlEscape(s.title) << "</a>";
  html << "</nav>\n";
  // Problems are known only after drawing; collect the body first.
  std::ostringstream md_body, html_body;
  int figure_no = 0;
  for (const auto& sec : sections) {
    md_body << "## " << sec.title << "\n\n";
    html_body << "<h2 id=\"" << sec.id << "\">" << HtmlEscape(sec.title) << "</h2>\n";
    for (const auto& block : sec.blocks) {
      if (const auto* t = std::get_if<Text>(&block)) {
        md_body << t->markdown << "\n\n";
        std::istringstream paragraphs(t->markdown);
        std::string line, para;
        auto flush = [&]() {
          if (!para.empty()) html_body << "<p>" << HtmlInline(para) << "</p>\n";
          para.clear();
        };
        while (std::getline(paragraphs, line)) {
          if (line.empty()) {
            flush();
          } else {
            para += (para.empty() ? "" : " ") + line;
          }
        }
        flush();
      } else if (const auto* code = std::get_if<Code>(&block)) {
        md_body << "```\n" << code->text << "\n```\n\n";
        html_body << "<pre>" << HtmlEscape(code->text) << "</pre>\n";
      } else if (const auto* tb = std::get_if<Table>(&block)) {
        const std::string csv = std::string(kDataDir) + "/" + tb->name + ".csv";
        WriteTableCsv(out_dir / csv, *tb);
        if (!tb->caption.empty()) md_body << "**" << tb->caption << "** ([" << csv << "](" << csv << "))\n\n";
        md_body << "|";
        for (const auto& h : tb->header) md_body << " " << MdCell(h) << " |";
        md_body << "\n|";
        for (std::size_t i = 0; i < tb->header.size(); ++i) md_body << (i ? " ---: |" : " --- |");
        md_body << "\n";
        for (const auto& row : tb->rows) {
          md_body << "|";
          for (const auto& c : row) md_body << " " << MdCell(c.Shown()) << " |";
          md_body << "\n";
        }
        md_body << "\n";
        html_body << (tb->header.size() > 10 ? "<table class=\"wide\"><caption>" : "<table><caption>")
                  << HtmlEscape(tb->caption) << " <span class=\"csv\">(" << LocalLink(csv)
                  << ")</span></caption>\n<tr>";
        for (const auto& h : tb->header) html_body << "<th>" << HtmlEscape(h) << "</th>";
        html_body << "</tr>\n";
        for (const auto& row : tb->rows) {
          html_body << "<tr>";
          for (const auto& c : row)
            html_body << (LooksNumeric(c) ? "<td>" : "<td class=\"t\">") << HtmlCellText(c.Shown()) << "</td>";
          html_body << "</tr>\n";
        }
        html_body << "</table>\n";
      } else if (const auto* pics = std::get_if<Pictures>(&block)) {
        html_body << "<figure><div class=\"pics\">";
        for (const auto& p : pics->pictures) {
          md_body << "![" << p.caption << "](" << p.file << ") ";
          const std::string png = ReadText(out_dir / p.file);
          html_body << "<figure><img alt=\"" << HtmlEscape(p.caption) << "\" src=\"data:image/png;base64,"
                    << Base64(png) << "\"><figcaption>" << HtmlInline(p.caption) << "</figcaption></figure>";
        }
        md_body << "\n\n*" << pics->caption << "*\n\n";
        html_body << "</div><figcaption>" << HtmlInline(pics->caption) << "</figcaption></figure>\n";
      } else if (const auto* f = std::get_if<Figure>(&block)) {
        ++figure_no;
        std::string csvs, csv_links;
        const std::vector<std::string> files = SeriesFiles(*f);
        for (std::size_t k = 0; k < f->series.size(); ++k) {
          const std::string file = std::string(kDataDir) + "/" + files[k];
          WriteSeriesCsv(out_dir / file, f->series[k]);
          if (k > 0) {
            csvs += ", ";
            csv_links += ", ";
          }
          csvs += file;
          csv_links += LocalLink(file);
        }
        std::string svg;
        if (figures && HasFinitePoint(*f)) {
          fs::create_directories(out_dir / kFiguresDir);
          const std::string script = std::string(kFiguresDir) + "/" + f->name + ".gp";
          const std::string svg_file = std::string(kFiguresDir) + "/" + f->name + ".svg";
          WriteText(out_dir / script, GnuplotScript(*f));
          const std::string problem = RunGnuplot(options.gnuplot, out_dir, script);
          if (problem.empty() && fs::exists(out_dir / svg_file)) {
            svg = ReadText(out_dir / svg_file);
            ++result.figures_drawn;
          } else {
            result.problems.push_back(problem.empty() ? svg_file + " was not written" : problem);
          }
        }
        const std::string caption =
            "Figure " + std::to_string(figure_no) + ": " + f->title + (f->caption.empty() ? "" : ". " + f->caption);
        if (!svg.empty()) md_body << "![" << f->title << "](" << kFiguresDir << "/" << f->name << ".svg)\n\n";
        md_body << "*" << caption << "* Data: " << csvs << "\n\n";
        html_body << "<figure>";
        if (!svg.empty()) html_body << InlineSvg(svg, std::string("f").append(std::to_string(figure_no)).append("_"));
        html_body << "<figcaption>" << HtmlInline(caption) << " <span class=\"csv\">Data: " << csv_links
                  << "</span></figcaption></figure>\n";
      } else if (const auto* m = std::get_if<MapFigure>(&block)) {
        ++figure_no;
        std::string svg;
        const std::string script_text = MapScript(*m, out_dir);  // writes the panels' CSVs
        if (figures && !m->panels.empty()) {
          fs::create_directories(out_dir / kFiguresDir);
          const std::string script = std::string(kFiguresDir) + "/" + m->name + ".gp";
          const std::string svg_file = std::string(kFiguresDir) + "/" + m->name + ".svg";
          WriteText(out_dir / script, script_text);
          const std::string problem = RunGnuplot(options.gnuplot, out_dir, script);
          if (problem.empty() && fs::exists(out_dir / svg_file)) {
            svg = ReadText(out_dir / svg_file);
            ++result.figures_drawn;
          } else {
            result.problems.push_back(problem.empty() ? m->name + ".svg was not written" : problem);
          }
        }
        std::string csvs, csv_links;
        for (std::size_t k = 0; k < m->panels.size(); ++k) {
          if (k > 0) {
            csvs += ", ";
            csv_links += ", ";
          }
          csvs += PanelFile(*m, k, "");
          csv_links += LocalLink(PanelFile(*m, k, ""));
        }
        const std::string caption =
            "Figure " + std::to_string(figure_no) + ": " + m->title + (m->caption.empty() ? "" : ". " + m->caption);
        if (!svg.empty()) md_body << "![" << m->title << "](" << kFiguresDir << "/" << m->name << ".svg)\n\n";
        md_body << "*" << caption << "* Data: " << csvs << "\n\n";
        html_body << "<figure>";
        if (!svg.empty()) html_body << InlineSvg(svg, std::string("f").append(std::to_string(figure_no)).append("_"));
        html_body << "<figcaption>" << HtmlInline(caption) << " <span class=\"csv\">Data: " << csv_links
                  << "</span></figcaption></figure>\n";
      }
    }
  }
  if (!result.problems.empty()) {
    md << "## Problems while writing this report\n\n";
    html << "<h2>Problems while writing this report</h2><ul>";
    for (const auto& p : result.problems) {
      md << "- " << p << "\n";
      html << "<li>" << HtmlEscape(p) << "</li>";
    }
    md << "\n";
    html << "</ul>\n";
  }
  md << md_body.str();
  html << html_body.str() << "</body></html>\n";
  result.markdown = out_dir / "report.md";
  result.html = out_dir / "report.html";
  WriteText(result.markdown, md.str());
  WriteText(result.html, html.str());
  return result;
}

void NotDrawn::AppendTo(Section& s) const {
  if (problems_.empty()) return;
  std::string text = "Not drawn:";
  for (const auto& problem : problems_) text += "\n\n" + problem;
  s.blocks.push_back(Text{text});
}

}  // namespace granary::analysis
