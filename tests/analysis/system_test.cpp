// "The system": human names of sweep axes, the fixed-parameter table, and the report section
// that opens the report (description, both tables, a bed and an end picture per point).
#include "analysis/system.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "analysis/report.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using nlohmann::json;
using testing::ReadFile;
using testing::TempDir;
using testing::WriteFile;

json MixtureSpec() {
  return {{"engine", "native"},
          {"time_step", 1e-4},
          {"gravity", 1.0},
          {"silo",
           {{"width", 100},
            {"height", 0},
            {"base_outlets", {{{"center", -20}, {"width", 8}}, {{"center", 20}, {"width", 10}}}},
            {"side_outlets", json::array()},
            {"obstacles", {{{"x", 0}, {"y", 10}, {"diameter", 6}}}}}},
          {"bodies",
           {{"count", 15000},
            {"density", 1.0},
            {"species",
             {{{"name", "dumbbell"}, {"shape", "dumbbell"}, {"fraction", 0.5}, {"diameter", 1.0}},
              {{"name", "disc"}, {"shape", "disc"}, {"fraction", 0.5}, {"diameter", 1.414214}}}}}},
          {"contact",
           {{"kn", 2e6},
            {"kt", 2.45e6},
            {"gamma_n", 1000},
            {"gamma_t", 1000},
            {"mu", 0.5},
            {"mu_wall", 0.5},
            {"tangential_cap", "lammps"},
            {"clip_normal", false}}},
          {"discharge",
           {{"mode", "reinject"},
            {"max_time", 200},
            {"stop_on_clog", false},
            {"clog_window", 5},
            {"clog_ke_per_body", 1e-4},
            {"exit_distance", 2}}},
          {"output", {{"frame_interval", 0.5}}}};
}

TEST(System, AxisNamesAreTheThesisNames) {
  const json two_outlets = MixtureSpec();
  json one_outlet = MixtureSpec();
  one_outlet["silo"]["base_outlets"] = {{{"center", 0}, {"width", 8}}};
  EXPECT_EQ(AxisName("/silo/base_outlets/0/width", one_outlet), "outlet width W");
  EXPECT_EQ(AxisName("/silo/base_outlets/1/width", two_outlets), "width W_2 of outlet 2");
  EXPECT_EQ(AxisName("/silo/base_outlets/0/center", two_outlets), "position x_1 of outlet 1");
  EXPECT_EQ(AxisName("/bodies/species/0/fraction", two_outlets), "dumbbell fraction X_db");
  EXPECT_EQ(AxisName("/bodies/species/1/fraction", two_outlets), "disc fraction X_d");
  EXPECT_EQ(AxisName("/silo/obstacles/0/y", two_outlets), "obstacle height h");
  EXPECT_EQ(AxisName("/bodies/species/0/big_diameter", two_outlets), "dumbbell big-disc diameter D_b");
  EXPECT_EQ(AxisName("engine", two_outlets), "engine");
  EXPECT_EQ(AxisName("/bed/batch_size", two_outlets), "/bed/batch_size") << "unknown: the pointer itself";
}

TEST(System, AxesHaveShortNamesForTablesAndKeys) {
  const json two_outlets = MixtureSpec();
  json one_species = MixtureSpec();
  one_species["bodies"]["species"] = {{{"shape", "disc"}, {"fraction", 1.0}}};
  const auto symbol = [](const std::string& pointer, const json& spec) {
    return ResolveAxisNames(pointer, spec).symbol;
  };
  EXPECT_EQ(symbol("/silo/base_outlets/1/width", two_outlets), "W_2");
  EXPECT_EQ(symbol("/bodies/species/0/fraction", two_outlets), "X_db");
  EXPECT_EQ(symbol("/bodies/species/1/fraction", two_outlets), "X_d");
  EXPECT_EQ(symbol("/bodies/count", two_outlets), "N");
  EXPECT_EQ(symbol("/contact/mu", two_outlets), "mu");
  EXPECT_EQ(symbol("engine", two_outlets), "engine");
  EXPECT_EQ(ResolveAxisNames("/contact/mu", two_outlets).name, "friction mu") << "the long name ends in the symbol";
  // The shape: of the body when there is one species, of a named species otherwise; its
  // values (disc, dumbbell, ...) are words, so the short name is a word too.
  EXPECT_EQ(AxisName("/bodies/species/0/shape", one_species), "body shape");
  EXPECT_EQ(AxisName("/bodies/species/1/shape", two_outlets), "shape of disc");
  EXPECT_EQ(symbol("/bodies/species/0/shape", one_species), "shape");
  // A species without a name: numbered, not "X_species 0".
  json unnamed = one_species;
  unnamed["bodies"]["species"][0].erase("shape");
  EXPECT_EQ(AxisName("/bodies/species/0/fraction", unnamed), "species 0 fraction X_0");
  EXPECT_EQ(symbol("/bodies/species/0/fraction", unnamed), "X_0");
}

TEST(System, FixedParametersSayWhatIsSweptAndDescribeTheBodies) {
  const Table t = FixedParameters(MixtureSpec(), {"/silo/base_outlets/0/width", "/bodies/species/0/fraction"});
  std::map<std::string, std::string> value;
  for (const auto& row : t.rows) {
    ASSERT_EQ(row.size(), 3u);
    value[row[1].Shown()] = row[2].Shown();
  }
  EXPECT_EQ(value.at("width L"), "100");
  EXPECT_EQ(value.at("height"), "as tall as the bed needs");
  EXPECT_EQ(value.at("base outlet 1: width W"), "swept (below)");
  EXPECT_EQ(value.at("base outlet 2: width W"), "10");
  EXPECT_EQ(value.at("obstacle: diameter D_o"), "6");
  EXPECT_EQ(value.at("species 1 \"dumbbell\""), "dumbbell: two touching discs of diameter 1");
  EXPECT_EQ(value.at("species 2 \"disc\""), "disc of diameter 1.414214");
  EXPECT_EQ(value.at("species 1 number fraction X_db"), "swept (below)");
  EXPECT_EQ(value.at("species 2 number fraction X_d"), "0.5");
  EXPECT_EQ(value.at("number N"), "15000");
  EXPECT_EQ(value.at("stiffness K_n, K_t"), "2000000, 2450000");
  EXPECT_EQ(value.at("time step dt"), "0.0001");
  EXPECT_NE(value.at("mode").find("reinject"), std::string::npos);
  EXPECT_EQ(value.at("on a clog"), "runs on (intermittent flow)");
  EXPECT_EQ(value.at("stops at time"), "200");
}

// The unclog protocol in words, with remove_arch's fallback only when the run had one.
TEST(System, TheUnclogProtocolSaysWhenRemoveArchFallsBackOnAKick) {
  json spec = MixtureSpec();
  spec["discharge"]["on_clog"] = "unclog";
  spec["discharge"]["unclog"] = {
      {"method", "remove_arch"}, {"max_clogs", 100}, {"max_attempts", 10}, {"kick_speed", 1.5}, {"kick_radius", 0.0}};
  auto on_a_clog = [](const json& s) {
    for (const auto& row : FixedParameters(s, {}).rows)
      if (row[1].Shown() == "on a clog") return row[2].Shown();
    return std::string("(no row)");
  };
  EXPECT_EQ(on_a_clog(spec), "unclogs: takes out the arch's bodies (up to 10 attempts) and goes on; ends at clog 100");
  spec["discharge"]["unclog"]["fallback"] = "kick";
  EXPECT_EQ(on_a_clog(spec),
            "unclogs: takes out the arch's bodies; kicks the bodies within W of the outlet upwards at 1.5 when it "
            "finds none (up to 10 attempts) and goes on; ends at clog 100");
}

// A finished run that clogged at t = 7.5 after one exit, written into `dir`.
RunRecord ClogRun(const std::filesystem::path& dir, const std::string& run_id, const std::string& point_id,
                  const std::string& engine, const json& point, const json& spec) {
  RunRecord r;
  r.run_id = run_id;
  r.point_id = point_id;
  r.state = "done";
  r.engine = engine;
  r.point = point;
  r.spec = spec;
  r.run_dir = dir / r.run_id;
  WriteFile(r.run_dir / "events.csv", "time,body,shape,mass,outlet\n1.0,3,disc,1.57,0\n");
  WriteFile(r.run_dir / "summary.json", json{{"engine", engine},
                                             {"run_id", r.run_id},
                                             {"end_reason", "clogged"},
                                             {"bodies", 15000},
                                             {"exited", 1},
                                             {"remaining", 14999},
                                             {"t_end", 7.5}}
                                            .dump());
  WriteFile(r.run_dir / "run.json", r.spec.dump());
  return r;
}

// The report opens with the system: description, the tables, and per point the pictures the
// draw_run hook made (a fake here; the real one is the renderer, tested in tests/render).
TEST(System, ResultsComeFirstThenTheSystemAndTheGalleryLast) {
  TempDir dir;
  CampaignInfo info;
  info.name = "mixtures";
  info.axes = {"/silo/base_outlets/0/width"};
  info.spec = {{"description", "Dumbbells and discs through two outlets."}};
  std::vector<RunRecord> runs;
  for (double w : {8.0, 12.0}) {
    json spec = MixtureSpec();
    spec["silo"]["base_outlets"][0]["width"] = w;
    const std::string n = std::to_string(static_cast<int>(w));
    runs.push_back(ClogRun(dir.Path(), "run" + n, "W" + n, "native", {{"/silo/base_outlets/0/width", w}}, spec));
  }
  ReportOptions opt;
  opt.out_dir = dir.Path() / "report";
  opt.figures = false;
  std::vector<std::string> drawn;
  opt.draw_run = [&](const std::filesystem::path& run_dir, const ReportOptions::RunPicture& picture,
                     const std::filesystem::path& png) {
    drawn.push_back(run_dir.filename().string() + (picture.kind == ReportOptions::Picture::kBed ? ":bed" : ":end"));
    std::ofstream(png) << "\x89PNG fake " << drawn.back();
    return std::string();
  };
  const ReportSummary s = WriteReport(info, runs, opt);
  EXPECT_EQ(drawn, (std::vector<std::string>{"run8:bed", "run8:end", "run12:bed", "run12:end"}));
  const std::string md = ReadFile(s.markdown), html = ReadFile(s.html);
  const auto system = md.find("## The system"), gallery = md.find("## Gallery"),
             first_other = md.find("## ", gallery + 5);
  ASSERT_NE(system, std::string::npos);
  EXPECT_LT(system, md.find("## Runs")) << "the system, then the runs";
  EXPECT_LT(md.find("## Flow rate"), system) << "results before the system";
  EXPECT_LT(md.find("## Per-run results"), gallery) << "the gallery of every point last";
  EXPECT_NE(md.find("Dumbbells and discs through two outlets."), std::string::npos);
  EXPECT_NE(md.find("| width W_1 of outlet 1 | W_1 | /silo/base_outlets/0/width | 8, 12 |"), std::string::npos)
      << "swept axes by their human names and the short ones tables use";
  EXPECT_NE(md.find("*width W_1 of outlet 1 = 8 (replica 0"), std::string::npos)
      << "pictures named by the human axis names";
  EXPECT_NE(md.find("![the bed before the outlets open (t = 0)](pictures/point-1-bed.png)"), std::string::npos);
  EXPECT_LT(md.find("clogged (t = 7.5)"), first_other);
  EXPECT_NE(html.find("data:image/png;base64,"), std::string::npos) << "pictures inside the self-contained html";
  EXPECT_NE(html.find("alt=\"clogged (t = 7.5)\""), std::string::npos);

  // Without the renderer: no pictures, and the section says so.
  opt.draw_run = nullptr;
  WriteReport(info, runs, opt);
  EXPECT_NE(ReadFile(s.markdown).find("(No pictures"), std::string::npos);
}

// A campaign on two engines shows each point twice in "The system": each caption names its
// engine, so the native and the LIGGGHTS pictures are told apart.
TEST(System, PicturesOfATwoEngineCampaignNameTheEngine) {
  TempDir dir;
  CampaignInfo info;
  info.name = "both";
  info.axes = {"/bodies/species/0/shape"};
  std::vector<RunRecord> runs;
  for (const std::string engine : {"native", "liggghts"}) {
    json spec = MixtureSpec();
    spec["engine"] = engine;
    spec["bodies"]["species"] = {{{"shape", "disc"}, {"fraction", 1.0}}};
    runs.push_back(ClogRun(dir.Path(), "run-" + engine, "P-" + engine, engine,
                           {{"/bodies/species/0/shape", "disc"}, {"/engine", engine}}, spec));
  }
  ReportOptions opt;
  opt.out_dir = dir.Path() / "report";
  opt.figures = false;
  opt.draw_run = [&](const std::filesystem::path&, const ReportOptions::RunPicture&, const std::filesystem::path& png) {
    std::ofstream(png) << "\x89PNG fake";
    return std::string();
  };
  const std::string md = ReadFile(WriteReport(info, runs, opt).markdown);
  EXPECT_NE(md.find("*body shape = disc, engine = native (replica 0"), std::string::npos) << md;
  EXPECT_NE(md.find("*body shape = disc, engine = liggghts (replica 0"), std::string::npos) << md;
  EXPECT_EQ(md.find("/bodies/species/0/shape ="), std::string::npos) << "the shape axis has a name";
  EXPECT_NE(md.find("| body shape | shape | /bodies/species/0/shape | disc |"), std::string::npos) << md;
  // Nor does the fixed-parameter table say "engine: native" for a campaign on both.
  EXPECT_NE(md.find("| integration | engine | swept (below) |"), std::string::npos) << md;
  EXPECT_NE(md.find("| engine | engine | /engine | liggghts, native |"), std::string::npos) << md;
}

}  // namespace
}  // namespace granary::analysis
