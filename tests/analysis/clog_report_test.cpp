// The clogged-state sections of the report (arches, contacts, orientation) on a synthetic
// campaign: hand-made run directories whose kept clog is an arch of four dumbbells, frames of
// the same dumbbells; the pictures through a drawing stub that records what it is asked for;
// the options' errors name their JSON path.
#include <gtest/gtest.h>

#include <numbers>
#include <sstream>

#include "analysis/options.h"
#include "analysis/registry.h"
#include "analysis/arches_analysis.h"
#include "analysis/contacts_analysis.h"
#include "analysis/orientation_analysis.h"
#include "analysis/report.h"
#include "clog_builder.h"
#include "rundir/clogs.h"
#include "rundir/frames.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::Clog;
using testing::ReadFile;
using testing::TempDir;
using testing::WriteFile;

nlohmann::json SpecFor(double w) {
  return {{"engine", "native"},
          {"silo", {{"width", 12}, {"base_outlets", {{{"center", 0.0}, {"width", w}}}}}},
          {"bodies", {{"count", 100}, {"species", {{{"shape", "dumbbell"}}}}}},
          {"discharge", {{"mode", "remove"}, {"clog_window", 2.0}}}};
}

// The arch of AnArchOfDumbbells (arches_test.cpp) over an outlet of width `w` <= 4: bodies 0..3,
// a disc on the floor (4), a row of discs above (5..).
Clog ArchOfDumbbells(double w) {
  Clog c(nlohmann::json{{"base_outlets", {{{"center", 0.0}, {"width", w}}}}});
  const double top = 1.936;
  c.Dumbbell(-2.4, 0.5, -2.4, 1.5);
  c.Dumbbell(-1.5, top, -0.5, top);
  c.Dumbbell(0.5, top, 1.5, top);
  c.Dumbbell(2.4, 1.5, 2.4, 0.5);
  c.Disc(-4.5, 0.5);
  c.Row(-5.5, 5.5, 3.6);
  return c;
}

// 30 exits, one clog kept (the arch), three frames of the same bodies at t = 0, 3 and 4, every
// disc moving straight down (1 sqrt(g d)) after the opening.
void WriteRun(const std::filesystem::path& dir, double w, const std::string& id) {
  std::ostringstream ev;
  ev << "time,body,shape,mass,outlet\n";
  for (int i = 1; i <= 30; ++i) ev << 0.2 * i << "," << 100 + i << ",dumbbell,1.5707963267948966,0\n";
  WriteFile(dir / "events.csv", ev.str());
  const nlohmann::json summary = {
      {"engine", "native"}, {"run_id", id}, {"spec", SpecFor(w)}, {"end_reason", "clogged"},
      {"bodies", 100},      {"exited", 30}, {"remaining", 70},    {"exits_per_outlet", {30}},
      {"t_end", 8.0},       {"clogs", 1}};
  WriteFile(dir / "summary.json", summary.dump());
  WriteFile(dir / "run.json", SpecFor(w).dump());
  Clog arch = ArchOfDumbbells(w);
  rundir::ClogState clog = arch.Made();
  clog.frame.timestep = clog.contacts.timestep = 80000;
  clog.frame.time = clog.contacts.time = 8.0;
  rundir::ClogWriter writer = rundir::ClogWriter::Create(dir);
  writer.Write(clog);
  writer.Close();
  rundir::FrameWriter frames = rundir::FrameWriter::Create(dir / "frames.dump");
  for (double t : {0.0, 3.0, 4.0}) {
    rundir::Frame f = clog.frame;
    f.time = t;
    f.timestep = static_cast<std::int64_t>(t * 1e4);
    if (t > 0)
      for (rundir::Disc& d : f.discs) d.vy = -1.0;
    frames.Write(f);
  }
  frames.Close();
  WriteFile(dir / "DONE", "clogged");
}

// The cell of the column called `name` (the header row) in the first row containing `row`.
std::string FormatCell(const std::string& csv, const std::string& row, const std::string& name) {
  const std::string header = csv.substr(0, csv.find('\n'));
  int column = 0;
  std::size_t at = 0;
  for (std::size_t next; (next = header.find(',', at)) != std::string::npos; at = next + 1, ++column)
    if (header.substr(at, next - at) == name) return testing::CsvCell(csv, {row}, column);
  return header.substr(at) == name ? testing::CsvCell(csv, {row}, column) : "no column " + name;
}

// The CSV of the first curve of figure `name` in the report folder, or "".
std::string CurveCsv(const std::filesystem::path& dir, const std::string& name) {
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().filename().string().rfind(name + "--", 0) == 0) return ReadFile(e.path());
  return "";
}

struct Drawn {
  std::filesystem::path run_dir;
  ClogPicture picture;
};

// Two replicas at each of W = 3 and 4 d, finished, their replicas listed in `replicas`' order.
std::vector<RunRecord> RunsAtW3AndW4(const std::filesystem::path& root, const std::vector<int>& replicas) {
  std::vector<RunRecord> runs;
  for (double w : {3.0, 4.0})
    for (int rep : replicas) {
      RunRecord r;
      r.point_id = "W" + std::to_string(static_cast<int>(w));
      r.run_id = r.point_id + "r" + std::to_string(rep);
      r.replica = rep;
      r.engine = "native";
      r.state = "done";
      r.point = {{"/silo/base_outlets/0/width", w}};
      r.spec = SpecFor(w);
      r.run_dir = root / r.run_id;
      WriteRun(r.run_dir, w, r.run_id);
      runs.push_back(r);
    }
  return runs;
}

// A report without figures whose clog pictures are recorded in `drawn` (a stand-in PNG each).
void RecordClogPictures(ReportOptions& opt, const std::filesystem::path& out_dir, std::vector<Drawn>& drawn) {
  opt.out_dir = out_dir;
  opt.figures = false;
  opt.draw_clog = [&drawn](const std::filesystem::path& run_dir, const ClogPicture& p,
                           const std::filesystem::path& png) {
    drawn.push_back({run_dir, p});
    WriteFile(png, "png");
    return std::string();
  };
}

TEST(ClogReport, ArchesContactsAndOrientationSectionsWithPictures) {
  TempDir dir;
  CampaignInfo info;
  info.name = "arches";
  info.axes = {"/silo/base_outlets/0/width"};
  // The legs' centres are at h = 1, the lying ones at 1.936; the right lying dumbbell is at
  // 62.7 degrees around the outlet's centre.
  // Regions: the default one's place against the vertical, the same against the flow (straight
  // down), and one above the bodies, where nothing flows.
  const nlohmann::json regions = {{{"name", "above"}, {"x", {-5, 5}}, {"y", {0, 10}}, {"director", 90}},
                                  {{"name", "flow"}, {"x", {-5, 5}}, {"y", {0, 10}}, {"director", "flow"}},
                                  {{"name", "empty"}, {"x", {-5, 5}}, {"y", {50, 60}}, {"director", "flow"}}};
  // 30 exits before each run's clog: enough for steady flow here (min_exits_before_clog).
  info.spec = {{"report",
                {{"window", {{"min_exits_before_clog", 20}}},
                 {"orientation", {{"heights", {1.5}}, {"window", {{"theta", 60}}}, {"regions", regions}}}}}};
  const std::vector<RunRecord> runs = RunsAtW3AndW4(dir.Path(), {0, 1});
  ReportOptions opt;
  std::vector<Drawn> drawn;
  RecordClogPictures(opt, dir.Path() / "report", drawn);
  WriteReport(info, runs, opt);
  const std::string md = ReadFile(opt.out_dir / "report.md");
  EXPECT_NE(md.find("## Arches (ch. 3, 4, 6)"), std::string::npos);
  EXPECT_NE(md.find("## Contacts in the clogged system (ch. 6)"), std::string::npos);
  EXPECT_NE(md.find("## Orientation of elongated bodies (ch. 4, 5, 6)"), std::string::npos);
  // Per point: 2 clogs, 2 arches of N_t = 4, w = 4.8, elongated fraction 1.
  const std::string arches = ReadFile(opt.out_dir / "data" / "arches.csv");
  EXPECT_EQ(FormatCell(arches, "W = 3", "clogs"), "2") << arches;
  EXPECT_EQ(FormatCell(arches, "W = 3", "arches"), "2");
  EXPECT_EQ(FormatCell(arches, "W = 4", "arch_n"), "4");
  EXPECT_EQ(FormatCell(arches, "W = 4", "arch_n_n"), "2");
  EXPECT_NEAR(std::stod(FormatCell(arches, "W = 4", "arch_width")), 4.8, 1e-9);
  EXPECT_EQ(FormatCell(arches, "W = 4", "arch_elongated_fraction"), "1");
  // Figures against W are there (as CSVs without gnuplot).
  EXPECT_NE(CurveCsv(opt.out_dir / "data", "arch_n"), "");
  EXPECT_NE(CurveCsv(opt.out_dir / "data", "arch_pressure_theta"), "");
  // One picture per point, of a clog with the arch's bodies outlined, near the outlet.
  ASSERT_EQ(drawn.size(), 2u);
  EXPECT_EQ(drawn[0].picture.clog, 1);
  EXPECT_EQ(drawn[0].picture.highlight, (std::set<std::int64_t>{0, 1, 2, 3}));
  EXPECT_LT(drawn[0].picture.x_lo, -2.4);
  EXPECT_GT(drawn[0].picture.x_hi, 2.4);
  EXPECT_LT(drawn[0].picture.y_lo, 0.0);
  EXPECT_NE(md.find("pictures/arch-point-1-1.png"), std::string::npos);
  // Contacts: the arch's dumbbells touch with a second disc against a first one (large-small by
  // disc order), everything else involves a lone disc (3 of 14 contacts).
  const std::string contacts = ReadFile(opt.out_dir / "data" / "contacts.csv");
  EXPECT_EQ(FormatCell(contacts, "W = 3", "contact_ss_n"), "2") << contacts;
  EXPECT_NEAR(std::stod(FormatCell(contacts, "W = 3", "contact_ls")), 3.0 / 14, 1e-12);
  EXPECT_EQ(FormatCell(contacts, "W = 3", "contact_ls_se"), "0");
  // Orientation: above the outlet two vertical and two lying dumbbells make S = 0 against the
  // vertical; the band at h = 1.5 holds all four; the arch window one lying axis.
  const std::string order = ReadFile(opt.out_dir / "data" / "orientation_order.csv");
  EXPECT_NEAR(std::stod(FormatCell(order, "W = 3", "order_parameter_0")), 0.0, 1e-12) << order;
  EXPECT_EQ(FormatCell(order, "W = 3", "order_parameter_0_n"), "2");
  // Against the flow: its direction, -90 degrees (down), a line the same as the vertical's.
  EXPECT_NEAR(std::stod(FormatCell(order, "W = 3", "order_parameter_1")), 0.0, 1e-12);
  EXPECT_EQ(FormatCell(order, "W = 4", "flow_direction_1"), "-90");
  EXPECT_EQ(FormatCell(order, "W = 4", "flow_direction_2"), "no flow");
  EXPECT_EQ(FormatCell(order, "W = 4", "order_parameter_2_n"), "0") << order;
  EXPECT_NE(
      md.find("| S, above | S, flow | flow direction, flow (degrees) | S, empty | flow direction, empty (degrees) |"),
      std::string::npos);
  EXPECT_NE(CurveCsv(opt.out_dir / "data", "orientation_s_1"), "");
  const std::string window = CurveCsv(opt.out_dir / "data", "orientation_window_arches");
  // Both runs' lying dumbbell, psi in [0, 10) degrees: density 2 / (2 x 10 degrees in radians).
  EXPECT_NE(window.find("\n5,5.729"), std::string::npos) << window;

  // Without the renderer the section says so.
  ReportOptions plain = opt;
  plain.draw_clog = nullptr;
  plain.out_dir = dir.Path() / "plain";
  WriteReport(info, runs, plain);
  EXPECT_NE(ReadFile(plain.out_dir / "report.md").find("No pictures of clogs"), std::string::npos);
}

// A pictures figure of kind "clog": per point the kept clog of its lowest replica whose arch
// has the point's median N_t, the arch's bodies outlined, the figure's marks and colouring
// handed on; the figure's window replaces the arch's.
TEST(ClogReport, APicturesFigureOfTheKeptClogs) {
  TempDir dir;
  CampaignInfo info;
  info.name = "arches";
  info.axes = {"/silo/base_outlets/0/width"};
  info.spec = {{"base", SpecFor(3)},
               {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {3, 4}}}}}},
               {"report",
                {{"arches", {{"pictures", 0}}},
                 {"figures",
                  {{{"name", "arches"},
                    {"kind", "pictures"},
                    {"picture", "clog"},
                    {"colour", "disc"},
                    {"annotate", {{{"dimension", "outlet_width"}}}}},
                   {{"name", "zoomed"},
                    {"kind", "pictures"},
                    {"picture", "clog"},
                    {"only", {{"W", 4}}},
                    {"window", {-5, 5, -1, 6}}}}}}}};
  const std::vector<RunRecord> runs = RunsAtW3AndW4(dir.Path(), {1, 0});
  ReportOptions opt;
  std::vector<Drawn> drawn;
  RecordClogPictures(opt, dir.Path() / "report", drawn);
  WriteReport(info, runs, opt);
  ASSERT_EQ(drawn.size(), 3u) << "two points, then the zoomed one";
  EXPECT_EQ(drawn[0].run_dir.filename(), "W3r0") << "the lowest replica";
  EXPECT_EQ(drawn[1].run_dir.filename(), "W4r0");
  EXPECT_EQ(drawn[0].picture.clog, 1);
  EXPECT_EQ(drawn[0].picture.highlight, (std::set<std::int64_t>{0, 1, 2, 3}));
  EXPECT_TRUE(drawn[0].picture.colour_by_disc);
  EXPECT_LT(drawn[0].picture.x_lo, -2.4) << "a window around the arch";
  EXPECT_GT(drawn[0].picture.x_hi, 2.4);
  ASSERT_EQ(drawn[0].picture.marks.size(), 1u);
  EXPECT_EQ(drawn[0].picture.marks[0].label, "W = 3 d");
  EXPECT_DOUBLE_EQ(drawn[0].picture.marks[0].x0, -1.5);
  EXPECT_FALSE(drawn[2].picture.colour_by_disc);
  EXPECT_EQ(drawn[2].picture.x_lo, -5) << "the figure's window";
  EXPECT_EQ(drawn[2].picture.y_hi, 6);
  const std::string md = ReadFile(opt.out_dir / "report.md");
  EXPECT_NE(md.find("(pictures/figure-arches-1-clog.png)"), std::string::npos) << md;
  EXPECT_NE(md.find("clog 1: N_t = 4 (the point's median N_t = 4), arch bodies outlined"), std::string::npos);
}

TEST(ClogReport, OptionErrorsNameTheirJsonPath) {
  auto error = [](const nlohmann::json& report) {
    try {
      SetupAnalyses({{"report", report}});
    } catch (const OptionError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error({{"arches", {{"theta_bins", 0}}}}).rfind("/report/arches/theta_bins: must be", 0), 0u);
  EXPECT_EQ(error({{"arches", {{"pictures", true}}}}).rfind("/report/arches/pictures: must be", 0), 0u);
  EXPECT_EQ(error({{"arches", {{"colour", 1}}}}).rfind("/report/arches/colour: unknown key", 0), 0u);
  EXPECT_EQ(
      error({{"orientation", {{"heights", nlohmann::json::array()}}}}).rfind("/report/orientation/heights: must be", 0),
      0u);
  EXPECT_EQ(error({{"orientation", {{"regions", {{{"x", {3, 1}}, {"y", {0, 1}}}}}}}})
                .rfind("/report/orientation/regions/0/x: must be [lo, hi] with lo < hi", 0),
            0u);
  EXPECT_EQ(
      error({{"orientation", {{"window", {{"theta", 200}}}}}}).rfind("/report/orientation/window/theta: must be", 0),
      0u);
  EXPECT_EQ(error({{"contacts", {{"x", 1}}}}).rfind("/report/contacts/x: unknown key", 0), 0u);
  EXPECT_EQ(error({{"arches", {{"theta_bins", 6}, {"obstacle_arches", false}, {"pictures", 2}}}}), "no error");
  const ArchesOptions a =
      ReadArchesOptions({{"theta_bins", 6}, {"obstacle_arches", false}, {"pictures", 2}}, "/report/arches");
  EXPECT_EQ(a.summary.theta_bins, 6);
  EXPECT_FALSE(a.summary.obstacle_arches);
  EXPECT_EQ(a.pictures, 2);
  const OrientationAnalysisOptions o =
      ReadOrientationOptions({{"heights", {3}},
                              {"window", {{"theta", 60}, {"radius", 8}}},
                              {"regions", {{{"name", "bulk"}, {"x", {-5, 5}}, {"y", {60, 70}}, {"director", 90}}}}},
                             "/report/orientation");
  EXPECT_EQ(o.where.heights, std::vector<double>{3});
  EXPECT_NEAR(o.where.window_theta, std::numbers::pi / 3, 1e-12);
  ASSERT_EQ(o.where.regions.size(), 1u);
  EXPECT_EQ(o.where.regions[0].name, "bulk");
  EXPECT_NEAR(o.where.regions[0].director, std::numbers::pi / 2, 1e-12);
}

// Fractions of all contacts per clog; a clog of lone discs has no size classes, so it counts
// for `other` only (not as a zero of small-small etc.).
TEST(ClogReport, ContactFractionsPerClogWithoutSizeClassesForLoneDiscs) {
  const auto contacts = MakeContactsAnalysis(nullptr, "/report/contacts");
  const nlohmann::json result = {{"present", true},
                                 {"clogs",
                                  {{{"small_small", 0}, {"large_small", 0}, {"large_large", 0}, {"other", 10}},
                                   {{"small_small", 1}, {"large_small", 2}, {"large_large", 1}, {"other", 4}}}}};
  const std::vector<Metric> m = contacts->RunMetrics(result);
  ASSERT_NE(FindMetric(m, "contact_ss"), nullptr);
  EXPECT_DOUBLE_EQ(FindMetric(m, "contact_ss")->value, 1.0 / 8);
  EXPECT_DOUBLE_EQ(FindMetric(m, "contact_ls")->value, 2.0 / 8);
  EXPECT_DOUBLE_EQ(FindMetric(m, "contact_other")->value, (1.0 + 0.5) / 2);
  EXPECT_TRUE(contacts->RunMetrics({{"present", false}, {"clogs", nlohmann::json::array()}}).empty());
}

}  // namespace
}  // namespace granary::analysis
