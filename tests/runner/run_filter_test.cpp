// --only by the names the report prints: an axis' short name ("D_b=1.5", "W=4") and a derived
// axis of the campaign spec's /axes ("D_eq=1.80278"), on plain run rows (no database).
#include "runner/run_filter.h"

#include <gtest/gtest.h>

#include <cmath>

namespace granary::runner {
namespace {

using nlohmann::json;

struct Runs {
  CampaignRow campaign;
  std::vector<RunRow> rows;
};

// W in {4, 6} x D_b in {1, 1.5}; /axes D_eq = sqrt(1 + D_b^2), W_over = W / D_eq.
Runs MakeRuns() {
  Runs r;
  r.campaign.name = "t";
  r.campaign.axes = {"/silo/base_outlets/0/width", "/bodies/species/0/big_diameter"};
  r.campaign.spec = {{"name", "t"}, {"axes", {{"D_eq", "sqrt(1 + D_b^2)"}, {"W_over", "W / D_eq"}}}};
  for (double w : {4.0, 6.0})
    for (double db : {1.0, 1.5}) {
      RunRow row;
      row.run_id = "w" + std::to_string(static_cast<int>(w)) + "db" + std::to_string(static_cast<int>(db * 10));
      row.state = RunState::kDone;
      row.point = {{"/silo/base_outlets/0/width", w}, {"/bodies/species/0/big_diameter", db}};
      row.params = {{"silo", {{"base_outlets", {{{"width", w}}}}}},
                    {"bodies", {{"species", {{{"shape", "snowman"}, {"diameter", 1.0}, {"big_diameter", db}}}}}}};
      r.rows.push_back(row);
    }
  return r;
}

std::vector<std::string> Passing(const RunFilter& f, const std::vector<RunRow>& rows) {
  std::vector<std::string> out;
  for (const auto& r : rows)
    if (f.Matches(r)) out.push_back(r.run_id);
  return out;
}

TEST(RunFilter, ShortNamesAsTheReportPrintsThem) {
  const Runs r = MakeRuns();
  const RunFilter f = ResolveFilters({"D_b=1.5", "W=4"}, r.campaign, r.rows);
  EXPECT_EQ(Passing(f, r.rows), (std::vector<std::string>{"w4db15"}));
  EXPECT_EQ(f.Texts(),
            (std::vector<std::string>{"/bodies/species/0/big_diameter=1.5", "/silo/base_outlets/0/width=4"}));
}

TEST(RunFilter, DerivedAxesSelectTheRunsWhoseValueMatches) {
  const Runs r = MakeRuns();
  // D_eq = sqrt(3.25) = 1.80278 (as the report prints it, 6 digits) selects D_b = 1.5.
  RunFilter f = ResolveFilters({"D_eq=1.80278"}, r.campaign, r.rows);
  EXPECT_EQ(Passing(f, r.rows), (std::vector<std::string>{"w4db15", "w6db15"}));
  // Its texts are the runs' ids: the same filter later, without the campaign at hand.
  EXPECT_EQ(Passing(RunFilter(f.Texts()), r.rows), (std::vector<std::string>{"w4db15", "w6db15"}));
  // Combined with a parameter: both hold.
  f = ResolveFilters({"D_eq=1.80278", "W=6"}, r.campaign, r.rows);
  EXPECT_EQ(Passing(f, r.rows), (std::vector<std::string>{"w6db15"}));
  // A derived axis of a derived axis: W / sqrt(2) for D_b = 1 and W = 4.
  f = ResolveFilters({"W_over=" + std::to_string(4 / std::sqrt(2.0))}, r.campaign, r.rows);
  EXPECT_EQ(Passing(f, r.rows), (std::vector<std::string>{"w4db10"}));
  try {
    ResolveFilters({"D_eq=2"}, r.campaign, r.rows);
    FAIL() << "D_eq=2 selects nothing";
  } catch (const FilterError& e) {
    EXPECT_EQ(std::string(e.what()), "--only D_eq=2: no run has D_eq = 2 (its values: 1.41421, 1.80278)");
  }
}

}  // namespace
}  // namespace granary::runner
