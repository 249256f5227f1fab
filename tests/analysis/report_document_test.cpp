// Rendering: markdown and html tables, CSVs, escaping, and gnuplot figures inlined as SVG.
#include "analysis/report_document.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::read_file;
using testing::TempDir;

TEST(Format, NumbersAndMeanSe) {
  EXPECT_EQ(format_number(12.0), "12");
  EXPECT_EQ(format_number(3.14159265, 4), "3.142");
  EXPECT_EQ(format_number(std::nan("")), "");
  EXPECT_EQ(format_mean_se(2.5, 0.25, 4), "2.5 ± 0.25 (4)");
  EXPECT_EQ(format_mean_se(2.5, std::nan(""), 1), "2.5 (1)");
  EXPECT_EQ(csv_escape("a,b"), "\"a,b\"");
  EXPECT_EQ(csv_escape("say \"x\", y"), "\"say \"\"x\"\", y\"");
  EXPECT_EQ(html_escape("<a & b>"), "&lt;a &amp; b&gt;");
}

TEST(RenderReport, TablesFiguresAndCsv) {
  TempDir dir;
  Section s{"sec", "A section", {}};
  s.blocks.push_back(Text{"Some **bold** and `code` <tag>."});
  s.blocks.push_back(Table{"tab", "A table", {"name", "value"}, {{"x|y", "1,5"}}, {}});
  // Numbers to full precision in the CSV, an estimate in three columns named by the keys.
  s.blocks.push_back(Table{"numbers",
                           "Numbers",
                           {"point", "Q (bodies/t)", "count"},
                           {{"a", Cell::estimate(2.0 / 3.0, 0.125, 4), Cell::count(7)},
                            {"b", Cell::estimate(1.5, std::nan(""), 1), Cell::number(std::nan(""))}},
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
  const auto out = dir.path() / "it's a report";  // shell quoting of the gnuplot call
  const RenderResult r = render_report("Title", {s}, out, opt);
  const std::string md = read_file(r.markdown);
  EXPECT_NE(md.find("| x\\|y | 1,5 |"), std::string::npos) << md;
  EXPECT_EQ(read_file(out / "tab.csv"), "name,value\nx|y,\"1,5\"\n");
  EXPECT_EQ(read_file(out / "numbers.csv"),
            "point,q,q_se,q_n,count\na,0.6666666666666666,0.125,4,7\nb,1.5,nan,1,nan\n");
  EXPECT_NE(md.find("| a | 0.6667 ± 0.12 (4) | 7 |"), std::string::npos) << md;
  // A figure's data files are named after what they hold.
  EXPECT_EQ(read_file(out / "fig--data.csv"), "x,y,y_se\n1,2,0.1\n2,4,nan\n3,6,0.3\n");
  const std::string html = read_file(r.html);
  EXPECT_NE(html.find("<b>bold</b>"), std::string::npos);
  EXPECT_NE(html.find("<code>code</code>"), std::string::npos);
  EXPECT_NE(html.find("&lt;tag&gt;"), std::string::npos);
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
  EXPECT_NE(gnuplot_script(f).find("using ($1):($2):($3 == $3 ? $3 : 0) with yerrorlines"), std::string::npos)
      << gnuplot_script(f);
  f.series[0].err = -1;
  EXPECT_EQ(gnuplot_script(f).find("yerror"), std::string::npos);
  EXPECT_NE(gnuplot_script(f).find("with linespoints"), std::string::npos);
}

TEST(RenderReport, CurveFilesAreNamedAfterTheirLabelsAndUnique) {
  Figure f{"flow_rate", "", "", "", {}, false, false, ""};
  for (const char* label : {"Q", "species.0.fraction=0.5, W/d", "Q", "", "a/b"}) {
    Series se;
    se.label = label;
    f.series.push_back(se);
  }
  EXPECT_EQ(series_files(f), (std::vector<std::string>{"flow_rate--Q.csv", "flow_rate--species.0.fraction_0.5_W_d.csv",
                                                       "flow_rate--Q-2.csv", "flow_rate--curve4.csv", "flow_rate--a_b.csv"}));
}

TEST(RenderReport, MissingGnuplotIsReported) {
  TempDir dir;
  Series se;
  se.columns = {"x", "y"};
  se.rows = {{1, 2}};
  Section s{"sec", "S", {Figure{"fig", "F", "x", "y", {se}, false, false, ""}}};
  RenderOptions opt;
  opt.gnuplot = "no-such-gnuplot-binary";
  const RenderResult r = render_report("T", {s}, dir.path(), opt);
  EXPECT_EQ(r.figures_drawn, 0);
  ASSERT_FALSE(r.problems.empty());
  EXPECT_NE(read_file(r.markdown).find("gnuplot ('no-such-gnuplot-binary') was not found"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "fig--curve1.csv"));  // no label: numbered
}

}  // namespace
}  // namespace granary::analysis
