// The shipped campaigns (campaigns/*.json): every one plans (dry run, the real planner) with
// its figures and expectations naming metrics and axes that exist; every chapter study of the
// thesis comes in the sizes quick, medium and full, which differ only in what makes a size;
// and a full study says what it costs.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "runner/cli/plan.h"
#ifdef GRANARY_HAVE_ANALYSIS
#include "analysis/expectations.h"
#endif

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const char* const kSizes[] = {"quick", "medium", "full"};

std::vector<fs::path> ShippedSpecs() {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(fs::path(GRANARY_SOURCE_DIR) / "campaigns"))
    if (e.path().extension() == ".json") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

// "ch3-outlet-width-quick" -> {"ch3-outlet-width", "quick"}; a spec of no chapter study -> {"", ""}.
std::pair<std::string, std::string> StudyAndSize(const fs::path& spec) {
  const std::string stem = spec.stem().string();
  if (stem.rfind("ch", 0) != 0) return {"", ""};
  for (const char* size : kSizes) {
    const std::string tail = std::string("-") + size;
    if (stem.size() > tail.size() && stem.compare(stem.size() - tail.size(), tail.size(), tail) == 0)
      return {stem.substr(0, stem.size() - tail.size()), size};
  }
  return {stem, ""};
}

// What remains of a spec without what makes its size: names and text, replicas, body count,
// silo width, time and clog limits (also where the sweep sets them per point: a full size's
// wide outlets need longer runs for their clogs), frame interval and format (full sizes write
// GSD, with fewer contact frames), the maps' window (the thesis' at full size, scaled with the
// silo and the bed at the others: ch4-free-flow), and the sweep's values (its axes stay).
json WithoutSize(json spec) {
  for (const char* key : {"name", "description", "size", "replicas"}) spec.erase(key);
  for (const char* pointer : {"/base/bodies/count", "/base/silo/width", "/base/discharge/max_time",
                              "/base/discharge/unclog/max_clogs", "/base/output/frame_interval", "/base/output/format",
                              "/base/output/contact_interval", "/report/fields/window"}) {
    const json::json_pointer p(pointer);
    if (spec.contains(p)) spec.at(p.parent_pointer()).erase(p.back());
  }
  json axes = json::object();
  const json sweep = spec.value("sweep", json::object());
  for (const auto& [part, value] : sweep.items()) {
    std::set<std::string> names;
    if (part == "points")
      for (const json& point : value)
        for (const auto& [axis, v] : point.items()) names.insert(axis);
    else
      for (const auto& [axis, v] : value.items()) names.insert(axis);
    for (const char* limit : {"/discharge/max_time", "/discharge/unclog/max_clogs"}) names.erase(limit);
    axes[part] = names;
  }
  spec["sweep"] = axes;
  return spec;
}

TEST(ShippedCampaigns, EverySpecPlansWithFiguresAndExpectationsNamingMetricsAndAxesThatExist) {
  const std::vector<fs::path> specs = ShippedSpecs();
  ASSERT_GE(specs.size(), 45u);
  const fs::path db = fs::temp_directory_path() / "granary-shipped-campaigns-never-written.db";
  ASSERT_FALSE(fs::exists(db));
  for (const fs::path& path : specs) {
    SCOPED_TRACE(path.filename().string());
    const json given = cli::ReadSpecFile("plan", path.string());
    CampaignSpec spec;
    try {
      const PlanSummary s = cli::PlanInto(given, path.string(), db.string(), true, kDefaultMaxRuns, spec);
      EXPECT_GT(s.total, 0) << "plans no run";
    } catch (const std::exception& e) {
      ADD_FAILURE() << e.what();
      continue;
    }
#ifdef GRANARY_HAVE_ANALYSIS
    EXPECT_NO_THROW(analysis::CheckMetricReferences(given));
#endif
    const auto [study, size] = StudyAndSize(path);
    if (study.empty()) continue;
    EXPECT_EQ(spec.size, size) << "a chapter study's /size is its file's size";
    EXPECT_TRUE(given.contains(json::json_pointer("/report/figures"))) << "a chapter study draws its chapter's figures";
  }
  EXPECT_FALSE(fs::exists(db)) << "a dry run writes no database";
}

TEST(ShippedCampaigns, EveryChapterStudyComesInThreeSizesThatDifferOnlyInSize) {
  std::map<std::string, std::map<std::string, json>> studies;
  for (const fs::path& path : ShippedSpecs()) {
    const auto [study, size] = StudyAndSize(path);
    if (study.empty()) continue;
    ASSERT_FALSE(size.empty()) << path << ": a chapter study's file ends in -quick, -medium or -full";
    studies[study][size] = cli::ReadSpecFile("plan", path.string());
  }
  EXPECT_GE(studies.size(), 15u);
  for (const auto& [study, sizes] : studies) {
    SCOPED_TRACE(study);
    ASSERT_EQ(sizes.size(), 3u) << "quick, medium and full";
    const json full = WithoutSize(sizes.at("full"));
    for (const char* size : {"quick", "medium"}) {
      const json other = WithoutSize(sizes.at(size));
      EXPECT_EQ(other, full) << size << " differs from full beyond its size: " << json::diff(full, other).dump();
    }
    const std::string cost = sizes.at("full").value("description", "");
    EXPECT_NE(cost.find("core-hours"), std::string::npos) << "the full size states its cost: " << cost;
  }
}

}  // namespace
}  // namespace granary::runner
