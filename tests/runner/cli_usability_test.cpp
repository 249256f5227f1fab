// The CLI as a new user meets it, end to end on the real `campaign` binary with the
// fake engine: status counts that add up, several validated --only filters on run, status and
// report, plain errors for a --db that is no campaign database, a dry run that creates no file.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <nlohmann/json.hpp>

#include "runner/cli/common.h"
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
    std::ofstream(p) << json{
        {"name", "u"},
        {"replicas", replicas},
        {"base", {{"bodies", {{"count", 100}}}, {"silo", {{"width", 30}}}}},
        {"sweep",
         {{"grid", {{"/silo/base_outlets/0/width", json::parse(widths)}, {"/contact/mu", json::parse(mus)}}}}}};
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

// plan --db in a directory that does not exist yet makes it (the runs go beside the database);
// one that cannot be made is said plainly, without SQLite's "unable to open database file".
TEST_F(CliUsability, PlanMakesTheDatabaseDirectory) {
  const fs::path nested = dir_ / "new" / "study" / "g.db";
  auto r = Sh(testing::Campaign() + " plan " + WriteSpec("[4]", "[0.5]", 1) + " --db " + nested.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(nested));
  std::ofstream(dir_ / "afile") << "x";
  r = Sh(testing::Campaign() + " plan " + WriteSpec("[4]", "[0.5]", 1) + " --db " + (dir_ / "afile" / "g.db").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("cannot make the directory"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("unable to open database file"), std::string::npos) << r.output;
}

TEST_F(CliUsability, DryRunCreatesNoFile) {
  const auto r = Sh(Cmd("plan --dry-run " + WriteSpec("[4, 6]", "[0.5]", 1)));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("added 2"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(Db()));
  EXPECT_FALSE(fs::exists(Db() + "-wal"));
  EXPECT_FALSE(fs::exists(dir_ / "runs"));
}

TEST_F(CliUsability, TheEstimateTableKeepsItsColumnsApart) {
  // A range of core-hours is wider than the column's header: every cell still ends in two spaces.
  const auto r = Sh(Cmd("plan --dry-run " + WriteSpec("[4, 6]", "[0.5]", 1)));
  ASSERT_EQ(r.code, 0) << r.output;
  std::istringstream lines(r.output);
  int rows = 0;
  for (std::string line; std::getline(lines, line);) {
    const std::size_t at = line.find(" core-hours");
    if (line.rfind("  ", 0) != 0 || at == std::string::npos) continue;  // the header and a row per point
    ++rows;
    EXPECT_EQ(line.substr(at + 11, 2), "  ") << line;
  }
  EXPECT_EQ(rows, 3) << r.output;
}

TEST_F(CliUsability, ShowTellsEverythingAboutOneRun) {
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4, 6]", "[0.5]", 1))).code, 0);
  ASSERT_EQ(Sh(RunCmd("--jobs 1")).code, 0);
  const json runs = Status()["runs"];
  const std::string id = runs[0]["run_id"];
  // A unique start of the id will do.
  auto r = Sh(Cmd("show " + id.substr(0, 5)));
  ASSERT_EQ(r.code, 0) << r.output;
  for (const std::string& expected :
       {"run " + id + " of campaign u", std::string(" done: discharged, 4 exits of 100 bodies, t_end 4\n"),
        std::string("  attempts "), std::string("results (summary.json):"), std::string(" *silo/base_outlets/0/width"),
        std::string("  contact/kn"), std::string("engine.log (last"), std::string("summary.json")})
    EXPECT_NE(r.output.find(expected), std::string::npos) << expected << "\n" << r.output;
  // The same as JSON, found by its directory.
  r = Sh(Cmd("show --json " + runs[0]["run_dir"].get<std::string>()) + " 2>/dev/null");
  ASSERT_EQ(r.code, 0) << r.output;
  const json j = json::parse(r.output);
  EXPECT_EQ(j["run_id"], id);
  EXPECT_EQ(j["state"], "done");
  EXPECT_EQ(j["results"]["exited"], 4);
  EXPECT_TRUE(j["run_dir_exists"].get<bool>());
  EXPECT_FALSE(j["log_tail"].empty());
  bool has_summary = false;
  for (const auto& f : j["files"]) has_summary = has_summary || f["name"] == "summary.json";
  EXPECT_TRUE(has_summary) << j["files"].dump();
  // A typo is a usage error that names what there is.
  r = Sh(Cmd("show zz" + id.substr(2)));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("no run id starts with \"zz"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("did you mean"), std::string::npos) << r.output;
  r = Sh(Cmd("show"));
  EXPECT_EQ(r.code, 2);
}

// Two widths and a failing max_time (the fake engine fails at max_time 13): 4 runs.
TEST_F(CliUsability, CleanRemovesRetiredAndFailedRunsAndUnusedBedsAndSaysHowMuch) {
  auto spec = [&](const std::string& widths) {
    const fs::path p = dir_ / "c.json";
    std::ofstream(p) << json{
        {"name", "u"},
        {"replicas", 1},
        {"base", {{"bodies", {{"count", 100}}}, {"silo", {{"width", 30}}}}},
        {"sweep",
         {{"grid", {{"/silo/base_outlets/0/width", json::parse(widths)}, {"/discharge/max_time", {100, 13}}}}}}};
    return p.string();
  };
  ASSERT_EQ(Sh(Cmd("plan " + spec("[4, 6]"))).code, 0);
  EXPECT_EQ(Sh(RunCmd("--jobs 2 --retries 0")).code, 1);  // the two max_time = 13 runs fail
  ASSERT_EQ(Sh(Cmd("plan " + spec("[4]"))).code, 0);      // W = 6 retired: one done, one failed
  json s = Status();
  ASSERT_EQ(s["retired"], 2);
  std::map<std::string, fs::path> dir_of;  // state -> a run directory in it
  for (const auto& run : s["runs"]) dir_of[run["state"].get<std::string>()] = run["run_dir"].get<std::string>();
  ASSERT_TRUE(fs::exists(dir_of["done"]) && fs::exists(dir_of["failed"]));
  // The bed every run uses (the fake engine makes none): this campaign's alone, and another
  // campaign's bed in the cache, which clean must not touch.
  // (Replica seeds do not depend on the point, and a bed not on outlets or discharge: every
  // run of this campaign shares one bed.)
  const json params = json::parse(std::ifstream(dir_of["done"] / "run.json"));
  const fs::path bed = params["bed"]["cache_file"].get<std::string>();
  fs::create_directories(bed.parent_path());
  std::ofstream(bed) << std::string(5000, 'b');
  const fs::path other_bed = bed.parent_path() / "0123456789abcdef.bed";
  std::ofstream(other_bed) << std::string(700, 'o');

  // Dry run: says what and how much, removes nothing.
  auto r = Sh(Cmd("clean --dry-run --json") + " 2>/dev/null");
  ASSERT_EQ(r.code, 0) << r.output;
  json j = json::parse(r.output);
  EXPECT_TRUE(j["dry_run"].get<bool>());
  ASSERT_EQ(j["items"].size(), 2u) << j.dump();  // the two retired directories
  std::uintmax_t listed = 0;
  for (const auto& it : j["items"]) {
    EXPECT_EQ(it["kind"], "retired");
    EXPECT_TRUE(fs::exists(it["path"].get<std::string>()));
    listed += it["bytes"].get<std::uintmax_t>();
  }
  EXPECT_GT(listed, 0u);
  EXPECT_EQ(j["bytes"], listed);
  EXPECT_EQ(j["freed_bytes"], 0);
  r = Sh(Cmd("clean --dry-run"));
  EXPECT_NE(r.output.find("would free "), std::string::npos) << r.output;

  // The real thing: retired directories gone, space freed as listed; kept runs untouched.
  r = Sh(Cmd("clean --json") + " 2>/dev/null");
  ASSERT_EQ(r.code, 0) << r.output;
  j = json::parse(r.output);
  EXPECT_EQ(j["freed_bytes"], listed);
  for (const auto& it : j["items"]) EXPECT_FALSE(fs::exists(it["path"].get<std::string>()));
  s = Status();
  int kept = 0;
  for (const auto& run : s["runs"])
    if (run["state"] != "retired") kept += fs::exists(run["run_dir"].get<std::string>()) ? 1 : 0;
  EXPECT_EQ(kept, 2);

  // --failed and --beds: the remaining failed run's directory; the bed is still needed by it
  // (a failed run runs again), so it stays until nothing unfinished uses it.
  r = Sh(Cmd("clean --failed --beds --json") + " 2>/dev/null");
  ASSERT_EQ(r.code, 0) << r.output;
  j = json::parse(r.output);
  ASSERT_EQ(j["items"].size(), 1u) << j.dump();
  EXPECT_EQ(j["items"][0]["kind"], "failed");
  EXPECT_TRUE(fs::exists(bed));
  // Once every run of W = 4 is done, the bed is nobody's need: --beds frees it, and only it.
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4]", "[0.5]", 1))).code, 0);
  ASSERT_EQ(Sh(RunCmd()).code, 0);
  r = Sh(Cmd("clean --beds --json") + " 2>/dev/null");
  ASSERT_EQ(r.code, 0) << r.output;
  j = json::parse(r.output);
  ASSERT_EQ(j["items"].size(), 1u) << j.dump();
  EXPECT_EQ(j["items"][0]["kind"], "bed");
  EXPECT_EQ(j["freed_bytes"], 5000);
  EXPECT_FALSE(fs::exists(bed));
  EXPECT_TRUE(fs::exists(other_bed));
  // Nothing left to give back.
  r = Sh(Cmd("clean --retired --failed --beds"));
  EXPECT_NE(r.output.find("freed 0 B"), std::string::npos) << r.output;
}

TEST_F(CliUsability, ExportTakesTheSameOnlyFilters) {
#ifdef GRANARY_HAVE_ANALYSIS
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4, 6, 8]", "[0.3, 0.5]", 1))).code, 0);
  ASSERT_EQ(Sh(RunCmd("--jobs 2")).code, 0);
  auto r = Sh(Cmd("export --format json --only width=4 --only width=8") + " 2>/dev/null");
  ASSERT_EQ(r.code, 0) << r.output;
  const json rows = json::parse(r.output);
  ASSERT_EQ(rows.size(), 4u) << rows.dump();
  for (const auto& row : rows) EXPECT_NE(row["base_outlets.0.width"], 6) << row.dump();
  r = Sh(Cmd("export --only width=5"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("no run has /silo/base_outlets/0/width = 5"), std::string::npos) << r.output;
#else
  GTEST_SKIP() << "no analysis library in this build";
#endif
}

// The schema an editor checks specs with: every shipped campaign passes it, and the mistakes
// the validator refuses (an unknown key, a value out of range, a wrong type) fail it too.
// Checked by python3-jsonschema, the validator VS Code's JSON support agrees with on draft-07.
TEST_F(CliUsability, SchemaAcceptsTheShippedCampaignsAndRefusesWhatTheValidatorRefuses) {
  const fs::path schema = dir_ / "campaign.schema.json";
  auto r = Sh(testing::Campaign() + " schema --out " + schema.string());
  ASSERT_EQ(r.code, 0) << r.output;
  const json s = json::parse(std::ifstream(schema));
  EXPECT_EQ(s["$schema"], "http://json-schema.org/draft-07/schema#");
  EXPECT_EQ(s["properties"]["base"]["$ref"], "#/definitions/run_spec") << s["properties"]["base"].dump();
  const json& mu = s["definitions"]["run_spec"]["properties"]["contact"]["properties"]["mu"];
  EXPECT_EQ(mu["default"], 0.5) << mu.dump();
  EXPECT_EQ(mu["minimum"], 0.0) << mu.dump();
  // The repository's copy (docs/campaign.schema.json, for editors that fetch it) is this one.
  const fs::path copy = fs::path(GRANARY_SOURCE_DIR) / "docs" / "campaign.schema.json";
  ASSERT_TRUE(fs::exists(copy)) << "update it with: build/bin/campaign schema --out docs/campaign.schema.json";
  EXPECT_EQ(json::parse(std::ifstream(copy)), s)
      << "docs/campaign.schema.json is stale; update it with: build/bin/campaign schema --out docs/campaign.schema.json";

  auto validates = [&](const fs::path& spec) {
    return Sh(
        "python3 -c 'import json, sys, jsonschema; jsonschema.validate(json.load(open(sys.argv[2])), "
        "json.load(open(sys.argv[1])))' " +
        schema.string() + " " + spec.string());
  };
  int shipped = 0;
  for (const auto& e : fs::directory_iterator(fs::path(GRANARY_SOURCE_DIR) / "campaigns")) {
    if (e.path().extension() != ".json") continue;
    const auto v = validates(e.path());
    EXPECT_EQ(v.code, 0) << e.path() << ":\n" << v.output;
    ++shipped;
  }
  EXPECT_GT(shipped, 5);
  const json good = {{"name", "u"},
                     {"replicas", 2},
                     {"base", {{"contact", {{"mu", 0.3}}}}},
                     {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {4, 6}}}}}}};
  const fs::path spec = dir_ / "s.json";
  std::ofstream(spec) << good;
  EXPECT_EQ(validates(spec).code, 0) << validates(spec).output;
  {
    json adaptive = good;
    adaptive["replicas"] =
        json::parse(R"({"min": 3, "max": 50, "until": [{"metric": "avalanche_size", "rel_se": 0.05}]})");
    std::ofstream(spec, std::ios::trunc) << adaptive;
    EXPECT_EQ(validates(spec).code, 0) << validates(spec).output;
    EXPECT_EQ(Sh(Cmd("plan --dry-run " + spec.string())).code, 0);
  }
  for (const auto& [pointer, bad] : std::vector<std::pair<std::string, json>>{
           {"/replicas", {{"min", 2}, {"max", 5}}},  // no target
           {"/replicas",
            {{"max", 5}, {"until", {{"metric", "q_count"}, {"se", 1}, {"rel_se", 1}}}}},  // two targets in one
           {"/base/contact/muu", 0.3},        // unknown key (did you mean mu)
           {"/base/contact/mu", -0.1},        // below its minimum
           {"/replicas", "two"},              // wrong type
           {"/base/discharge/mode", "drain"}  // not one of the modes
       }) {
    json j = good;
    j[json::json_pointer(pointer)] = bad;
    std::ofstream(spec, std::ios::trunc) << j;
    EXPECT_NE(validates(spec).code, 0) << pointer << " = " << bad.dump() << " passed the schema";
    EXPECT_EQ(Sh(Cmd("plan --dry-run " + spec.string())).code, 2) << pointer << ": the validator took it";
  }
}

// Bash completes verbs, a verb's flags, run ids and --only filters, through the real script.
TEST_F(CliUsability, BashCompletesVerbsFlagsRunIdsAndFilters) {
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4, 6]", "[0.5]", 1))).code, 0);
  const fs::path script = dir_ / "campaign.bash";
  ASSERT_EQ(Sh(testing::Campaign() + " completion bash > " + script.string()).code, 0);
  // COMPREPLY for the words typed so far (the last one being completed).
  auto complete = [&](const std::string& words) {
    const fs::path t = dir_ / "complete.sh";
    std::ofstream(t, std::ios::trunc) << "source " << script.string() << "\nCOMP_WORDS=(" << testing::Campaign() << " "
                                      << words << ")\nCOMP_CWORD=$((${#COMP_WORDS[@]} - 1))\n"
                                      << "[[ \"" << words
                                      << "\" == *' ' ]] && COMP_WORDS+=('') && COMP_CWORD=$((${#COMP_WORDS[@]} - 1))\n"
                                      << "_campaign\nprintf '%s\\n' \"${COMPREPLY[@]}\"\n";
    const auto r = Sh("bash " + t.string() + " 2>&1");
    EXPECT_EQ(r.code, 0) << r.output;
    return r.output;
  };
  EXPECT_EQ(complete("s"), "status\nscan\nshow\nschema\nsnapshot\n");
  EXPECT_EQ(complete("clean --d"), "--db\n--dry-run\n");
  const json runs = Status()["runs"];
  const std::string id = runs[0]["run_id"];
  EXPECT_EQ(complete("show --db " + Db() + " " + id.substr(0, 4)), id + "\n");
  const std::string only = complete("status --db " + Db() + " --only /silo");
  EXPECT_NE(only.find("/silo/base_outlets/0/width=4"), std::string::npos) << only;
  EXPECT_NE(only.find("/silo/base_outlets/0/width=6"), std::string::npos) << only;
  // Unknown verbs and a missing database complete to nothing rather than to an error.
  EXPECT_EQ(complete("frobnicate --"), "\n");
  EXPECT_EQ(complete("show --db /nonexistent/g.db "), "\n");
}

// Every verb of the table (cli/verbs.cpp) is listed by `campaign --help`, completed as a verb,
// has its own help and completes its flags; its operand completes as its row says.
TEST_F(CliUsability, EveryVerbOfTheTableHasHelpFlagsAndCompletion) {
  const auto help = Sh(testing::Campaign() + " --help");
  ASSERT_EQ(help.code, 0);
  std::vector<std::string> verbs;
  std::istringstream lines(help.output.substr(help.output.find("verbs:\n") + 7));
  for (std::string line; std::getline(lines, line) && !line.empty();)
    verbs.push_back(line.substr(2, line.find(' ', 2) - 2));
  ASSERT_EQ(verbs.size(), cli::Verbs().size()) << help.output;
  std::string all;
  for (const auto& v : verbs) all += v + "\n";
  EXPECT_EQ(Sh(testing::Campaign() + " __complete 1 campaign").output, all + "--help\n--version\n");
  for (const auto& v : verbs) {
    const auto h = Sh(testing::Campaign() + " " + v + " --help");
    EXPECT_EQ(h.code, 0) << v;
    EXPECT_EQ(h.output.rfind("usage: campaign " + v, 0), 0u) << h.output;
    const auto flags = Sh(testing::Campaign() + " __complete 2 campaign " + v + " --").output;
    EXPECT_NE(flags.find("--help\n"), std::string::npos) << v << ": " << flags;
    // Every flag that completion offers is one the parser knows (its help names it).
    std::istringstream offered(flags);
    for (std::string flag; std::getline(offered, flag);) {
      if (flag == "--help") continue;
      EXPECT_NE(h.output.find(flag.substr(2)), std::string::npos) << v << " " << flag;
    }
  }
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4]", "[0.5]", 1))).code, 0);
  const std::string id = Status()["runs"][0]["run_id"];
  const std::map<std::string, std::string> operand = {{"plan", "__files__\n"},
                                                      {"compare", "__files__\n"},
                                                      {"dump", "__files__\n"},
                                                      {"completion", "bash\n"},
                                                      {"show", id + "\n"},
                                                      {"snapshot", id + "\n"},
                                                      {"movie", id + "\n"},
                                                      {"status", ""},
                                                      {"run", ""}};
  for (const auto& [v, expected] : operand)
    EXPECT_EQ(Sh(testing::Campaign() + " __complete 4 campaign " + v + " --db " + Db() + " ''").output, expected) << v;
}

// Several --help texts left out the exit codes.
TEST_F(CliUsability, EveryVerbsHelpSaysItsExitCodes) {
  const auto help = Sh(testing::Campaign() + " --help");
  ASSERT_EQ(help.code, 0) << help.output;
  int verbs = 0;
  std::istringstream lines(help.output.substr(help.output.find("verbs:\n") + 7));
  for (std::string line; std::getline(lines, line) && !line.empty();) {
    const std::string verb = line.substr(2, line.find(' ', 2) - 2);
    ++verbs;
    const auto r = Sh(testing::Campaign() + " " + verb + " --help");
    EXPECT_EQ(r.code, 0) << verb << ": " << r.output;
    EXPECT_NE(r.output.find("Exit: 0"), std::string::npos) << verb << ":\n" << r.output;
  }
  EXPECT_GE(verbs, 10) << help.output;
}

// The run-time progress line's ETA counted up between two progress reports, the
// bed phase showed "t 33.6/0.0", and status showed an ETA with no runner alive.
TEST_F(CliUsability, StatusHasNoEtaWithoutARunnerAtWork) {
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4, 6]", "[0.5]", 1))).code, 0);
  const auto status = Sh(Cmd("status"));
  EXPECT_EQ(status.code, 0) << status.output;
  EXPECT_NE(status.output.find("ETA - (no runner at work: campaign run continues)"), std::string::npos)
      << status.output;
  EXPECT_TRUE(Status()["eta_s"].is_null());
  // A run left running in its bed phase by a runner that is gone: its simulated time alone
  // (the bed has no end time), and still no ETA.
  ASSERT_EQ(Sh("sqlite3 " + Db() +
               " \"UPDATE runs SET state = 'running', progress = "
               "'{\\\"phase\\\": \\\"bed\\\", \\\"fraction\\\": 0.3, \\\"t\\\": 33.6, \\\"t_end\\\": 0.0, "
               "\\\"exited\\\": 0, \\\"wall_s\\\": 2.0}' WHERE rowid = 1\"")
                .code,
            0);
  const auto bed = Sh(Cmd("status"));
  EXPECT_NE(bed.output.find("t 33.6  0 exits"), std::string::npos) << bed.output;
  EXPECT_EQ(bed.output.find("33.6/"), std::string::npos) << bed.output;
  EXPECT_NE(bed.output.find("(runner gone: resumes on the next campaign run)"), std::string::npos) << bed.output;
  EXPECT_NE(bed.output.find("ETA - (no runner at work"), std::string::npos) << bed.output;
}

// GRANARY_CACHE_DIR set at run time was ignored without a word (the plan fixes it).
TEST_F(CliUsability, ACacheDirectorySetAtRunTimeIsSaidToBeFixedByThePlan) {
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4]", "[0.5]", 1))).code, 0);
  const auto r = Sh("GRANARY_CACHE_DIR=" + (dir_ / "elsewhere").string() + " " + RunCmd());
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("note: GRANARY_CACHE_DIR=" + (dir_ / "elsewhere").string() +
                          " is not used: the plan fixed the prepared beds' directory at " + (dir_ / "beds").string()),
            std::string::npos)
      << r.output;
  // The same directory as planned: no note.
  ASSERT_EQ(Sh(Cmd("plan " + WriteSpec("[4, 5]", "[0.5]", 1))).code, 0);
  EXPECT_EQ(Sh(RunCmd()).output.find("note: GRANARY_CACHE_DIR"), std::string::npos);
}

}  // namespace
}  // namespace granary::runner
