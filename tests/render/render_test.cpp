// The renderer against scenes with known answers (SVG circles where the discs are, at their
// scale; PNG pixels of the body colours at disc centres and of the background elsewhere), and
// the verbs end to end on a real native run: snapshot PNG/SVG, the K-th clog, a movie whose
// frame count ffprobe confirms.
#include <cairo.h>
#include <gtest/gtest.h>

#include <boost/process.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "analysis/arches.h"
#include "render/run_picture.h"
#include "render/scene.h"
#include "rundir/clogs.h"

namespace granary::render {
namespace {
namespace fs = std::filesystem;
namespace bp = boost::process;

rundir::Frame TestFrame() {
  rundir::Frame f;
  // A dumbbell (body 0, species 1) lying on the base and a disc (body 1, species 2, r = 0.7).
  f.discs = {{1, 0, 1, -1.0, 0.5, 0.5, 0.785, 0, 0, 0},
             {2, 0, 1, 0.0, 0.5, 0.5, 0.785, 0, 0, 0},
             {3, 1, 2, 2.0, 3.0, 0.7, 1.54, 0, -2, 0}};
  return f;
}

silo::SiloOutline TestSilo() {
  Silo silo;
  silo.width = 10;
  silo.base_outlets = {{3.0, 2.0}};
  silo.obstacles = {{-2.0, 4.0, 1.0}};
  return silo::OutlineOf(silo, 6.0);
}

std::vector<std::array<double, 3>> Circles(const std::string& svg, const std::string& cls) {
  std::vector<std::array<double, 3>> out;
  const std::regex re("<circle class=\"" + cls + "\" cx=\"([-0-9.]+)\" cy=\"([-0-9.]+)\" r=\"([-0-9.]+)\"");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator(); ++it)
    out.push_back({std::stod((*it)[1]), std::stod((*it)[2]), std::stod((*it)[3])});
  return out;
}

TEST(Render, SvgHasOneCircleAtEachDiscToScale) {
  SceneOptions o;
  o.window = {-6, 6, -3, 7};  // 12 d wide
  o.highlight = {1};
  o.species = {"dumbbell", "disc"};
  const Scene scene = MakeScene(TestFrame(), TestSilo(), o);
  const std::string svg = Svg(scene, 1200);  // 100 px per d
  const auto discs = Circles(svg, "disc"), outlined = Circles(svg, "disc highlight");
  ASSERT_EQ(discs.size(), 2u);
  ASSERT_EQ(outlined.size(), 1u) << "body 1 highlighted";
  EXPECT_NEAR(discs[0][0], (-1 + 6) * 100, 0.01);
  EXPECT_NEAR(discs[1][0], (0 + 6) * 100, 0.01);
  EXPECT_NEAR(discs[0][2], 50, 0.01);
  EXPECT_NEAR(outlined[0][0], (2 + 6) * 100, 0.01);
  EXPECT_NEAR(outlined[0][2], 70, 0.01);
  EXPECT_NEAR(discs[0][1] - outlined[0][1], (3.0 - 0.5) * 100, 0.01) << "y up";
  const auto obstacles = Circles(svg, "obstacle");
  ASSERT_EQ(obstacles.size(), 1u);
  EXPECT_NEAR(obstacles[0][0], (-2 + 6) * 100, 0.01);
  EXPECT_NEAR(obstacles[0][2], 50, 0.01);
  EXPECT_NEAR(obstacles[0][1] - outlined[0][1], -(4.0 - 3.0) * 100, 0.01);
  // Base left and right of the outlet, two side walls; one outlet band.
  std::size_t walls = 0, outlets = 0;
  for (std::size_t p = 0; (p = svg.find("class=\"wall\"", p)) != std::string::npos; ++p) ++walls;
  for (std::size_t p = 0; (p = svg.find("class=\"outlet\"", p)) != std::string::npos; ++p) ++outlets;
  EXPECT_EQ(walls, 4u);
  EXPECT_EQ(outlets, 1u);
  EXPECT_NE(svg.find(">dumbbell</text>"), std::string::npos) << "legend names the species";
}

TEST(Render, ForceColoursAndNetworkNeedContacts) {
  SceneOptions o;
  o.window = {-6, 6, -3, 7};
  o.forces = true;
  EXPECT_THROW(MakeScene(TestFrame(), TestSilo(), o), std::invalid_argument);
  rundir::ContactFrame c;
  c.contacts = {{0, 1, 0.0, 0.5, 2.0, 3.0, 0.3, 0.9, 1.0, 0.0}, {0, -1, -1.0, 0.5, -1.0, 0.0, -1.0, 0.0, 0.0, 4.0}};
  o.contacts = &c;
  o.colour = Colour::kForce;
  const Scene s = MakeScene(TestFrame(), TestSilo(), o);
  ASSERT_EQ(s.forces.size(), 2u);
  EXPECT_NEAR(s.forces[1].width / s.forces[0].width, 4.0, 1e-12) << "width proportional to |f|";
  EXPECT_DOUBLE_EQ(s.forces[1].y2, 0.0) << "a wall contact ends at the contact point";
  // Body 0 carries 1 + 4, body 1 carries 1: body 0 darker on the heat scale.
  EXPECT_LT(s.discs[0].fill.g, s.discs[2].fill.g);
}

TEST(Render, PngHasTheSizeAndTheBodiesWhereTheyAre) {
  SceneOptions o;
  o.window = {-6, 6, -3, 7};
  const Scene scene = MakeScene(TestFrame(), TestSilo(), o);
  const fs::path file = fs::path(GRANARY_RENDER_TEST_TMP) / "scene.png";
  fs::create_directories(file.parent_path());
  WritePng(scene, 600, file);  // 50 px per d
  cairo_surface_t* png = cairo_image_surface_create_from_png(file.c_str());
  ASSERT_EQ(cairo_surface_status(png), CAIRO_STATUS_SUCCESS);
  const PixelSize size = SizeFor(scene, 600);
  EXPECT_EQ(cairo_image_surface_get_width(png), size.width);
  EXPECT_EQ(cairo_image_surface_get_height(png), size.height);
  const int header = size.height - 10 * 50;  // the window is 10 d high
  const unsigned char* px = cairo_image_surface_get_data(png);
  const int stride = cairo_image_surface_get_stride(png);
  const auto at = [&](double x, double y) {  // silo coordinates -> (r, g, b)
    const int col = static_cast<int>((x + 6) * 50), row = header + static_cast<int>((7 - y) * 50);
    const unsigned char* p = px + row * stride + col * 4;  // B G R A
    return std::array<int, 3>{p[2], p[1], p[0]};
  };
  const std::array<int, 3> white{255, 255, 255};
  EXPECT_NE(at(-1, 0.5), white) << "dumbbell disc";
  EXPECT_NE(at(2, 3), white) << "single disc";
  EXPECT_NE(at(at(-1, 0.5) == at(2, 3) ? 100 : 2, 3), at(-1, 0.5)) << "species differ in colour";
  EXPECT_EQ(at(0, 5), white) << "empty silo";
  for (int c : at(-2, 4)) EXPECT_NEAR(c, 0.3 * 255, 1) << "dark grey obstacle";
  const auto base = at(-4, -0.25);
  EXPECT_EQ(base[0], base[1]) << "grey wall below the base";
  const auto outlet = at(3, -0.25);
  EXPECT_GT(outlet[0], 150) << "red outlet band";
  EXPECT_LT(outlet[1], 100);
  cairo_surface_destroy(png);
}

// Marks: a region outlined and shaded, a dimension with its label, both where the silo
// coordinates put them; in the SVG text and in the PNG's pixels.
TEST(Render, MarksSitWhereTheirCoordinatesSay) {
  SceneOptions o;
  o.window = {-6, 6, -3, 7};  // 12 d wide
  o.marks = {{Mark::Kind::kRect, -2.5, 0, 1.5, 4, "A", true},
             {Mark::Kind::kDimension, 1.5, -1.5, 4.5, -1.5, "W = 3 d"}};
  const Scene scene = MakeScene(TestFrame(), TestSilo(), o);
  const std::string svg = Svg(scene, 1200);  // 100 px per d
  // The window's top in pixels, from the obstacle's centre (y = 4): the header's height is not whole.
  const double header = Circles(svg, "obstacle").at(0)[1] - (7 - 4) * 100;
  const std::regex rect(
      "<rect class=\"mark shaded\" x=\"([-0-9.]+)\" y=\"([-0-9.]+)\" width=\"([-0-9.]+)\" "
      "height=\"([-0-9.]+)\" fill=\"#ffc700\" fill-opacity=\"0.35\"");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(svg, m, rect)) << svg;
  EXPECT_NEAR(std::stod(m[1]), (-2.5 + 6) * 100, 0.01);
  EXPECT_NEAR(std::stod(m[2]), header + (7 - 4) * 100, 0.01) << "its top at y = 4";
  EXPECT_NEAR(std::stod(m[3]), 4 * 100, 0.01);
  EXPECT_NEAR(std::stod(m[4]), 4 * 100, 0.01);
  EXPECT_NE(svg.find(">A</text>"), std::string::npos);
  const std::regex line("<line class=\"dimension\" x1=\"([-0-9.]+)\" y1=\"([-0-9.]+)\" x2=\"([-0-9.]+)\"");
  ASSERT_TRUE(std::regex_search(svg, m, line)) << svg;
  EXPECT_NEAR(std::stod(m[1]), (1.5 + 6) * 100, 0.01);
  EXPECT_NEAR(std::stod(m[2]), header + (7 + 1.5) * 100, 0.01);
  EXPECT_NEAR(std::stod(m[3]), (4.5 + 6) * 100, 0.01);
  EXPECT_NE(svg.find("text-anchor=\"middle\">W = 3 d</text>"), std::string::npos) << "the label on its line";
  // A mark outside the window is clipped to it: the header strip stays clear.
  SceneOptions far = o;
  far.marks = {{Mark::Kind::kRect, -2, 5, 2, 50, "", false}};
  const std::string clipped = Svg(MakeScene(TestFrame(), TestSilo(), far), 1200);
  ASSERT_TRUE(std::regex_search(clipped, m, std::regex("<rect class=\"mark\" x=\"[-0-9.]+\" y=\"([-0-9.]+)\"")));
  EXPECT_NEAR(std::stod(m[1]), header, 0.01) << "cut at the window's top";
  EXPECT_GT(header, 20) << "below the header strip";

  // The PNG: translucent gold over white inside the region where no body is, white outside it.
  const PixelSize size = SizeFor(scene, 600);  // 50 px per d
  const std::vector<unsigned char> px = Pixels(scene, size);
  const int top = size.height - 10 * 50;
  const auto at = [&](double x, double y) {
    const std::size_t i = 4 * (static_cast<std::size_t>(top + static_cast<int>((7 - y) * 50)) * size.width +
                               static_cast<std::size_t>((x + 6) * 50));
    return std::array<int, 3>{px[i + 2], px[i + 1], px[i]};
  };
  const auto blend = [](double c) { return static_cast<int>(std::lround(255 * (0.65 + 0.35 * c))); };
  const std::array<int, 3> inside = at(1.0, 2.5);
  EXPECT_NEAR(inside[0], blend(1.0), 2);
  EXPECT_NEAR(inside[1], blend(0.78), 2);
  EXPECT_NEAR(inside[2], blend(0.0), 2);
  EXPECT_EQ(at(1.0, 5.5), (std::array<int, 3>{255, 255, 255})) << "above the region";
}

// Colour by disc: a snowman's large and small discs apart, each kind the same in every body.
TEST(Render, ColourByDiscTellsASnowmansHeadFromItsBody) {
  rundir::Frame f;
  f.discs = {{1, 0, 1, 0.0, 1.0, 0.5, 0.785, 0, 0, 0},
             {2, 0, 1, 1.5, 1.0, 1.0, 3.14, 0, 0, 0},
             {3, 1, 1, 3.0, 4.0, 1.0, 3.14, 0, 0, 0},
             {4, 1, 1, 4.5, 4.0, 0.5, 0.785, 0, 0, 0}};
  SceneOptions o;
  o.window = {-6, 6, -3, 7};
  o.colour = ColourFromName("disc");
  o.species = {"snowman"};
  const Scene s = MakeScene(f, TestSilo(), o);
  const auto same = [](const Rgb& a, const Rgb& b) { return a.r == b.r && a.g == b.g && a.b == b.b; };
  EXPECT_FALSE(same(s.discs[0].fill, s.discs[1].fill)) << "head and body apart";
  EXPECT_TRUE(same(s.discs[0].fill, s.discs[3].fill)) << "the heads alike, whatever their order in the body";
  EXPECT_TRUE(same(s.discs[1].fill, s.discs[2].fill));
  ASSERT_EQ(s.legend.size(), 2u);
  EXPECT_EQ(s.legend[0].label, "snowman: disc of D = 2 d");
  EXPECT_EQ(s.legend[1].label, "snowman: disc of D = 1 d");
  EXPECT_THROW(ColourFromName("mood"), std::invalid_argument);
}

// The dimension lines of kDiscs marks in an SVG: every third <line class="dimension"> is a
// line itself (the two after it are its end ticks), as {x1, y1, x2, y2} in pixels.
std::vector<std::array<double, 4>> DimensionLines(const std::string& svg) {
  const std::regex re(
      "<line class=\"dimension\" x1=\"([-0-9.]+)\" y1=\"([-0-9.]+)\" x2=\"([-0-9.]+)\" y2=\"([-0-9.]+)\"");
  std::vector<std::array<double, 4>> out;
  int k = 0;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator(); ++it, ++k)
    if (k % 3 == 0) out.push_back({std::stod((*it)[1]), std::stod((*it)[2]), std::stod((*it)[3]), std::stod((*it)[4])});
  return out;
}

// A snowman's two diameters measured on the body nearest the mark's point: one line across each
// disc, through its centre and across the body's axis, as long as the disc is wide at the
// picture's scale, labelled D_s and D_b with their values, each label beyond its own disc.
TEST(Render, DiscDiametersMeasureTheBodyNearestThePoint) {
  rundir::Frame f;
  // Body 0: a snowman tilted 30 degrees, head (r = 0.5) at (0, 2), body (r = 1) 1.5 d away along
  // the axis; body 1: a snowman farther from the point, the lines must not be on it.
  const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
  f.discs = {{1, 0, 1, 0.0, 2.0, 0.5, 0.785, 0, 0, 0},
             {2, 0, 1, 1.5 * c, 2.0 + 1.5 * s, 1.0, 3.14, 0, 0, 0},
             {3, 1, 1, -4.0, 5.0, 1.0, 3.14, 0, 0, 0},
             {4, 1, 1, -2.5, 5.0, 0.5, 0.785, 0, 0, 0}};
  SceneOptions o;
  o.window = {-6, 6, -3, 7};  // 12 d wide
  Mark discs{Mark::Kind::kDiscs, 0.5, 2.0, 0.0, 0.0, ""};
  discs.labels = {"D_s", "D_b"};
  o.marks = {discs};
  const std::string svg = Svg(MakeScene(f, TestSilo(), o), 1200);  // 100 px per d
  const auto circles = Circles(svg, "disc");
  ASSERT_EQ(circles.size(), 4u);
  const auto lines = DimensionLines(svg);
  ASSERT_EQ(lines.size(), 2u) << svg;
  const double diameter[] = {1.0, 2.0};
  for (std::size_t k = 0; k < 2; ++k) {
    const auto& l = lines[k];
    EXPECT_NEAR(std::hypot(l[2] - l[0], l[3] - l[1]), diameter[k] * 100, 0.02) << "line " << k << " to scale";
    EXPECT_NEAR(0.5 * (l[0] + l[2]), circles[k][0], 0.02) << "through disc " << k << "'s centre";
    EXPECT_NEAR(0.5 * (l[1] + l[3]), circles[k][1], 0.02);
    // Across the axis (c, s) (pixels: y down): no component along it.
    EXPECT_NEAR((l[2] - l[0]) * c - (l[3] - l[1]) * s, 0.0, 0.02) << "line " << k << " across the axis";
  }
  std::smatch m;
  ASSERT_TRUE(std::regex_search(svg, m,
                                std::regex("x=\"([-0-9.]+)\" y=\"[-0-9.]+\" font-size=\"[-0-9.]+\" "
                                           "text-anchor=\"middle\">D_s = 1 d</text>")))
      << svg;
  EXPECT_LT(std::stod(m[1]), circles[0][0] - 50) << "the head's label beyond the head, away from the body";
  ASSERT_TRUE(std::regex_search(svg, m,
                                std::regex("x=\"([-0-9.]+)\" y=\"[-0-9.]+\" font-size=\"[-0-9.]+\" "
                                           "text-anchor=\"middle\">D_b = 2 d</text>")))
      << svg;
  EXPECT_GT(std::stod(m[1]), circles[1][0] + 100) << "the body's label beyond the body";

  // Near body 1 instead: its lines; without labels, the snowman's own names.
  o.marks = {{Mark::Kind::kDiscs, -3.0, 5.0, 0.0, 0.0, ""}};
  const std::string other = Svg(MakeScene(f, TestSilo(), o), 1200);
  const auto other_lines = DimensionLines(other);
  ASSERT_EQ(other_lines.size(), 2u);
  EXPECT_NEAR(0.5 * (other_lines[0][0] + other_lines[0][2]), circles[3][0], 0.02) << "body 1's head";
  EXPECT_NEAR(std::hypot(other_lines[1][2] - other_lines[1][0], other_lines[1][3] - other_lines[1][1]), 200, 0.02);
  EXPECT_NE(other.find(">D_s = 1 d</text>"), std::string::npos);
  EXPECT_NE(other.find(">D_b = 2 d</text>"), std::string::npos);

  // A dumbbell has one size: one line, "D"; two labels for it are an error that says so.
  o.marks = {{Mark::Kind::kDiscs, -0.5, 0.5, 0.0, 0.0, ""}};
  const std::string dumbbell = Svg(MakeScene(TestFrame(), TestSilo(), o), 1200);
  ASSERT_EQ(DimensionLines(dumbbell).size(), 1u);
  EXPECT_NE(dumbbell.find(">D = 1 d</text>"), std::string::npos);
  o.marks = {discs};
  o.marks[0].x0 = -0.5;
  o.marks[0].y0 = 0.5;
  try {
    MakeScene(TestFrame(), TestSilo(), o);
    ADD_FAILURE() << "two labels for one disc size";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("has 1 disc size(s), but 2 label(s)"), std::string::npos) << e.what();
  }
  EXPECT_THROW(MakeScene(rundir::Frame{}, TestSilo(), o), std::invalid_argument) << "no body to measure";
}

// The origin: a dot where (x0, y0) is, with x and y arrows and its label.
TEST(Render, OriginMarkSitsAtItsPoint) {
  SceneOptions o;
  o.window = {-6, 6, -3, 7};
  o.marks = {{Mark::Kind::kOrigin, 0.0, 0.0, 0.0, 0.0, "(0, 0)"}};
  const std::string svg = Svg(MakeScene(TestFrame(), TestSilo(), o), 1200);
  const double header = Circles(svg, "obstacle").at(0)[1] - (7 - 4) * 100;
  const auto dot = Circles(svg, "origin");
  ASSERT_EQ(dot.size(), 1u) << svg;
  EXPECT_NEAR(dot[0][0], 6 * 100, 0.01);
  EXPECT_NEAR(dot[0][1], header + 7 * 100, 0.01);
  EXPECT_NE(svg.find(">(0, 0)</text>"), std::string::npos);
  EXPECT_NE(svg.find(">x</text>"), std::string::npos);
  EXPECT_NE(svg.find(">y</text>"), std::string::npos);
}

// ---- the verbs on a real run -------------------------------------------------------------

struct Outcome {
  int code;
  std::string output;
};
Outcome Campaign(const std::vector<std::string>& args) {
  bp::ipstream out;
  bp::child c(GRANARY_CAMPAIGN_EXE, args, (bp::std_out & bp::std_err) > out);
  Outcome o{0, ""};
  for (std::string line; std::getline(out, line);) o.output += line + "\n";
  c.wait();
  o.code = c.exit_code();
  return o;
}

fs::path EngineRun(const std::string& name, double outlet) {
  const fs::path dir = fs::path(GRANARY_RENDER_TEST_TMP) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  const nlohmann::json spec = {
      {"run_id", name},
      {"seed", 3},
      {"silo", {{"width", 10}, {"base_outlets", {{{"center", 0}, {"width", outlet}}}}}},
      {"bodies", {{"count", 50}, {"species", {{{"shape", "dumbbell"}}}}}},
      {"bed",
       {{"settle_ke_per_body", 1e-4},
        {"max_settle_time", 10},
        {"cache_file", (dir.parent_path() / "bed.json").string()}}},
      {"discharge", {{"mode", "remove"}, {"max_time", 3}, {"clog_window", 1}}},
      {"output", {{"frame_interval", 0.25}, {"contact_forces", true}, {"checkpoint_interval", 0}}}};
  std::ofstream(dir / "run.json") << spec.dump(2);
  bp::ipstream out;
  bp::child c(GRANARY_ENGINE_EXE, "run", dir.string(), (bp::std_out & bp::std_err) > out);
  for (std::string line; std::getline(out, line);) {
  }
  c.wait();
  EXPECT_EQ(c.exit_code(), 0);
  return dir;
}

TEST(RenderVerbs, SnapshotAndMovieOfARun) {
  const fs::path run = EngineRun("flowing", 4);
  const fs::path tmp = run.parent_path();
  Outcome o = Campaign({"snapshot", run.string(), "--first", "--out", (tmp / "first.png").string()});
  ASSERT_EQ(o.code, 0) << o.output;
  EXPECT_NE(o.output.find("t = 0 "), std::string::npos) << o.output;
  o = Campaign(
      {"snapshot", run.string(), "--time", "1.1", "--color", "force", "--forces", "--out", (tmp / "t1.svg").string()});
  ASSERT_EQ(o.code, 0) << o.output;
  EXPECT_NE(o.output.find("t = 1 "), std::string::npos) << "nearest frame to 1.1: " << o.output;
  std::ifstream in(tmp / "t1.svg");
  const std::string svg((std::istreambuf_iterator<char>(in)), {});
  EXPECT_GT(Circles(svg, "disc").size(), 50u);
  EXPECT_NE(svg.find("class=\"force\""), std::string::npos);
  // Usage and what the run cannot give.
  EXPECT_EQ(Campaign({"snapshot", run.string(), "--out", (tmp / "x.jpg").string()}).code, 2);
  EXPECT_EQ(Campaign({"snapshot", run.string(), "--time", "1", "--last", "--out", (tmp / "x.png").string()}).code, 2);
  EXPECT_EQ(Campaign({"snapshot", run.string(), "--color", "mood", "--out", (tmp / "x.png").string()}).code, 2);
  o = Campaign({"snapshot", run.string(), "--clog", "9", "--out", (tmp / "x.png").string()});
  EXPECT_EQ(o.code, 1);
  EXPECT_NE(o.output.find("not a clog 9"), std::string::npos) << o.output;

  // A movie of every frame: t = 0, 0.25, ..., 3 unless the run ended earlier.
  int frames = 0;
  {
    rundir::FrameReader r(run / "frames.dump");
    for (rundir::Frame f; r.Next(f);) ++frames;
  }
  ASSERT_GE(frames, 5);
  o = Campaign({"movie", run.string(), "--out", (tmp / "run.mp4").string(), "--fps", "10", "--width", "320"});
  ASSERT_EQ(o.code, 0) << o.output;
  bp::ipstream probe;
  bp::child c(bp::search_path("ffprobe"), "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
              "stream=nb_read_frames,width", "-of", "default=noprint_wrappers=1", (tmp / "run.mp4").string(),
              bp::std_out > probe);
  std::string all;
  for (std::string line; std::getline(probe, line);) all += line + "\n";
  c.wait();
  EXPECT_NE(all.find("nb_read_frames=" + std::to_string(frames) + "\n"), std::string::npos) << all;
  EXPECT_NE(all.find("width=320\n"), std::string::npos) << all;
}

TEST(RenderVerbs, TheClogOfARunThatClogged) {
  const fs::path run = EngineRun("clogged", 1.5);
  const nlohmann::json summary = nlohmann::json::parse(std::ifstream(run / "summary.json"));
  ASSERT_EQ(summary["end_reason"], "clogged");
  const Outcome o =
      Campaign({"snapshot", run.string(), "--clog", "1", "--out", (run.parent_path() / "clog.png").string()});
  ASSERT_EQ(o.code, 0) << o.output;
  char t[32];
  std::snprintf(t, sizeof t, "t = %.4g ", summary["t_end"].get<double>());
  EXPECT_NE(o.output.find(t), std::string::npos) << "the last frame of a run that ended clogged: " << o.output;
}

// What the report's arches section asks for: the clog the engine kept, in a window around its
// arch, the arch's bodies outlined and nothing else; no frames.dump needed.
TEST(RenderVerbs, AKeptClogInAWindowWithItsArchOutlined) {
  const fs::path run = EngineRun("arch", 1.5);
  const std::vector<rundir::ClogState> clogs = rundir::ReadClogs(run);
  ASSERT_GE(clogs.size(), 1u);
  const nlohmann::json spec = nlohmann::json::parse(std::ifstream(run / "run.json"));
  const analysis::ClogArches arches = analysis::AnalyseClog(clogs[0], spec);
  ASSERT_EQ(arches.arches.size(), 1u);
  PictureOptions o;
  std::size_t arch_discs = 0;
  for (const analysis::ArchBody& b : arches.arches[0].bodies) {
    o.highlight.insert(b.id);
    arch_discs += static_cast<std::size_t>(b.discs);
  }
  fs::remove(run / "frames.dump");
  const Scene scene = ClogScene(run, 1, o, Window{-4, 4, -1, 6});
  EXPECT_EQ(scene.window.x_lo, -4);
  EXPECT_EQ(scene.window.y_hi, 6);
  EXPECT_NE(scene.caption.find("clog 1"), std::string::npos) << scene.caption;
  std::size_t outlined = 0;
  for (const DiscShape& d : scene.discs) outlined += d.highlight;
  EXPECT_EQ(outlined, arch_discs);
  EXPECT_EQ(scene.discs.size(), clogs[0].frame.discs.size());
  EXPECT_THROW(ClogScene(run, 2, o), std::runtime_error);
}

}  // namespace
}  // namespace granary::render
