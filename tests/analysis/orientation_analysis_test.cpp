// The orientation analysis on frames of dumbbells placed by hand: which frames it takes for the
// bed before the opening (the first at t <= 0) and for steady flow (those in the steady window),
// its order parameters per region with their metric names (S = 2 <cos^2(axis - director)> - 1
// counted by hand: 1 for axes along the director, -1 across it, 0 for half of each), a "flow"
// director resolved per run and reported (or noted as missing where nothing moves), the runs
// it has nothing to say about, and the errors of /report/orientation.
#include "analysis/orientation_analysis.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <numbers>

#include "analysis/options.h"
#include "analysis/registry.h"
#include "analysis/run_pass.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

constexpr double kPi = std::numbers::pi;
using testing::TempDir;

// A silo of width 40 with one base outlet of width 4 at x = 0 (no clog files in `dir`).
rundir::RunData SiloRun(const std::filesystem::path& dir) {
  rundir::RunData data;
  data.spec = {{"discharge", {{"mode", "remove"}, {"clog_window", 5.0}}},
               {"silo", {{"width", 40.0}, {"base_outlets", {{{"center", 0.0}, {"width", 4.0}}}}}}};
  data.dir = dir;
  data.has_frames = true;
  return data;
}

// A frame at time t of dumbbells (two unit discs 1 apart) centred at (x, y) with their axes at
// `degrees` from the horizontal.
rundir::Frame Dumbbells(double t, const std::vector<std::array<double, 3>>& bodies) {
  rundir::Frame f;
  f.time = t;
  std::int64_t mol = 0;
  for (const auto& [x, y, degrees] : bodies) {
    const double ax = 0.5 * std::cos(degrees * kPi / 180), ay = 0.5 * std::sin(degrees * kPi / 180);
    for (double side : {-1.0, 1.0})
      f.discs.push_back(
          {static_cast<std::int64_t>(f.discs.size() + 1), mol, 1, x + side * ax, y + side * ay, 0.5, kPi / 4, 0, 0, 0});
    ++mol;
  }
  return f;
}

void Add(RunAccumulator& accumulator, const rundir::Frame& frame) {
  const std::vector<rundir::Body> bodies = rundir::BodiesOf(frame.discs);
  accumulator.AddFrame({frame, bodies, nullptr});
}

// Without events the steady window runs from /report/window/start_time (2) on. The bed is the
// first frame at t <= 0 alone; a frame between the opening and the window counts nowhere.
TEST(OrientationAnalysis, BedAndSteadyFlowFrames) {
  TempDir dir;
  const rundir::RunData data = SiloRun(dir.Path());
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  const auto analysis = MakeOrientationAnalysis(nullptr, "/report/orientation");
  const auto accumulator = analysis->Start(view);
  const FrameRequest request = accumulator->Frames();
  ASSERT_EQ(request.windows.size(), 2u);
  EXPECT_EQ(request.windows[0].start, -std::numeric_limits<double>::infinity());
  EXPECT_EQ(request.windows[0].end, 0.0);
  EXPECT_EQ(request.windows[1].start, view.steady.start);
  EXPECT_EQ(request.windows[1].end, view.steady.end);
  EXPECT_FALSE(request.contacts);
  // The default region is |s| < 5, 0 < h < 10 above the outlet, its director vertical.
  const rundir::Frame lying = Dumbbells(-1.0, {{0, 3, 0}, {2, 6, 0}});
  Add(*accumulator, lying);
  Add(*accumulator, Dumbbells(0.0, {{0, 3, 0}, {2, 6, 0}}));
  Add(*accumulator, Dumbbells(1.0, {{0, 3, 0}, {2, 6, 0}}));
  // Steady flow: upright in the region, lying outside it (x = 12).
  Add(*accumulator, Dumbbells(3.0, {{0, 3, 90}, {2, 6, 90}, {12, 3, 0}}));
  Add(*accumulator, Dumbbells(4.0, {{-1, 4, 90}, {12, 3, 0}}));
  const nlohmann::json result = accumulator->Finish();
  EXPECT_TRUE(result.at("elongated").get<bool>());
  EXPECT_EQ(result.at("regions"), (nlohmann::json{"above the outlet"}));
  EXPECT_EQ(OrientationSumsFromJson(result.at("bed")).frames, 1);
  EXPECT_EQ(OrientationSumsFromJson(result.at("flow")).frames, 2);
  EXPECT_FALSE(result.contains("notes"));
  const std::vector<Metric> m = analysis->RunMetrics(result);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].name, "flow_frames");
  EXPECT_DOUBLE_EQ(m[0].value, 2.0);
  EXPECT_EQ(m[0].unit, "frames");
  EXPECT_EQ(m[1].name, "order_parameter_0");
  EXPECT_EQ(m[1].title, "order parameter S in above the outlet");
  EXPECT_EQ(m[1].unit, "1");
  EXPECT_NEAR(m[1].value, 1.0, 1e-12);  // 3 upright bodies in the region, none lying
  EXPECT_TRUE(std::isnan(m[1].se));
}

// Regions of the spec, each against its own director: upright bodies against a horizontal
// director give S = -1; one upright and one lying against the vertical give S = 0.
TEST(OrientationAnalysis, OrderParameterPerRegionOfTheSpec) {
  TempDir dir;
  const rundir::RunData data = SiloRun(dir.Path());
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  const nlohmann::json options = {
      {"regions",
       {{{"name", "left"}, {"x", {-10, -2}}, {"y", {0, 10}}, {"director", 0}}, {{"x", {2, 10}}, {"y", {0, 10}}}}}};
  const auto analysis = MakeOrientationAnalysis(options, "/report/orientation");
  EXPECT_EQ(analysis->RunOptions(), options);  // the cache key holds them
  const auto accumulator = analysis->Start(view);
  Add(*accumulator, Dumbbells(3.0, {{-5, 3, 90}, {-4, 6, 90}, {5, 3, 90}, {6, 6, 0}}));
  const nlohmann::json result = accumulator->Finish();
  const std::vector<Metric> m = analysis->RunMetrics(result);
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[1].name, "order_parameter_0");
  EXPECT_EQ(m[1].title, "order parameter S in left");
  EXPECT_NEAR(m[1].value, -1.0, 1e-12);
  EXPECT_EQ(m[2].name, "order_parameter_1");
  EXPECT_EQ(m[2].title, "order parameter S in region 2");
  EXPECT_NEAR(m[2].value, 0.0, 1e-12);
}

// "director": "flow": each run's S against the direction its region's bodies moved, that
// direction in the result (degrees); a region whose bodies stood still gets no number but a note.
TEST(OrientationAnalysis, FlowDirectorPerRunAndNoFlowNoted) {
  TempDir dir;
  const rundir::RunData data = SiloRun(dir.Path());
  const RunView view = MakeRunView(data, PassOptions{});
  const nlohmann::json options = {{"regions",
                                   {{{"name", "moving"}, {"x", {-10, -2}}, {"y", {0, 10}}, {"director", "flow"}},
                                    {{"name", "still"}, {"x", {2, 10}}, {"y", {0, 10}}, {"director", "flow"}},
                                    {{"name", "fixed"}, {"x", {-10, -2}}, {"y", {0, 10}}, {"director", 0}}}}};
  const auto analysis = MakeOrientationAnalysis(options, "/report/orientation");
  const auto accumulator = analysis->Start(view);
  // Left: axes at 45 degrees moving down-left along them, (-1, -1); right: upright at rest.
  for (double t : {3.0, 4.0}) {
    rundir::Frame f = Dumbbells(t, {{-5, 3, 45}, {-4, 6, 45}, {5, 3, 90}});
    for (std::size_t i = 0; i < 4; ++i) f.discs[i].vx = f.discs[i].vy = -1.0;
    Add(*accumulator, f);
  }
  const nlohmann::json result = accumulator->Finish();
  ASSERT_EQ(result.at("directors").size(), 3u);
  EXPECT_NEAR(result.at("directors")[0].get<double>(), -135.0, 1e-9);
  EXPECT_TRUE(result.at("directors")[1].is_null());
  EXPECT_NEAR(result.at("directors")[2].get<double>(), 0.0, 1e-12);
  ASSERT_TRUE(result.contains("notes"));
  ASSERT_EQ(result.at("notes").size(), 1u);
  EXPECT_EQ(result.at("notes")[0].get<std::string>().rfind("orientation: region \"still\" has no flow direction", 0),
            0u)
      << result.at("notes");
  const std::vector<Metric> m = analysis->RunMetrics(result);
  EXPECT_NEAR(FindMetric(m, "order_parameter_0")->value, 1.0, 1e-12);  // along the flow's line
  EXPECT_TRUE(std::isnan(FindMetric(m, "order_parameter_1")->value));
  EXPECT_NEAR(FindMetric(m, "order_parameter_2")->value, 0.0, 1e-12);  // cos(2 x 45)
}

// Bounds over the campaign's axes (thesis fig. 5.5: 10 < y < W - 5), evaluated at each run's
// point from its spec: W/2 < y < W + 2 holds y = 2 .. 6 at W = 4 and 1 .. 4 at W = 2.
TEST(OrientationAnalysis, RegionBoundsFollowEachPointsAxes) {
  TempDir dir;
  const nlohmann::json region = {{"name", "low"}, {"x", {-10, 10}}, {"y", {"W_half", "W + 2"}}, {"director", 90}};
  const nlohmann::json campaign = {
      {"name", "bounds"},
      {"base", {{"silo", {{"width", 40.0}, {"base_outlets", {{{"center", 0.0}, {"width", 4.0}}}}}}}},
      {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {2, 4}}}}}},
      {"axes", {{"W_half", "W / 2"}}},
      {"report", {{"orientation", {{"regions", nlohmann::json::array({region})}}}}}};
  const AnalysisSetup setup = SetupAnalyses(campaign);
  const Analysis* orientation = nullptr;
  for (const Analysis* a : setup.List())
    if (a->Key() == "orientation") orientation = a;
  ASSERT_TRUE(orientation);
  EXPECT_TRUE(orientation->RunOptions().at("axes").contains("W_half"));  // the cache key holds the definitions
  // Upright bodies at y = 3 and 5: inside 2 < y < 6 at W = 4; at W = 2 (1 < y < 4) only y = 3.
  // A lying one at y = 4.5: inside at W = 4 only.
  for (const double w : {4.0, 2.0}) {
    rundir::RunData data = SiloRun(dir.Path());
    data.spec["silo"]["base_outlets"][0]["width"] = w;
    const PassOptions pass;
    const RunView view = MakeRunView(data, pass);
    const auto accumulator = orientation->Start(view);
    Add(*accumulator, Dumbbells(3.0, {{0, 3, 90}, {0, 5, 90}, {4, 4.5, 0}}));
    const nlohmann::json result = accumulator->Finish();
    EXPECT_EQ(result.at("region_bounds")[0], (nlohmann::json{-10.0, 10.0, w / 2, w + 2})) << w;
    const Metric* s = FindMetric(orientation->RunMetrics(result), "order_parameter_0");
    ASSERT_TRUE(s) << w;
    // W = 4: two along the director, one across: S = (1 + 1 - 1) / 3. W = 2: one along: S = 1.
    EXPECT_NEAR(s->value, w == 4.0 ? 1.0 / 3.0 : 1.0, 1e-12) << w;
  }
  // An empty region at a point (lo >= hi there): no body in it, and a note naming it.
  nlohmann::json upside = campaign;
  upside["report"]["orientation"]["regions"][0]["y"] = {"W", 3};
  const AnalysisSetup setup2 = SetupAnalyses(upside);
  for (const Analysis* a : setup2.List())
    if (a->Key() == "orientation") {
      rundir::RunData data = SiloRun(dir.Path());
      const RunView view = MakeRunView(data, PassOptions{});
      const auto accumulator = a->Start(view);  // W = 4: 4 < y < 3
      Add(*accumulator, Dumbbells(3.0, {{0, 3.5, 90}}));
      const nlohmann::json result = accumulator->Finish();
      ASSERT_TRUE(result.contains("notes"));
      EXPECT_NE(result.at("notes")[0].get<std::string>().find("region \"low\" is empty at this point"),
                std::string::npos)
          << result.at("notes");
      EXPECT_TRUE(std::isnan(FindMetric(a->RunMetrics(result), "order_parameter_0")->value));
    }
  // Names checked when the analyses are set up (plan time), with the path of the bound.
  auto error = [&](const nlohmann::json& y) -> std::string {
    nlohmann::json spec = campaign;
    spec["report"]["orientation"]["regions"][0]["y"] = y;
    try {
      SetupAnalyses(spec);
    } catch (const OptionError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(error({0, "W_s - 5"})
                .rfind("/report/orientation/regions/0/y/1: names no axis: W_s (a bound is a number or an expression "
                       "over the axes: W, W_half)",
                       0),
            0u)
      << error({0, "W_s - 5"});
  EXPECT_EQ(error({0, "W -"}).rfind("/report/orientation/regions/0/y/1:", 0), 0u) << error({0, "W -"});
  EXPECT_EQ(error({0, true}).rfind("/report/orientation/regions/0/y/1: must be a number", 0), 0u) << error({0, true});
  EXPECT_EQ(error({3}).rfind("/report/orientation/regions/0/y: must be [lo, hi]", 0), 0u) << error({3});
}

// Discs only: nothing to orient, no metrics. An outlet the run does not have: a note, and no
// frames asked for.
TEST(OrientationAnalysis, RunsWithoutAnythingToMeasure) {
  TempDir dir;
  const rundir::RunData data = SiloRun(dir.Path());
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  const auto analysis = MakeOrientationAnalysis(nullptr, "/report/orientation");
  const auto accumulator = analysis->Start(view);
  rundir::Frame discs;
  discs.time = 3.0;
  for (int i = 0; i < 5; ++i) discs.discs.push_back({i + 1, i, 1, 1.0 * i, 3.0, 0.5, kPi / 4, 0, 0, 0});
  Add(*accumulator, discs);
  const nlohmann::json result = accumulator->Finish();
  EXPECT_FALSE(result.at("elongated").get<bool>());
  EXPECT_TRUE(analysis->RunMetrics(result).empty());

  const auto other = MakeOrientationAnalysis({{"outlet", 1}}, "/report/orientation");
  const auto none = other->Start(view);
  EXPECT_TRUE(none->Frames().windows.empty());
  const nlohmann::json r = none->Finish();
  EXPECT_EQ(r.at("notes"), (nlohmann::json{"orientation: the run has no outlet 1"}));
  EXPECT_TRUE(other->RunMetrics(r).empty());
}

TEST(OrientationAnalysis, OptionErrorsNameTheirPath) {
  auto error = [](const nlohmann::json& options) -> std::string {
    try {
      MakeOrientationAnalysis(options, "/report/orientation");
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(error({{"heights", nlohmann::json::array()}})
                .rfind("/report/orientation/heights: must be a non-empty array of numbers", 0),
            0u);
  EXPECT_EQ(error({{"radii", {5, -1}}}).rfind("/report/orientation/radii/1: must be in", 0), 0u);
  EXPECT_EQ(error({{"window", {{"theta", 200}}}}).rfind("/report/orientation/window/theta: must be in", 0), 0u);
  EXPECT_EQ(error({{"window", {{"phi", 2}}}}).rfind("/report/orientation/window/phi: unknown key", 0), 0u);
  EXPECT_EQ(error({{"regions", {{{"x", {3, 1}}, {"y", {0, 1}}}}}})
                .rfind("/report/orientation/regions/0/x: must be [lo, hi] with lo < hi", 0),
            0u);
  EXPECT_EQ(error({{"regions", {{{"x", {0, 1}}}}}}).rfind("/report/orientation/regions/0: must have \"y\"", 0), 0u);
  EXPECT_EQ(error({{"regions", {{{"x", {0, 1}}, {"y", {0, 1}}, {"name", 7}}}}})
                .rfind("/report/orientation/regions/0/name: must be a string", 0),
            0u);
  // A director is an angle or "flow", nothing else.
  for (const nlohmann::json& bad : {nlohmann::json("Flow"), nlohmann::json(true), nlohmann::json({0, 1})})
    EXPECT_EQ(error({{"regions", {{{"x", {0, 1}}, {"y", {0, 1}}, {"director", bad}}}}})
                  .rfind("/report/orientation/regions/0/director: must be an angle in degrees in [-360, 360] "
                         "(0 = horizontal, 90 = vertical) or \"flow\"",
                         0),
              0u)
        << bad;
  const nlohmann::json box = {{"x", {0, 1}}, {"y", {0, 1}}};
  nlohmann::json far = box;
  far["director"] = 400;
  EXPECT_EQ(error({{"regions", {box, far}}}).rfind("/report/orientation/regions/1/director: must be in [-360, 360]", 0),
            0u);
  EXPECT_EQ(error({{"regions", {{{"x", {0, 1}}, {"y", {0, 1}}, {"director", "flow"}}}}}), "no error");
  EXPECT_EQ(error({{"outlet", -1}}).rfind("/report/orientation/outlet: must be in", 0), 0u);
  EXPECT_EQ(error({{"rings", 2}}).rfind("/report/orientation/rings: unknown key", 0), 0u);
  // The defaults: heights and radii 5 and 10 d.
  const OrientationAnalysisOptions o = ReadOrientationOptions(nullptr, "/report/orientation");
  EXPECT_EQ(o.where.heights, (std::vector<double>{5, 10}));
  EXPECT_EQ(o.where.radii, (std::vector<double>{5, 10}));
  EXPECT_EQ(o.outlet, 0);
}

}  // namespace
}  // namespace granary::analysis
