// A Python analysis (/report/python) on a constructed run directory, in the real interpreter
// pool: the script counts the exits of events.csv (3) and takes the mean of their masses (1, 2
// and 3) times its option `scale` (10), with the se it is given; a script that raises fails
// that run's analysis with the exception's message, never the pass; entries are checked at
// their JSON path.
#include "analysis/python_analysis.h"

#include <gtest/gtest.h>

#include "analysis/options.h"
#include "analysis/run_pass.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::TempDir;
using testing::WriteFile;

constexpr char kCount[] = R"(
def analyse(run, options):
    ev = run.events()
    return {"exits": (float(len(ev)), None, "bodies"),
            "scaled_mass": (float(ev["mass"].mean()) * options["scale"], 0.5, "m")}
)";

constexpr char kRaise[] = R"(
def analyse(run, options):
    raise ValueError("no clog in " + run.id)
)";

void WriteRun(const std::filesystem::path& dir) {
  WriteFile(dir / "run.json", R"({"run_id": "r1", "bodies": {"count": 10}})");
  WriteFile(dir / "summary.json",
            R"({"engine":"native","run_id":"r1","bodies":10,"exited":3,"remaining":7,"t_end":5})");
  WriteFile(dir / "events.csv", "time,body,shape,mass,outlet\n1,0,disc,1,0\n2,1,disc,2,0\n3,2,disc,3,0\n");
}

RunPassResult Pass(const std::filesystem::path& dir, const Analysis& a) {
  RunPassOptions no_cache;
  no_cache.read_cache = no_cache.write_cache = false;
  return AnalyseRun(dir, {&a}, PassOptions{}, no_cache);
}

TEST(PythonAnalysis, AScriptsAnswersAreTheRunsMetrics) {
  TempDir dir;
  WriteRun(dir.Path() / "r1");
  WriteFile(dir.Path() / "count.py", kCount);
  const auto analyses = MakePythonAnalyses(
      {{{"key", "counted"}, {"script", (dir.Path() / "count.py").string()}, {"options", {{"scale", 10}}}}},
      "/report/python");
  ASSERT_EQ(analyses.size(), 1u);
  EXPECT_EQ(analyses[0]->Key(), "counted");
  const nlohmann::json result = Pass(dir.Path() / "r1", *analyses[0]).results.at(0);
  EXPECT_EQ(PythonFailure(result), "") << result.dump();
  const std::vector<Metric> m = analyses[0]->RunMetrics(result);
  ASSERT_NE(FindMetric(m, "exits"), nullptr) << result.dump();
  EXPECT_DOUBLE_EQ(FindMetric(m, "exits")->value, 3.0);
  EXPECT_EQ(FindMetric(m, "exits")->unit, "bodies");
  ASSERT_NE(FindMetric(m, "scaled_mass"), nullptr);
  EXPECT_DOUBLE_EQ(FindMetric(m, "scaled_mass")->value, 20.0);
  EXPECT_DOUBLE_EQ(FindMetric(m, "scaled_mass")->se, 0.5);
}

TEST(PythonAnalysis, AScriptThatRaisesFailsItsRunWithTheMessage) {
  TempDir dir;
  WriteRun(dir.Path() / "r1");
  WriteFile(dir.Path() / "raise.py", kRaise);
  const auto analyses =
      MakePythonAnalyses({{{"key", "raising"}, {"script", (dir.Path() / "raise.py").string()}}}, "/report/python");
  const nlohmann::json result = Pass(dir.Path() / "r1", *analyses.at(0)).results.at(0);
  EXPECT_NE(PythonFailure(result).find("ValueError: no clog in r1"), std::string::npos) << result.dump();
  EXPECT_TRUE(analyses[0]->RunMetrics(result).empty());
}

TEST(PythonAnalysis, EntriesAreCheckedAtTheirPath) {
  TempDir dir;
  WriteFile(dir.Path() / "count.py", kCount);
  const std::string script = (dir.Path() / "count.py").string();
  const auto path_of = [](const nlohmann::json& entries) {
    try {
      MakePythonAnalyses(entries, "/report/python");
    } catch (const OptionError& e) {
      return e.Path();
    }
    return std::string("no error");
  };
  EXPECT_EQ(path_of({{{"key", "Bad Key"}, {"script", script}}}), "/report/python/0/key");
  EXPECT_EQ(path_of({{{"key", "a"}, {"script", script}}, {{"key", "a"}, {"script", script}}}), "/report/python/1/key");
  EXPECT_EQ(path_of({{{"key", "a"}, {"script", (dir.Path() / "missing.py").string()}}}), "/report/python/0/script");
  EXPECT_EQ(path_of({{{"key", "a"}, {"script", script}, {"timeout", 0}}}), "/report/python/0/timeout");
  EXPECT_EQ(path_of({{{"key", "a"}, {"script", script}, {"scirpt", script}}}), "/report/python/0/scirpt");
}

}  // namespace
}  // namespace granary::analysis
