// manifest.json: written by WriteDone with the sizes, checksums and counts of what the run
// directory holds, and VerifyRun's answer for every kind of damage to every file the
// analyses read (cut mid-frame, cut at a frame boundary, changed in place, header-only or
// empty events, garbage summary), cached by size and mtime, and for runs without a manifest.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "rundir/clogs.h"
#include "rundir/contacts.h"
#include "rundir/events.h"
#include "rundir/frames.h"
#include "rundir/manifest.h"
#include "rundir/run_directory.h"
#include "rundir/summary.h"
#include "test_util.h"

namespace granary::rundir {
namespace {

namespace fs = std::filesystem;
using analysis::testing::ReadFile;
using analysis::testing::TempDir;
using analysis::testing::WriteFile;

Frame FrameAt(std::int64_t step, int discs) {
  Frame f;
  f.timestep = step;
  f.time = static_cast<double>(step) * 1e-3;
  f.box[0][0] = -10;
  f.box[0][1] = 10;
  f.box[1][1] = 20;
  for (int k = 0; k < discs; ++k)
    f.discs.push_back({k + 1, k, 1, 0.1 * k, 0.5 + static_cast<double>(step) * 1e-4, 0.5, 0.785, 0.0, -0.1, 0.0});
  return f;
}

ContactFrame ContactsAt(std::int64_t step) {
  ContactFrame c;
  c.timestep = step;
  c.time = static_cast<double>(step) * 1e-3;
  c.contacts.push_back({0, 1, 0, 0, 1, 0, 0.5, 0, 1.0, 0.0});
  return c;
}

// A finished run: 3 exits, 4 frames (with contact frames), 1 clog; `gz` writes the dumps gzip.
void MakeRun(const fs::path& dir, bool gz = false) {
  fs::create_directories(dir);
  WriteRunSpec(dir, {{"run_id", "r1"}});
  EventWriter ev = EventWriter::Create(dir / kEventsFile);
  for (int k = 0; k < 3; ++k) ev.Write({0.5 * k, k, "disc", 0.785, 0});
  ev.Close();
  FrameWriter fw = FrameWriter::Create(dir / (gz ? kFramesGzFile : kFramesFile), gz);
  ContactWriter cw = ContactWriter::Create(dir / (gz ? kContactsGzFile : kContactsFile), gz);
  for (int k = 0; k < 4; ++k) {
    fw.Write(FrameAt(1000 * k, 5));
    cw.Write(ContactsAt(1000 * k));
  }
  fw.Close();
  cw.Close();
  ClogWriter clogs = ClogWriter::Create(dir);
  clogs.Write({FrameAt(2500, 3), ContactsAt(2500)});
  clogs.Close();
  Summary s;
  s.engine = "native";
  s.run_id = "r1";
  s.end_reason = "time_limit";
  s.bodies = 5;
  s.exited = 3;
  s.remaining = 2;
  s.exits_per_outlet = {3};
  WriteSummary(dir, s);
  WriteDone(dir, "time_limit");
}

std::string Texts(const Verification& v) { return v.Text(); }

TEST(Manifest, WriteDoneRecordsSizesChecksumsAndCounts) {
  TempDir t;
  MakeRun(t.Path());
  const auto m = ReadManifest(t.Path());
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(m->format, kManifestFormat);
  for (const char* name :
       {kRunSpecFile, kSummaryFile, kEventsFile, kFramesFile, kContactsFile, kClogFramesFile, kClogContactsFile}) {
    ASSERT_TRUE(m->files.count(name)) << name;
    EXPECT_EQ(m->files.at(name).size, fs::file_size(t.Path() / name)) << name;
    EXPECT_EQ(m->files.at(name).xxh3, FileXxh3(t.Path() / name)) << name;
  }
  EXPECT_EQ(m->counts.at("events"), 3);
  EXPECT_EQ(m->counts.at("frames"), 4);
  EXPECT_EQ(m->counts.at("contact_frames"), 4);
  EXPECT_EQ(m->counts.at("clogs"), 1);
  EXPECT_EQ(m->files.at(kFramesFile).count, 4);
  // The manifest is complete before DONE is: both exist, DONE holds the end reason.
  EXPECT_EQ(ReadFile(t.Path() / kDoneFile), "time_limit\n");
  // XXH3-64 of a known text (the reference value of xxhsum -H3 for "abc").
  WriteFile(t.Path() / "abc", "abc");
  EXPECT_EQ(FileXxh3(t.Path() / "abc"), "78af5f94892f3950");
}

TEST(Manifest, GzipDumpsAreCountedThroughTheirReader) {
  TempDir t;
  MakeRun(t.Path(), true);
  const auto m = ReadManifest(t.Path());
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(m->files.at(kFramesGzFile).count, 4);
  EXPECT_EQ(m->files.at(kContactsGzFile).count, 4);
  EXPECT_FALSE(m->files.count(kFramesFile));
  EXPECT_EQ(VerifyRun(t.Path()).integrity, Integrity::kWhole);
}

TEST(Manifest, AWholeRunIsHashedOnceThenByItsCachedSizesAndMtimes) {
  TempDir t;
  MakeRun(t.Path());
  const Verification first = VerifyRun(t.Path());
  EXPECT_EQ(first.integrity, Integrity::kWhole) << Texts(first);
  EXPECT_EQ(first.files_hashed, 7);
  const Verification second = VerifyRun(t.Path());
  EXPECT_EQ(second.integrity, Integrity::kWhole);
  EXPECT_EQ(second.files_hashed, 0);
  const Verification full = VerifyRun(t.Path(), {VerifyLevel::kChecksums, true});
  EXPECT_EQ(full.files_hashed, 7);
  EXPECT_EQ(VerifyRun(t.Path(), {VerifyLevel::kSizes, true}).files_hashed, 0);
}

TEST(Manifest, FramesCutInHalfOrAtAFrameBoundaryAreDamaged) {
  for (const bool boundary : {false, true}) {
    TempDir t;
    MakeRun(t.Path());
    ASSERT_EQ(VerifyRun(t.Path()).integrity, Integrity::kWhole);  // cached as whole first
    const fs::path frames = t.Path() / kFramesFile;
    const auto size = fs::file_size(frames);
    // A frame boundary: the start of the third frame.
    const std::string text = ReadFile(frames);
    std::size_t cut = size / 2;
    if (boundary) cut = text.find("ITEM: TIME\n", text.find("ITEM: TIME\n", 1) + 1);
    fs::resize_file(frames, cut);
    const Verification v = VerifyRun(t.Path());
    EXPECT_EQ(v.integrity, Integrity::kDamaged);
    ASSERT_FALSE(v.problems.empty());
    EXPECT_EQ(v.problems[0].file, kFramesFile);
    EXPECT_NE(
        v.Text().find(std::to_string(cut) + " bytes, the manifest records " + std::to_string(size) + " (cut short)"),
        std::string::npos)
        << v.Text();
    EXPECT_NE(v.Text().find(boundary ? "2 frames readable, the manifest records 4"
                                     : "frames readable, the manifest records 4"),
              std::string::npos)
        << v.Text();
    // The cheapest check (status) sees it too.
    EXPECT_EQ(VerifyRun(t.Path(), {VerifyLevel::kSizes, true}).integrity, Integrity::kDamaged);
  }
}

TEST(Manifest, AByteChangedInPlaceIsFoundAfterTheRunWasVerified) {
  TempDir t;
  MakeRun(t.Path());
  ASSERT_EQ(VerifyRun(t.Path()).integrity, Integrity::kWhole);
  {
    std::fstream f(t.Path() / kContactsFile, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(-3, std::ios::end);
    f.put('7');
  }
  const Verification v = VerifyRun(t.Path());
  EXPECT_EQ(v.integrity, Integrity::kDamaged);
  EXPECT_NE(v.Text().find("contacts.dump: checksum"), std::string::npos) << v.Text();
  EXPECT_NE(v.Text().find("(changed in place)"), std::string::npos) << v.Text();
}

TEST(Manifest, TheCheapCheckHashesOnlyWhatChangedSinceItWasFoundWhole) {
  TempDir t;
  MakeRun(t.Path());
  const auto change = [&] {
    std::fstream f(t.Path() / kFramesFile, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(-3, std::ios::end);
    f.put('7');
  };
  // Never verified: the sizes alone (no file is hashed), so an in-place change is not seen yet.
  change();
  Verification v = VerifyRun(t.Path(), {VerifyLevel::kSizes, true});
  EXPECT_EQ(v.integrity, Integrity::kWhole);
  EXPECT_EQ(v.files_hashed, 0);
  // Verified whole (as a report does), then changed in place: the cheap check hashes that file.
  MakeRun(t.Path());
  ASSERT_EQ(VerifyRun(t.Path()).integrity, Integrity::kWhole);
  EXPECT_EQ(VerifyRun(t.Path(), {VerifyLevel::kSizes, true}).files_hashed, 0);
  change();
  v = VerifyRun(t.Path(), {VerifyLevel::kSizes, true});
  EXPECT_EQ(v.integrity, Integrity::kDamaged);
  EXPECT_EQ(v.files_hashed, 1);
  EXPECT_NE(v.Text().find("frames.dump: checksum"), std::string::npos) << v.Text();
  // What a check found damaged is remembered with the file's size and mtime: the next cheap
  // check says it again without hashing, also when nothing was verified before the damage.
  v = VerifyRun(t.Path(), {VerifyLevel::kSizes, true});
  EXPECT_EQ(v.integrity, Integrity::kDamaged);
  EXPECT_EQ(v.files_hashed, 0);
  MakeRun(t.Path());
  std::filesystem::remove_all(t.Path() / "analyses");
  change();
  ASSERT_EQ(VerifyRun(t.Path()).integrity, Integrity::kDamaged);  // a report's check
  v = VerifyRun(t.Path(), {VerifyLevel::kSizes, true});
  EXPECT_EQ(v.integrity, Integrity::kDamaged);
  EXPECT_EQ(v.files_hashed, 0);
  EXPECT_NE(v.Text().find("(changed in place)"), std::string::npos) << v.Text();
  // Restored: whole again.
  MakeRun(t.Path());
  EXPECT_EQ(VerifyRun(t.Path()).integrity, Integrity::kWhole);
  EXPECT_EQ(VerifyRun(t.Path(), {VerifyLevel::kSizes, true}).integrity, Integrity::kWhole);
}

TEST(Manifest, EventsCutHeaderOnlyOrEmptyDisagreeWithTheSummary) {
  for (const std::string what : {"half", "header", "empty", "missing"}) {
    TempDir t;
    MakeRun(t.Path());
    const fs::path events = t.Path() / kEventsFile;
    const std::string text = ReadFile(events);
    if (what == "half") fs::resize_file(events, text.find('\n', text.find('\n') + 1) + 1);  // header and one row
    if (what == "header") fs::resize_file(events, text.find('\n') + 1);
    if (what == "empty") fs::resize_file(events, 0);
    if (what == "missing") fs::remove(events);
    const Verification v = VerifyRun(t.Path());
    EXPECT_EQ(v.integrity, Integrity::kDamaged) << what;
    const std::string rows = what == "half" ? "1 row" : "0 rows";
    if (what == "missing") {
      EXPECT_NE(v.Text().find("events.csv: missing"), std::string::npos) << v.Text();
    } else {
      EXPECT_NE(v.Text().find("events.csv: " + rows + ", summary.json says 3 bodies exited"), std::string::npos)
          << what << ": " << v.Text();
      EXPECT_NE(v.Text().find("events.csv: " + rows + ", the manifest records 3"), std::string::npos) << v.Text();
    }
  }
}

TEST(Manifest, GarbageSummaryIsDamaged) {
  TempDir t;
  MakeRun(t.Path());
  WriteFile(t.Path() / kSummaryFile, "{\"engine\": \"nat");
  const Verification v = VerifyRun(t.Path());
  EXPECT_EQ(v.integrity, Integrity::kDamaged);
  EXPECT_NE(v.Text().find("summary.json: not valid JSON"), std::string::npos) << v.Text();
}

TEST(Manifest, ARunWithoutAManifestIsNotVerifiableButStillCrossChecked) {
  TempDir t;
  MakeRun(t.Path());
  fs::remove(t.Path() / kManifestFile);
  EXPECT_EQ(VerifyRun(t.Path()).integrity, Integrity::kNotVerifiable);
  EXPECT_STREQ(IntegrityName(Integrity::kNotVerifiable), "not verifiable");
  fs::resize_file(t.Path() / kEventsFile, ReadFile(t.Path() / kEventsFile).find('\n') + 1);
  const Verification v = VerifyRun(t.Path());
  EXPECT_EQ(v.integrity, Integrity::kDamaged);
  EXPECT_NE(v.Text().find("events.csv: 0 rows, summary.json says 3 bodies exited"), std::string::npos) << v.Text();
}

TEST(Manifest, AGarbageOrFutureManifestIsDamagedAndAnUnfinishedRunIsNotChecked) {
  TempDir t;
  MakeRun(t.Path());
  WriteFile(t.Path() / kManifestFile, R"({"format": 99, "files": {}})");
  const Verification v = VerifyRun(t.Path());
  EXPECT_EQ(v.integrity, Integrity::kDamaged);
  EXPECT_NE(v.Text().find("manifest format 99"), std::string::npos) << v.Text();
  fs::remove(t.Path() / kDoneFile);
  EXPECT_EQ(VerifyRun(t.Path()).integrity, Integrity::kNotDone);
  EXPECT_THROW(VerifyRun(t.Path() / "nope"), ReadError);
}

TEST(Manifest, WithoutWriteCacheNothingIsKeptAndEveryCheckHashes) {
  TempDir t;
  MakeRun(t.Path());
  const Verification v = VerifyRun(t.Path(), {VerifyLevel::kCached, false});
  EXPECT_EQ(v.integrity, Integrity::kWhole);
  EXPECT_FALSE(fs::exists(t.Path() / "analyses" / "verified.json"));
  EXPECT_EQ(VerifyRun(t.Path(), {VerifyLevel::kCached, false}).files_hashed, 7);
}

}  // namespace
}  // namespace granary::rundir
