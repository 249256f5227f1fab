// Bed preparation: a settled bed loaded from its JSON file, with its stored contact history,
// is in equilibrium (net force per body << its weight); without the history (or with the
// shear of each pair flipped, as a wrong disc renumbering would do) it is not. Also the bed
// key check and the species counts of a mixture.
#include "engine/bed.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <omp.h>
#include <nlohmann/json.hpp>

namespace granary::engine {
namespace {

RunSpec SmallBedSpec() {
  nlohmann::json j = {{"seed", std::uint64_t{5}},
                      {"silo", {{"width", 12.0}, {"base_outlets", {{{"center", 0.0}, {"width", 6.0}}}}}},
                      {"bodies", {{"count", 60}}},
                      {"bed", {{"batch_size", 60}, {"settle_ke_per_body", 1e-6}, {"max_settle_time", 30.0}}}};
  return RunSpec::FromJson(j);
}

// RMS over bodies of |net force| / weight at the first force computation.
double RmsNetForce(const RunSpec& spec, const BedState& bed, bool history, bool flip) {
  Silo closed;
  closed.width = spec.silo.width;
  World w(ParamsFromSpec(spec), MakeTemplates(spec), silo::BuildGeometry(closed, kTallWall));
  for (std::size_t b = 0; b < bed.x.size(); ++b) {
    const int id = w.AddBody(bed.species[b], bed.x[b], bed.y[b], bed.theta[b]);
    w.SetVelocity(id, bed.vx[b], bed.vy[b], bed.omega[b]);
  }
  std::vector<HistoryEntry> pairs = bed.pair_history, walls = bed.wall_history;
  if (!history) pairs.clear(), walls.clear();
  if (flip)
    for (HistoryEntry& h : pairs) h.sx = -h.sx, h.sy = -h.sy;
  w.ImportHistory(pairs, walls);
  w.ComputeForces();
  double sum = 0.0;
  for (int b = 0; b < w.BodyCount(); ++b)
    sum += (w.body_fx_[b] * w.body_fx_[b] + w.body_fy_[b] * w.body_fy_[b]) /
           (w.body_mass_[b] * w.body_mass_[b] * spec.gravity * spec.gravity);
  return std::sqrt(sum / w.BodyCount());
}

TEST(Bed, LoadedBedWithItsHistoryIsInEquilibrium) {
  const RunSpec spec = SmallBedSpec();
  const BedState prepared = PrepareBed(spec, nullptr);
  const BedState bed = BedFromJson(nlohmann::json::parse(BedToJson(prepared, spec).dump()), spec, "test");
  ASSERT_EQ(bed.x.size(), 60u);
  EXPECT_EQ(bed.x, prepared.x);  // JSON round trip is exact
  EXPECT_FALSE(bed.pair_history.empty());
  EXPECT_FALSE(bed.wall_history.empty());
  EXPECT_LT(RmsNetForce(spec, bed, true, false), 0.3);
  EXPECT_GT(RmsNetForce(spec, bed, false, false), 1.0);
  EXPECT_GT(RmsNetForce(spec, bed, true, true), 1.0);
  // the bed lies on the base, below the height of 60 dumbbells packed in a width of 12
  EXPECT_GT(bed.height, 60 * 1.5708 / 12 * 0.9);
  EXPECT_LT(bed.height, 60 * 1.5708 / 12 / 0.6);
}

// bed/next_batch = landed places a batch once the last one rests on the pile (its kinetic
// energy per body back below kBedLandedKePerBody): the same bed (settled, the same height
// within a few per cent) in less simulated time than the fixed wait sqrt(2 h / g) + 1 per
// batch. 120 discs in three batches.
TEST(Bed, NextBatchOnLandingSavesTimeAndGivesTheSameBed) {
  RunSpec spec = SmallBedSpec();
  spec.bodies.count = 120;
  spec.bed.batch_size = 40;
  spec.bed.next_batch = NextBatch::kFixed;
  const BedState fixed = PrepareBed(spec, nullptr);
  spec.bed.next_batch = NextBatch::kLanded;
  const BedState landed = PrepareBed(spec, nullptr);
  EXPECT_NE(fixed.x, landed.x);  // the option is not ignored
  // the fixed waits alone: 2 x (sqrt(2 h / g) + 1) with h = 40 (pi/4) / (12 x 0.3) at least
  const double waits = 2 * (std::sqrt(2 * 40 * 0.7854 / (12 * 0.3)) + 1);
  EXPECT_GT(fixed.settle_time, waits);
  EXPECT_LT(landed.settle_time, fixed.settle_time - 0.25 * waits) << fixed.settle_time;
  EXPECT_LT(landed.settle_time, spec.bed.max_settle_time);  // settled, not given up
  EXPECT_NEAR(landed.height, fixed.height, 0.05 * fixed.height);
}

// The bed's Verlet skin (kBedSkin) only changes when the lists are rebuilt, never which
// pairs touch or in what order their forces are summed: the same bed to the bit at the run's
// skin and at the bed's. 240 discs in four batches, so that the lists are rebuilt at
// different steps.
TEST(Bed, TheSkinDoesNotChangeTheBed) {
  RunSpec spec = SmallBedSpec();
  spec.bodies.count = 240;
  spec.bed.batch_size = 60;
  const BedState a = PrepareBed(spec, nullptr, WorldParams{}.skin);
  const BedState b = PrepareBed(spec, nullptr, kBedSkin);
  ASSERT_NE(WorldParams{}.skin, kBedSkin);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.y, b.y);
  EXPECT_EQ(a.theta, b.theta);
  EXPECT_EQ(a.vx, b.vx);
  EXPECT_EQ(a.omega, b.omega);
  EXPECT_EQ(a.settle_time, b.settle_time);
  ASSERT_EQ(a.pair_history.size(), b.pair_history.size());
  for (std::size_t k = 0; k < a.pair_history.size(); ++k) {
    EXPECT_EQ(a.pair_history[k].sx, b.pair_history[k].sx);
    EXPECT_EQ(a.pair_history[k].sy, b.pair_history[k].sy);
  }
}

// Same bits on one and two threads: 1200 dumbbells (2400 discs, above the engine's
// parallel_min_discs, so the threaded loops run) in three batches that follow on landing.
TEST(Bed, OneAndTwoThreadsPrepareTheSameBed) {
  RunSpec spec = SmallBedSpec();
  spec.silo.width = 40.0;
  spec.bodies.count = 1200;
  spec.bed.batch_size = 400;
  spec.bed.settle_ke_per_body = 1e-4;
  ASSERT_GE(2 * spec.bodies.count, WorldParams{}.parallel_min_discs);
  omp_set_num_threads(1);
  const BedState one = PrepareBed(spec, nullptr);
  omp_set_num_threads(2);
  const BedState two = PrepareBed(spec, nullptr);
  EXPECT_EQ(one.x, two.x);
  EXPECT_EQ(one.y, two.y);
  EXPECT_EQ(one.theta, two.theta);
  EXPECT_EQ(one.vy, two.vy);
  EXPECT_EQ(one.settle_time, two.settle_time);
  EXPECT_LT(one.settle_time, 3 * 10.0 + spec.bed.max_settle_time);  // settled
}

TEST(Bed, FileOfAnotherBedKeyIsRefused) {
  RunSpec spec = SmallBedSpec();
  BedState bed;
  bed.species = {0};
  bed.x = bed.y = bed.theta = bed.vx = bed.vy = bed.omega = {0.0};
  const nlohmann::json j = BedToJson(bed, spec);
  spec.seed = 6;
  try {
    BedFromJson(j, spec, "beds/x.json");
    FAIL() << "expected a refusal";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("beds/x.json was prepared for another bed key"), std::string::npos)
        << e.what();
  }
}

// Prepared beds carry a format version and a checksum: a cached bed with one number changed
// (or of an older format) is refused with a message, put aside and prepared again, so the
// run still starts from the bed its spec and seed give.
TEST(Bed, ACorruptOrOldCachedBedIsRefusedAndPreparedAgain) {
  namespace fs = std::filesystem;
  std::string tmpl = (fs::temp_directory_path() / "granary-bed-test-XXXXXX").string();
  ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
  const fs::path dir = tmpl;
  RunSpec spec = SmallBedSpec();
  spec.bed.cache_file = (dir / "bed.json").string();
  const ObtainedBed first = ObtainBed(spec, dir.string(), nullptr);
  ASSERT_TRUE(first.prepared_here);
  EXPECT_TRUE(ObtainBed(spec, dir.string(), nullptr).refused.empty());

  // One coordinate changed in the file: still valid JSON, still a bed of the right key.
  nlohmann::json j = nlohmann::json::parse(std::ifstream(spec.bed.cache_file));
  EXPECT_EQ(j["version"], 3);
  EXPECT_EQ(j["checksum"].get<std::string>().rfind("crc32:", 0), 0u);
  j["bodies"][7][1] = j["bodies"][7][1].get<double>() + 1e-9;
  std::ofstream(spec.bed.cache_file) << j.dump();
  const ObtainedBed again = ObtainBed(spec, dir.string(), nullptr);
  EXPECT_TRUE(again.prepared_here);
  EXPECT_NE(again.refused.find("bed.json is corrupt: its checksum is crc32:"), std::string::npos) << again.refused;
  EXPECT_TRUE(fs::exists(spec.bed.cache_file + ".corrupt"));
  EXPECT_EQ(again.bed.x, first.bed.x);

  // An older format (no checksum) is not trusted either.
  j = nlohmann::json::parse(std::ifstream(spec.bed.cache_file));
  j["version"] = 2;
  j.erase("checksum");
  std::ofstream(spec.bed.cache_file) << j.dump();
  EXPECT_NE(ObtainBed(spec, dir.string(), nullptr).refused.find("has format version 2; this engine reads version 3"),
            std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace granary::engine
