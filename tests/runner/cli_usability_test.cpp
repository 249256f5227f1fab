// The CLI as a new user meets it (issue 18), end to end on the real `campaign` binary with the
// fake engine: status counts that add up, several validated --only filters on run, status and
// report, plain errors for a --db that is no campaign database, a dry run that creates no file.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "test_util.h"

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::Sh;

class CliUsability : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir();
    setenv("GRANARY_CACHE_DIR", (dir_ / "beds").c_str(), 1);
    setenv("FAKE_ENGINE_STEPS", "4", 1);
    setenv("FAKE_ENGINE_STEP_MS", "5", 1);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // widths x mu x replicas runs.
  std::string WriteSpec(const std::string& widths, const std::string& mus, int replicas) {
    const fs::path p = dir_ / "c.json";
    std::ofstream(p) << json{{"name", "u"},
                             {"replicas", replicas},
                             {"base", {{"bodies", {{"count", 100}}}, {"silo", {{"width", 30}}}}},
                             {"sweep",
                              {{"grid", {{"/silo/base_outlets/0/width", json::parse(widths)},
                                         {"/contact/mu", json::parse(mus)}}}}}};
    return p.string();
  }
  std::string Db() const { return (dir_ / "g.db").string(); }
  std::string Cmd(const std::string& verb_and_flags) const {
    return testing::Campaign() + " " + verb_and_flags + " --db " + Db();
  }
  std::string RunCmd(const std::string& flags = "") const {
    return Cmd("run --engine " + testing::FakeEngine() + " " + flags);
  }
  json Status(const std::string& flags = "") const {
    const auto r = Sh(Cmd("status --json " + flags) + " 2>/dev/null");
    EXPECT_EQ(r.code, 0) << r.output;
    return json::parse(r.output);
  }
  fs::path dir_;
};

int Sum(const json& counts) {
  int n = 0;
  for (const auto& [state, k] : counts.items()) n += k.get<int>();
  return n;
}

TEST_F(CliUsability, StatusCountsAddUpAndRetiredRunsStandApart) {
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4, 6]", "[0.5]", 2))).code, 0);
  ASSERT_EQ(Sh(RunCmd("--jobs 2")).code, 0);
  // The edited spec drops W = 6: its two runs are retired.
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4]", "[0.5]", 2))).code, 0);
  const json s = Status();
  EXPECT_EQ(s["total"], 2);
  EXPECT_EQ(s["retired"], 2);
  EXPECT_FALSE(s["counts"].contains("retired")) << s["counts"].dump();
  EXPECT_EQ(Sum(s["counts"]), s["total"].get<int>()) << s["counts"].dump();
  for (const auto& run : s["runs"]) {
    // A finished run has no progress: its last progress.json is history, not progress.
    EXPECT_FALSE(run.contains("progress")) << run.dump();
  }
  const auto text = Sh(Cmd("status"));
  EXPECT_NE(text.output.find("2 runs"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("planned 0, running 0, done 2, failed 0, interrupted 0  (and 2 retired"),
            std::string::npos)
      << text.output;
  EXPECT_NE(text.output.find("ETA -"), std::string::npos) << text.output;
}

TEST_F(CliUsability, SeveralOnlyFiltersOnRunStatusAndReport) {
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4, 6, 8]", "[0.3, 0.5]", 1))).code, 0);
  // Values of one parameter are alternatives; a short name ends one sweep axis.
  auto r = Sh(RunCmd("--only width=4 --only /silo/base_outlets/0/width=8"));
  ASSERT_EQ(r.code, 0) << r.output;
  json s = Status();
  EXPECT_EQ(s["counts"]["done"], 4);
  for (const auto& run : s["runs"])
    EXPECT_EQ(run["state"], run["point"]["/silo/base_outlets/0/width"] == 6 ? "planned" : "done") << run.dump();
  // Different parameters must all hold.
  s = Status("--only width=6 --only mu=0.3");
  EXPECT_EQ(s["total"], 1);
  EXPECT_EQ(s["only"], json::array({"/silo/base_outlets/0/width=6", "/contact/mu=0.3"}));
  ASSERT_EQ(Sh(RunCmd("--only " + s["runs"][0]["run_id"].get<std::string>().substr(0, 6))).code, 0);
  EXPECT_EQ(Status("--only width=6")["counts"]["done"], 1);

  // Filters that select nothing are errors that say what there is.
  r = Sh(RunCmd("--only width=5"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("no run has /silo/base_outlets/0/width = 5 (its values: 4.0, 6.0, 8.0)"), std::string::npos)
      << r.output;
  r = Sh(Cmd("status --only wdth=4"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("\"wdth\" ends no sweep axis"), std::string::npos) << r.output;
  r = Sh(Cmd("status --only zz99"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("no run id starts with \"zz99\""), std::string::npos) << r.output;
  r = Sh(Cmd("status --only /contact/muu=0.3"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("did you mean \"/contact/mu\"?"), std::string::npos) << r.output;
#ifdef GRANARY_HAVE_ANALYSIS
  r = Sh(Cmd("report --no-figures --only mu=0.5 --out " + (dir_ / "rep").string()));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("runs used 2, missing 1,"), std::string::npos) << r.output;
  r = Sh(Cmd("report --no-figures --only mu=0.7"));
  EXPECT_EQ(r.code, 2) << r.output;
#endif
}

TEST_F(CliUsability, ADbThatIsNoCampaignDatabaseIsSaidPlainly) {
  const fs::path text = dir_ / "notes.txt";
  std::ofstream(text) << "these are my notes, not a database\n";
  auto r = Sh(testing::Campaign() + " status --db " + text.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find(text.string() + " is not a campaign database"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("SQLite code"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("PRAGMA"), std::string::npos) << r.output;

  r = Sh(testing::Campaign() + " status --db " + dir_.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find(dir_.string() + " is a directory"), std::string::npos) << r.output;

  // Somebody else's SQLite file is refused, and left as it was.
  const fs::path other = dir_ / "other.sqlite";
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(other.c_str(), &db), SQLITE_OK);
  sqlite3_exec(db, "CREATE TABLE birds (name TEXT)", nullptr, nullptr, nullptr);
  sqlite3_close(db);
  r = Sh(testing::Campaign() + " status --db " + other.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("is an SQLite database but not a campaign database (it has the tables birds)"),
            std::string::npos)
      << r.output;
  r = Sh(testing::Campaign() + " plan " + WriteSpec("[4]", "[0.5]", 1) + " --db " + other.string());
  EXPECT_NE(r.code, 0);
  ASSERT_EQ(sqlite3_open(other.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* q = nullptr;
  sqlite3_prepare_v2(db, "SELECT count(*) FROM sqlite_master WHERE type = 'table'", -1, &q, nullptr);
  ASSERT_EQ(sqlite3_step(q), SQLITE_ROW);
  EXPECT_EQ(sqlite3_column_int(q, 0), 1);  // still only birds
  sqlite3_finalize(q);
  sqlite3_close(db);
}

TEST_F(CliUsability, DryRunCreatesNoFile) {
  const auto r = Sh(Cmd("plan --dry-run " + WriteSpec("[4, 6]", "[0.5]", 1)));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("added 2"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(Db()));
  EXPECT_FALSE(fs::exists(Db() + "-wal"));
  EXPECT_FALSE(fs::exists(dir_ / "runs"));
}

}  // namespace
}  // namespace granary::runner
