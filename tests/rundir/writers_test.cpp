// Every run-directory writer against the documented text (docs/run-directory.md) and read
// back by its reader; a continued run's files cut back to a checkpoint's offsets.
#include <gtest/gtest.h>

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "rundir/clogs.h"
#include "rundir/contacts.h"
#include "rundir/dump_text.h"
#include "rundir/events.h"
#include "rundir/frames.h"
#include "rundir/progress.h"
#include "rundir/run_directory.h"
#include "rundir/summary.h"
#include "rundir/unclogs.h"
#include "test_util.h"

namespace granary::rundir {
namespace {

using analysis::testing::ReadFile;
using analysis::testing::TempDir;
using analysis::testing::WriteFile;

Frame TwoDiscFrame(std::int64_t step) {
  Frame f;
  f.timestep = step;
  f.time = static_cast<double>(step) * 1e-4;
  f.box[0][0] = -11;
  f.box[0][1] = 11;
  f.box[1][0] = -1.25;
  f.box[1][1] = 18.5;
  f.discs = {{1, 0, 1, 0.25, 0.5, 0.5, 0.7853981633974483, 0.1, -0.2, 0.3},
             {2, 0, 1, 1.25, 0.5, 0.5, 0.7853981633974483, 0.1, 0.1, 0.3}};
  return f;
}

TEST(Writers, FramesAreTheDocumentedDumpAndReadBack) {
  TempDir dir;
  const auto file = dir.Path() / kFramesFile;
  FrameWriter w = FrameWriter::Create(file);
  w.Write(TwoDiscFrame(12000));
  w.Close();
  EXPECT_EQ(ReadFile(file),
            "ITEM: TIME\n1.2\nITEM: TIMESTEP\n12000\nITEM: NUMBER OF ATOMS\n2\n"
            "ITEM: BOX BOUNDS ff ff pp\n-11 11\n-1.25 18.5\n-0.5 0.5\n"
            "ITEM: ATOMS id mol type x y z radius mass vx vy vz omegaz\n"
            "1 0 1 0.25 0.5 0 0.5 0.7853981634 0.1 -0.2 0 0.3\n"
            "2 0 1 1.25 0.5 0 0.5 0.7853981634 0.1 0.1 0 0.3\n");
  FrameReader r(file);
  Frame f;
  ASSERT_TRUE(r.Next(f));
  EXPECT_EQ(f.timestep, 12000);
  EXPECT_DOUBLE_EQ(f.box[1][1], 18.5);
  ASSERT_EQ(f.discs.size(), 2u);
  EXPECT_EQ(f.discs[1].id, 2);
  EXPECT_DOUBLE_EQ(f.discs[0].vy, -0.2);
  EXPECT_DOUBLE_EQ(f.discs[1].omega, 0.3);
  EXPECT_FALSE(r.Next(f));
}

TEST(Writers, ContactsAreTheDocumentedDumpAndReadBack) {
  TempDir dir;
  const auto file = dir.Path() / kContactsFile;
  ContactFrame c;
  c.timestep = 5;
  c.time = 0.5;
  c.box[0][0] = -9;
  c.box[0][1] = 9;
  c.box[1][0] = -1;
  c.box[1][1] = 20;
  c.contacts = {{3, 4, 0, 0, 1, 0, 0.5, 0, -2, 0}, {4, -1, 1, 0.5, 1, 0, 1, 0, 0, 3}};
  ContactWriter w = ContactWriter::Create(file);
  w.Write(c);
  w.Close();
  EXPECT_EQ(ReadFile(file),
            "ITEM: TIME\n0.5\nITEM: TIMESTEP\n5\nITEM: NUMBER OF ENTRIES\n2\n"
            "ITEM: BOX BOUNDS ff ff pp\n-9 9\n-1 20\n-0.5 0.5\n"
            "ITEM: ENTRIES body_i body_j xi yi xj yj cx cy fx fy\n"
            "3 4 0 0 1 0 0.5 0 -2 0\n4 -1 1 0.5 1 0 1 0 0 3\n");
  ContactReader r(file);
  ContactFrame f;
  ASSERT_TRUE(r.Next(f));
  EXPECT_DOUBLE_EQ(f.box[1][1], 20.0);
  ASSERT_EQ(f.contacts.size(), 2u);
  EXPECT_EQ(f.contacts[1].body_j, -1);
  EXPECT_DOUBLE_EQ(f.contacts[1].fy, 3.0);
}

// The dump writers format numbers with std::to_chars (dump_text.h), which must write what
// printf's "%.10g" writes: whole numbers, tiny and huge magnitudes, values that round up to
// another exponent, negative zero, infinities and NaN, and a million random bit patterns.
TEST(Writers, DumpNumbersAreThoseOfPrintf) {
  std::vector<double> values = {0.0,
                                -0.0,
                                1.0,
                                -1.0,
                                0.5,
                                1e-4,
                                9.9999999995e-5,
                                9.99999999949e9,
                                1e10,
                                123456789012.0,
                                1e-300,
                                5e-324,
                                1.7976931348623157e308,
                                0.1,
                                2.0 / 3.0,
                                -49.99999999999,
                                1e15,
                                1e16,
                                std::numeric_limits<double>::infinity(),
                                -std::numeric_limits<double>::infinity(),
                                std::numeric_limits<double>::quiet_NaN()};
  std::mt19937_64 rng(19);
  for (int k = 0; k < 1000000; ++k) {
    const std::uint64_t bits = rng();
    double v;
    std::memcpy(&v, &bits, sizeof v);
    values.push_back(k % 2 ? v : std::ldexp(static_cast<double>(bits >> 11), -40 - static_cast<int>(bits % 40)));
  }
  std::string ours;
  char theirs[64];
  for (const double v : values) {
    ours.clear();
    detail::AppendG10(ours, v);
    std::snprintf(theirs, sizeof theirs, "%.10g", v);
    ASSERT_EQ(ours, theirs) << "bits " << std::hex << std::bit_cast<std::uint64_t>(v);
  }
  for (const std::int64_t i : {std::int64_t{0}, std::int64_t{-1}, std::int64_t{7999}, INT64_MIN, INT64_MAX}) {
    ours.clear();
    detail::AppendInt(ours, i);
    EXPECT_EQ(ours, std::to_string(i));
  }
}

TEST(Writers, EventsStreamedAndWholeAreTheSameFile) {
  TempDir dir;
  const std::vector<ExitEvent> events = {{1.6123, 4711, "dumbbell", 1.5707963267948966, 0},
                                         {2.0000000000000004, 12, "disc", 0.7853981633974483, 1}};
  EventWriter w = EventWriter::Create(dir.Path() / "streamed.csv");
  for (const ExitEvent& e : events) w.Write(e);
  w.Close();
  WriteEvents(dir.Path() / "whole.csv", events);
  const std::string text = ReadFile(dir.Path() / "whole.csv");
  EXPECT_EQ(text,
            "time,body,shape,mass,outlet\n1.6123,4711,dumbbell,1.5707963267948966,0\n"
            "2,12,disc,0.78539816339744828,1\n");
  EXPECT_EQ(ReadFile(dir.Path() / "streamed.csv"), text);
  const std::vector<ExitEvent> back = ReadEvents(dir.Path() / "whole.csv");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].body, 4711);
  EXPECT_EQ(back[0].mass, events[0].mass);  // full precision
  EXPECT_EQ(back[1].shape, "disc");
  EXPECT_EQ(back[1].outlet, 1);
}

// unclogs.csv: the documented rows, read back; a continue cuts it back to its checkpoint's
// offset; a missing file is no unclogs; a bad row names file:line.
TEST(Writers, UnclogsAreTheDocumentedRowsAndContinueAtTheCheckpoint) {
  TempDir dir;
  const std::filesystem::path file = dir.Path() / "unclogs.csv";
  EXPECT_TRUE(ReadUnclogs(file).empty());
  UnclogWriter w = UnclogWriter::Create(file);
  w.Write({41.23, 412300, 1, 1, "remove_arch", {17, 52, 88, 130}});
  const std::int64_t offset = w.Offset();
  w.Write({60.5, 605000, 2, 1, "kick", {3}});
  w.Close();
  EXPECT_EQ(ReadFile(file),
            "time,step,clog,attempt,method,bodies\n41.23,412300,1,1,remove_arch,17 52 88 130\n"
            "60.5,605000,2,1,kick,3\n");
  std::vector<UnclogEvent> back = ReadUnclogs(file);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].bodies, (std::vector<std::int64_t>{17, 52, 88, 130}));
  EXPECT_EQ(back[1].method, "kick");
  EXPECT_EQ(back[1].step, 605000);
  w = UnclogWriter::ContinueAt(file, offset);
  w.Write({61.0, 610000, 2, 1, "kick", {}});
  w.Close();
  back = ReadUnclogs(file);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[1].time, 61.0);
  EXPECT_TRUE(back[1].bodies.empty());
  WriteFile(file, "time,step,clog,attempt,method,bodies\n1,10,0,1,kick,3\n");
  try {
    ReadUnclogs(file);
    ADD_FAILURE() << "no error";
  } catch (const ReadError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ":2: clog '0' is not a clog number (1, 2, ...)");
  }
}

TEST(Writers, ContinuingCutsEveryDumpBackToTheCheckpoint) {
  TempDir dir;
  const auto events = dir.Path() / kEventsFile, frames = dir.Path() / kFramesFile;
  EventWriter ew = EventWriter::Create(events);
  FrameWriter fw = FrameWriter::Create(frames);
  ew.Write({0.5, 1, "disc", 1.0, 0});
  fw.Write(TwoDiscFrame(100));
  const std::int64_t event_offset = ew.Offset(), frame_offset = fw.Offset();  // a checkpoint here
  ew.Write({0.7, 2, "disc", 1.0, 0});
  fw.Write(TwoDiscFrame(200));
  ew.Close();
  fw.Close();
  const std::string events_at_checkpoint = ReadFile(events).substr(0, static_cast<std::size_t>(event_offset));
  ew = EventWriter::ContinueAt(events, event_offset);
  fw = FrameWriter::ContinueAt(frames, frame_offset);
  EXPECT_EQ(ew.Offset(), event_offset);
  ew.Write({0.7, 2, "disc", 1.0, 0});
  fw.Write(TwoDiscFrame(300));
  ew.Close();
  fw.Close();
  EXPECT_EQ(ReadFile(events), events_at_checkpoint + "0.7,2,disc,1,0\n");
  FrameReader r(frames);
  Frame f;
  std::vector<std::int64_t> steps;
  while (r.Next(f)) steps.push_back(f.timestep);
  EXPECT_EQ(steps, (std::vector<std::int64_t>{100, 300}));
}

ClogState ClogAt(std::int64_t step) {
  ClogState c;
  c.frame = TwoDiscFrame(step);
  c.contacts.timestep = step;
  c.contacts.time = c.frame.time;
  c.contacts.contacts = {{0, -1, 0.25, 0.5, 0.25, 0, 0.25, 0, 0, 1.5}, {0, -1, 1.25, 0.5, 1.25, 0, 1.25, 0, 0, 1.5}};
  return c;
}

// Each clog is a block of the frames format and one of the contacts format, read back in
// pairs; a continued run keeps the clogs up to its checkpoint's step, whatever the offsets.
TEST(Writers, ClogsAreFrameAndContactBlocksKeptUpToTheCheckpointOnContinue) {
  TempDir dir;
  ClogWriter w = ClogWriter::Create(dir.Path());
  w.Write(ClogAt(100));
  // Flushed at once: a checkpoint taken now finds the clog on disk.
  const std::string one_frame = ReadFile(dir.Path() / kClogFramesFile);
  EXPECT_EQ(one_frame.rfind("ITEM: TIME\n0.01\nITEM: TIMESTEP\n100\n", 0), 0u);
  EXPECT_NE(ReadFile(dir.Path() / kClogContactsFile).find("ITEM: ENTRIES body_i body_j"), std::string::npos);
  w.Write(ClogAt(250));
  const std::size_t two_clogs = ReadFile(dir.Path() / kClogFramesFile).size();
  w.Write(ClogAt(400));
  w.Close();
  const std::size_t three_clogs = ReadFile(dir.Path() / kClogFramesFile).size();
  std::vector<ClogState> clogs = ReadClogs(dir.Path());
  ASSERT_EQ(clogs.size(), 3u);
  EXPECT_EQ(clogs[1].frame.timestep, 250);
  EXPECT_EQ(clogs[1].contacts.timestep, 250);
  ASSERT_EQ(clogs[2].contacts.contacts.size(), 2u);
  EXPECT_DOUBLE_EQ(clogs[2].contacts.contacts[1].fy, 1.5);
  EXPECT_EQ(clogs[0].frame.discs.size(), 2u);

  // Killed while writing a fourth clog (half a block), continued from a checkpoint at step 250.
  { std::ofstream(dir.Path() / kClogFramesFile, std::ios::app) << "ITEM: TIME\n0.05\nITEM: TIMESTEP\n500\nITEM: NUMB"; }
  EXPECT_EQ(DumpOffsetAfter(dir.Path() / kClogFramesFile, 400), static_cast<std::int64_t>(three_clogs));
  w = ClogWriter::ContinueAfter(dir.Path(), 250);
  EXPECT_EQ(ReadFile(dir.Path() / kClogFramesFile).size(), two_clogs);
  w.Write(ClogAt(420));
  w.Close();
  clogs = ReadClogs(dir.Path());
  ASSERT_EQ(clogs.size(), 3u);
  EXPECT_EQ(clogs[0].frame.timestep, 100);
  EXPECT_EQ(clogs[1].frame.timestep, 250);
  EXPECT_EQ(clogs[2].frame.timestep, 420);
  EXPECT_EQ(clogs[2].contacts.timestep, 420);

  // A checkpoint before any clog keeps none.
  w = ClogWriter::ContinueAfter(dir.Path(), 99);
  w.Close();
  EXPECT_TRUE(ReadFile(dir.Path() / kClogFramesFile).empty());
  EXPECT_TRUE(ReadFile(dir.Path() / kClogContactsFile).empty());
  EXPECT_TRUE(ReadClogs(dir.Path()).empty());
}

TEST(Readers, ClogFilesMustAgreeAndMayBeAbsent) {
  TempDir dir;
  ClogReader none(dir.Path());
  EXPECT_FALSE(none.Present());
  ClogWriter w = ClogWriter::Create(dir.Path());
  ClogState odd = ClogAt(100);
  odd.contacts.timestep = 101;
  w.Write(odd);
  w.Close();
  try {
    ReadClogs(dir.Path());
    FAIL() << "expected a ReadError";
  } catch (const ReadError& e) {
    EXPECT_NE(std::string(e.what()).find("timestep 101 beside the configuration at timestep 100"), std::string::npos)
        << e.what();
  }
  std::filesystem::remove(dir.Path() / kClogContactsFile);
  EXPECT_THROW(ClogReader{dir.Path()}, ReadError);
}

TEST(Writers, SummaryRoundTripsAndWritesOnlyTheKeysItHas) {
  TempDir dir;
  Summary s;
  s.engine = "native";
  s.engine_version = "0.1.0";
  s.granary_commit = "abc";
  s.run_id = "r1";
  s.spec = {{"seed", 3}};
  s.end_reason = "clogged";
  s.bodies = 100;
  s.exited = 40;
  s.remaining = 60;
  s.exits_per_outlet = {30, 10};
  s.t_end = 12.5;
  s.steps = 125000;
  s.clogs = 1;
  s.bed = {"bed.json", 20.5, true, 9.5, "", {}, {}};
  s.timing = Timing{3.0, 1.0, 2.0, 5e7, 2};
  WriteSummary(dir.Path(), s);
  const nlohmann::json j = nlohmann::json::parse(ReadFile(dir.Path() / kSummaryFile));
  for (const char* absent :
       {"granary_version", "cleared_by_obstacles", "max_out_of_plane", "tangential_cap", "reinject_position"})
    EXPECT_FALSE(j.contains(absent)) << absent;
  EXPECT_EQ(j["timing"]["threads"], 2);
  const Summary back = ReadSummary(dir.Path() / kSummaryFile);
  EXPECT_EQ(back.ToJson(), s.ToJson());
  EXPECT_EQ(back.exits_per_outlet, (std::vector<int>{30, 10}));
  ASSERT_TRUE(back.clogs.has_value());
  EXPECT_EQ(*back.clogs, 1);
  EXPECT_DOUBLE_EQ(back.timing->disc_steps_per_s, 5e7);

  s.engine = "liggghts";
  s.granary_version = "0.1.0";
  s.tangential_cap = "liggghts";
  s.reinject_position = "periodic";
  s.max_out_of_plane = 0.0;
  s.cleared_by_obstacles = 2;
  WriteSummary(dir.Path(), s);
  EXPECT_EQ(ReadSummary(dir.Path() / kSummaryFile).ToJson(), s.ToJson());
}

TEST(Writers, ProgressIsReplacedWholeAndClamped) {
  TempDir dir;
  EXPECT_FALSE(ReadProgress(dir.Path()).has_value());
  WriteProgress(dir.Path(), {"discharge", 1.2, 4.2, 10.0, 130, 2.5}, false);
  EXPECT_EQ(ReadFile(dir.Path() / kProgressFile),
            "{\"exited\":130,\"fraction\":1.0,\"phase\":\"discharge\",\"t\":4.2,\"t_end\":10.0,\"wall_s\":2.5}\n");
  const auto p = ReadProgress(dir.Path());
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->phase, "discharge");
  EXPECT_EQ(p->exited, 130);
  EXPECT_EQ((Progress{"discharge", 0.42, 4.2, 10.0, 130, 2.5}.Line()),
            "progress phase=discharge fraction=0.420 t=4.2 exited=130");
  WriteFile(dir.Path() / kProgressFile, "{\"phase\": ");  // torn by a foreign writer
  EXPECT_FALSE(ReadProgress(dir.Path()).has_value());
}

TEST(Writers, RunSpecAndDone) {
  TempDir dir;
  const nlohmann::json spec = {{"run_id", "r1"}, {"silo", {{"width", -1.0}}}};
  WriteRunSpec(dir.Path() / "run", spec);
  EXPECT_EQ(ReadFile(dir.Path() / "run" / kRunSpecFile), spec.dump(2) + "\n");
  EXPECT_EQ(ReadRunSpecJson(dir.Path() / "run"), spec);
  try {
    ReadRunSpec(dir.Path() / "run");
    FAIL() << "no error";
  } catch (const SpecError& e) {
    EXPECT_EQ(e.Path(), "/silo/width");
    EXPECT_NE(std::string(e.what()).find("[" + (dir.Path() / "run" / kRunSpecFile).string() + "]"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(ReadRunSpec(dir.Path() / "missing"), ReadError);
  EXPECT_FALSE(IsDone(dir.Path()));
  WriteDone(dir.Path(), "clogged");
  EXPECT_TRUE(IsDone(dir.Path()));
  EXPECT_EQ(ReadFile(dir.Path() / kDoneFile), "clogged\n");
}

}  // namespace
}  // namespace granary::rundir

// ToDouble's fast path must give std::from_chars' bits for every number a writer prints
// ("%.10g", shortest round trip) and hand everything else to from_chars unchanged.
TEST(DumpText, ToDoubleHasTheBitsOfFromChars) {
  std::mt19937_64 rng(14);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> power(-30, 30);
  std::vector<std::string> texts = {"0",
                                    "-0",
                                    "+1.5",
                                    "1.",
                                    ".5",
                                    "-.5",
                                    "1e22",
                                    "1e23",
                                    "1e-22",
                                    "1e-23",
                                    "9007199254740993",
                                    "12345678901234567890",
                                    "0.1e+3",
                                    "2E-3",
                                    "1e+",
                                    "1e",
                                    "-",
                                    ".",
                                    "",
                                    "1e5x",
                                    "inf",
                                    "nan",
                                    "1e00001",
                                    "0.000000000000000000001"};
  for (int i = 0; i < 200000; ++i) {
    const double x = unit(rng) * std::pow(10.0, power(rng));
    char buf[64];
    for (int precision : {6, 10, 17}) {
      texts.emplace_back(buf, std::to_chars(buf, buf + sizeof buf, x, std::chars_format::general, precision).ptr);
    }
    texts.emplace_back(buf, std::to_chars(buf, buf + sizeof buf, x).ptr);
    texts.emplace_back(buf, std::to_chars(buf, buf + sizeof buf, x, std::chars_format::fixed, 12).ptr);
  }
  for (const std::string& text : texts) {
    std::string_view s(text);
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    double expected = 0.0;
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), expected);
    const bool expected_ok = ec == std::errc() && ptr == s.data() + s.size();
    double got = 0.0;
    ASSERT_EQ(granary::rundir::detail::ToDouble(text, got), expected_ok) << text;
    if (expected_ok) {
      ASSERT_EQ(std::bit_cast<std::uint64_t>(got), std::bit_cast<std::uint64_t>(expected)) << text;
    }
    // The same number read in place from a row (NextDouble), between blanks.
    if (text.empty()) continue;
    const std::string row = " \t" + text + " 7";
    const char* p = row.data();
    const char* const end = p + row.size();
    double in_row = 0.0, next = 0.0;
    ASSERT_EQ(granary::rundir::detail::NextDouble(p, end, in_row), expected_ok) << text;
    if (!expected_ok) continue;
    ASSERT_EQ(std::bit_cast<std::uint64_t>(in_row), std::bit_cast<std::uint64_t>(expected)) << text;
    ASSERT_TRUE(granary::rundir::detail::NextDouble(p, end, next)) << text;
    ASSERT_EQ(next, 7.0);
    ASSERT_FALSE(granary::rundir::detail::NextDouble(p, end, next));
  }
}

// Integers read in place (NextInt) as ToInt reads them: signs, "12.0", too many digits.
TEST(DumpText, NextIntIsToInt) {
  for (const std::string text : {"0", "-0", "+3", "12", "-7", "12.0", "1.5", "x", "-", "123456789012345678",
                                 "1234567890123456789", "99999999999999999999", "3e2"}) {
    std::int64_t expected = 0, got = 0;
    const bool ok = granary::rundir::detail::ToInt(text, expected);
    const std::string row = text + "  4";
    const char* p = row.data();
    ASSERT_EQ(granary::rundir::detail::NextInt(p, row.data() + row.size(), got), ok) << text;
    if (ok) {
      EXPECT_EQ(got, expected) << text;
    }
  }
}
