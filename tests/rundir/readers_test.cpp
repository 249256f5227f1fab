// The readers on hand-written run files (other writers' output: extra columns, missing
// optional columns, rows out of order), and their errors on malformed input.
#include "rundir/contacts.h"
#include "rundir/events.h"
#include "rundir/frames.h"
#include "rundir/run_directory.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <numbers>

#include "test_util.h"

namespace granary::rundir {
namespace {

using analysis::testing::TempDir;
using analysis::testing::WriteFile;

constexpr double kPi = std::numbers::pi;

// Two frames: a dumbbell (body 0, discs d = 1 at x = 1 and 2, y = 5) moving with v = (1, 0)
// and omega = 0, and a single disc (body 1, radius 0.7) with an extra column.
const char* kFrames =
    "ITEM: TIMESTEP\n100\nITEM: TIME\n0.01\nITEM: NUMBER OF ATOMS\n3\n"
    "ITEM: BOX BOUNDS ff ff pp\n-50 50\n-5 160\n-0.5 0.5\n"
    "ITEM: ATOMS id mol type x y z radius mass vx vy vz omegaz extra\n"
    "1 0 1 1.0 5.0 0 0.5 0.7853981633974483 1.0 0.0 0 0.0 9\n"
    "2 0 1 2.0 5.0 0 0.5 0.7853981633974483 1.0 0.0 0 0.0 9\n"
    "3 1 2 4.0 3.0 0 0.7 1.5393804002589986 0.0 -2.0 0 0.5 9\n"
    "\n"
    "ITEM: TIMESTEP\n200\nITEM: TIME\n0.02\nITEM: NUMBER OF ATOMS\n2\n"
    "ITEM: BOX BOUNDS ff ff pp\n-50 50\n-5 160\n-0.5 0.5\n"
    "ITEM: ATOMS id mol x y radius vx vy omegaz\n"
    // rotating dumbbell about its centre (1.5, 5): omega = 2, disc velocities -+omega * r
    "2 0 2.0 5.0 0.5 0.0 1.0 2.0\n"
    "1 0 1.0 5.0 0.5 0.0 -1.0 2.0\n";

TEST(Readers, FramesRoundTripAndBodies) {
  TempDir dir;
  WriteFile(dir.Path() / "frames.dump", kFrames);
  FrameReader reader(dir.Path() / "frames.dump");
  Frame f;
  ASSERT_TRUE(reader.Next(f));
  EXPECT_EQ(f.timestep, 100);
  EXPECT_DOUBLE_EQ(f.time, 0.01);
  EXPECT_DOUBLE_EQ(f.box[1][1], 160.0);
  ASSERT_EQ(f.discs.size(), 3u);
  std::vector<Body> b = BodiesOf(f.discs);
  ASSERT_EQ(b.size(), 2u);
  EXPECT_EQ(b[0].id, 0);
  EXPECT_EQ(b[0].n_discs, 2);
  EXPECT_NEAR(b[0].x, 1.5, 1e-14);
  EXPECT_NEAR(b[0].y, 5.0, 1e-14);
  EXPECT_NEAR(b[0].vx, 1.0, 1e-14);
  EXPECT_NEAR(b[0].mass, kPi / 2.0, 1e-14);
  // I = 2 [m (1/2)^2 + (2/5) m (1/2)^2] with m = pi/4 (docs/model.md)
  EXPECT_NEAR(b[0].inertia, 2.0 * (kPi / 4.0) * (0.25 + 0.4 * 0.25), 1e-14);
  EXPECT_NEAR(b[0].theta, 0.0, 1e-14);
  EXPECT_NEAR(b[0].area, kPi / 2.0, 1e-14);
  EXPECT_EQ(b[1].type, 2);
  EXPECT_NEAR(b[1].vy, -2.0, 1e-14);
  EXPECT_NEAR(b[1].omega, 0.5, 1e-14);
  EXPECT_NEAR(b[1].inertia, 0.4 * kPi * 0.49 * 0.49, 1e-14);

  // Second frame: no type or mass column, discs out of order.
  ASSERT_TRUE(reader.Next(f));
  EXPECT_EQ(f.timestep, 200);
  b = BodiesOf(f.discs);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_NEAR(b[0].mass, kPi / 2.0, 1e-14);  // density 1: pi r^2 per disc
  EXPECT_NEAR(b[0].vy, 0.0, 1e-14);
  EXPECT_NEAR(b[0].omega, 2.0, 1e-14);
  EXPECT_NEAR(b[0].theta, 0.0, 1e-14);  // from disc 1 to disc 2
  EXPECT_FALSE(reader.Next(f));
}

TEST(Readers, TruncatedLastFrameEndsQuietly) {
  TempDir dir;
  std::string text = kFrames;
  text.resize(text.size() - 20);  // cut the last row
  WriteFile(dir.Path() / "frames.dump", text);
  FrameReader reader(dir.Path() / "frames.dump");
  Frame f;
  EXPECT_TRUE(reader.Next(f));
  EXPECT_FALSE(reader.Next(f));
}

// The reader takes the file in blocks of 1 MiB: a line longer than a block (here a header
// and rows with 300,000 extra columns, 2.4 MB each), rows across block ends, and the same
// text gzip-compressed read alike.
TEST(Readers, LinesLongerThanABlockAndGzip) {
  TempDir dir;
  std::string extra_names, extra_values;
  for (int k = 0; k < 300000; ++k) extra_names += " e" + std::to_string(k % 10), extra_values += " 1.5e-3";
  std::string text = "ITEM: TIMESTEP\n7\nITEM: NUMBER OF ATOMS\n2\nITEM: ATOMS x extra" + extra_names + " id mol y\n";
  text += "1.25 0" + extra_values + " 1 0 -2.5\n";
  text += "3.5 0" + extra_values + " 2 0 4e1\r\n";
  for (int f = 0; f < 40000; ++f)  // frames enough to cross many block ends
    text += "ITEM: TIMESTEP\n" + std::to_string(8 + f) + "\nITEM: NUMBER OF ATOMS\n1\nITEM: ATOMS id mol x y\n3 1 " +
            std::to_string(f) + ".125 -0.5\n";
  WriteFile(dir.Path() / "frames.dump", text);
  gzFile gz = gzopen((dir.Path() / "frames.dump.gz").c_str(), "wb");
  ASSERT_NE(gz, nullptr);
  ASSERT_EQ(gzwrite(gz, text.data(), static_cast<unsigned>(text.size())), static_cast<int>(text.size()));
  gzclose(gz);
  for (const char* name : {"frames.dump", "frames.dump.gz"}) {
    FrameReader reader(dir.Path() / name);
    Frame f;
    ASSERT_TRUE(reader.Next(f)) << name;
    EXPECT_EQ(f.timestep, 7);
    ASSERT_EQ(f.discs.size(), 2u);
    EXPECT_EQ(f.discs[0].x, 1.25);
    EXPECT_EQ(f.discs[0].y, -2.5);
    EXPECT_EQ(f.discs[1].id, 2);
    EXPECT_EQ(f.discs[1].y, 40.0);
    int frames = 0;
    while (reader.Next(f)) {
      ASSERT_EQ(f.discs.size(), 1u);
      ASSERT_EQ(f.discs[0].x, frames + 0.125) << name << " frame " << frames;
      ++frames;
    }
    EXPECT_EQ(frames, 40000) << name;
  }
}

TEST(Readers, MalformedFrameNamesFileAndLine) {
  TempDir dir;
  const auto file = dir.Path() / "frames.dump";
  WriteFile(file,
            "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: ATOMS id mol x y\n"
            "1 0 abc 2\n");
  FrameReader reader(file);
  Frame f;
  try {
    reader.Next(f);
    FAIL() << "no error";
  } catch (const ReadError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ":6: x 'abc' is not a number");
  }
  WriteFile(file, "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: ATOMS id x y\n1 1 2\n");
  FrameReader r2(file);
  try {
    r2.Next(f);
    FAIL() << "no error";
  } catch (const ReadError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ":5: atoms header has no 'mol' column ('ITEM: ATOMS id x y')");
  }
  WriteFile(file, "garbage\n");
  FrameReader r3(file);
  EXPECT_THROW(r3.Next(f), ReadError);
}

TEST(Readers, EventsWithExtraColumnsAndOrder) {
  TempDir dir;
  const auto file = dir.Path() / "events.csv";
  WriteFile(file,
            "time,body,shape,mass,outlet,speed\n"
            "1.5,7,dumbbell,1.5707963267948966,1,0.3\n"
            "0.5,3,disc,1.5707963267948966,0,0.2\r\n");
  const auto ev = ReadEvents(file);
  ASSERT_EQ(ev.size(), 2u);
  EXPECT_DOUBLE_EQ(ev[0].time, 0.5);
  EXPECT_EQ(ev[0].body, 3);
  EXPECT_EQ(ev[0].shape, "disc");
  EXPECT_EQ(ev[0].outlet, 0);
  EXPECT_EQ(ev[1].outlet, 1);
  EXPECT_NEAR(ev[1].mass, kPi / 2.0, 1e-15);
}

TEST(Readers, MalformedEventsNameFileAndLine) {
  TempDir dir;
  const auto file = dir.Path() / "events.csv";
  WriteFile(file, "time,body,shape,mass,outlet\n1.0,1,disc,1.0,0\n2.0,2,disc\n");
  try {
    ReadEvents(file);
    FAIL() << "no error";
  } catch (const ReadError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ":3: expected 5 fields, got 3 ('2.0,2,disc')");
  }
  WriteFile(file, "time,body,shape,mass,outlet\nx,1,disc,1.0,0\n");
  try {
    ReadEvents(file);
    FAIL() << "no error";
  } catch (const ReadError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ":2: time 'x' is not a number");
  }
  WriteFile(file, "body,outlet\n1,0\n");
  EXPECT_THROW(ReadEvents(file), ReadError);
}

TEST(Readers, SummaryAndRunDirectory) {
  TempDir dir;
  WriteFile(dir.Path() / "summary.json",
            R"({"engine":"native","engine_version":"0.1.0","granary_commit":"abc","run_id":"r1",
                 "spec":{"discharge":{"mode":"remove"}},"end_reason":"clogged","bodies":100,
                 "exited":40,"remaining":60,"exits_per_outlet":[40],"t_end":12.5,"new_key":[1,2]})");
  WriteFile(dir.Path() / "events.csv", "time,body,shape,mass,outlet\n0.1,1,disc,1,0\n");
  WriteFile(dir.Path() / "DONE", "");
  const RunData r = ReadRun(dir.Path());
  EXPECT_TRUE(r.done);
  EXPECT_TRUE(r.has_summary);
  EXPECT_FALSE(r.has_frames);
  EXPECT_EQ(r.summary.end_reason, "clogged");
  EXPECT_EQ(r.summary.remaining, 60);
  EXPECT_EQ(r.summary.exits_per_outlet, std::vector<int>{40});
  EXPECT_DOUBLE_EQ(r.summary.t_end, 12.5);
  EXPECT_EQ(r.spec["discharge"]["mode"], "remove");  // from summary when run.json is absent
  EXPECT_EQ(r.events.size(), 1u);
  EXPECT_EQ(r.summary.raw["new_key"].size(), 2u);

  WriteFile(dir.Path() / "summary.json", "{\"bodies\": \"many\"}");
  EXPECT_THROW(ReadRun(dir.Path()), ReadError);
  WriteFile(dir.Path() / "summary.json", "{not json");
  EXPECT_THROW(ReadRun(dir.Path()), ReadError);
  EXPECT_THROW(ReadRun(dir.Path() / "missing"), ReadError);
}

// LAMMPS writes ITEM: UNITS and ITEM: TIME before ITEM: TIMESTEP (as the engines now do); run
// directories of earlier Granary versions have TIME after TIMESTEP. Both read alike.
std::string InLammpsOrder(std::string dump, bool units) {
  for (std::size_t p = dump.find("ITEM: TIMESTEP\n"); p != std::string::npos;
       p = dump.find("ITEM: TIMESTEP\n", p + 1)) {
    const std::size_t time = dump.find("ITEM: TIME\n", p);
    const std::size_t end = dump.find('\n', time + 11) + 1;
    const std::string item = dump.substr(time, end - time);
    dump.erase(time, end - time);
    dump.insert(p, (units ? "ITEM: UNITS\nlj\n" : "") + item);
    p += item.size() + (units ? 15 : 0);
  }
  return dump;
}

TEST(Readers, FramesInLammpsOrderReadAsInTheOldOrder) {
  TempDir dir;
  const std::string lammps = InLammpsOrder(kFrames, true);
  ASSERT_EQ(lammps.rfind("ITEM: UNITS\nlj\nITEM: TIME\n0.01\nITEM: TIMESTEP\n100\nITEM: NUMBER OF ATOMS\n3\n", 0), 0u)
      << lammps;
  WriteFile(dir.Path() / "old.dump", kFrames);
  WriteFile(dir.Path() / "lammps.dump", lammps);
  FrameReader old_order(dir.Path() / "old.dump"), lammps_order(dir.Path() / "lammps.dump");
  Frame a, b;
  for (int k = 0; k < 2; ++k) {
    ASSERT_TRUE(old_order.Next(a));
    ASSERT_TRUE(lammps_order.Next(b));
    EXPECT_EQ(a.timestep, b.timestep);
    EXPECT_EQ(a.time, b.time);
    EXPECT_EQ(b.time, 0.01 * (k + 1));
    ASSERT_EQ(a.discs.size(), b.discs.size());
    for (std::size_t i = 0; i < a.discs.size(); ++i) {
      EXPECT_EQ(a.discs[i].id, b.discs[i].id);
      EXPECT_EQ(a.discs[i].x, b.discs[i].x);
      EXPECT_EQ(a.discs[i].omega, b.discs[i].omega);
    }
  }
  EXPECT_FALSE(lammps_order.Next(b));
  // A time that is not a number is an error wherever it stands.
  WriteFile(dir.Path() / "bad.dump",
            "ITEM: TIME\nsoon\nITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n0\nITEM: ATOMS id mol x y\n");
  FrameReader bad(dir.Path() / "bad.dump");
  try {
    bad.Next(b);
    ADD_FAILURE() << "no error";
  } catch (const ReadError& e) {
    EXPECT_EQ(std::string(e.what()), (dir.Path() / "bad.dump").string() + ":2: time 'soon' is not a number");
  }
}

TEST(Readers, Contacts) {
  TempDir dir;
  const auto file = dir.Path() / "contacts.dump";
  WriteFile(file,
            "ITEM: TIMESTEP\n5\nITEM: TIME\n0.5\nITEM: NUMBER OF ENTRIES\n2\n"
            "ITEM: BOX BOUNDS ff ff pp\n-50 50\n-5 160\n-0.5 0.5\n"
            "ITEM: ENTRIES body_i body_j xi yi xj yj cx cy fx fy\n"
            "0 1 0 0 1 0 0.5 0 -2 0\n"
            "1 -1 1 0.5 1 0 1 0 0 3\n");
  ContactReader reader(file);
  ContactFrame f;
  ASSERT_TRUE(reader.Next(f));
  EXPECT_EQ(f.timestep, 5);
  EXPECT_DOUBLE_EQ(f.time, 0.5);
  ASSERT_EQ(f.contacts.size(), 2u);
  EXPECT_EQ(f.contacts[1].body_j, -1);
  EXPECT_DOUBLE_EQ(f.contacts[0].fx, -2.0);
  EXPECT_DOUBLE_EQ(f.contacts[1].fy, 3.0);
  EXPECT_FALSE(reader.Next(f));

  // The same frame as LAMMPS' dump local writes it: TIME before TIMESTEP.
  WriteFile(file,
            "ITEM: TIME\n0.5\nITEM: TIMESTEP\n5\nITEM: NUMBER OF ENTRIES\n1\n"
            "ITEM: BOX BOUNDS ff ff pp\n-50 50\n-5 160\n-0.5 0.5\n"
            "ITEM: ENTRIES body_i body_j xi yi xj yj cx cy fx fy\n"
            "0 1 0 0 1 0 0.5 0 -2 0\n");
  ContactReader lammps_order(file);
  ASSERT_TRUE(lammps_order.Next(f));
  EXPECT_EQ(f.timestep, 5);
  EXPECT_DOUBLE_EQ(f.time, 0.5);
  ASSERT_EQ(f.contacts.size(), 1u);
  EXPECT_DOUBLE_EQ(f.contacts[0].cx, 0.5);
  EXPECT_FALSE(lammps_order.Next(f));
}

}  // namespace
}  // namespace granary::rundir
