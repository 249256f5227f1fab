// The region analysis on lattice frames (lattice_frame.h: discs of radius 0.5 at unit spacing,
// packing fraction pi/4 in any rectangle whose edges cut the discs through their centres)
// whose columns move sideways at +-a, so that the bodies in a region have <v_x> = 0 and hand-
// counted temperatures T_g(ch. 3) = a^2 / 2 and T_g(ch. 4-5) = m a^2 / 3 (m = pi/4): the
// region next to each outlet in that outlet's coordinates, the per-outlet metric names, the
// mean and se over frames, the frames it asks for, and the errors of /report/region.
#include "analysis/region_analysis.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <utility>
#include <vector>

#include "analysis/figures.h"
#include "analysis/run_pass.h"
#include "lattice_frame.h"

namespace granary::analysis {
namespace {

constexpr double kPi = std::numbers::pi;

// Two base outlets of width 2 at x = -6 and x = 6: the ch. 3 region of each, (W + 2) x 10,
// covers the columns x = -8 .. -5 (outlet 0) and 4 .. 7 (outlet 1), rows y = 0.5 .. 9.5.
rundir::RunData TwoOutletRun() {
  rundir::RunData data;
  const nlohmann::json outlets = {{{"center", -6.0}, {"width", 2.0}}, {{"center", 6.0}, {"width", 2.0}}};
  data.spec = {{"discharge", {{"mode", "remove"}, {"clog_window", 5.0}}},
               {"silo", {{"width", 24.0}, {"base_outlets", outlets}}},
               {"bodies", {{"count", 525}}}};
  data.has_frames = true;
  // Exits to t = 10 through both outlets: a steady flow window around the frames at t = 3, 4.
  for (int i = 1; i <= 100; ++i) data.events.push_back({0.1 * i, i, "disc", 1.0, i % 2});
  data.summary.t_end = 10.0;
  return data;
}

// The lattice at time t, columns moving at +a and -a alternately: amplitude `left` for x < 0,
// `right` for x > 0.
rundir::Frame ShearedLattice(double t, double left, double right) {
  rundir::Frame f = testing::LatticeFrame(t, 0.0).first;
  for (rundir::Disc& d : f.discs) {
    const long col = std::lround(d.x);
    d.vx = (col % 2 == 0 ? 1.0 : -1.0) * (d.x < 0 ? left : right);
  }
  return f;
}

void Add(RunAccumulator& accumulator, const rundir::Frame& frame) {
  const std::vector<rundir::Body> bodies = rundir::BodiesOf(frame.discs);
  accumulator.AddFrame({frame, bodies, nullptr});
}

TEST(RegionAnalysis, EachOutletsRegionInItsOwnMetrics) {
  const rundir::RunData data = TwoOutletRun();
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  const auto analysis = MakeRegionAnalysis("ch3", "/report/region");
  const auto accumulator = analysis->Start(view);
  // The frames of the steady window, without contacts.
  const FrameRequest request = accumulator->Frames();
  ASSERT_EQ(request.windows.size(), 1u);
  EXPECT_EQ(request.windows[0].start, view.steady.start);
  EXPECT_EQ(request.windows[0].end, view.steady.end);
  EXPECT_FALSE(request.contacts);
  // Frame 1: a = 1 on the left, 2 on the right; frame 2: a = 2 and 4.
  Add(*accumulator, ShearedLattice(3.0, 1.0, 2.0));
  Add(*accumulator, ShearedLattice(4.0, 2.0, 4.0));
  const nlohmann::json result = accumulator->Finish();
  EXPECT_EQ(result.at("frames"), 2);
  const std::vector<Metric> m = analysis->RunMetrics(result);
  std::vector<std::string> names;
  for (const Metric& x : m) names.push_back(x.name);
  EXPECT_EQ(names, (std::vector<std::string>{"phi", "tg_translational", "tg_full", "phi_outlet1",
                                             "tg_translational_outlet1", "tg_full_outlet1"}));
  EXPECT_NEAR(FindMetric(m, "phi")->value, kPi / 4, 1e-12);
  EXPECT_NEAR(FindMetric(m, "phi_outlet1")->value, kPi / 4, 1e-12);
  EXPECT_NEAR(FindMetric(m, "phi")->se, 0.0, 1e-12);  // the same in both frames
  // Outlet 0: a^2 / 2 = 0.5 and 2 over the two frames: mean 1.25, se |2 - 0.5| / 2 = 0.75.
  EXPECT_NEAR(FindMetric(m, "tg_translational")->value, 1.25, 1e-12);
  EXPECT_NEAR(FindMetric(m, "tg_translational")->se, 0.75, 1e-12);
  // Outlet 1: 2 and 8.
  EXPECT_NEAR(FindMetric(m, "tg_translational_outlet1")->value, 5.0, 1e-12);
  EXPECT_NEAR(FindMetric(m, "tg_translational_outlet1")->se, 3.0, 1e-12);
  // m a^2 / 3 with m = pi/4: (1 + 4) / 2 and (4 + 16) / 2 times pi / 12.
  EXPECT_NEAR(FindMetric(m, "tg_full")->value, 2.5 * kPi / 12, 1e-12);
  EXPECT_NEAR(FindMetric(m, "tg_full_outlet1")->value, 10.0 * kPi / 12, 1e-12);
  EXPECT_EQ(FindMetric(m, "phi")->unit, "1");
  EXPECT_EQ(FindMetric(m, "tg_translational")->unit, "g d");
  EXPECT_EQ(FindMetric(m, "tg_full")->unit, "rho g d^3");
  EXPECT_TRUE(FindMetric(m, "phi")->headline);
  EXPECT_FALSE(FindMetric(m, "phi_outlet1")->headline);
  EXPECT_EQ(FindMetric(m, "phi_outlet1")->title,
            "packing fraction next to " + result.at("outlets").at(1).get<std::string>());
  // The velocity distribution of the region next to outlet 0: 40 bodies a frame at v_x = +-1
  // (frame 1) and +-2 (frame 2), 20 each.
  const Samples vx = analysis->Distribution("vx", result);
  ASSERT_EQ(vx.values.size(), 4u);
  EXPECT_NEAR(vx.values[0], -2.0, 1e-9);
  EXPECT_NEAR(vx.values[3], 2.0, 1e-9);
  EXPECT_EQ(vx.weights, (std::vector<double>{20, 20, 20, 20}));
}

// The ch. 4 region (the default) is (W + 2 sqrt2) x 5 sqrt2: its own size, which the run
// options (the cache key) carry.
TEST(RegionAnalysis, RegionSizeOptions) {
  EXPECT_EQ(MakeRegionAnalysis(nullptr, "/report/region")->RunOptions(),
            MakeRegionAnalysis("ch4", "/report/region")->RunOptions());
  const nlohmann::json ch3 = MakeRegionAnalysis("ch3", "/report/region")->RunOptions();
  EXPECT_DOUBLE_EQ(ch3.at("pad").get<double>(), 2.0);
  EXPECT_DOUBLE_EQ(ch3.at("height").get<double>(), 10.0);
  const nlohmann::json own = MakeRegionAnalysis({{"pad", 1.5}, {"height", 3}}, "/report/region")->RunOptions();
  EXPECT_DOUBLE_EQ(own.at("pad").get<double>(), 1.5);
  EXPECT_DOUBLE_EQ(own.at("height").get<double>(), 3.0);
  auto error = [](const nlohmann::json& options) -> std::string {
    try {
      MakeRegionAnalysis(options, "/report/region");
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(error("ch5").rfind("/report/region: must be \"ch3\", \"ch4\", \"ch6\" or {", 0), 0u);
  EXPECT_EQ(error({{"pad", 2}, {"height", 5}, {"unit", "cm"}}),
            "/report/region/unit: must be \"d\" or \"D_eq\" (got \"cm\")");
  // A size in D_eq has its own cache key; one in d keeps the key it had.
  EXPECT_EQ(MakeRegionAnalysis("ch6", "/report/region")->RunOptions(),
            (nlohmann::json{{"pad", 2.0}, {"height", 5.0}, {"unit", "D_eq"}}));
  EXPECT_EQ(MakeRegionAnalysis({{"pad", 2}, {"height", 5}, {"unit", "D_eq"}}, "/report/region")->RunOptions(),
            MakeRegionAnalysis("ch6", "/report/region")->RunOptions());
  EXPECT_EQ(MakeRegionAnalysis({{"pad", 1.5}, {"height", 3}, {"unit", "d"}}, "/report/region")->RunOptions(), own);
  EXPECT_EQ(error({{"pad", 2}}).rfind("/report/region: must be", 0), 0u);
  EXPECT_EQ(error({{"pad", 2}, {"height", -1}}).rfind("/report/region/height: must be in", 0), 0u);
  EXPECT_EQ(error({{"pad", "2"}, {"height", 1}}).rfind("/report/region/pad: must be a number", 0), 0u);
  EXPECT_EQ(error({{"pad", 2}, {"height", 1}, {"width", 3}}).rfind("/report/region/width: unknown key", 0), 0u);
}

// D_eq, the diameter of the disc of a body's area: sqrt(D_s^2 + D_b^2) for a snowman.
TEST(RegionAnalysis, EquivalentDiameterOfTheRunsBodies) {
  auto bodies = [](const nlohmann::json& species) { return nlohmann::json{{"bodies", {{"species", species}}}}; };
  const nlohmann::json snowman = {{"shape", "snowman"}, {"diameter", 1.0}, {"big_diameter", 2.0}};
  EXPECT_NEAR(EquivalentDiameter(bodies(nlohmann::json::array({snowman}))), std::sqrt(5.0), 1e-12);
  EXPECT_NEAR(EquivalentDiameter(bodies({{{"shape", "dumbbell"}}})), std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(EquivalentDiameter(bodies({{{"shape", "disc"}, {"diameter", 3.0}}})), 3.0, 1e-12);
  EXPECT_NEAR(EquivalentDiameter(bodies({{{"shape", "rod"}, {"n", 4}}})), 2.0, 1e-12);
  // A mixture: the number-weighted mean area, (1 + 5) / 2 discs of d = 1.
  nlohmann::json half_snowmen = snowman;
  half_snowmen["fraction"] = 0.5;
  half_snowmen["name"] = "sm";
  EXPECT_NEAR(EquivalentDiameter(bodies({half_snowmen, {{"shape", "disc"}, {"fraction", 0.5}}})), std::sqrt(3.0),
              1e-12);
  try {
    EquivalentDiameter(bodies({{{"shape", "cube"}}}));
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("D_eq: the run's spec does not describe its bodies: ", 0), 0u) << what;
    EXPECT_NE(what.find("/bodies/species/0/shape"), std::string::npos) << what;
  }
  // A size in d is the same for every run; one in D_eq scales with the run's.
  const RegionSize ch4 = RegionForRun(Chapter4Region(), nlohmann::json::object());
  EXPECT_DOUBLE_EQ(ch4.pad, Chapter4Region().pad);
  const RegionSize ch6 = RegionForRun(Chapter6Region(), bodies(nlohmann::json::array({snowman})));
  EXPECT_NEAR(ch6.pad, 2.0 * std::sqrt(5.0), 1e-12);
  EXPECT_NEAR(ch6.height, 5.0 * std::sqrt(5.0), 1e-12);
  EXPECT_FALSE(ch6.in_d_eq);
}

// Thesis ch. 6's region R for snowmen of D_b = 2 (D_eq = sqrt 5) above an outlet of W = 2:
// (W + 2 sqrt5) x 5 sqrt5 centred on the outlet, x in +-(1 + sqrt5) = +-3.236, y < 11.18. A
// disc at (0, 9) lies inside it but above ch. 4's region (5 sqrt2 = 7.07 high); one at
// (0, 12) and one at (5, 2) lie outside.
TEST(RegionAnalysis, Chapter6RegionIsSizedByTheRunsDeq) {
  rundir::RunData data;
  data.spec = {
      {"discharge", {{"mode", "remove"}, {"clog_window", 5.0}}},
      {"silo", {{"width", 40.0}, {"base_outlets", {{{"center", 0.0}, {"width", 2.0}}}}}},
      {"bodies", {{"count", 100}, {"species", {{{"shape", "snowman"}, {"diameter", 1.0}, {"big_diameter", 2.0}}}}}}};
  data.has_frames = true;
  for (int i = 1; i <= 100; ++i) data.events.push_back({0.1 * i, i, "snowman", 1.0, 0});
  data.summary.t_end = 10.0;
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  const auto analysis = MakeRegionAnalysis("ch6", "/report/region");
  const auto accumulator = analysis->Start(view);
  rundir::Frame frame;
  frame.time = 5.0;
  std::int64_t id = 0;
  for (const auto& [x, y] : std::vector<std::pair<double, double>>{{0.0, 9.0}, {0.0, 12.0}, {5.0, 2.0}}) {
    rundir::Disc d;
    d.id = ++id;
    d.mol = id;
    d.x = x;
    d.y = y;
    d.radius = 0.5;
    d.mass = kPi / 4;
    frame.discs.push_back(d);
  }
  Add(*accumulator, frame);
  const nlohmann::json result = accumulator->Finish();
  const double d_eq = std::sqrt(5.0);
  EXPECT_NEAR(result.at("pad").get<double>(), 2 * d_eq, 1e-12);
  EXPECT_NEAR(result.at("height").get<double>(), 5 * d_eq, 1e-12);
  const std::vector<Metric> m = analysis->RunMetrics(result);
  EXPECT_NEAR(FindMetric(m, "phi")->value, (kPi / 4) / ((2.0 + 2 * d_eq) * 5 * d_eq), 1e-12);
  // The same frame in ch. 4's region: no disc inside.
  const auto ch4 = MakeRegionAnalysis("ch4", "/report/region");
  const auto ch4_accumulator = ch4->Start(view);
  Add(*ch4_accumulator, frame);
  EXPECT_NEAR(FindMetric(ch4->RunMetrics(ch4_accumulator->Finish()), "phi")->value, 0.0, 1e-12);
}

// A pictures figure's "region" mark draws the region the analysis measures: ch. 6's R in the
// run's D_eq, around an outlet of W = 8 at x = 3; a run spec without describable bodies is a
// problem said, not a wrong outline.
TEST(RegionAnalysis, PictureMarkOfChapter6Region) {
  FigureSpec figure;
  figure.annotate = {MarkSpec{"region", -1, "R", true}};
  const nlohmann::json campaign = {{"report", {{"region", "ch6"}}}};
  const nlohmann::json run = {
      {"silo", {{"width", 40.0}, {"base_outlets", {{{"center", 3.0}, {"width", 8.0}}}}}},
      {"bodies", {{"species", {{{"shape", "snowman"}, {"diameter", 1.0}, {"big_diameter", 2.0}}}}}}};
  std::vector<std::string> problems;
  const std::vector<PictureMark> marks = PictureMarksOf(figure, campaign, run, 0.0, problems);
  EXPECT_TRUE(problems.empty());
  ASSERT_EQ(marks.size(), 1u);
  const double d_eq = std::sqrt(5.0);
  EXPECT_NEAR(marks[0].x0, 3.0 - 4.0 - d_eq, 1e-12);
  EXPECT_NEAR(marks[0].x1, 3.0 + 4.0 + d_eq, 1e-12);
  EXPECT_NEAR(marks[0].y0, 0.0, 1e-12);
  EXPECT_NEAR(marks[0].y1, 5.0 * d_eq, 1e-12);
  nlohmann::json bad = run;
  bad["bodies"]["species"][0]["shape"] = "cube";
  EXPECT_TRUE(PictureMarksOf(figure, campaign, bad, 0.0, problems).empty());
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].rfind("R: D_eq: the run's spec does not describe its bodies", 0), 0u) << problems[0];
}

// One base outlet of width 2 at x = 0 and `exits` exits at 10 a time unit from t = 0.1; the
// run goes on at rest to t = 30 (a clog).
rundir::RunData ClogRun(int exits) {
  rundir::RunData data;
  data.spec = {{"discharge", {{"mode", "remove"}, {"clog_window", 5.0}}},
               {"silo", {{"width", 24.0}, {"base_outlets", {{{"center", 0.0}, {"width", 2.0}}}}}},
               {"bodies", {{"count", 525}}}};
  data.has_frames = true;
  for (int i = 1; i <= exits; ++i) data.events.push_back({0.1 * i, i, "disc", 1.0, 0});
  data.summary.t_end = 30.0;
  data.summary.bodies = 525;
  return data;
}

// Thesis fig. 3.5 takes the velocities in steady flow: the frames of a clogged bed (at rest,
// after the flow window) add no weight at v = 0, though they count for phi and T_g.
TEST(RegionAnalysis, VelocityDistributionsTakeTheFlowWindowsFramesOnly) {
  const rundir::RunData data = ClogRun(100);  // exits to t = 10, then a clog
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  ASSERT_TRUE(view.flow.ok) << view.flow.note;
  ASSERT_NEAR(view.flow.t_end, 10.0, 1e-9);
  const auto analysis = MakeRegionAnalysis("ch3", "/report/region");
  const auto accumulator = analysis->Start(view);
  // Flowing at v_y = -1 at t = 5 and 6; at rest at t = 15 and 20 (frames the pass would not
  // hand over inside this window either, added here to see that they are refused).
  for (const double t : {5.0, 6.0}) Add(*accumulator, testing::LatticeFrame(t, -1.0).first);
  for (const double t : {15.0, 20.0}) Add(*accumulator, testing::LatticeFrame(t, 0.0).first);
  const nlohmann::json result = accumulator->Finish();
  EXPECT_EQ(result.at("frames"), 4);
  EXPECT_EQ(result.at("regions")[0].at("velocity").at("frames"), 2);
  // The ch. 3 region of W = 2: 4 columns x 10 rows, 40 bodies a frame, all at v_y = -1.
  const Samples vy = analysis->Distribution("vy", result);
  double total = 0.0;
  for (std::size_t k = 0; k < vy.values.size(); ++k) {
    EXPECT_NEAR(vy.values[k], -1.0, 1e-9) << "weight " << vy.weights[k] << " at v_y = " << vy.values[k];
    total += vy.weights[k];
  }
  EXPECT_EQ(total, 80.0);
  EXPECT_NEAR(FindMetric(analysis->RunMetrics(result), "phi")->value, kPi / 4, 1e-12);  // all 4 frames
}

// A run that clogs after 5 exits has no steady flow window: no velocities, and a note saying so.
TEST(RegionAnalysis, ARunWithoutAFlowWindowGivesNoVelocities) {
  const rundir::RunData data = ClogRun(5);
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  ASSERT_FALSE(view.flow.ok);
  const auto analysis = MakeRegionAnalysis("ch3", "/report/region");
  const auto accumulator = analysis->Start(view);
  Add(*accumulator, testing::LatticeFrame(0.3, -1.0).first);
  const nlohmann::json result = accumulator->Finish();
  EXPECT_TRUE(analysis->Distribution("vy", result).values.empty());
  EXPECT_EQ(result.at("regions")[0].at("velocity").at("frames"), 0);
  ASSERT_EQ(result.at("notes").size(), 1u);
  EXPECT_EQ(result.at("notes")[0].get<std::string>().rfind("velocity distributions: none", 0), 0u)
      << result.at("notes")[0];
}

// A run whose frames all lie outside the window: no regions, no metrics, and a note saying so.
TEST(RegionAnalysis, NoFramesInTheWindowGiveNoMetrics) {
  const rundir::RunData data = TwoOutletRun();
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  const auto analysis = MakeRegionAnalysis(nullptr, "/report/region");
  const nlohmann::json result = analysis->Start(view)->Finish();
  EXPECT_FALSE(result.contains("regions"));
  EXPECT_EQ(result.at("frames"), 0);
  ASSERT_EQ(result.at("notes").size(), 1u);
  EXPECT_EQ(result.at("notes")[0].get<std::string>().rfind("frames: none inside the window", 0), 0u);
  EXPECT_TRUE(analysis->RunMetrics(result).empty());
}

}  // namespace
}  // namespace granary::analysis
