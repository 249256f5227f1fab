// A damaged run directory is never analysed as if it were whole. Real runs of the
// native engine; every file the analyses read is damaged in turn (cut in half, cut at a
// frame boundary, header-only, empty, garbage, changed in place), before and after a report
// has cached the run's analyses, and `report`, `export`, `status`, `show` and `scan --verify`
// must each say which run and file, keep it out of every number and exit as documented
// (docs/cli.md). Restoring the file makes the run whole again.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "rundir/files.h"
#include "test_util.h"

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::ReadFile;
using testing::Sh;

class DamagedRunsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(testing::MakeTempDir());
    setenv("GRANARY_CACHE_DIR", (*dir_ / "beds").c_str(), 1);
    const std::string engine = testing::BinDir() + "/granary-engine";
    if (!fs::exists(engine)) return;
    std::ofstream(*dir_ / "c.json") << R"({"name": "dmg", "seed": 3, "replicas": 1,
      "base": {"bodies": {"count": 60}, "silo": {"width": 12},
               "discharge": {"mode": "remove", "max_time": 3, "clog_window": 0.5},
               "output": {"frame_interval": 0.25, "contact_forces": true, "checkpoint_interval": 1}},
      "sweep": {"grid": {"/silo/base_outlets/0/width": [2.2, 7]}}})";
    if (Sh(Cmd("plan " + (*dir_ / "c.json").string())).code != 0) return;
    ran_ = Sh(Cmd("run --jobs 2")).code == 0;
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  void SetUp() override {
    if (!ran_) GTEST_SKIP() << "granary-engine not built or the campaign did not run";
  }
  static std::string Cmd(const std::string& verb_and_flags) {
    return testing::Campaign() + " " + verb_and_flags + " --db " + (*dir_ / "g.db").string();
  }
  static json Status() { return json::parse(Sh(Cmd("status --json") + " 2>/dev/null").output); }
  // The run directory of the run at outlet width `width`.
  static fs::path RunDir(double width) {
    const json status = Status();  // (a range-for over Status()["runs"] would outlive the temporary)
    for (const auto& r : status["runs"])
      if (r["point"]["/silo/base_outlets/0/width"].get<double>() == width) return r["run_dir"].get<std::string>();
    return {};
  }
  static std::string RunId(const fs::path& run_dir) { return run_dir.filename().string(); }
  static int ExportRows(const std::string& csv) {
    int n = -1;  // the header
    std::istringstream in(csv);
    for (std::string line; std::getline(in, line);) n += line.empty() ? 0 : 1;
    return n;
  }
  static fs::path* dir_;
  static bool ran_;
};

fs::path* DamagedRunsTest::dir_ = nullptr;
bool DamagedRunsTest::ran_ = false;

struct Damage {
  std::string name;
  std::string file;
  std::string says;  // what the damaged run's problem must contain
};

// Applies one damage to `file` (whose original text is `text`).
void Apply(const std::string& name, const fs::path& file, const std::string& text) {
  if (name == "cut in half") fs::resize_file(file, text.size() / 2);
  if (name == "cut at a frame boundary") fs::resize_file(file, text.find("ITEM: TIME\n", text.size() / 2));
  if (name == "header only") fs::resize_file(file, text.find('\n') + 1);
  if (name == "empty") fs::resize_file(file, 0);
  if (name == "garbage") std::ofstream(file) << "{\"engine\": \"native\", \"exited\": ";
  if (name == "changed in place") {
    std::string changed = text;
    const std::size_t at = changed.find_last_of("0123456789");
    changed[at] = changed[at] == '1' ? '2' : '1';
    std::ofstream(file, std::ios::binary) << changed;
  }
}

TEST_F(DamagedRunsTest, EveryFileTheAnalysesReadBeforeAndAfterACachedReport) {
  const fs::path run = RunDir(7), other = RunDir(2.2);
  ASSERT_FALSE(run.empty());
  ASSERT_FALSE(other.empty());
  // The run kept a clog? Either way both clog files exist and are in the manifest.
  const json manifest = json::parse(ReadFile(run / "manifest.json"));
  for (const char* f : {"run.json", "summary.json", "events.csv", "frames.dump", "contacts.dump", "clog_frames.dump",
                        "clog_contacts.dump"})
    ASSERT_TRUE(manifest["files"].contains(f)) << f << ": " << manifest.dump();
  ASSERT_GT(manifest["counts"]["frames"].get<int>(), 3);
  ASSERT_GT(manifest["counts"]["events"].get<int>(), 3);

  const std::vector<Damage> damages = {
      {"cut in half", "frames.dump", "(cut short)"},
      {"cut at a frame boundary", "frames.dump", "frames readable, the manifest records"},
      {"changed in place", "frames.dump", "(changed in place)"},
      {"cut in half", "contacts.dump", "(cut short)"},
      {"cut in half", "events.csv", "(cut short)"},
      {"header only", "events.csv", "0 rows, summary.json says"},
      {"empty", "events.csv", "0 rows, summary.json says"},
      {"garbage", "summary.json", "not valid JSON"},
      {"changed in place", "run.json", "(changed in place)"},
      {"cut in half", "clog_frames.dump", ""},
      {"changed in place", "clog_contacts.dump", ""},
  };
  for (const bool cached : {true, false}) {
    for (const Damage& d : damages) {
      const fs::path file = run / d.file;
      const std::string text = ReadFile(file);
      if (text.size() < 2) continue;  // an empty clog file (no clog): nothing to cut
      const std::string what = d.name + " " + d.file + (cached ? " after a cached report" : " before any report");
      if (cached) {
        const auto clean = Sh(Cmd("report --no-figures"));
        ASSERT_EQ(clean.code, 0) << what << "\n" << clean.output;
      } else {
        fs::remove_all(run / "analyses");
        fs::remove_all(other / "analyses");
      }
      Apply(d.name, file, text);

      const auto report = Sh(Cmd("report --no-figures"));
      EXPECT_EQ(report.code, 4) << what << "\n" << report.output;
      EXPECT_NE(report.output.find("runs used 1, "), std::string::npos) << what << "\n" << report.output;
      EXPECT_NE(report.output.find("damaged 1"), std::string::npos) << what << "\n" << report.output;
      EXPECT_NE(report.output.find("report: run " + RunId(run) +
                                   " (silo/base_outlets/0/width=7 r0) is damaged and left out:"),
                std::string::npos)
          << what << "\n"
          << report.output;
      EXPECT_NE(report.output.find("\n    " + d.file + ": "), std::string::npos) << what << "\n" << report.output;
      EXPECT_NE(report.output.find(d.says), std::string::npos) << what << "\n" << report.output;
      const std::string md = ReadFile(*dir_ / "report" / "report.md");
      EXPECT_NE(md.find("Damaged runs"), std::string::npos) << what;
      EXPECT_NE(md.find("| " + d.file + " |"), std::string::npos) << what;

      // (the table to a file: the run's name on stderr, the table without it)
      const auto exported = Sh(Cmd("export --out " + (*dir_ / "runs.csv").string()));
      EXPECT_EQ(exported.code, 4) << what << "\n" << exported.output;
      const std::string table = ReadFile(*dir_ / "runs.csv");
      EXPECT_EQ(ExportRows(table), 1) << what << "\n" << table;
      EXPECT_EQ(table.find(RunId(run)), std::string::npos) << what;
      EXPECT_NE(
          exported.output.find("export: run " + RunId(run) +
                               " (silo/base_outlets/0/width=7 r0) is damaged and left out:\n    " + d.file + ": "),
          std::string::npos)
          << what << "\n"
          << exported.output;

      const json status = Status();
      EXPECT_EQ(status["damaged"], 1) << what;
      for (const auto& r : status["runs"]) {
        if (r["run_id"] != RunId(run)) continue;
        EXPECT_EQ(r["integrity"], "damaged") << what;
        EXPECT_FALSE(r.contains("metrics")) << what << ": a damaged run's metrics are no numbers of the campaign";
      }
      const auto text_status = Sh(Cmd("status"));
      EXPECT_NE(text_status.output.find("damaged: 1 done run(s)"), std::string::npos) << what << "\n"
                                                                                      << text_status.output;
      const auto show = Sh(Cmd("show " + RunId(run)));
      EXPECT_NE(show.output.find("damaged"), std::string::npos) << what << "\n" << show.output;
      const auto scan = Sh(Cmd("scan --verify"));
      EXPECT_EQ(scan.code, 4) << what << "\n" << scan.output;
      EXPECT_NE(scan.output.find("1 whole, 1 damaged, 0 not verifiable"), std::string::npos) << what << "\n"
                                                                                             << scan.output;
      EXPECT_NE(scan.output.find("  damaged " + RunId(run) + ":\n    " + d.file + ": "), std::string::npos)
          << what << "\n"
          << scan.output;

      // Restored, the run is whole again and used again.
      std::ofstream(file, std::ios::binary) << text;
      const auto again = Sh(Cmd("report --no-figures"));
      EXPECT_EQ(again.code, 0) << what << "\n" << again.output;
      EXPECT_NE(again.output.find("runs used 2, "), std::string::npos) << what << "\n" << again.output;
      EXPECT_EQ(Sh(Cmd("scan --verify")).code, 0) << what;
    }
  }
}

TEST_F(DamagedRunsTest, ARunWithoutAManifestIsUsedAndSaidNotVerifiable) {
  const fs::path run = RunDir(7);
  const std::string manifest = ReadFile(run / "manifest.json");
  fs::remove(run / "manifest.json");
  const auto report = Sh(Cmd("report --no-figures"));
  EXPECT_EQ(report.code, 0) << report.output;
  EXPECT_NE(report.output.find("runs used 2, "), std::string::npos) << report.output;
  EXPECT_NE(report.output.find("not verifiable 1"), std::string::npos) << report.output;
  EXPECT_NE(report.output.find("1 of 2 used runs are not verifiable"), std::string::npos) << report.output;
  EXPECT_NE(ReadFile(*dir_ / "report" / "report.md").find("**not verifiable**"), std::string::npos);
  const auto scan = Sh(Cmd("scan --verify"));
  EXPECT_EQ(scan.code, 0) << scan.output;
  EXPECT_NE(scan.output.find("1 whole, 0 damaged, 1 not verifiable"), std::string::npos) << scan.output;
  // Still cross-checked: events.csv against summary.json.
  const std::string events = ReadFile(run / "events.csv");
  fs::resize_file(run / "events.csv", events.find('\n') + 1);
  const auto damaged = Sh(Cmd("report --no-figures"));
  EXPECT_EQ(damaged.code, 4) << damaged.output;
  EXPECT_NE(damaged.output.find("events.csv: 0 rows, summary.json says"), std::string::npos) << damaged.output;
  std::ofstream(run / "events.csv", std::ios::binary) << events;
  std::ofstream(run / "manifest.json", std::ios::binary) << manifest;
  EXPECT_EQ(Sh(Cmd("report --no-figures")).code, 0);
}

// Two reports into one --out at once lost figure links; the second now waits for
// the first and says so.
TEST_F(DamagedRunsTest, ASecondReportIntoTheSameFolderWaitsAndSaysSo) {
  const fs::path out = *dir_ / "report2";
  fs::create_directories(out);
  const std::string log = (*dir_ / "report2.log").string();
  pid_t pid = -1;
  {
    const FileLock held(out / ".report.lock");  // as a report writing there holds it
    pid = testing::Spawn(
        {testing::Campaign(), "report", "--no-figures", "--out", out.string(), "--db", (*dir_ / "g.db").string()}, log);
    ASSERT_TRUE(testing::WaitFor(
        [&] { return ReadFile(log).find("another campaign report is writing") != std::string::npos; }, 120))
        << ReadFile(log);
    EXPECT_FALSE(fs::exists(out / "report.md"));
  }
  EXPECT_EQ(testing::WaitExit(pid), 0) << ReadFile(log);
  EXPECT_TRUE(fs::exists(out / "report.md"));
}

}  // namespace
}  // namespace granary::runner
