// Rendering: markdown and html tables, CSVs, escaping, and gnuplot figures inlined as SVG.
#include "analysis/report_document.h"

#include <gtest/gtest.h>

#include <array>

#include <cmath>
#include <cstdlib>
#include <regex>

#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::ReadFile;
using testing::TempDir;

TEST(Format, NumbersAndMeanSe) {
  EXPECT_EQ(FormatNumber(12.0), "12");
  EXPECT_EQ(FormatNumber(3.14159265, 4), "3.142");
  EXPECT_EQ(FormatNumber(std::nan("")), "");
  EXPECT_EQ(FormatMeanSe(2.5, 0.25, 4), "2.5 ± 0.25 (4)");
  EXPECT_EQ(FormatMeanSe(2.5, std::nan(""), 1), "2.5 (1)");
  EXPECT_EQ(CsvEscape("a,b"), "\"a,b\"");
  EXPECT_EQ(CsvEscape("say \"x\", y"), "\"say \"\"x\"\", y\"");
  EXPECT_EQ(HtmlEscape("<a & b>"), "&lt;a &amp; b&gt;");
}

TEST(RenderReport, TablesFiguresAndCsv) {
  TempDir dir;
  Section s{"sec", "A section", {}};
  s.blocks.push_back(Text{"Some **bold** and `code` <tag>."});
  s.blocks.push_back(Text{"See the [gallery](#gallery), [data](data/tab.csv) and [elsewhere](http://x.org)."});
  s.blocks.push_back(Table{"tab", "A table", {"name", "value"}, {{"x|y", "1,5"}}, {}});
  // Numbers to full precision in the CSV, an estimate in three columns named by the keys.
  s.blocks.push_back(Table{"numbers",
                           "Numbers",
                           {"point", "Q (bodies/t)", "count"},
                           {{"a", Cell::Estimate(2.0 / 3.0, 0.125, 4), Cell::Count(7)},
                            {"b", Cell::Estimate(1.5, std::nan(""), 1), Cell::Number(std::nan(""))}},
                           {"point", "q", "count"}});
  Series se;
  se.label = "data";
  se.columns = {"x", "y", "y_se"};
  se.rows = {{1, 2, 0.1}, {2, 4, std::nan("")}, {3, 6, 0.3}};
  se.style = Series::Style::kErrorBars;
  se.err = 2;
  s.blocks.push_back(Figure{"fig", "A figure", "x (d)", "y (1/t)", {se}, false, false, "caption"});
  RenderOptions opt;
  opt.figures = std::system("command -v gnuplot > /dev/null 2>&1") == 0;
  const auto out = dir.Path() / "it's a report";  // shell quoting of the gnuplot call
  const RenderResult r = RenderReport("Title", {s}, out, opt);
  const std::string md = ReadFile(r.markdown);
  EXPECT_NE(md.find("| x\\|y | 1,5 |"), std::string::npos) << md;
  EXPECT_EQ(ReadFile(out / "data" / "tab.csv"), "name,value\nx|y,\"1,5\"\n");
  EXPECT_EQ(ReadFile(out / "data" / "numbers.csv"),
            "point,q,q_se,q_n,count\na,0.6666666666666666,0.125,4,7\nb,1.5,nan,1,nan\n");
  EXPECT_NE(md.find("| a | 0.6667 ± 0.12 (4) | 7 |"), std::string::npos) << md;
  // A figure's data files are named after what they hold.
  EXPECT_EQ(ReadFile(out / "data" / "fig--data.csv"), "x,y,y_se\n1,2,0.1\n2,4,nan\n3,6,0.3\n");
  const std::string html = ReadFile(r.html);
  EXPECT_NE(html.find("<b>bold</b>"), std::string::npos);
  EXPECT_NE(html.find("<code>code</code>"), std::string::npos);
  EXPECT_NE(html.find("&lt;tag&gt;"), std::string::npos);
  EXPECT_NE(html.find("<a href=\"#gallery\">gallery</a>"), std::string::npos);
  EXPECT_NE(html.find("<a href=\"data/tab.csv\">data</a>"), std::string::npos);
  EXPECT_NE(html.find("[elsewhere](http://x.org)"), std::string::npos);  // no links out of the report
  if (opt.figures) {
    EXPECT_EQ(r.figures_drawn, 1) << (r.problems.empty() ? "" : r.problems.front());
    EXPECT_NE(html.find("<svg"), std::string::npos);
    EXPECT_EQ(html.find("<?xml"), std::string::npos);
  }
}

// A curve of means with standard errors draws its error bars; without an se column it is a
// plain line with points.
TEST(GnuplotScript, LinesWithErrorBars) {
  Series se;
  se.label = "profile";
  se.columns = {"x", "v", "v_se"};
  se.rows = {{-0.5, -0.2, 0.05}, {0.0, -1.0, 0.1}, {0.5, -0.2, std::nan("")}};
  se.style = Series::Style::kLinesPoints;
  se.err = 2;
  Figure f{"prof", "Profile", "x/W", "v", {se}, false, false, ""};
  EXPECT_NE(GnuplotScript(f).find("using ($1):($2):(valid(3) && $3 == $3 ? $3 : 0) with yerrorlines"),
            std::string::npos)
      << GnuplotScript(f);
  f.series[0].err = -1;
  EXPECT_EQ(GnuplotScript(f).find("yerror"), std::string::npos);
  EXPECT_NE(GnuplotScript(f).find("with linespoints"), std::string::npos);
}

TEST(RenderReport, CurveFilesAreNamedAfterTheirLabelsAndUnique) {
  Figure f{"flow_rate", "", "", "", {}, false, false, ""};
  for (const char* label : {"Q", "species.0.fraction=0.5, W/d", "Q", "", "a/b"}) {
    Series se;
    se.label = label;
    f.series.push_back(se);
  }
  EXPECT_EQ(SeriesFiles(f),
            (std::vector<std::string>{"flow_rate--Q.csv", "flow_rate--species.0.fraction_0.5_W_d.csv",
                                      "flow_rate--Q-2.csv", "flow_rate--curve4.csv", "flow_rate--a_b.csv"}));
  // A fit whose quality is in its key keeps one file name whatever the quality.
  Series fit;
  fit.label = "beverloo_2d (X_db = 0.5), ill-determined";
  fit.file_label = "beverloo_2d (X_db = 0.5)";
  f.series = {fit};
  EXPECT_EQ(SeriesFiles(f), std::vector<std::string>{"flow_rate--beverloo_2d_X_db_0.5.csv"});
}

TEST(RenderReport, MissingGnuplotIsReported) {
  TempDir dir;
  Series se;
  se.columns = {"x", "y"};
  se.rows = {{1, 2}};
  Section s{"sec", "S", {Figure{"fig", "F", "x", "y", {se}, false, false, ""}}};
  RenderOptions opt;
  opt.gnuplot = "no-such-gnuplot-binary";
  const RenderResult r = RenderReport("T", {s}, dir.Path(), opt);
  EXPECT_EQ(r.figures_drawn, 0);
  ASSERT_FALSE(r.problems.empty());
  EXPECT_NE(ReadFile(r.markdown).find("gnuplot ('no-such-gnuplot-binary') was not found"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir.Path() / "data" / "fig--curve1.csv"));  // no label: numbered
}

}  // namespace

// Figures a referee can read.
Series PointsAt(const std::string& label, std::vector<std::vector<double>> rows,
                Series::Style style = Series::Style::kErrorBars) {
  Series se;
  se.label = label;
  se.columns = {"x", "y", "y_se"};
  se.rows = std::move(rows);
  se.style = style;
  se.err = style == Series::Style::kErrorBars ? 2 : -1;
  return se;
}

TEST(GnuplotScript, TwelveCurvesTakeTwelveDistinctColours) {
  Figure f{"many", "Many", "x", "y", {}, false, false, ""};
  for (int k = 0; k < 12; ++k) f.series.push_back(PointsAt("c" + std::to_string(k), {{k + 1.0, 1.0, 0.1}}));
  const std::string gp = GnuplotScript(f);
  for (int k = 1; k <= 12; ++k)
    EXPECT_NE(gp.find(" lt " + std::to_string(k) + " lw 1.5 title 'c" + std::to_string(k - 1) + "'"), std::string::npos)
        << gp;
  // Every pair of palette colours is far apart in RGB (and none is near the black of the
  // reference lines).
  auto rgb = [](const char* hex) {
    const unsigned v = static_cast<unsigned>(std::stoul(std::string(hex + 1), nullptr, 16));
    return std::array<double, 3>{double(v >> 16), double((v >> 8) & 255), double(v & 255)};
  };
  auto distance = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
  };
  for (int i = 0; i < kPaletteSize; ++i) {
    EXPECT_GT(distance(rgb(kPalette[i]), {0, 0, 0}), 60) << kPalette[i];
    for (int j = i + 1; j < kPaletteSize; ++j)
      EXPECT_GT(distance(rgb(kPalette[i]), rgb(kPalette[j])), 60) << kPalette[i] << " " << kPalette[j];
    EXPECT_NE(gp.find(std::string("lc rgb '") + kPalette[i] + "'"), std::string::npos);
  }
}

TEST(GnuplotScript, AxesFitTheDataNotTheFittedCurves) {
  // Non-negative values whose error bars reach below 0, and a fitted line down to -20.
  Series fit = PointsAt("fit", {{0.0, -20.0}, {10.0, 12.0}}, Series::Style::kLines);
  fit.role = Series::Role::kFit;
  Figure f{"axes", "Axes", "x", "y", {PointsAt("data", {{2.0, 0.5, 1.0}, {8.0, 10.0, 0.5}}), fit}, false, false, ""};
  const std::string gp = GnuplotScript(f);
  EXPECT_NE(gp.find("set yrange [0:"), std::string::npos) << gp;        // no negative axis for >= 0 values
  EXPECT_NE(gp.find("set xrange [1.7:8.3]"), std::string::npos) << gp;  // the data's x, 5 % margin
  EXPECT_EQ(gp.find("-20"), std::string::npos) << gp;
  EXPECT_NE(gp.find("dt 2"), std::string::npos) << gp;  // the fit: dashed
  // Values below 0 keep their negative axis.
  f.series[0].rows[0][1] = -3.0;
  EXPECT_NE(GnuplotScript(f).find("set yrange [-"), std::string::npos);
}

// Curves offset along x by +-0.25 read as W = 6.25 and put the outermost points
// outside the x range; every point is drawn at its true x, told apart by colour and shape.
TEST(GnuplotScript, PointsOfSeveralCurvesAtOneXAreDrawnAtTheirTrueX) {
  Figure f{"side",
           "Side",
           "x",
           "y",
           {PointsAt("a", {{6.0, 1.0, 0.1}, {10.0, 2.0, 0.1}}), PointsAt("b", {{6.0, 1.0, 0.1}, {10.0, 2.0, 0.1}})},
           false,
           false,
           ""};
  const std::string gp = GnuplotScript(f);
  EXPECT_EQ(gp.find("($1+"), std::string::npos) << gp;
  EXPECT_EQ(gp.find("($1*"), std::string::npos) << gp;
  std::size_t uses = 0;
  for (std::size_t at = gp.find("using ($1):($2)"); at != std::string::npos; at = gp.find("using ($1):($2)", at + 1))
    ++uses;
  EXPECT_EQ(uses, 2u) << gp;
  EXPECT_NE(gp.find("set xrange [5.8:10.2]"), std::string::npos) << gp;  // holds 6 and 10
  EXPECT_NE(gp.find(" lt 1 "), std::string::npos) << gp;                 // two colours (and point shapes)
  EXPECT_NE(gp.find(" lt 2 "), std::string::npos) << gp;
}

TEST(GnuplotScript, ReferenceLinesCanBeToldApart) {
  Figure f{"ref", "Ref", "x", "ratio", {PointsAt("r", {{1.0, 1.0, 0.1}, {2.0, 1.05, 0.1}})}, false, false, ""};
  for (const char* label : {"equal", "-10 %", "+10 %"}) {
    Series line = PointsAt(label, {{1.0, 1.0}, {2.0, 1.0}}, Series::Style::kLines);
    line.role = Series::Role::kReference;
    f.series.push_back(line);
  }
  const std::string gp = GnuplotScript(f);
  EXPECT_NE(gp.find("lc rgb '#000000' dt 1 lw 1.5 title 'equal'"), std::string::npos) << gp;
  EXPECT_NE(gp.find("dt 2 lw 1.5 title '-10 %'"), std::string::npos) << gp;
  EXPECT_NE(gp.find("dt 3 lw 1.5 title '+10 %'"), std::string::npos) << gp;
}

TEST(RenderReport, FilesAreGroupedIntoDataAndFigures) {
  TempDir dir;
  Figure f{"g", "G", "x", "y", {PointsAt("a", {{1.0, 1.0, 0.1}})}, false, false, ""};
  Table t{"tab", "T", {"a"}, {{Cell("1")}}, {}};
  const RenderResult r = RenderReport("grouped", {Section{"s", "S", {t, f}}}, dir.Path(), RenderOptions{});
  EXPECT_TRUE(std::filesystem::exists(dir.Path() / "data" / "tab.csv"));
  EXPECT_TRUE(std::filesystem::exists(dir.Path() / "data" / "g--a.csv"));
  for (const auto& e : std::filesystem::directory_iterator(dir.Path()))
    EXPECT_TRUE(e.is_directory() || e.path().extension() == ".md" || e.path().extension() == ".html") << e.path();
  if (r.figures_drawn > 0) {
    EXPECT_TRUE(std::filesystem::exists(dir.Path() / "figures" / "g.svg"));
    EXPECT_FALSE(std::filesystem::exists(dir.Path() / "figures" / "g.gp.log"));  // kept only when gnuplot fails
  }
  EXPECT_NE(ReadFile(dir.Path() / "report.html").find("href=\"data/tab.csv\""), std::string::npos);
}

}  // namespace granary::analysis

namespace granary::analysis {
namespace {

// The compare report's flow-rate figure: 4 groups x (data + fit), titles of 55-95 characters.
// Drawn by gnuplot, every key entry lies inside the canvas (its right-aligned title's anchor
// and the title's width at most 7.5 px a character), below the plot and above the bottom.
TEST(GnuplotScript, AKeyOfLongTitlesFitsInsideTheCanvas) {
  TempDir dir;
  Figure f{"flow_rate", "Flow rate", "W/d (outlet width W)", "Q (bodies/sqrt(d/g))", {}, false, false, ""};
  for (const char* shape : {"disc", "dumbbell"})
    for (const char* engine : {"native", "liggghts"}) {
      const std::string group =
          std::string("body shape = ") + shape + ", number of bodies N = 1000, engine = " + engine;
      f.series.push_back(PointsAt(group, {{15, 40, 1}, {25, 90, 2}}));
      Series fit = PointsAt("beverloo_2d (" + group + "), ill-determined", {{15, 41}, {25, 89}}, Series::Style::kLines);
      fit.role = Series::Role::kFit;
      f.series.push_back(fit);
    }
  const KeyLayout key = ComputeKeyLayout(f);
  EXPECT_EQ(key.columns, 1) << "two 95-character titles do not fit across 800 px";
  EXPECT_GT(key.width, 800) << "nor does one";
  RenderOptions opt;
  const RenderResult r = RenderReport("T", {Section{"s", "S", {f}}}, dir.Path(), opt);
  ASSERT_EQ(r.figures_drawn, 1) << (r.problems.empty() ? "" : r.problems.front());
  const std::string svg = ReadFile(dir.Path() / "figures" / "flow_rate.svg");
  const std::regex size_re(R"re(<svg[^>]*width="(\d+)"[^>]*height="(\d+)")re");
  std::smatch size;
  ASSERT_TRUE(std::regex_search(svg, size, size_re));
  const double width = std::stod(size[1]), height = std::stod(size[2]);
  EXPECT_EQ(width, key.width);
  int titles = 0;
  for (const Series& se : f.series) {
    const std::string text = "<text>" + se.label + "</text>";
    const auto at = svg.find(text);
    ASSERT_NE(at, std::string::npos) << se.label;
    const auto translate = svg.rfind("translate(", at);
    ASSERT_NE(translate, std::string::npos);
    const double x = std::stod(svg.substr(translate + 10)), y = std::stod(svg.substr(svg.find(',', translate) + 1));
    EXPECT_LE(x + 40, width) << se.label << ": the sample line right of the title is cut";
    EXPECT_GE(x - 7.5 * static_cast<double>(se.label.size()), 0) << se.label << ": the title runs off the left edge";
    EXPECT_GT(y, 440 - 60) << se.label << ": the key is below the plot";
    EXPECT_LT(y, height) << se.label;
    ++titles;
  }
  EXPECT_EQ(titles, 8);
}

// Thesis fig. 6.5a as the report drew it: a title of 115 characters and two key entries of 32
// and 33 characters. The title lies inside the canvas (centred on its anchor, at most 7.5 px
// a character), and so does each key entry's sample line right of its title.
TEST(GnuplotScript, ALongTitleAndTwoKeyColumnsFitInsideTheCanvas) {
  TempDir dir;
  const std::string title =
      "Axis angle psi in the bed before the outlet opens at theta = 45 degrees, r = 10 d, W/D_eq = 8, one curve "
      "per D_b/D_s";
  Figure f{"fig", title, "psi (degrees)", "probability density", {}, false, false, ""};
  f.series.push_back(PointsAt("D_b = 1 d, W = 11.3137 d (n = 20)", {{5, 0.02, 0.001}, {15, 0.01, 0.001}}));
  f.series.push_back(PointsAt("D_b = 2 d, W = 17.8885 d (n = 8)", {{5, 0.0125, 0.001}, {15, 0.0, 0.001}}));
  const KeyLayout key = ComputeKeyLayout(f);
  const RenderResult r = RenderReport("T", {Section{"s", "S", {f}}}, dir.Path(), RenderOptions{});
  ASSERT_EQ(r.figures_drawn, 1) << (r.problems.empty() ? "" : r.problems.front());
  const std::string svg = ReadFile(dir.Path() / "figures" / "fig.svg");
  const std::regex size_re(R"re(<svg[^>]*width="(\d+)"[^>]*height="(\d+)")re");
  std::smatch size;
  ASSERT_TRUE(std::regex_search(svg, size, size_re));
  const double width = std::stod(size[1]);
  EXPECT_EQ(width, key.width);
  auto anchor_x = [&](const std::string& text) {
    const auto at = svg.find("<text>" + text + "</text>");
    EXPECT_NE(at, std::string::npos) << text;
    const auto translate = svg.rfind("translate(", at);
    return at == std::string::npos || translate == std::string::npos ? -1e9 : std::stod(svg.substr(translate + 10));
  };
  const double half = 7.5 * static_cast<double>(title.size()) / 2;
  EXPECT_GE(anchor_x(title) - half, 0) << "the title runs off the left edge";
  EXPECT_LE(anchor_x(title) + half, width) << "the title runs off the right edge";
  for (const Series& se : f.series) {
    const double x = anchor_x(se.label);
    EXPECT_LE(x + 40, width) << se.label << ": the sample line right of the title is cut";
    EXPECT_GE(x - 7.5 * static_cast<double>(se.label.size()), 0) << se.label << ": the title runs off the left edge";
  }
}

// A point name in a narrow table column breaks between its "name = value" pairs, never
// inside one ("W =" on one line, "12" on the next); the CSV keeps plain spaces.
TEST(RenderReport, PointNamesBreakOnlyBetweenTheirPairs) {
  TempDir dir;
  Table t{"points", "Points", {"point", "Q"}, {{"W = 12, X_db = 0.5", Cell::Number(3)}}, {}};
  const RenderResult r = RenderReport("T", {Section{"s", "S", {t}}}, dir.Path(), RenderOptions{});
  EXPECT_NE(ReadFile(r.html).find(">W&#160;=&#160;12, X_db&#160;=&#160;0.5</td>"), std::string::npos)
      << ReadFile(r.html);
  EXPECT_EQ(ReadFile(dir.Path() / "data" / "points.csv"), "point,Q\n\"W = 12, X_db = 0.5\",3\n");
}

}  // namespace
}  // namespace granary::analysis
