// The estimate end to end with the real `campaign` and `granary-engine`: the estimate of tiny
// campaigns of each shape and mode against what their runs measure (wall time within a
// factor of 2, disk within 20 %), and a raised max_time that continues finished runs from
// their checkpoints with the same bits as runs planned with the new limit from the start.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "test_util.h"

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::ReadFile;
using testing::Sh;

class CostTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir();
    setenv("GRANARY_CACHE_DIR", (dir_ / "beds").c_str(), 1);
    engine_ = testing::BinDir() + "/granary-engine";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Cmd(const std::string& db, const std::string& verb_and_flags) const {
    return testing::Campaign() + " " + verb_and_flags + " --db " + (dir_ / db).string();
  }
  std::string Write(const std::string& name, const json& spec) const {
    const fs::path p = dir_ / (name + ".json");
    std::ofstream(p) << spec.dump(2);
    return p.string();
  }
  static std::uintmax_t Bytes(const fs::path& dir) {
    std::uintmax_t n = 0;
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.is_regular_file()) n += e.file_size();
    return n;
  }
  fs::path dir_;
  std::string engine_;
};

// `command` with its stderr dropped (Sh adds 2>&1 after it): JSON on stdout alone.
std::string Quiet(const std::string& command) {
  std::string q = "(";
  q += command;
  q += " 2>/dev/null)";
  return q;
}

double ChildrenCpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_CHILDREN, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

json Tiny(const std::string& name, const json& species, const std::string& mode, double max_time, const json& output) {
  json base = {{"bodies", {{"count", 250}, {"species", species}}},
               {"silo", {{"width", 24}, {"base_outlets", {{{"width", 8}}}}}},
               {"discharge", {{"mode", mode}, {"max_time", max_time}, {"stop_on_clog", mode == "remove"}}},
               {"output", output}};
  return {{"name", name}, {"seed", 3}, {"replicas", 2}, {"base", base}};
}

// Estimate before, measure after: every shape (lone discs, dumbbells, the ch. 4 mixture) and
// both modes, plain, compressed and with contact frames.
TEST_F(CostTest, EstimatesMatchWhatTinyCampaignsOfEachShapeAndModeTake) {
  if (!fs::exists(engine_)) GTEST_SKIP() << "granary-engine not built";
  const json disc = json::array({{{"shape", "disc"}}});
  const json dumbbell = json::array({{{"shape", "dumbbell"}}});
  const json mixture = json::array(
      {{{"shape", "dumbbell"}, {"fraction", 0.5}}, {{"shape", "disc"}, {"diameter", 1.414214}, {"fraction", 0.5}}});
  const std::vector<json> specs = {
      Tiny("discs", disc, "reinject", 8, {{"frame_interval", 0.25}}),
      Tiny("dumbbells", dumbbell, "reinject", 6, {{"frame_interval", 0.25}, {"contact_forces", true}}),
      Tiny("mixture", mixture, "reinject", 6, {{"frame_interval", 0.25}, {"compress", true}, {"contact_forces", true}}),
      Tiny("remove", dumbbell, "remove", 60, {{"frame_interval", 0.5}}),
      // output.format "gsd": the estimator counts GSD's bytes, contact frames every 2nd frame.
      Tiny("gsd", mixture, "reinject", 6,
           {{"frame_interval", 0.25}, {"format", "gsd"}, {"contact_forces", true}, {"contact_interval", 2}})};
  for (const json& spec : specs) {
    const std::string name = spec["name"];
    const std::string db = name + ".db";
    const auto plan = Sh(Quiet(Cmd(db, "plan " + Write(name, spec) + " --jobs 1 --json")));
    ASSERT_EQ(plan.code, 0) << plan.output;
    const json e = json::parse(plan.output)["estimate"];
    ASSERT_TRUE(e["wall_s"].is_array()) << name << ": no calibration: " << e.dump();
    const auto start = std::chrono::steady_clock::now();
    const double cpu0 = ChildrenCpuSeconds();
    const auto run = Sh(Cmd(db, "run --jobs 1"));
    // The CPU time of the runner and its engines: the wall time of one run at a time on a core
    // of its own, which a machine shared with other work (this one's tests) does not give.
    const double cpu = ChildrenCpuSeconds() - cpu0;
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_EQ(run.code, 0) << run.output;
    const double bytes = static_cast<double>(Bytes(dir_ / "runs"));
    const double wall_low = e["wall_s"][0], wall_high = e["wall_s"][1];
    const double bytes_low = e["bytes"][0], bytes_high = e["bytes"][1];
    // A remove run ends at a clog or when the silo has discharged: the measure lies in the range.
    EXPECT_GE(cpu, 0.5 * wall_low) << name << ": took " << cpu << " CPU s, estimated " << e.dump();
    EXPECT_LE(cpu, 2.0 * wall_high) << name << ": took " << cpu << " CPU s, estimated " << e.dump();
    EXPECT_GE(wall, 0.5 * wall_low) << name << ": took " << wall << " s, estimated " << e.dump();
    EXPECT_GE(bytes, 0.8 * bytes_low) << name << ": wrote " << bytes << " bytes, estimated " << e.dump();
    EXPECT_LE(bytes, 1.2 * bytes_high) << name << ": wrote " << bytes << " bytes, estimated " << e.dump();
    if (spec["base"]["discharge"]["mode"] == "reinject") {
      // Its end is known: one figure, within a factor of 2 (time) and 20 % (disk) of the measure.
      EXPECT_EQ(wall_low, wall_high) << name;
      EXPECT_EQ(bytes_low, bytes_high) << name;
      EXPECT_LE(std::fabs(bytes_high - bytes), 0.2 * bytes)
          << name << ": wrote " << bytes << " bytes, estimated " << e.dump();
    }
    std::printf("%s: CPU %.2f s, wall %.2f s (estimated %.2f-%.2f), disk %.0f bytes (estimated %.0f-%.0f)\n",
                name.c_str(), cpu, wall, wall_low, wall_high, bytes, bytes_low, bytes_high);
    // Status after the runs: nothing left, the estimate scaled from them.
    const json status = json::parse(Sh(Quiet(Cmd(db, "status --json"))).output);
    EXPECT_EQ(status["remaining_core_hours"], 0.0) << status.dump();
    fs::remove_all(dir_ / "runs");
  }
}

// The files a continued run must reproduce byte for byte.
const char* const kOutputs[] = {"events.csv", "frames.dump", "contacts.dump", "clog_frames.dump", "clog_contacts.dump"};

TEST_F(CostTest, ARaisedMaxTimeContinuesEachRunWithTheBitsOfARunPlannedWithIt) {
  if (!fs::exists(engine_)) GTEST_SKIP() << "granary-engine not built";
  json spec = Tiny("extend", json::array({{{"shape", "dumbbell"}}}), "reinject", 2.0,
                   {{"frame_interval", 0.25}, {"contact_forces", true}, {"checkpoint_interval", 1.0}});
  spec["base"]["bodies"]["count"] = 150;
  spec["base"]["silo"]["base_outlets"][0]["width"] = 4;  // clogs on the way: clog files too
  ASSERT_EQ(Sh(Cmd("a.db", "plan " + Write("short", spec))).code, 0);
  auto r = Sh(Cmd("a.db", "run --jobs 2"));
  ASSERT_EQ(r.code, 0) << r.output;
  const json before = json::parse(Sh(Quiet(Cmd("a.db", "status --json"))).output);
  ASSERT_EQ(before["counts"]["done"], 2);

  // 2 -> 3.5: past the last checkpoint (2) and not on one.
  spec["base"]["discharge"]["max_time"] = 3.5;
  const std::string longer = Write("long", spec);
  r = Sh(Cmd("a.db", "plan " + longer + " --dry-run"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("would extend 2 run(s)"), std::string::npos) << r.output;
  r = Sh(Quiet(Cmd("a.db", "plan " + longer + " --json")));
  ASSERT_EQ(r.code, 0) << r.output;
  const json plan = json::parse(r.output);
  ASSERT_EQ(plan["extended"].size(), 2u) << plan.dump();
  r = Sh(Cmd("a.db", "run --jobs 2"));
  ASSERT_EQ(r.code, 0) << r.output;
  const json after = json::parse(Sh(Quiet(Cmd("a.db", "status --json"))).output);
  EXPECT_EQ(after["counts"]["done"], 2);
  EXPECT_EQ(after["retired"], 2);

  // The same campaign planned with 3.5 from the start, in another database.
  ASSERT_EQ(Sh(Cmd("b.db", "plan " + longer)).code, 0);
  r = Sh(Cmd("b.db", "run --jobs 2"));
  ASSERT_EQ(r.code, 0) << r.output;
  const json fresh = json::parse(Sh(Quiet(Cmd("b.db", "status --json"))).output);
  std::map<std::string, std::string> fresh_dirs;
  for (const auto& run : fresh["runs"]) fresh_dirs[run["run_id"]] = run["run_dir"];
  int compared = 0;
  for (const auto& run : after["runs"]) {
    if (run["state"] != "done") continue;
    const fs::path extended = run["run_dir"].get<std::string>();
    ASSERT_TRUE(fresh_dirs.count(run["run_id"])) << "same run ids in both databases";
    const fs::path from_start = fresh_dirs[run["run_id"]];
    const json summary = json::parse(ReadFile(extended / "summary.json"));
    EXPECT_TRUE(summary["continued_from_checkpoint"].get<bool>());
    EXPECT_TRUE(summary.contains("extended_from")) << summary.dump();
    EXPECT_DOUBLE_EQ(summary["t_end"].get<double>(), 3.5);
    for (const char* file : kOutputs) {
      EXPECT_EQ(ReadFile(extended / file), ReadFile(from_start / file)) << file << " of " << run["run_id"];
    }
    EXPECT_FALSE(ReadFile(extended / "frames.dump").empty());
    ++compared;
  }
  EXPECT_EQ(compared, 2);

  // Any other change is another run: retired, not extended.
  spec["base"]["discharge"]["max_time"] = 5.0;
  spec["base"]["contact"] = {{"mu", 0.4}};
  r = Sh(Quiet(Cmd("a.db", "plan " + Write("other", spec) + " --json")));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(json::parse(r.output)["extended"].empty()) << r.output;
  EXPECT_EQ(json::parse(r.output)["retired"], 2);
}

// campaign clean --frames on a tiny campaign of the real engine (GSD frames): after a report
// has cached the analyses, the frames go, the manifests say so, the report gives the same
// numbers from the cache, the runs stay whole; an analysis that must read the frames anew
// fails that run with a sentence that says why.
TEST_F(CostTest, CleanFramesDropsAnalysedFramesAndTheReportKeepsItsNumbers) {
  if (!fs::exists(engine_)) GTEST_SKIP() << "granary-engine not built";
#ifndef GRANARY_HAVE_ANALYSIS
  GTEST_SKIP() << "built without the analyses";
#else
  json spec = Tiny("clean", json::array({{{"shape", "dumbbell"}}}), "reinject", 3,
                   {{"frame_interval", 0.25}, {"format", "gsd"}, {"contact_forces", true}});
  spec["base"]["bodies"]["count"] = 120;
  ASSERT_EQ(Sh(Cmd("c.db", "plan " + Write("clean", spec))).code, 0);
  auto r = Sh(Cmd("c.db", "run --jobs 2"));
  ASSERT_EQ(r.code, 0) << r.output;
  const json status = json::parse(Sh(Quiet(Cmd("c.db", "status --json"))).output);
  std::vector<fs::path> dirs;
  for (const auto& run : status["runs"]) dirs.push_back(run["run_dir"].get<std::string>());
  ASSERT_EQ(dirs.size(), 2u);
  for (const fs::path& d : dirs) ASSERT_TRUE(fs::exists(d / "frames.gsd") && fs::exists(d / "contacts.gsd")) << d;

  // Before any report nothing is cached: --frames keeps every run's frames and says why.
  r = Sh(Quiet(Cmd("c.db", "clean --frames --dry-run --json")));
  ASSERT_EQ(r.code, 0) << r.output;
  json j = json::parse(r.output);
  EXPECT_TRUE(j["items"].empty()) << j.dump();
  ASSERT_EQ(j["frames_kept"].size(), 2u) << j.dump();
  EXPECT_NE(j["frames_kept"][0].get<std::string>().find("no analysis of it is cached yet"), std::string::npos);

  r = Sh(Quiet(Cmd("c.db", "export --format json")));
  ASSERT_EQ(r.code, 0) << r.output;
  const json before = json::parse(r.output);
  // The dry run lists the frames files, removes nothing.
  r = Sh(Quiet(Cmd("c.db", "clean --frames --dry-run --json")));
  j = json::parse(r.output);
  EXPECT_TRUE(j["dry_run"].get<bool>());
  std::uintmax_t listed = 0;
  for (const auto& it : j["items"]) {
    EXPECT_EQ(it["kind"], "frames");
    EXPECT_TRUE(fs::exists(it["path"].get<std::string>()));
    listed += it["bytes"].get<std::uintmax_t>();
  }
  EXPECT_EQ(j["items"].size(), 4u) << j.dump();  // frames.gsd and contacts.gsd of each run
  r = Sh(Cmd("c.db", "clean --frames"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("frames of analysed runs"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no longer computable for them"), std::string::npos) << r.output;
  for (const fs::path& d : dirs) {
    EXPECT_FALSE(fs::exists(d / "frames.gsd"));
    EXPECT_FALSE(fs::exists(d / "contacts.gsd"));
    const json m = json::parse(ReadFile(d / "manifest.json"));
    EXPECT_TRUE(m["dropped"].contains("frames.gsd")) << m.dump();
    EXPECT_EQ(m["dropped"]["frames.gsd"]["by"], "campaign clean --frames");
    EXPECT_FALSE(m["files"].contains("frames.gsd"));
  }
  // Whole, and the same numbers from the cache.
  r = Sh(Cmd("c.db", "scan --verify"));
  EXPECT_NE(r.output.find("2 whole, 0 damaged"), std::string::npos) << r.output;
  r = Sh(Quiet(Cmd("c.db", "export --format json")));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(json::parse(r.output), before);

  // A cached result gone (as after a new analysis version): that run cannot be analysed anew.
  for (const auto& e : fs::directory_iterator(dirs[0] / "analyses"))
    if (e.path().filename() != "verified.json") fs::remove(e.path());
  r = Sh(Cmd("c.db", "report --no-figures --out " + (dir_ / "rep").string()));
  EXPECT_NE(r.output.find("was removed by campaign clean --frames"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("run the run again"), std::string::npos) << r.output;
#endif
}

// The bed the engine measured is in summary.json and in `campaign show`.
TEST_F(CostTest, TheBedsPackingFractionHeightAndSettlingTimeAreRecordedAndShown) {
  if (!fs::exists(engine_)) GTEST_SKIP() << "granary-engine not built";
  json spec = Tiny("bed", json::array({{{"shape", "disc"}}}), "reinject", 0.5, json::object());
  spec["replicas"] = 1;
  spec["base"]["bodies"]["count"] = 600;  // about 35 d high: a band of 25 d to measure phi in
  spec["base"]["silo"] = {{"width", 16}, {"base_outlets", {{{"width", 6}}}}};
  ASSERT_EQ(Sh(Cmd("c.db", "plan " + Write("bed", spec))).code, 0);
  ASSERT_EQ(Sh(Cmd("c.db", "run")).code, 0);
  const json status = json::parse(Sh(Quiet(Cmd("c.db", "status --json"))).output);
  const std::string id = status["runs"][0]["run_id"];
  const json summary =
      json::parse(ReadFile(fs::path(status["runs"][0]["run_dir"].get<std::string>()) / "summary.json"));
  const double phi = summary["bed"]["packing_fraction"];
  // Monodisperse discs settle into a packing near the hexagonal one (0.907) with defects.
  EXPECT_GT(phi, 0.75);
  EXPECT_LT(phi, 0.91);
  EXPECT_GT(summary["bed"]["surface"].get<double>(), 0.8 * 600 * 0.785 / 16);
  EXPECT_LE(summary["bed"]["surface"].get<double>(), summary["bed"]["height"].get<double>());
  const auto show = Sh(Cmd("c.db", "show " + id));
  ASSERT_EQ(show.code, 0) << show.output;
  const auto at = show.output.find("packing fraction ");
  ASSERT_NE(at, std::string::npos) << show.output;
  EXPECT_NEAR(std::stod(show.output.substr(at + 17)), phi, 1e-3) << show.output;
  EXPECT_NE(show.output.find("settled in"), std::string::npos) << show.output;
}

}  // namespace
}  // namespace granary::runner
