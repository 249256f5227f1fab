// The contacts analysis on two clogs written by the engines' clog writer: two snowmen (a
// small disc of r = 0.5 and a large one of r = 0.75 each) and a lone disc. The first clog has
// one contact of each kind between different bodies (small-small, large-small, large-large,
// the lone disc's), besides a contact inside a body and one with a wall that do not count: a
// quarter each. The second has only the small-small contact: all of it. The run's fractions
// are the means over its clogs.
#include "analysis/contacts_analysis.h"

#include <gtest/gtest.h>

#include <cmath>

#include "analysis/run_pass.h"
#include "rundir/clogs.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::TempDir;

rundir::Disc DiscOf(std::int64_t id, std::int64_t body, int type, double x, double y, double r) {
  rundir::Disc d;
  d.id = id;
  d.mol = body;
  d.type = type;
  d.x = x;
  d.y = y;
  d.radius = r;
  d.mass = r * r;
  return d;
}

rundir::ContactRow Touch(std::int64_t i, std::int64_t j, const rundir::Disc& a, const rundir::Disc& b) {
  return {i, j, a.x, a.y, b.x, b.y, (a.x + b.x) / 2, (a.y + b.y) / 2, 0.0, 1.0};
}

TEST(ContactsAnalysis, FractionsOfEachKindPerClogAveragedOverTheRunsClogs) {
  TempDir dir;
  // Snowman 0 lies on the base; snowman 1 on top of it; the lone disc beside them.
  const rundir::Disc s0{DiscOf(1, 0, 1, 0.0, 0.5, 0.5)}, l0{DiscOf(2, 0, 1, 1.25, 0.75, 0.75)};
  const rundir::Disc s1{DiscOf(3, 1, 1, 0.0, 1.5, 0.5)}, l1{DiscOf(4, 1, 1, 1.25, 2.25, 0.75)};
  const rundir::Disc lone{DiscOf(5, 2, 2, -1.0, 0.5, 0.5)};
  rundir::ClogState first;
  first.frame.timestep = first.contacts.timestep = 1000;
  first.frame.time = first.contacts.time = 0.1;
  first.frame.discs = {s0, l0, s1, l1, lone};
  first.contacts.contacts = {Touch(0, 1, s0, s1), Touch(1, 0, s1, l0),
                             Touch(0, 1, l0, l1), Touch(2, 0, lone, s0),
                             Touch(0, 0, s0, l0), {0, -1, s0.x, s0.y, s0.x, 0.0, s0.x, 0.0, 0.0, 1.0}};
  rundir::ClogState second = first;
  second.frame.timestep = second.contacts.timestep = 2000;
  second.frame.time = second.contacts.time = 0.2;
  second.contacts.contacts = {Touch(0, 1, s0, s1)};
  {
    rundir::ClogWriter w = rundir::ClogWriter::Create(dir.Path());
    w.Write(first);
    w.Write(second);
    w.Close();
  }
  rundir::RunData data;
  data.dir = dir.Path();
  data.spec = nlohmann::json::object();
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  const auto analysis = MakeContactsAnalysis(nullptr, "/report/contacts");
  const nlohmann::json result = analysis->Start(view)->Finish();
  ASSERT_EQ(result.at("clogs").size(), 2u);
  EXPECT_EQ(result.at("clogs")[0].at("small_small"), 1);
  EXPECT_EQ(result.at("clogs")[0].at("large_small"), 1);
  EXPECT_EQ(result.at("clogs")[0].at("large_large"), 1);
  EXPECT_EQ(result.at("clogs")[0].at("other"), 1);
  const std::vector<Metric> m = analysis->RunMetrics(result);
  ASSERT_NE(FindMetric(m, "contact_ss"), nullptr);
  EXPECT_DOUBLE_EQ(FindMetric(m, "contact_ss")->value, (0.25 + 1.0) / 2);
  EXPECT_DOUBLE_EQ(FindMetric(m, "contact_ss")->se, 0.375);  // sd of {1/4, 1} over sqrt 2
  EXPECT_DOUBLE_EQ(FindMetric(m, "contact_ls")->value, 0.125);
  EXPECT_DOUBLE_EQ(FindMetric(m, "contact_ll")->value, 0.125);
  EXPECT_DOUBLE_EQ(FindMetric(m, "contact_other")->value, 0.125);
}

TEST(ContactsAnalysis, ARunWithoutClogFilesHasNoMetrics) {
  TempDir dir;
  rundir::RunData data;
  data.dir = dir.Path();
  const PassOptions pass;
  const RunView view = MakeRunView(data, pass);
  const auto analysis = MakeContactsAnalysis(nullptr, "/report/contacts");
  const nlohmann::json result = analysis->Start(view)->Finish();
  EXPECT_EQ(result.at("present"), false);
  EXPECT_TRUE(analysis->RunMetrics(result).empty());
}

}  // namespace
}  // namespace granary::analysis
