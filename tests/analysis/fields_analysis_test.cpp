// The fields analysis in the registry: its options (errors with the JSON path), the campaign
// spec it turns contact output on in, the per-run sums as JSON and their merging over
// replicas, and one pass over a constructed run (a lattice falling rigidly while the exit
// stream flows, then at rest while it is clogged): steady and split windows, region means,
// the series above the outlet, the force chains.
#include "analysis/fields_analysis.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include "analysis/figures.h"
#include "analysis/options.h"
#include "analysis/registry.h"
#include "analysis/run_pass.h"
#include "rundir/contacts.h"
#include "rundir/frames.h"
#include "rundir/run_directory.h"
#include "lattice_frame.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::TempDir;
using testing::WriteFile;

std::string ErrorOf(const nlohmann::json& fields) {
  try {
    SetupAnalyses({{"report", {{"fields", fields}}}});
  } catch (const OptionError& e) {
    return e.what();
  }
  return "";
}

bool HasFields(const AnalysisSetup& s) {
  for (const auto& a : s.analyses)
    if (a->Key() == "fields") return true;
  return false;
}

TEST(FieldsAnalysis, OffUnlessAskedFor) {
  EXPECT_FALSE(HasFields(SetupAnalyses(nlohmann::json::object())));
  EXPECT_FALSE(HasFields(SetupAnalyses({{"report", {{"fields", false}}}})));
  EXPECT_TRUE(HasFields(SetupAnalyses({{"report", {{"fields", true}}}})));
  EXPECT_TRUE(HasFields(SetupAnalyses({{"report", {{"fields", nlohmann::json::object()}}}})));
}

TEST(FieldsAnalysis, OptionErrorsNameTheJsonPathTheValueAndWhatIsAllowed) {
  EXPECT_NE(ErrorOf({{"maps", {"phi", "presure"}}}).find("/report/fields/maps/1"), std::string::npos);
  EXPECT_NE(ErrorOf({{"maps", {"phi", "presure"}}}).find("pressure"), std::string::npos);  // the allowed names
  EXPECT_NE(ErrorOf({{"colour", 1}}).find("/report/fields/colour"), std::string::npos);
  EXPECT_NE(ErrorOf({{"spacing", 5.0}}).find("/report/fields/spacing"), std::string::npos);
  EXPECT_NE(ErrorOf({{"frames", "sometimes"}}).find("/report/fields/frames"), std::string::npos);
  EXPECT_NE(ErrorOf({{"frames", {{"from", 5.0}, {"to", 2.0}}}}).find("/report/fields/frames/to"), std::string::npos);
  EXPECT_NE(ErrorOf({{"window", {1, 0, 0, 1}}}).find("/report/fields/window"), std::string::npos);
  EXPECT_NE(ErrorOf({{"cutoff", 0.5}}).find("(got 0.5)"), std::string::npos);
  EXPECT_NE(ErrorOf(3).find("/report/fields"), std::string::npos);
  EXPECT_EQ(ErrorOf({{"maps", {"phi", "kinetic_pressure"}}, {"frames", "split"}, {"spacing", 0.5}}), "");
}

TEST(FieldsAnalysis, StressMapsTurnContactOutputOnOrThePlanSaysWhy) {
  const nlohmann::json campaign = {{"base", {{"output", {{"frame_interval", 0.5}}}}}, {"report", {{"fields", true}}}};
  EXPECT_EQ(WithFieldsOutput(campaign)["base"]["output"]["contact_forces"], true);
  // Maps without stress and no force chains: the output stays as it was.
  nlohmann::json kinematic = campaign;
  kinematic["report"]["fields"] = {{"maps", {"phi", "speed"}}, {"force_chains", false}};
  EXPECT_FALSE(WithFieldsOutput(kinematic)["base"]["output"].contains("contact_forces"));
  // Turned off in the spec: an error at that path.
  nlohmann::json off = campaign;
  off["base"]["output"]["contact_forces"] = false;
  try {
    WithFieldsOutput(off);
    ADD_FAILURE() << "no error";
  } catch (const OptionError& e) {
    EXPECT_EQ(e.Path(), "/base/output/contact_forces");
  }
  // No frames at all.
  nlohmann::json no_frames = campaign;
  no_frames["base"].erase("output");
  try {
    WithFieldsOutput(no_frames);
    ADD_FAILURE() << "no error";
  } catch (const OptionError& e) {
    EXPECT_EQ(e.Path(), "/base/output/frame_interval");
  }
  // Without /report/fields nothing changes.
  EXPECT_EQ(WithFieldsOutput({{"base", nlohmann::json::object()}}),
            nlohmann::json({{"base", nlohmann::json::object()}}));
}

CgSums FilledSums(int ny, double value) {
  CgSums s;
  s.Resize({-2.0, 1.5, 1.0, 5, ny});
  s.frames = 2;
  s.contact_frames = 1;
  for (std::size_t n = 0; n < s.phi.size(); ++n) {
    s.phi[n] = value * static_cast<double>(n);
    s.syy[n] = -value;
    s.n_defined[n] = 2;
  }
  return s;
}

TEST(FieldsAnalysis, SumsRoundTripAndMergeOverTheRowsReplicasShare) {
  const CgSums a = FilledSums(4, 0.25);
  const CgSums back = SumsFromJson(nlohmann::json::parse(SumsToJson(a).dump()));
  EXPECT_EQ(back.grid, a.grid);
  EXPECT_EQ(back.phi, a.phi);
  EXPECT_EQ(back.syy, a.syy);
  EXPECT_EQ(back.n_defined, a.n_defined);
  EXPECT_EQ(back.contact_frames, 1);
  // A replica whose bed stood lower has fewer rows: the merge keeps the rows both have.
  CgSums merged = a;
  ASSERT_TRUE(AddCommonRows(merged, FilledSums(3, 1.0)));
  EXPECT_EQ(merged.grid.ny, 3);
  ASSERT_EQ(merged.phi.size(), 15u);
  for (std::size_t n = 0; n < 15; ++n) EXPECT_EQ(merged.phi[n], 1.25 * static_cast<double>(n));
  EXPECT_EQ(merged.frames, 4);
  // Different columns (another silo width): not mergeable.
  CgSums other = FilledSums(3, 1.0);
  other.grid.x0 = -3.0;
  EXPECT_FALSE(AddCommonRows(merged, other));
}

// A run: a lattice of discs (unit spacing, radius 0.5) over x in [-12, 12], y in [0.5, 20.5],
// falling rigidly at speed 1 while the exits flow (frames at t = 2.2, 2.3), at rest once
// clogged (t = 15), every frame with vertical chains carrying the weight above.
void WriteRun(const std::filesystem::path& dir) {
  rundir::WriteRunSpec(dir, {{"silo", {{"width", 25.0}, {"base_outlets", {{{"center", 0.0}, {"width", 4.0}}}}}},
                             {"bodies", {{"density", 1.0}, {"count", 525}}},
                             {"discharge", {{"mode", "reinject"}, {"clog_window", 3.0}}}});
  WriteFile(dir / "summary.json",
            R"({"bodies":525,"exited":12,"remaining":525,"t_end":20,"end_reason":"time_limit","clogs":1})");
  std::string events = "time,body,shape,mass,outlet\n";
  for (int k = 0; k < 12; ++k) events += std::to_string(2.0 + 0.05 * k) + "," + std::to_string(k) + ",disc,1,0\n";
  WriteFile(dir / "events.csv", events);
  auto frames = rundir::FrameWriter::Create(dir / rundir::kFramesFile);
  auto contacts = rundir::ContactWriter::Create(dir / rundir::kContactsFile);
  for (double t : {2.2, 2.3, 15.0}) {
    const auto [f, c] = testing::LatticeFrame(t, t < 10.0 ? -1.0 : 0.0);
    frames.Write(f);
    contacts.Write(c);
  }
  frames.Close();
  contacts.Close();
}

struct Pass {
  AnalysisSetup setup;
  nlohmann::json result;
  std::map<std::string, double> metrics;
};

Pass PassWith(const std::filesystem::path& dir, const nlohmann::json& fields) {
  Pass p;
  p.setup = SetupAnalyses(
      {{"report",
        {{"window", {{"start_time", 1.0}, {"min_events", 5}, {"min_exits_before_clog", 5}}}, {"fields", fields}}}});
  RunPassOptions o;
  o.read_cache = o.write_cache = false;
  const RunPassResult r = AnalyseRun(dir, p.setup.List(), p.setup.pass, o);
  for (std::size_t k = 0; k < p.setup.analyses.size(); ++k)
    if (p.setup.analyses[k]->Key() == "fields") {
      p.result = r.results[k];
      for (const Metric& m : p.setup.analyses[k]->RunMetrics(p.result)) p.metrics[m.name] = m.value;
    }
  return p;
}

TEST(FieldsAnalysis, SteadyWindowOfTheFlowAnalysis) {
  TempDir dir;
  WriteRun(dir.Path());
  const Pass p = PassWith(dir.Path(), true);
  ASSERT_EQ(p.result["parts"].size(), 1u);
  const nlohmann::json& part = p.result["parts"][0];
  EXPECT_EQ(part["name"], "steady");
  EXPECT_EQ(part["frames"], 2);  // 2.2 and 2.3: the flow window ends at the last exit, 2.55
  EXPECT_EQ(part["contact_frames"], 2);
  // A rigid translation: v of that translation wherever defined, so its region mean too.
  const CgMaps maps(SumsFromJson(part["sums"]));
  for (std::size_t n = 0; n < maps.Grid().size(); ++n)
    if (std::isfinite(maps.Value(CgField::kVy, n))) {
      EXPECT_NEAR(maps.Value(CgField::kVy, n), -1.0, 1e-12);
      EXPECT_NEAR(maps.Value(CgField::kTg, n), 0.0, 1e-12);
    }
  EXPECT_NEAR(p.metrics.at("cg_speed"), 1.0, 1e-12);
  EXPECT_TRUE(p.metrics.count("cg_pressure"));
  EXPECT_GT(p.metrics.at("cg_pressure"), 0.0);
  // The series above the outlet: one value per frame, the speed 1.
  ASSERT_EQ(p.result["series"].size(), 1u);
  EXPECT_EQ(NumbersOf(p.result["series"][0]["time"]), (std::vector<double>{2.2, 2.3}));
  for (double s : NumbersOf(p.result["series"][0]["speed"])) EXPECT_NEAR(s, 1.0, 1e-12);
  // The force chain of the first frame: the strong half of the chains (load above the mean).
  ASSERT_TRUE(part.contains("force_chain"));
  EXPECT_EQ(part["force_chain"]["time"], 2.2);
  for (const auto& seg : part["force_chain"]["segments"]) EXPECT_GT(seg[4].get<double>(), 10.0);
}

TEST(FieldsAnalysis, SplitIntoFlowingAndClogged) {
  TempDir dir;
  WriteRun(dir.Path());
  const Pass p = PassWith(dir.Path(), {{"frames", "split"}, {"maps", {"speed", "pressure"}}});
  ASSERT_EQ(p.result["parts"].size(), 2u);
  EXPECT_EQ(p.result["parts"][0]["name"], "flowing");
  EXPECT_EQ(p.result["parts"][0]["frames"], 2);
  EXPECT_EQ(p.result["parts"][1]["name"], "clogged");
  EXPECT_EQ(p.result["parts"][1]["frames"], 1);  // t = 15, inside the clog from the last exit on
  EXPECT_NEAR(p.metrics.at("cg_speed"), 1.0, 1e-12);
  EXPECT_NEAR(p.metrics.at("cg_speed_clogged"), 0.0, 1e-12);
  // The same load in both states: the same pressure above the outlet.
  EXPECT_NEAR(p.metrics.at("cg_pressure_clogged"), p.metrics.at("cg_pressure"), 1e-9);
  EXPECT_EQ(NumbersOf(p.result["series"][0]["time"]), (std::vector<double>{2.2, 2.3, 15.0}));
  // A time range instead.
  const Pass r = PassWith(dir.Path(), {{"frames", {{"from", 2.25}, {"to", 20.0}}}});
  EXPECT_EQ(r.result["parts"][0]["frames"], 2);  // 2.3 and 15
  EXPECT_NEAR(r.metrics.at("cg_speed"), 0.5, 1e-12);
}

// What the figure kinds "maps" and "profile" ask for: a field by name from several runs'
// results merged (two copies of the run here), with the silo to draw over it.
TEST(FieldsAnalysis, OffersEveryFieldByNameFromRunsMerged) {
  TempDir dir;
  WriteRun(dir.Path());
  const Pass p = PassWith(dir.Path(), {{"frames", "split"}, {"maps", {"speed"}}});
  const Analysis* fields = nullptr;
  for (const Analysis* a : p.setup.List())
    if (a->Key() == "fields") fields = a;
  ASSERT_TRUE(fields);
  std::vector<std::string> names;
  for (const FieldInfo& f : fields->FieldNames()) names.push_back(f.name);
  for (const char* want : {"phi", "vy", "pressure", "tg", "vy_clogged", "pressure_clogged"})
    EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
  const nlohmann::json spec = {{"silo", {{"width", 25.0}, {"base_outlets", {{{"center", 0.0}, {"width", 4.0}}}}}}};
  const std::vector<const nlohmann::json*> twice = {&p.result, &p.result};
  const std::optional<FieldMap> vy = fields->Field("vy", twice, spec);
  ASSERT_TRUE(vy.has_value());
  EXPECT_EQ(vy->runs, 2);
  EXPECT_EQ(vy->frames, 4);  // the flowing part's 2 frames of each copy
  ASSERT_EQ(vy->values.size(), static_cast<std::size_t>(vy->nx * vy->ny));
  int defined = 0;
  for (double v : vy->values)
    if (std::isfinite(v)) {
      EXPECT_NEAR(v, -1.0, 1e-12);  // the lattice falls rigidly at speed 1 while it flows
      ++defined;
    }
  EXPECT_GT(defined, vy->nx * vy->ny / 2);
  EXPECT_FALSE(vy->lines.empty());
  // The clogged part: at rest; a profile of it across the silo is 0 wherever defined.
  const std::optional<FieldMap> rest = fields->Field("vy_clogged", twice, spec);
  ASSERT_TRUE(rest.has_value());
  EXPECT_EQ(rest->frames, 2);
  const FieldProfile across = ComputeFieldProfile(*rest, 'x', 5.0, 1.0);
  ASSERT_EQ(across.position.size(), static_cast<std::size_t>(rest->nx));
  for (std::size_t i = 0; i < across.position.size(); ++i) {
    if (across.nodes[i] > 0) {
      EXPECT_NEAR(across.value[i], 0.0, 1e-12);
    }
  }
  // |v| comes with the velocity as arrows: straight down while it flows.
  const std::optional<FieldMap> speed = fields->Field("speed", twice, spec);
  ASSERT_TRUE(speed.has_value());
  EXPECT_GT(speed->arrow_spacing, 0.0);
  ASSERT_FALSE(speed->arrows.empty());
  for (const auto& a : speed->arrows) {
    EXPECT_NEAR(a[2], 0.0, 1e-12);
    EXPECT_NEAR(a[3], -1.0, 1e-12);
  }
  EXPECT_TRUE(vy->arrows.empty());
  EXPECT_FALSE(fields->Field("no_such_field", twice, spec).has_value());
  EXPECT_FALSE(fields->Field("vy", {}, spec).has_value());
}

TEST(FieldsAnalysis, SiloDrawingLeavesTheOutletsOpen) {
  const SiloDrawing d = MakeSiloDrawing({{"silo",
                                          {{"width", 20.0},
                                           {"base_outlets", {{{"center", 2.0}, {"width", 4.0}}}},
                                           {"obstacles", {{{"x", 0.0}, {"y", 8.0}, {"diameter", 3.0}}}}}}},
                                        30.0);
  // Base: -10 .. 0 and 4 .. 10; the side walls 0 .. 30.
  ASSERT_EQ(d.lines.size(), 4u);
  EXPECT_EQ(d.lines[0], (std::vector<std::array<double, 2>>{{-10.0, 0.0}, {0.0, 0.0}}));
  EXPECT_EQ(d.lines[1], (std::vector<std::array<double, 2>>{{4.0, 0.0}, {10.0, 0.0}}));
  EXPECT_EQ(d.lines[3], (std::vector<std::array<double, 2>>{{10.0, 0.0}, {10.0, 30.0}}));
  ASSERT_EQ(d.circles.size(), 1u);
  EXPECT_EQ(d.circles[0], (std::array<double, 3>{0.0, 8.0, 1.5}));
}

}  // namespace
}  // namespace granary::analysis
