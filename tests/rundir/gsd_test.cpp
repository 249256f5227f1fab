// frames.gsd and contacts.gsd (output.format "gsd"): the file layer's documented layout, the
// round trip of every field (float32 bits where the format stores float32), a continued
// run's files cut back to a checkpoint, a file still being written, and the run directory
// finding them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "rundir/contacts.h"
#include "rundir/frames.h"
#include "rundir/gsd.h"
#include "rundir/run_directory.h"
#include "test_util.h"

namespace granary::rundir {
namespace {

using analysis::testing::ReadFile;
using analysis::testing::TempDir;
using analysis::testing::WriteFile;

// A rigid dumbbell (body 0: two discs at +-0.5 of (2.3, 4.1), V = (0.2, -1.1), omega = 0.7)
// and a lone disc (body 1) of another species; a box whose centre is off the origin.
Frame Bodies(std::int64_t step, double shift = 0.0) {
  Frame f;
  f.timestep = step;
  f.time = static_cast<double>(step) * 1e-4;
  f.box[0][0] = -10.5;
  f.box[0][1] = 13.25;
  f.box[1][0] = -7;
  f.box[1][1] = 41.7;
  const double X = 2.3 + shift, Y = 4.1, vx = 0.2, vy = -1.1, w = 0.7, th = 0.3;
  for (int q = 0; q < 2; ++q) {
    const double off = q == 0 ? -0.5 : 0.5;
    Disc d;
    d.id = q + 1;
    d.mol = 0;
    d.type = 1;
    d.x = X + off * std::cos(th);
    d.y = Y + off * std::sin(th);
    d.radius = 0.5;
    d.mass = 0.7853981633974483;
    d.vx = vx - w * (d.y - Y);
    d.vy = vy + w * (d.x - X);
    d.omega = w;
    f.discs.push_back(d);
  }
  Disc lone;
  lone.id = 3;
  lone.mol = 1;
  lone.type = 2;
  lone.x = -3.0000001;
  lone.y = 17.123456789;
  lone.radius = 0.35;
  lone.mass = 0.3848451000647496;
  lone.vx = 0.01;
  lone.vy = -2.5;
  lone.omega = -0.125;
  f.discs.push_back(lone);
  return f;
}

double Float(double v) { return static_cast<double>(static_cast<float>(v)); }

TEST(Gsd, TheHeaderAndIndexAreTheDocumentedFileLayer) {
  TempDir dir;
  const auto file = dir.Path() / kFramesGsdFile;
  FrameWriter w = FrameWriter::Create(file);
  w.Write(Bodies(0));
  w.Write(Bodies(100));
  w.Close();
  const std::string bytes = ReadFile(file);
  ASSERT_GE(bytes.size(), 256u);
  std::uint64_t head[5];
  std::uint32_t versions[2];
  std::memcpy(head, bytes.data(), sizeof head);
  std::memcpy(versions, bytes.data() + 40, sizeof versions);
  EXPECT_EQ(head[0], 0x65DF65DF65DF65DFULL);                // magic
  EXPECT_EQ(versions[0], (1u << 16) | 4u);                  // schema hoomd 1.4
  EXPECT_EQ(versions[1], 2u << 16);                         // file layer 2.0
  EXPECT_EQ(std::string(bytes.data() + 48, 7), "Granary");  // application
  EXPECT_EQ(std::string(bytes.data() + 112), "hoomd");      // schema
  // Index entries (32 bytes) sorted by frame, then by name id, ended by location 0.
  std::vector<gsd::IndexEntry> index(head[2]);
  std::memcpy(index.data(), bytes.data() + head[1], index.size() * sizeof(gsd::IndexEntry));
  std::size_t used = 0;
  while (used < index.size() && index[used].location != 0) ++used;
  EXPECT_EQ(used, 8u + 7u + 8u);  // frame 0 with the per-disc constants, frame 1 without
  for (std::size_t k = 1; k < used; ++k) {
    const auto& a = index[k - 1];
    const auto& b = index[k];
    EXPECT_TRUE(a.frame < b.frame || (a.frame == b.frame && a.id < b.id)) << k;
  }
  // The name list: names ended by 0 bytes, then an empty name.
  const std::string names = bytes.substr(head[3], head[4] * 64);
  EXPECT_NE(names.find(std::string("particles/position\0", 19)), std::string::npos);
  gsd::GsdReader r(file);
  EXPECT_EQ(r.Frames(), 2u);
  const gsd::IndexEntry* pos = r.Find(1, "particles/position");
  ASSERT_NE(pos, nullptr);
  EXPECT_EQ(pos->n, 3u);
  EXPECT_EQ(pos->m, 3u);
  EXPECT_EQ(pos->type, static_cast<std::uint8_t>(gsd::Type::kFloat));
  EXPECT_EQ(r.Find(1, "particles/typeid"), nullptr);  // constants only in frame 0
}

TEST(Gsd, FramesRoundTripWithFloat32PositionsAndRigidBodyVelocities) {
  TempDir dir;
  const auto file = dir.Path() / kFramesGsdFile;
  FrameWriter w = FrameWriter::Create(file);
  const Frame a = Bodies(0), b = Bodies(250, 0.75);
  const Frame c = [] {
    Frame f = Bodies(500);
    f.discs.erase(f.discs.begin(), f.discs.begin() + 2);  // the dumbbell has left: new constants
    return f;
  }();
  for (const Frame* f : {&a, &b, &c}) w.Write(*f);
  w.Close();
  FrameReader r(file);
  Frame f;
  for (const Frame* want : {&a, &b, &c}) {
    ASSERT_TRUE(r.Next(f));
    EXPECT_EQ(f.timestep, want->timestep);
    EXPECT_EQ(f.time, want->time);
    for (int k = 0; k < 3; ++k)
      for (int e = 0; e < 2; ++e) EXPECT_EQ(f.box[k][e], want->box[k][e]);
    ASSERT_EQ(f.discs.size(), want->discs.size());
    const double cx = (want->box[0][0] + want->box[0][1]) / 2, cy = (want->box[1][0] + want->box[1][1]) / 2;
    for (std::size_t i = 0; i < f.discs.size(); ++i) {
      const Disc& d = f.discs[i];
      const Disc& e = want->discs[i];
      EXPECT_EQ(d.id, e.id);
      EXPECT_EQ(d.mol, e.mol);
      EXPECT_EQ(d.type, e.type);
      // Exactly the float32 of the position relative to the box centre, added back.
      EXPECT_EQ(d.x, static_cast<double>(static_cast<float>(e.x - cx)) + cx);
      EXPECT_EQ(d.y, static_cast<double>(static_cast<float>(e.y - cy)) + cy);
      EXPECT_EQ(d.radius, 0.5 * Float(2 * e.radius));
      EXPECT_EQ(d.mass, Float(e.mass));
      EXPECT_EQ(d.omega, Float(e.omega));
      EXPECT_NEAR(d.vx, e.vx, 1e-6);
      EXPECT_NEAR(d.vy, e.vy, 1e-6);
    }
    // The bodies' centre-of-mass velocities are the float32 of the exact ones.
    const auto got = BodiesOf(f.discs), exact = BodiesOf(want->discs);
    ASSERT_EQ(got.size(), exact.size());
    for (std::size_t k = 0; k < got.size(); ++k) {
      EXPECT_NEAR(got[k].vx, Float(exact[k].vx), 1e-12);
      EXPECT_NEAR(got[k].vy, Float(exact[k].vy), 1e-12);
    }
  }
  EXPECT_FALSE(r.Next(f));
  // Frame 2 carries its own constants (one disc), frame 1 does not.
  gsd::GsdReader raw(file);
  EXPECT_EQ(raw.Find(1, "particles/body"), nullptr);
  ASSERT_NE(raw.Find(2, "particles/body"), nullptr);
  EXPECT_EQ(raw.Find(2, "particles/body")->n, 1u);
}

TEST(Gsd, ContactsRoundTripAsFloat32) {
  TempDir dir;
  const auto file = dir.Path() / kContactsGsdFile;
  ContactWriter w = ContactWriter::Create(file);
  ContactFrame c;
  c.timestep = 400;
  c.time = 0.04;
  c.box[0][0] = -10.5;
  c.box[0][1] = 13.25;
  c.box[1][0] = -7;
  c.box[1][1] = 41.7;
  c.contacts = {{0, 1, 2.1, 4.0, 2.9, 4.3, 2.5, 4.15, 1.25e-3, -3.75},
                {1, -1, -3.0, 0.35, -3.0, 0.0, -3.0, 0.0, 0.0, 12.5}};
  w.Write(c);
  ContactFrame empty = c;
  empty.timestep = 500;
  empty.contacts.clear();
  w.Write(empty);
  w.Close();
  ContactReader r(file);
  ContactFrame f;
  ASSERT_TRUE(r.Next(f));
  EXPECT_EQ(f.timestep, 400);
  EXPECT_EQ(f.time, 0.04);
  ASSERT_EQ(f.contacts.size(), 2u);
  const double cx = (c.box[0][0] + c.box[0][1]) / 2, cy = (c.box[1][0] + c.box[1][1]) / 2;
  for (std::size_t i = 0; i < 2; ++i) {
    const ContactRow& g = f.contacts[i];
    const ContactRow& e = c.contacts[i];
    EXPECT_EQ(g.body_i, e.body_i);
    EXPECT_EQ(g.body_j, e.body_j);
    EXPECT_EQ(g.xi, Float(e.xi - cx) + cx);
    EXPECT_EQ(g.yj, Float(e.yj - cy) + cy);
    EXPECT_EQ(g.cx, Float(e.cx - cx) + cx);
    EXPECT_EQ(g.fx, Float(e.fx));
    EXPECT_EQ(g.fy, Float(e.fy));
  }
  ASSERT_TRUE(r.Next(f));
  EXPECT_EQ(f.timestep, 500);
  EXPECT_TRUE(f.contacts.empty());
  EXPECT_FALSE(r.Next(f));
}

// Many frames (the index outgrows its first block twice), a checkpoint at frame 40, frames
// written after it, then the run continued: the frames up to the checkpoint and the new ones.
TEST(Gsd, ContinuingCutsTheFileBackToTheCheckpoint) {
  TempDir dir;
  const auto file = dir.Path() / kFramesGsdFile;
  FrameWriter w = FrameWriter::Create(file);
  std::int64_t offset = 0;
  for (int k = 0; k < 100; ++k) {
    w.Write(Bodies(k * 10));
    if (k == 40) offset = w.Offset();
  }
  w.Close();
  w = FrameWriter::ContinueAt(file, offset);
  for (int k = 41; k < 45; ++k) w.Write(Bodies(k * 10 + 1));
  w.Close();
  FrameReader r(file);
  Frame f;
  std::vector<std::int64_t> steps;
  while (r.Next(f)) {
    steps.push_back(f.timestep);
    ASSERT_EQ(f.discs.size(), 3u);
    EXPECT_EQ(f.discs[2].type, 2);
  }
  std::vector<std::int64_t> want;
  for (int k = 0; k <= 40; ++k) want.push_back(k * 10);
  for (int k = 41; k < 45; ++k) want.push_back(k * 10 + 1);
  EXPECT_EQ(steps, want);
}

// A run killed after a checkpoint and continued writes the uninterrupted run's bytes: for
// checkpoints before the first frame, before and after the index outgrows a block (frame 0
// has 15 entries, later ones 8: the 256-entry block is outgrown at frame 31, the 512-entry one
// at frame 63), and with the killed run's index grown past the checkpoint.
TEST(Gsd, AContinuedFileIsByteForByteTheUninterruptedOne) {
  TempDir dir;
  const auto whole = dir.Path() / "whole.gsd";
  FrameWriter a = FrameWriter::Create(whole);
  for (int k = 0; k < 100; ++k) a.Write(Bodies(k * 10, 0.01 * k));
  a.Close();
  const std::string want = ReadFile(whole);
  for (const int checkpoint : {-1, 0, 30, 31, 40, 62, 63, 99}) {
    const auto file = dir.Path() / ("cut-" + std::to_string(checkpoint) + ".gsd");
    FrameWriter w = FrameWriter::Create(file);
    std::int64_t offset = w.Offset();
    for (int k = 0; k < std::min(checkpoint + 30, 100); ++k) {
      w.Write(Bodies(k * 10, 0.01 * k));
      if (k == checkpoint) offset = w.Offset();
    }
    w = FrameWriter();  // killed: the frames after the checkpoint stay in the file
    w = FrameWriter::ContinueAt(file, offset);
    for (int k = checkpoint + 1; k < 100; ++k) w.Write(Bodies(k * 10, 0.01 * k));
    w.Close();
    EXPECT_EQ(ReadFile(file) == want, true) << "checkpoint after frame " << checkpoint;
  }
}

// contacts.gsd names its contact chunks at the first frame with contacts: a checkpoint before
// it, and a killed run that named them after it, continue into the same bytes.
TEST(Gsd, AContinuedContactFileIsByteForByteTheUninterruptedOne) {
  TempDir dir;
  auto frame = [](int k) {
    ContactFrame c;
    c.timestep = k;
    c.time = 0.01 * k;
    if (k >= 5) c.contacts.assign(static_cast<std::size_t>(k), {0, 1, 2.1, 4.0, 2.9, 4.3, 2.5, 4.15, 1e-3 * k, -3.75});
    return c;
  };
  const auto whole = dir.Path() / "whole.gsd";
  ContactWriter a = ContactWriter::Create(whole);
  for (int k = 0; k < 60; ++k) a.Write(frame(k));
  a.Close();
  const auto file = dir.Path() / "cut.gsd";
  ContactWriter w = ContactWriter::Create(file);
  std::int64_t offset = 0;
  for (int k = 0; k < 40; ++k) {
    w.Write(frame(k));
    if (k == 3) offset = w.Offset();
  }
  w = ContactWriter();
  w = ContactWriter::ContinueAt(file, offset);
  for (int k = 4; k < 60; ++k) w.Write(frame(k));
  w.Close();
  EXPECT_EQ(ReadFile(file) == ReadFile(whole), true);
}

// A file continued by an older build has its name list and index moved to the end, where
// writing its frames anew would not put them: it is continued as before (name list and index
// written anew at the end) and reads whole.
TEST(Gsd, AFileContinuedByAnOlderBuildStillContinuesAndReads) {
  TempDir dir;
  const auto file = dir.Path() / kFramesGsdFile;
  FrameWriter w = FrameWriter::Create(file);
  for (int k = 0; k < 10; ++k) w.Write(Bodies(k));
  w.Close();
  // The older build's continue: a copy of the name list and of the index (twice the entries,
  // at least 256) at the end, the header pointing at them.
  std::string bytes = ReadFile(file);
  std::uint64_t index_location = 0, index_entries = 0, names_location = 0, name_slots = 0;
  std::memcpy(&index_location, bytes.data() + 8, 8);
  std::memcpy(&index_entries, bytes.data() + 16, 8);
  std::memcpy(&names_location, bytes.data() + 24, 8);
  std::memcpy(&name_slots, bytes.data() + 32, 8);
  const std::string names = bytes.substr(names_location, name_slots * 64);
  std::string index = bytes.substr(index_location, index_entries * 32);
  const std::uint64_t used = 10 * gsd::kGsdFrameEntries + 7;
  index.resize(std::max<std::uint64_t>(256, 2 * used) * 32, '\0');
  const std::uint64_t new_names = bytes.size(), new_index = bytes.size() + names.size(), new_slots = names.size() / 64,
                      new_entries = index.size() / 32;
  bytes += names + index;
  std::memcpy(bytes.data() + 8, &new_index, 8);
  std::memcpy(bytes.data() + 16, &new_entries, 8);
  std::memcpy(bytes.data() + 24, &new_names, 8);
  std::memcpy(bytes.data() + 32, &new_slots, 8);
  WriteFile(file, bytes);
  ASSERT_EQ(gsd::GsdReader(file).Frames(), 10u);
  w = FrameWriter::ContinueAt(file, static_cast<std::int64_t>(bytes.size()));
  for (int k = 10; k < 40; ++k) w.Write(Bodies(k));
  w.Close();
  FrameReader r(file);
  Frame f;
  std::vector<std::int64_t> steps, want;
  while (r.Next(f)) steps.push_back(f.timestep);
  for (int k = 0; k < 40; ++k) want.push_back(k);
  EXPECT_EQ(steps, want);
}

TEST(Gsd, AFileCutInsideItsLastFrameEndsBeforeIt) {
  TempDir dir;
  const auto file = dir.Path() / kFramesGsdFile;
  FrameWriter w = FrameWriter::Create(file);
  for (int k = 0; k < 3; ++k) w.Write(Bodies(k));
  w.Close();
  std::filesystem::resize_file(file, std::filesystem::file_size(file) - 5);
  FrameReader r(file);
  Frame f;
  int frames = 0;
  while (r.Next(f)) ++frames;
  EXPECT_EQ(frames, 2);
}

TEST(Gsd, ANewerFileLayerIsRefusedByName) {
  TempDir dir;
  const auto file = dir.Path() / kFramesGsdFile;
  FrameWriter w = FrameWriter::Create(file);
  w.Write(Bodies(0));
  w.Close();
  std::string bytes = ReadFile(file);
  const std::uint32_t v3 = 3u << 16;
  std::memcpy(bytes.data() + 44, &v3, 4);
  WriteFile(file, bytes);
  try {
    FrameReader r(file);
    FAIL() << "read a version 3 file";
  } catch (const ReadError& e) {
    EXPECT_EQ(std::string(e.what()),
              file.string() + ": GSD file layer version 3.0 is newer than this build reads (1.x, 2.x)");
  }
}

// A run directory with frames.gsd is read through it; one with the text dumps (older runs,
// output.format "text") as before.
TEST(Gsd, TheRunDirectoryFindsGsdAndTextFrames) {
  TempDir dir;
  FrameWriter::Create(dir.Path() / kFramesGsdFile).Write(Bodies(7));
  ContactWriter::Create(dir.Path() / kContactsGsdFile).Write(ContactFrame{});
  RunData gsd_run = ReadRun(dir.Path());
  EXPECT_TRUE(gsd_run.gsd);
  EXPECT_EQ(gsd_run.FramesFile(), dir.Path() / kFramesGsdFile);
  EXPECT_EQ(gsd_run.ContactsFile(), dir.Path() / kContactsGsdFile);
  EXPECT_TRUE(gsd_run.has_frames);
  EXPECT_TRUE(gsd_run.has_contacts);
  TempDir old;
  {
    FrameWriter t = FrameWriter::Create(old.Path() / kFramesFile);
    t.Write(Bodies(7));
  }
  RunData text_run = ReadRun(old.Path());
  EXPECT_FALSE(text_run.gsd);
  EXPECT_EQ(text_run.FramesFile(), old.Path() / kFramesFile);
  FrameReader r(text_run.FramesFile());
  Frame f;
  ASSERT_TRUE(r.Next(f));
  EXPECT_EQ(f.timestep, 7);
  EXPECT_EQ(f.discs.size(), 3u);
  Output o;
  o.format = FrameFormat::kGsd;
  EXPECT_STREQ(FramesFileName(o), "frames.gsd");
  EXPECT_STREQ(ContactsFileName(o), "contacts.gsd");
  o.format = FrameFormat::kText;
  o.compress = true;
  EXPECT_STREQ(FramesFileName(o), "frames.dump.gz");
}

// The estimator's count of a file's bytes is what the writer writes: per frame its chunks and
// index entries (GsdFrameBytes), frame 0's constants, and the header, name list and index
// blocks outgrown on the way (GsdOverheadBytes; 40 frames outgrow the first block).
TEST(Gsd, FileBytesAreWhatTheEstimatorCounts) {
  TempDir dir;
  const auto file = dir.Path() / kFramesGsdFile;
  FrameWriter w = FrameWriter::Create(file);
  std::int64_t frames = 0;
  for (int k = 0; k < 40; ++k, frames += gsd::GsdFrameBytes(Bodies(k))) w.Write(Bodies(k));
  w.Close();
  const std::uint64_t entries = 40 * gsd::kGsdFrameEntries + 7;
  ASSERT_GT(entries, 256u);
  // Frame 0's constants: 3 discs, 2 type names of 8 bytes, the dimensions byte; 7 entries.
  const std::int64_t constants = 3 * gsd::kGsdConstantBytesPerDisc + 2 * 8 + 1 + 7 * 32;
  EXPECT_EQ(static_cast<std::int64_t>(std::filesystem::file_size(file)),
            gsd::GsdOverheadBytes(entries) + frames + constants);
  const auto cfile = dir.Path() / kContactsGsdFile;
  ContactWriter cw = ContactWriter::Create(cfile);
  ContactFrame c;
  c.contacts.resize(5);
  for (int k = 0; k < 3; ++k) cw.Write(c);
  cw.Close();
  EXPECT_EQ(static_cast<std::int64_t>(std::filesystem::file_size(cfile)),
            gsd::GsdOverheadBytes(3 * gsd::kGsdContactEntries) + 3 * gsd::GsdContactBytes(c));
}

}  // namespace
}  // namespace granary::rundir
