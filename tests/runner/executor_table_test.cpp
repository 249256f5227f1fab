// The executor table (runner/executors.h) is what `campaign run` offers: every row is accepted
// by --executor and by the spec's executor block, its name, summary and flags are in `campaign
// run --help`, and its flags are refused with another executor; a name not in the table is
// refused with the table's names. On the real `campaign` binary; nothing is run or submitted.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "runner/campaign_spec.h"
#include "runner/executors.h"
#include "test_util.h"

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::Sh;

class ExecutorTable : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir();
    std::ofstream(dir_ / "c.json") << json{{"name", "e"}, {"base", {{"bodies", {{"count", 10}}}}}};
    ASSERT_EQ(Sh(Cmd("plan " + (dir_ / "c.json").string())).code, 0);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Cmd(const std::string& verb_and_flags) const {
    return testing::Campaign() + " " + verb_and_flags + " --db " + (dir_ / "e.db").string() + " 2>&1";
  }
  fs::path dir_;
};

bool Owns(const ExecutorRow& row, const std::string& flag) {
  return std::any_of(row.flags.begin(), row.flags.end(), [&](const auto& f) { return f.first == flag; });
}

TEST_F(ExecutorTable, EveryRowIsListedByRunHelpWithItsFlags) {
  ASSERT_GE(ExecutorRows().size(), 2u);
  const auto help = Sh(testing::Campaign() + " run --help");
  ASSERT_EQ(help.code, 0);
  for (const ExecutorRow& row : ExecutorRows()) {
    EXPECT_NE(help.output.find(std::string(row.name) + " "), std::string::npos) << row.name << "\n" << help.output;
    EXPECT_NE(help.output.find(row.summary), std::string::npos) << row.name;
    for (const auto& [flag, takes_value] : row.flags)
      EXPECT_NE(help.output.find("--" + flag), std::string::npos) << row.name << ": --" << flag;
  }
}

TEST_F(ExecutorTable, EveryRowIsAnExecutorOfRunAndOfTheSpecAndItsFlagsAreItsOwn) {
  for (const ExecutorRow& row : ExecutorRows()) {
    // The spec's block accepts the row's name (the plan checks it).
    EXPECT_NO_THROW(CampaignSpec::FromJson(json{{"name", "t"}, {"executor", {{"type", row.name}}}})) << row.name;
    // --executor NAME passes, and a flag of another executor is then refused as that one's:
    // the table, not a list of names, decided both.
    bool tried = false;
    for (const ExecutorRow& other : ExecutorRows()) {
      if (&other == &row) continue;
      for (const auto& [flag, takes_value] : other.flags) {
        if (Owns(row, flag)) continue;
        const auto r = Sh(Cmd("run --executor " + std::string(row.name) + " --" + flag + (takes_value ? " 1" : "")));
        EXPECT_EQ(r.code, 2) << r.output;
        EXPECT_NE(r.output.find("--" + flag + ": only with --executor " + other.name), std::string::npos)
            << row.name << " --" << flag << ": " << r.output;
        tried = true;
        break;
      }
    }
    EXPECT_TRUE(tried) << row.name << ": no other executor has a flag of its own to try it with";
  }
}

TEST_F(ExecutorTable, ANameNotInTheTableIsRefusedWithTheTablesNames) {
  const auto r = Sh(Cmd("run --executor pbs"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--executor: must be " + ExecutorNames(false) + " (got \"pbs\")"), std::string::npos)
      << r.output;
  try {
    CampaignSpec::FromJson(json{{"name", "t"}, {"executor", {{"type", "pbs"}}}});
    ADD_FAILURE() << "no error";
  } catch (const SpecError& e) {
    EXPECT_EQ(std::string(e.what()), "/executor/type: must be " + ExecutorNames(true) + " (got \"pbs\")");
  }
}

}  // namespace
}  // namespace granary::runner
