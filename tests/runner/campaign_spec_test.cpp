// Tests of the campaign spec: sweep expansion (grid, zip, points, replicas), stable ids,
// replica seeds shared across points (so beds are shared), and one test per class of error.
#include "runner/campaign_spec.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "runner/util.h"

namespace granary::runner {
namespace {

using nlohmann::json;

std::string ErrorOf(const json& j) {
  try {
    const CampaignSpec s = CampaignSpec::FromJson(j);
    Expand(s, "/cache");
  } catch (const SpecError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(HashTest, Fnv1aKnownAnswers) {
  // Reference values of FNV-1a 64 (Fowler/Noll/Vo test vectors).
  EXPECT_EQ(HashHex(""), "cbf29ce484222325");
  EXPECT_EQ(HashHex("a"), "af63dc4c8601ec8c");
  EXPECT_EQ(HashHex("foobar"), "85944171f73967e8");
}

TEST(NearestTest, SuggestsCloseWordsOnly) {
  EXPECT_EQ(Nearest("stauts", {"plan", "run", "status", "report"}), "status");
  EXPECT_EQ(Nearest("xyzzy", {"plan", "run", "status", "report"}), "");
}

// Adaptive replicas: the plan has `min` per point; the replicas a runner adds later are the
// ones a plan of more replicas would have had (same seeds and ids), replicas 0..min-1 unchanged.
TEST(CampaignSpecTest, AdaptiveReplicasPlanMinAndAddWithThePlansIds) {
  const json j =
      json::parse(R"({"name": "t", "replicas": {"min": 2, "max": 5, "until": {"metric": "q_count", "rel_se": 0.1}},
    "base": {"bodies": {"count": 300}, "silo": {"width": 30}},
    "sweep": {"grid": {"/silo/base_outlets/0/width": [4, 6]}}})");
  const CampaignSpec s = CampaignSpec::FromJson(j);
  EXPECT_EQ(s.replicas, 2);
  EXPECT_TRUE(s.replica_rule.Adaptive());
  EXPECT_EQ(s.replica_rule.max, 5);
  const auto planned = Expand(s, "/cache");
  ASSERT_EQ(planned.size(), 4u);
  const auto more = Expand(s, "/cache", kDefaultMaxRuns, 5);
  ASSERT_EQ(more.size(), 10u);
  for (const auto& p : planned) {
    const auto it = std::find_if(more.begin(), more.end(), [&](const PlannedRun& m) { return m.run_id == p.run_id; });
    ASSERT_NE(it, more.end());
    EXPECT_EQ(it->replica, p.replica);
    EXPECT_EQ(it->params_json, p.params_json);
  }
  // A fixed spec of 5 replicas has the same runs.
  json fixed = j;
  fixed["replicas"] = 5;
  const auto five = Expand(CampaignSpec::FromJson(fixed), "/cache");
  ASSERT_EQ(five.size(), 10u);
  for (std::size_t k = 0; k < five.size(); ++k) EXPECT_EQ(five[k].run_id, more[k].run_id);
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "replicas": {"max": 5, "until": {"metric": "q", "rel_se": 0}}})")),
            "/replicas/until/rel_se: must be a positive number (got 0)");
  // The schema offers both forms.
  const json schema = CampaignSpecSchema();
  ASSERT_TRUE(schema["properties"]["replicas"].contains("oneOf")) << schema["properties"]["replicas"].dump();
  EXPECT_EQ(schema["properties"]["replicas"]["oneOf"][0]["type"], "integer");
  EXPECT_EQ(schema["properties"]["replicas"]["oneOf"][1]["required"], json({"max", "until"}));
}

TEST(CampaignSpecTest, GridZipPointsAndReplicasExpand) {
  const json j = json::parse(R"({"name": "t", "replicas": 2,
    "base": {"bodies": {"count": 300}, "silo": {"width": 30}},
    "sweep": {"grid": {"/silo/base_outlets/0/width": [4, 6, 8]},
              "zip": {"/contact/mu": [0.3, 0.5], "/contact/mu_wall": [0.2, 0.4]},
              "points": [{"/discharge/mode": "remove"}, {"/discharge/mode": "reinject"}]}})");
  const CampaignSpec s = CampaignSpec::FromJson(j);
  EXPECT_EQ(s.axes, (std::vector<std::string>{"/silo/base_outlets/0/width", "/contact/mu", "/contact/mu_wall",
                                              "/discharge/mode"}));
  const auto runs = Expand(s, "/cache");
  ASSERT_EQ(runs.size(), 3u * 2u * 2u * 2u);
  // Zipped axes stay paired.
  for (const auto& r : runs) {
    const double mu = r.Params()["contact"]["mu"];
    const double mu_wall = r.Params()["contact"]["mu_wall"];
    EXPECT_EQ(mu == 0.3 ? 0.2 : 0.4, mu_wall);
  }
  std::set<std::string> ids;
  for (const auto& r : runs) ids.insert(r.run_id);
  EXPECT_EQ(ids.size(), runs.size());
  // The first grid axis is the slowest; replicas are innermost.
  EXPECT_EQ(runs[0].Params()["silo"]["base_outlets"][0]["width"], 4.0);
  EXPECT_EQ(runs[0].replica, 0);
  EXPECT_EQ(runs[1].replica, 1);
  EXPECT_EQ(runs[0].point_id, runs[1].point_id);
  EXPECT_NE(runs[0].point_id, runs[2].point_id);
  EXPECT_EQ(runs[0].Params()["run_id"], runs[0].run_id);
  // The id is the hash of the resolved spec, whichever way it is recomputed.
  for (const auto& r : runs) EXPECT_EQ(RunIdOf(RunSpec::FromJson(r.Params())), r.run_id);
}

TEST(CampaignSpecTest, ReplicaSeedsAndBedsSharedAcrossOutletWidths) {
  const json j = json::parse(R"({"name": "t", "seed": 9, "replicas": 2, "base": {"silo": {"width": 30}},
    "sweep": {"grid": {"/silo/base_outlets/0/width": [4, 6]}}})");
  const auto runs = Expand(CampaignSpec::FromJson(j), "/cache");
  ASSERT_EQ(runs.size(), 4u);
  EXPECT_EQ(runs[0].Params()["seed"], runs[2].Params()["seed"]);  // replica 0 of both widths
  EXPECT_NE(runs[0].Params()["seed"], runs[1].Params()["seed"]);
  EXPECT_EQ(runs[0].Params()["seed"], ReplicaSeed(9, 0));
  EXPECT_EQ(runs[0].Params()["bed"]["cache_file"], runs[2].Params()["bed"]["cache_file"]);
  EXPECT_NE(runs[0].Params()["bed"]["cache_file"], runs[1].Params()["bed"]["cache_file"]);
  EXPECT_EQ(runs[0].Params()["bed"]["cache_file"].get<std::string>().rfind("/cache/", 0), 0u);
}

TEST(CampaignSpecTest, IdsAreStableAndIgnoreCacheDir) {
  const json j = json::parse(R"({"name": "t", "base": {"silo": {"width": 30}}})");
  const auto a = Expand(CampaignSpec::FromJson(j), "/cache-a");
  const auto b = Expand(CampaignSpec::FromJson(j), "/cache-b");
  EXPECT_EQ(a[0].run_id, b[0].run_id);
  EXPECT_EQ(a[0].run_id.size(), 16u);
}

// The straightforward expansion planning used before it was made fast: every replica
// resolved through RunSpec::from_json and dumped in full. Ids must never change.
struct ReferenceRun {
  std::string run_id, point_id, params_json;
};
std::vector<ReferenceRun> ReferenceExpand(const CampaignSpec& spec, const std::vector<json>& points,
                                          const std::string& cache_dir) {
  json base = spec.base;
  base["engine"] = spec.engines.front();
  const json canonical = RunSpec::FromJson(base).ToJson();
  std::vector<ReferenceRun> out;
  for (const json& point : points) {
    json params = canonical;
    for (const auto& [key, value] : point.items()) params[json::json_pointer(key)] = value;
    const std::uint64_t source = point.contains("/seed") ? params["seed"].get<std::uint64_t>() : spec.seed;
    for (int r = 0; r < spec.replicas; ++r) {
      RunSpec rs = RunSpec::FromJson(params);
      rs.seed = ReplicaSeed(source, r);
      RunSpec zero = rs;
      zero.seed = 0;
      ReferenceRun ref;
      ref.run_id = RunIdOf(rs);
      ref.point_id = RunIdOf(zero);
      rs.run_id = ref.run_id;
      rs.bed.cache_file = cache_dir + "/" + HashHex(rs.BedKey().dump()) + ".bed";
      ref.params_json = rs.ToJson().dump();
      out.push_back(ref);
    }
  }
  return out;
}

TEST(CampaignSpecTest, FastExpansionGivesTheIdsAndParamsOfTheReferencePath) {
  const json j = json::parse(R"({"name": "t", "seed": 77, "replicas": 3,
    "base": {"bodies": {"count": 300, "species": [{"name": "a\"b/\\\u00e9", "shape": "dumbbell"}]},
             "silo": {"width": 30}},
    "sweep": {"grid": {"/silo/base_outlets/0/width": [4, 6.5], "/contact/mu": [0.3, 0.5]},
              "points": [{"/discharge/mode": "remove"}, {"/seed": 12345, "/discharge/mode": "reinject"}]}})");
  const CampaignSpec s = CampaignSpec::FromJson(j);
  const auto runs = Expand(s, "/cache dir");
  std::vector<json> points;
  for (std::size_t i = 0; i < runs.size(); i += 3) points.push_back(runs[i].point);
  ASSERT_EQ(points.size(), 8u);
  const auto reference = ReferenceExpand(s, points, "/cache dir");
  ASSERT_EQ(runs.size(), reference.size());
  for (std::size_t i = 0; i < runs.size(); ++i) {
    EXPECT_EQ(runs[i].run_id, reference[i].run_id) << i;
    EXPECT_EQ(runs[i].point_id, reference[i].point_id) << i;
    EXPECT_EQ(runs[i].params_json, reference[i].params_json) << i;
    EXPECT_EQ(runs[i].point_json, runs[i].point.dump());
  }
}

TEST(CampaignSpecTest, EngineListPlansEveryPointOncePerEngineWithTheSameSeeds) {
  const json j = json::parse(R"({"name": "t", "replicas": 2, "engine": ["native", "liggghts"],
    "base": {"silo": {"width": 30}}, "sweep": {"grid": {"/silo/base_outlets/0/width": [4, 6]}}})");
  const CampaignSpec s = CampaignSpec::FromJson(j);
  EXPECT_EQ(s.engines, (std::vector<std::string>{"native", "liggghts"}));
  const auto runs = Expand(s, "/cache");
  ASSERT_EQ(runs.size(), 2u * 2u * 2u);
  // Point, then engine, then replica.
  const std::vector<std::string> engines = {"native", "native", "liggghts", "liggghts"};
  for (std::size_t i = 0; i < runs.size(); ++i) {
    EXPECT_EQ(runs[i].engine, engines[i % 4]);
    EXPECT_EQ(runs[i].Params()["engine"], engines[i % 4]);
    EXPECT_EQ(RunIdOf(RunSpec::FromJson(runs[i].Params())), runs[i].run_id);
  }
  EXPECT_EQ(runs[0].point, runs[2].point);
  EXPECT_NE(runs[0].point_id, runs[2].point_id);
  EXPECT_NE(runs[0].run_id, runs[2].run_id);
  EXPECT_EQ(runs[0].Params()["seed"], runs[2].Params()["seed"]);
  EXPECT_NE(runs[0].Params()["bed"]["cache_file"], runs[2].Params()["bed"]["cache_file"]);
  // The native runs are the runs of the single-engine campaign: a comparison reuses them.
  json single = j;
  single["engine"] = "native";
  const auto native = Expand(CampaignSpec::FromJson(single), "/cache");
  EXPECT_EQ(native[0].run_id, runs[0].run_id);
  EXPECT_EQ(native[2].run_id, runs[4].run_id);
}

TEST(DumpTemplateTest, FillEqualsTheDumpOfTheFilledDocument) {
  const json doc = {{"b", {{"x", 1}, {"s", "\x01granary-field-1\x01"}}}, {"a", 2}, {"c", "z"}};
  const DumpTemplate t(doc, {"/c"});
  EXPECT_TRUE(t.Spliced());
  json expect = doc;
  expect["c"] = "q\"";
  EXPECT_EQ(t.Fill({json("q\"").dump()}), expect.dump());
  // A document already holding a placeholder text cannot be spliced; fill still dumps right.
  const DumpTemplate clash(doc, {"/a", "/c"});
  EXPECT_FALSE(clash.Spliced());
  expect["c"] = "w";
  expect["a"] = 3;
  EXPECT_EQ(clash.Fill({"3", json("w").dump()}), expect.dump());
}

TEST(CampaignSpecErrorTest, UnknownKeys) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "replica": 2})")),
            "/replica: unknown key; did you mean \"replicas\"?");
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "sweep": {"gird": {}}})")),
            "/sweep/gird: unknown key; did you mean \"grid\"?");
}

TEST(CampaignSpecErrorTest, BadTopLevelValues) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"replicas": 2})")), "/name: must be a non-empty string (got nothing)");
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "replicas": 0})")),
            "/replicas: must be an integer in [1, 100000] (got 0)");
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "engine": "gromacs"})")),
            "/engine: must be \"native\", \"liggghts\", \"lammps\" or a list of them, e.g. [\"native\", \"lammps\"] "
            "(got \"gromacs\")");
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "engine": ["native", "native"]})")),
            "/engine: must be \"native\", \"liggghts\", \"lammps\" or a list of them, e.g. [\"native\", \"lammps\"] "
            "(got [\"native\",\"native\"])");
}

TEST(CampaignSpecErrorTest, BaseErrorsPointIntoBase) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "base": {"silo": {"widht": 30}}})")),
            "/base/silo/widht: unknown key; did you mean \"width\"?");
}

TEST(CampaignSpecErrorTest, AxisMustBeAPointerWithValues) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "sweep": {"grid": {"silo/width": [1]}}})")),
            "/sweep/grid/silo~1width: an axis must be a JSON Pointer into the run spec such as \"/silo/width\" (got "
            "\"silo/width\")");
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "sweep": {"grid": {"/silo/width": []}}})")),
            "/sweep/grid/~1silo~1width: must be a non-empty array of values (got [])");
}

TEST(CampaignSpecErrorTest, ZipLengthsMustMatch) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "sweep": {"zip": {"/contact/mu": [0.1, 0.2], "/gravity": [1]}}})")),
            "/sweep/zip/~1gravity: zipped axes must have equal lengths (got 1, \"/contact/mu\" has 2)");
}

TEST(CampaignSpecErrorTest, InvalidPointNamesThePoint) {
  EXPECT_EQ(
      ErrorOf(json::parse(
          R"({"name": "t", "base": {"silo": {"width": 30}}, "sweep": {"grid": {"/silo/base_outlets/0/width": [6, 40]}}})")),
      "/sweep: point 1 {\"/silo/base_outlets/0/width\":40}: /silo/base_outlets/0/width: must be < the silo width "
      "30.0 (got 40.0)");
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "sweep": {"grid": {"/silo/widht": [6]}}})")),
            "/sweep: point 0 {\"/silo/widht\":6}: /silo/widht: unknown key; did you mean \"width\"?");
  EXPECT_EQ(
      ErrorOf(json::parse(R"({"name": "t", "sweep": {"grid": {"/nothing/here": [6]}}})")),
      "/sweep/grid/~1nothing~1here: axis \"/nothing/here\" does not resolve: the run spec has no key \"nothing\"");
}

TEST(CampaignSpecTest, ASweptShapeNamesItsDefaultNamedSpecies) {
  const json j = json::parse(R"({"name": "t", "base": {"silo": {"width": 30}},
    "sweep": {"grid": {"/bodies/species/0/shape": ["disc", "dumbbell"]}}})");
  const auto runs = Expand(CampaignSpec::FromJson(j), "/cache");
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(runs[0].Params()["bodies"]["species"][0]["name"], "disc");
  EXPECT_EQ(runs[1].Params()["bodies"]["species"][0]["name"], "dumbbell");
  // A name the user gave stays.
  const json named = json::parse(R"({"name": "t", "base": {"silo": {"width": 30},
    "bodies": {"species": [{"name": "grain"}]}},
    "sweep": {"grid": {"/bodies/species/0/shape": ["disc", "dumbbell"]}}})");
  const auto runs2 = Expand(CampaignSpec::FromJson(named), "/cache");
  EXPECT_EQ(runs2[0].Params()["bodies"]["species"][0]["name"], "grain");
}

// Sweep pointers that do not resolve gave raw library errors without a /sweep path.
TEST(CampaignSpecErrorTest, SweepPointersThatDoNotResolveNameTheAxis) {
  EXPECT_EQ(
      ErrorOf(json::parse(R"({"name": "t", "sweep": {"grid": {"/silo/width/x": [1]}}})")),
      "/sweep/grid/~1silo~1width~1x: axis \"/silo/width/x\" does not resolve: \"/silo/width\" is a number, not an "
      "object or array");
  EXPECT_EQ(
      ErrorOf(
          json::parse(R"({"name": "t", "sweep": {"grid": {"/silo/base_outlets/99999999999999999999/width": [1]}}})")),
      "/sweep/grid/~1silo~1base_outlets~199999999999999999999~1width: axis "
      "\"/silo/base_outlets/99999999999999999999/width\" does not resolve: \"/silo/base_outlets\" is an array of 1 "
      "element (indices 0 to 1), not \"99999999999999999999\"");
  // A misspelt key inside the pointer gets the corrected axis.
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "sweep": {"grid": {"/silo/base_outlet/0/width": [4]}}})")),
            "/sweep/grid/~1silo~1base_outlet~10~1width: axis \"/silo/base_outlet/0/width\" does not resolve: \"/silo\" "
            "has no key \"base_outlet\"; did you mean \"/silo/base_outlets/0/width\"?");
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "sweep": {"points": [{"/silo/base_outlets/-/width": 3}]}})")),
            "/sweep/points/0/~1silo~1base_outlets~1-~1width: axis \"/silo/base_outlets/-/width\" does not resolve: "
            "\"/silo/base_outlets\" is an array of 1 element (indices 0 to 1), not \"-\"");
  // A zip and a grid addressing the same value (one inside the other).
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "base": {"silo": {"width": 30}}, "sweep": {
                "grid": {"/silo/base_outlets/0": [{"center": 0, "width": 5}]},
                "zip": {"/silo/base_outlets/0/width": [4, 6]}}})")),
            "/sweep/zip/~1silo~1base_outlets~10~1width: axis \"/silo/base_outlets/0/width\" sets part of the axis "
            "\"/silo/base_outlets/0\" (/sweep/grid/~1silo~1base_outlets~10); sweep each value in one place");
  // A second outlet may be added at the end of the array.
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "base": {"silo": {"width": 30}},
                "sweep": {"grid": {"/silo/base_outlets/1": [{"center": 8, "width": 4}]}}})")),
            "(no error)");
}

// A 300 x 100 grid x 1000 replicas ended in std::bad_alloc. The count is checked
// before anything is expanded (this test would take minutes and gigabytes otherwise).
TEST(CampaignSpecErrorTest, ASweepOverTheRunLimitIsRefusedBeforeExpanding) {
  json widths = json::array(), mus = json::array();
  for (int i = 0; i < 300; ++i) widths.push_back(3.0 + i * 0.01);
  for (int i = 0; i < 100; ++i) mus.push_back(0.1 + i * 0.001);
  const json j = {{"name", "t"},
                  {"replicas", 1000},
                  {"base", {{"silo", {{"width", 30}}}}},
                  {"sweep", {{"grid", {{"/silo/base_outlets/0/width", widths}, {"/contact/mu", mus}}}}}};
  const CampaignSpec s = CampaignSpec::FromJson(j);
  EXPECT_EQ(PlannedRunCount(s), 30000000u);
  try {
    Expand(s, "/cache");
    FAIL() << "expected a refusal";
  } catch (const SpecError& e) {
    EXPECT_EQ(
        std::string(e.what()),
        "/sweep: expands to 30000000 runs (100 x 300 x 1 engine(s) x 1000 replicas), more than the limit of 100000; "
        "narrow the sweep, or raise the limit with --max-runs");
  }
  json small = j;
  small["replicas"] = 2;
  small["sweep"]["grid"]["/contact/mu"] = json::array({0.1, 0.2, 0.3, 0.4, 0.5});
  EXPECT_EQ(Expand(CampaignSpec::FromJson(small), "/cache", 3000).size(), 3000u);  // at the limit
}

// /base/engine was silently overridden by the campaign's engine, and an unknown
// engine name there was accepted.
TEST(CampaignSpecErrorTest, TheEngineIsSetInOnePlace) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "base": {"engine": "gromacs"}})")),
            "/base/engine: must be \"native\", \"liggghts\" or \"lammps\" (got \"gromacs\")");
  EXPECT_EQ(
      ErrorOf(json::parse(R"({"name": "t", "engine": "native", "base": {"engine": "liggghts"}})")),
      "/base/engine: \"liggghts\" conflicts with the campaign's \"engine\" \"native\"; set the engine in one place "
      "(the campaign's \"engine\")");
  const CampaignSpec s = CampaignSpec::FromJson(json::parse(R"({"name": "t", "base": {"engine": "liggghts"}})"));
  EXPECT_EQ(s.engines, std::vector<std::string>{"liggghts"});
  EXPECT_EQ(Expand(s, "/cache").at(0).engine, "liggghts");
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "engine": ["liggghts"], "base": {"engine": "liggghts"}})")),
            "(no error)");
}

// A NUL in a species name was accepted and cut the events.csv shape column; line
// separators, \v and \f were accepted too.
TEST(CampaignSpecErrorTest, NamesRefuseControlCharactersAndLineBreaks) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"a\\u0000b", "U+0000 (NUL)"},
      {"a\\u2028b", "U+2028 (LINE SEPARATOR)"},
      {"a\\u0085b", "U+0085 (NEXT LINE)"},
      {"a\\u000bb", "U+000B (LINE TABULATION (\\v))"},
      {"a\\u000cb", "U+000C (FORM FEED (\\f))"},
      {"a\\u2029b", "U+2029 (PARAGRAPH SEPARATOR)"},
      {"a\\u202eb", "U+202E (an invisible format character)"},
      {"a,b", "','"}};
  for (const auto& [name, what] : cases) {
    const json j = json::parse(R"({"name": "t", "base": {"bodies": {"species": [{"name": ")" + name + R"("}]}}})");
    const std::string error = ErrorOf(j);
    EXPECT_EQ(
        error.rfind("/base/bodies/species/0/name: must be a non-empty name without commas, control characters", 0), 0u)
        << error;
    EXPECT_NE(error.find("which holds " + what + ")"), std::string::npos) << error;
  }
  EXPECT_EQ(
      ErrorOf(json::parse(R"({"name": "a\u2028b"})")),
      "/name: must not hold control characters or line breaks (got \"a\u2028b\", which holds U+2028 (LINE SEPARATOR))");
  EXPECT_EQ(ErrorOf(json::parse(R"({"name": "t", "base": {"bodies": {"species": [{"name": "grès-é"}]}}})")),
            "(no error)");
}

// A syntax error said only "not valid JSON"; a spec nested 10^5 deep crashed
// `campaign plan` with SIGSEGV while formatting the error.
TEST(CampaignSpecErrorTest, SyntaxErrorsAndDeepNestingSayWhere) {
  try {
    ParseSpecText("{\n  \"name\": \"t\",\n  \"replicas\": 2,,\n}\n", "c.json");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("c.json:3:17: not valid JSON: syntax error while parsing object key", 0), 0u)
        << e.what();
  }
  const std::string deep = "{\"name\": \"t\", \"base\": " + std::string(100000, '[') + std::string(100000, ']') + "}";
  try {
    ParseSpecText(deep, "deep.json");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "deep.json:1:86: nested deeper than 64 levels (a campaign spec needs fewer than 10)");
  }
  // Brackets inside strings do not count.
  EXPECT_EQ(ParseSpecText(R"({"name": "[[[[{{{{\"[["})", "s.json")["name"], "[[[[{{{{\"[[");
}

// A number out of a double's range gave nlohmann's raw out_of_range.406 text, no place.
TEST(CampaignSpecErrorTest, ANumberOutOfRangeSaysWhere) {
  try {
    ParseSpecText("{\n  \"name\": \"1e400\",\n  \"seed\": 1e400\n}\n", "c.json");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(
        std::string(e.what()),
        "c.json:3:11: the number 1e400 is out of range (a JSON number must fit a double, magnitude below 1.8e308)");
  }
  try {
    ParseSpecText(R"({"name": "t", "base": {"silo": {"width": -2E+999}}})", "d.json");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("d.json:1:42: the number -2E+999 is out of range", 0), 0u) << e.what();
  }
}

}  // namespace
}  // namespace granary::runner
