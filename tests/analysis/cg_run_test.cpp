// cg_fields_of_run on a run directory written through the run-directory writers: frames
// paired with the contact frames of the same timestep, the time range, the stride, routing
// frames into parts (flowing / clogged) and the default window of the silo.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "analysis/cg_run.h"
#include "rundir/contacts.h"
#include "rundir/frames.h"
#include "rundir/run_directory.h"
#include "lattice_frame.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::TempDir;

// A square lattice of discs (spacing 1, radius 0.5) filling x in [-12, 12], y in [0.5, 20.5],
// falling at speed `t` at time t; contact frames (vertical chains carrying weight 1 per disc
// above) only at the timesteps listed.
void WriteRun(const std::filesystem::path& dir, const std::vector<double>& frame_times,
              const std::vector<double>& contact_times) {
  rundir::WriteRunSpec(dir, {{"silo", {{"width", 25.0}}}, {"bodies", {{"density", 1.0}}}});
  auto frames = rundir::FrameWriter::Create(dir / rundir::kFramesFile);
  auto contacts = rundir::ContactWriter::Create(dir / rundir::kContactsFile);
  for (double t : frame_times) {
    const auto [f, c] = testing::LatticeFrame(t, -t);
    frames.Write(f);
    if (std::find(contact_times.begin(), contact_times.end(), t) != contact_times.end()) contacts.Write(c);
  }
  frames.Close();
  contacts.Close();
}

// Four frames with contact frames at t = 0, 2 and 3, mapped inside the lattice from t = 0.5.
CgRunOptions WritePairedRun(const std::filesystem::path& dir) {
  WriteRun(dir, {0.0, 1.0, 2.0, 3.0}, {0.0, 2.0, 3.0});
  CgRunOptions o;
  o.cg.window = {-5.0, 5.0, 5.0, 15.0};
  o.t_start = 0.5;
  return o;
}

TEST(CgRun, PairsFramesWithTheirContactFramesOverTheTimeRange) {
  TempDir tmp;
  const CgRunOptions o = WritePairedRun(tmp.Path());
  const rundir::RunData data = rundir::ReadRun(tmp.Path());
  const CgRunResult r = CgFieldsOfRun(data, o);
  ASSERT_EQ(r.parts.size(), 1u);
  const CgMaps maps(r.parts[0]);
  EXPECT_EQ(maps.Frames(), 3);         // t = 1, 2, 3
  EXPECT_EQ(maps.ContactFrames(), 2);  // t = 2, 3
  EXPECT_EQ(r.frames_without_contacts, 1);
  EXPECT_TRUE(r.has_contacts);
  EXPECT_EQ(r.first_time, 1.0);
  EXPECT_EQ(r.last_time, 3.0);
  const std::size_t centre = maps.Grid().size() / 2;
  EXPECT_NEAR(maps.Value(CgField::kVy, centre), -2.0, 1e-12);  // mean of -1, -2, -3
  // The column above y carries (20.5 - y) discs' "weight" of 1 each: sigma_yy = -(20.5 - y) per
  // unit width (one chain per 1 d), to the cut kernel's error (2e-4 of the load, measured 1.1e-4).
  const double y = maps.Grid().Y(static_cast<int>(centre / maps.Grid().nx));
  EXPECT_NEAR(maps.Value(CgField::kSigmaYY, centre), -(21.0 - y), 2e-4 * (21.0 - y));
}

// With two threads a frame's discs and its contact frame are parsed side by side: the same
// sums as on one thread, and a malformed contact row (of the frame at t = 1, step 10000)
// still comes out as its ReadError.
TEST(CgRun, TwoReadersGiveTheSameSumsAndTheirErrors) {
  TempDir tmp;
  CgRunOptions o = WritePairedRun(tmp.Path());
  const rundir::RunData data = rundir::ReadRun(tmp.Path());
  o.cg.threads = 1;
  const CgSums one = CgFieldsOfRun(data, o).parts[0];
  o.cg.threads = 2;
  const CgSums two = CgFieldsOfRun(data, o).parts[0];
  EXPECT_EQ(two.contact_frames, 2);
  EXPECT_EQ(one.phi, two.phi);
  EXPECT_EQ(one.vy, two.vy);
  EXPECT_EQ(one.sxx, two.sxx);
  EXPECT_EQ(one.syy, two.syy);
  EXPECT_EQ(one.kyy, two.kyy);
  testing::WriteFile(tmp.Path() / rundir::kContactsFile,
                     "ITEM: TIMESTEP\n10000\nITEM: TIME\n1\nITEM: NUMBER OF ENTRIES\n1\n"
                     "ITEM: ENTRIES body_i body_j xi yi xj yj cx cy fx fy\n0 1 0 0 1 0 0.5 0 abc 0\n");
  const rundir::RunData bad = rundir::ReadRun(tmp.Path());
  EXPECT_THROW(CgFieldsOfRun(bad, o), rundir::ReadError);
}

TEST(CgRun, StrideMaxFramesAndRouting) {
  TempDir tmp;
  WriteRun(tmp.Path(), {0.0, 1.0, 2.0, 3.0, 4.0, 5.0}, {});
  const rundir::RunData data = rundir::ReadRun(tmp.Path());
  CgRunOptions o;
  o.cg.window = {-5.0, 5.0, 5.0, 15.0};
  o.frame_stride = 2;  // t = 0, 2, 4
  o.route = [](double t) { return t < 1.0 ? -1 : (t < 3.0 ? 0 : 1); };
  o.parts = 2;
  o.series = {{"vy", {-1.0, 1.0, 9.0, 11.0}, CgField::kVy}};
  const CgRunResult r = CgFieldsOfRun(data, o);
  ASSERT_EQ(r.parts.size(), 2u);
  EXPECT_EQ(r.parts[0].frames, 1);  // t = 2
  EXPECT_EQ(r.parts[1].frames, 1);  // t = 4
  EXPECT_EQ(r.parts[0].contact_frames, 0);
  ASSERT_EQ(r.series.size(), 1u);
  ASSERT_EQ(r.series[0].time, (std::vector<double>{2.0, 4.0}));
  EXPECT_NEAR(r.series[0].value[0], -2.0, 1e-12);
  EXPECT_NEAR(r.series[0].value[1], -4.0, 1e-12);
  o.route = nullptr;
  o.max_frames = 2;
  EXPECT_EQ(CgFieldsOfRun(data, o).parts[0].frames, 2);
}

TEST(CgRun, DefaultWindowIsTheSiloUpToTheBed) {
  TempDir tmp;
  WriteRun(tmp.Path(), {0.0}, {0.0});
  const rundir::RunData data = rundir::ReadRun(tmp.Path());
  const Rect w = CgRunWindow(data);  // no summary: the top of the first frame's discs
  EXPECT_EQ(w.x0, -11.0);
  EXPECT_EQ(w.x1, 11.0);
  EXPECT_EQ(w.y0, 1.5);
  EXPECT_EQ(w.y1, 21.0);
  const CgRunResult r = CgFieldsOfRun(data, CgRunOptions());
  EXPECT_EQ(r.parts[0].grid, GridOver(w, 1.0));
}

}  // namespace
}  // namespace granary::analysis
