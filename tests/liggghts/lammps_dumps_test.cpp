// LAMMPS itself reads what both engines write: Debian's `lmp` reruns every frame of a run's
// frames.dump (rerun = read_dump per snapshot, box from the file, atoms purged and added), writes
// its own dump of the atoms it read and, for every frame, a local dump of the disc pairs that
// touch. The test compares LAMMPS' view with the run's frames and contact frames: the same
// frames, ids, types and positions to the bit, every disc inside the run's fixed box, the
// same header items in the same order as LAMMPS writes them, and the pairs of touching
// bodies that LAMMPS finds are the pair rows of contacts.dump, whose disc centres are where
// LAMMPS put those discs. A local dump (contacts.dump) is not something LAMMPS reads back
// (read_dump takes per-atom dumps only), so its rows are checked against LAMMPS' own.
#include <gtest/gtest.h>

#include <algorithm>
#include <boost/process.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "rundir/contacts.h"
#include "rundir/run_directory.h"
#include "rundir/frames.h"

namespace {

namespace fs = std::filesystem;
namespace bp = boost::process;
using nlohmann::json;
using namespace granary::rundir;

const fs::path kTmp = GRANARY_LIGGGHTS_TEST_TMP;

// The ITEM lines of a dump, in order, with the column names of the last item cut off.
std::vector<std::string> Items(const fs::path& file, std::size_t blocks) {
  std::ifstream in(file);
  std::vector<std::string> items;
  std::string line;
  std::size_t seen = 0;
  while (std::getline(in, line)) {
    if (line.rfind("ITEM: ", 0) != 0) continue;
    if (line.rfind("ITEM: ATOMS", 0) == 0) line = "ITEM: ATOMS";
    if (line.rfind("ITEM: ENTRIES", 0) == 0) line = "ITEM: ENTRIES";
    if (line.rfind("ITEM: TIME", 0) == 0 && line != "ITEM: TIMESTEP" && ++seen > blocks) break;
    items.push_back(line);
  }
  return items;
}

// One block of a LAMMPS text dump: timestep, box and rows of numbers under named columns.
struct Block {
  long long step = -1;
  double box[2][2] = {{0, 0}, {0, 0}};
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
  int Col(const std::string& name) const {
    for (std::size_t i = 0; i < columns.size(); ++i)
      if (columns[i] == name) return static_cast<int>(i);
    ADD_FAILURE() << "no column " << name;
    return 0;
  }
};
std::vector<Block> ReadBlocks(const fs::path& file) {
  std::ifstream in(file);
  std::vector<Block> blocks;
  std::string line;
  while (std::getline(in, line)) {
    if (line == "ITEM: TIME" || line == "ITEM: UNITS") {
      std::getline(in, line);
    } else if (line == "ITEM: TIMESTEP") {
      blocks.emplace_back();
      std::getline(in, line);
      blocks.back().step = std::stoll(line);
    } else if (line.rfind("ITEM: BOX BOUNDS", 0) == 0) {
      for (auto& b : blocks.back().box) in >> b[0] >> b[1];
      std::getline(in, line);
      std::getline(in, line);  // z bounds
    } else if (line.rfind("ITEM: NUMBER OF", 0) == 0) {
      std::getline(in, line);
      blocks.back().rows.reserve(std::stoul(line));
    } else if (line.rfind("ITEM: ATOMS", 0) == 0 || line.rfind("ITEM: ENTRIES", 0) == 0) {
      std::istringstream names(line.substr(line.find(' ', 6) + 1));
      for (std::string n; names >> n;) blocks.back().columns.push_back(n);
    } else if (!line.empty() && line.rfind("ITEM:", 0) != 0 && !blocks.empty() && !blocks.back().columns.empty()) {
      std::istringstream values(line);
      std::vector<double> row;
      for (std::string v; values >> v;) row.push_back(std::stod(v));
      blocks.back().rows.push_back(std::move(row));
    }
  }
  return blocks;
}

std::string Lammps() {
  const char* env = std::getenv("GRANARY_LAMMPS");
  return env && *env ? env : bp::search_path("lmp").string();
}

// Reruns DIR/frames.dump[.gz] in LAMMPS; its dumps go to DIR/lammps/.
void RerunInLammps(const fs::path& dir, const std::string& frames, int types) {
  const fs::path work = dir / "lammps";
  fs::create_directories(work);
  const std::string lmp = Lammps();
  ASSERT_FALSE(lmp.empty()) << "LAMMPS (lmp) not found: install Debian's package lammps (scripts/setup.sh does)";
  std::ofstream(work / "rerun.in")
      << "units lj\natom_style sphere\nboundary f f p\n"
         "region box block -1 1 -1 1 -0.5 0.5\ncreate_box "
      << types
      << " box\n"
         // Discs of diameter 1 (atom_style sphere's default); the pair style only makes LAMMPS
         // build the neighbour lists that compute pair/local reports. Its cutoff comes from
         // the radii of the atoms present at the first run, so the first frame is read first.
         "read_dump ../"
      << frames
      << " 0 x y z box yes add keep\n"
         "pair_style gran/hooke 1.0 NULL 0.0 NULL 0.0 0\npair_coeff * *\ncomm_modify vel yes\n"
         "neighbor 0.3 bin\nthermo_modify lost ignore\n"
         "compute touching all property/local patom1 patom2\ncompute distance all pair/local dist\n"
         "dump atoms all custom 1 frames.dump id type x y vx vy\n"
         "dump_modify atoms time yes sort id format float %.17g\n"
         "dump contacts all local 1 contacts.dump c_touching[1] c_touching[2] c_distance\n"
         "dump_modify contacts time yes format float %.17g\n"
         "rerun ../"
      << frames << " dump x y z vx vy vz box yes purge yes replace no add keep\n";
  bp::ipstream out;
  bp::child c(lmp, "-in", "rerun.in", "-log", "log.lammps", (bp::std_out & bp::std_err) > out,
              bp::start_dir(work.string()));
  std::string all, line;
  while (std::getline(out, line)) all += line + "\n";
  c.wait();
  ASSERT_EQ(c.exit_code(), 0) << all;
}

fs::path MakeRun(const std::string& engine, const std::string& name, bool compress = false,
                 const char* format = "text") {
  const fs::path dir = kTmp / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  // Discs and dumbbells, all of diameter 1, flowing out of a narrow silo.
  const json j = {{"run_id", name},
                  {"seed", 5},
                  {"engine", engine},
                  {"silo", {{"width", 12}, {"base_outlets", {{{"center", 0}, {"width", 7}}}}}},
                  {"bodies",
                   {{"count", 60},
                    {"species", {{{"shape", "disc"}, {"fraction", 0.5}}, {{"shape", "dumbbell"}, {"fraction", 0.5}}}}}},
                  {"bed",
                   {{"settle_ke_per_body", 1e-5},
                    {"max_settle_time", 20},
                    {"cache_file", (kTmp / "beds_lammps" / "bed.json").string()}}},
                  {"discharge", {{"mode", "remove"}, {"max_time", 4}, {"clog_window", 3}}},
                  {"output",
                   {{"checkpoint_interval", 0},
                    {"frame_interval", 0.5},
                    {"contact_forces", true},
                    {"compress", compress},
                    {"format", format}}}};
  std::ofstream(dir / "run.json") << j.dump(2);
  return dir;
}

void RunEngine(const std::string& exe, const fs::path& dir) {
  bp::ipstream out;
  bp::child c(exe, "run", dir.string(), (bp::std_out & bp::std_err) > out);
  std::string all, line;
  while (std::getline(out, line)) all += line + "\n";
  c.wait();
  ASSERT_EQ(c.exit_code(), 0) << all;
}

// The comparison; `contact_tolerance` is how closely a contact row's disc centres match the
// frame (LIGGGHTS prints its local dumps with fewer digits than its atom dumps).
void LammpsReadsTheRun(const fs::path& dir, double contact_tolerance) {
  const RunData run = ReadRun(dir);
  ASSERT_TRUE(run.has_frames);
  ASSERT_TRUE(run.has_contacts);
  RerunInLammps(dir, run.FramesFile().filename().string(), 2);
  if (::testing::Test::HasFatalFailure()) return;
  std::vector<Frame> frames;
  {
    FrameReader reader(run.FramesFile());
    for (Frame f; reader.Next(f);) frames.push_back(f);
  }
  std::vector<ContactFrame> contacts;
  {
    ContactReader reader(run.ContactsFile());
    for (ContactFrame c; reader.Next(c);) contacts.push_back(c);
  }
  const std::vector<Block> atoms = ReadBlocks(dir / "lammps" / "frames.dump");
  const std::vector<Block> pairs = ReadBlocks(dir / "lammps" / "contacts.dump");
  ASSERT_GE(frames.size(), 5u);
  ASSERT_EQ(contacts.size(), frames.size());
  ASSERT_EQ(atoms.size(), frames.size()) << "LAMMPS reran every frame";
  ASSERT_EQ(pairs.size(), frames.size());
  EXPECT_LT(frames.back().discs.size(), frames.front().discs.size()) << "bodies left: frames of different sizes";

  // The header items in LAMMPS' order (TIME before TIMESTEP), for atoms and for entries.
  if (!run.compressed) {
    EXPECT_EQ(Items(dir / "frames.dump", 2), Items(dir / "lammps" / "frames.dump", 2));
    EXPECT_EQ(Items(dir / "contacts.dump", 2), Items(dir / "lammps" / "contacts.dump", 2));
    EXPECT_EQ(Items(dir / "frames.dump", 1).front(), "ITEM: TIME");
  }

  int touching_pairs = 0;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const Frame& ours = frames[k];
    const Block& lammps = atoms[k];
    SCOPED_TRACE("frame at t = " + std::to_string(ours.time));
    // One box for the whole run, as LAMMPS read it from every frame.
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b) {
        EXPECT_EQ(ours.box[a][b], frames[0].box[a][b]);
        EXPECT_EQ(lammps.box[a][b], ours.box[a][b]);
      }
    EXPECT_EQ(lammps.step, ours.timestep);
    // Every disc read, none lost outside the box, at the same place with the same velocity.
    ASSERT_EQ(lammps.rows.size(), ours.discs.size());
    std::map<long long, const Disc*> by_id;
    for (const Disc& d : ours.discs) by_id[d.id] = &d;
    const int c_id = lammps.Col("id"), c_type = lammps.Col("type"), c_x = lammps.Col("x"), c_y = lammps.Col("y"),
              c_vx = lammps.Col("vx"), c_vy = lammps.Col("vy");
    std::map<long long, std::pair<double, double>> where;
    for (const auto& row : lammps.rows) {
      const auto it = by_id.find(std::llround(row[c_id]));
      ASSERT_NE(it, by_id.end()) << "LAMMPS read a disc id the frame does not have";
      const Disc& d = *it->second;
      EXPECT_EQ(std::llround(row[c_type]), d.type);
      EXPECT_EQ(row[c_x], d.x);
      EXPECT_EQ(row[c_y], d.y);
      EXPECT_EQ(row[c_vx], d.vx);
      EXPECT_EQ(row[c_vy], d.vy);
      where[d.id] = {row[c_x], row[c_y]};
    }
    // Pairs of bodies whose discs LAMMPS finds touching (distance < 1, both diameter 1), with a
    // margin for contacts within rounding of the written positions.
    ASSERT_EQ(pairs[k].step, ours.timestep);
    std::set<std::pair<long long, long long>> lammps_sure, lammps_maybe;
    const int c_a = pairs[k].Col("c_touching[1]"), c_b = pairs[k].Col("c_touching[2]"),
              c_d = pairs[k].Col("c_distance");
    for (const auto& row : pairs[k].rows) {
      const long long bi = by_id.at(std::llround(row[c_a]))->mol, bj = by_id.at(std::llround(row[c_b]))->mol;
      if (bi == bj) continue;
      const auto key = std::minmax(bi, bj);
      if (row[c_d] < 1 - 1e-6) lammps_sure.insert(key);
      if (row[c_d] < 1 + 1e-6) lammps_maybe.insert(key);
    }
    const ContactFrame& cf = contacts[k];
    EXPECT_EQ(cf.timestep, ours.timestep);
    std::set<std::pair<long long, long long>> ours_pairs;
    for (const ContactRow& c : cf.contacts) {
      if (c.body_j < 0) continue;
      ours_pairs.insert(std::minmax(c.body_i, c.body_j));
      // The rows' disc centres are discs of those bodies where LAMMPS put them.
      auto at = [&](double x, double y, long long body) {
        for (const Disc& d : ours.discs)
          if (d.mol == body && std::hypot(where.at(d.id).first - x, where.at(d.id).second - y) < contact_tolerance)
            return true;
        return false;
      };
      EXPECT_TRUE(at(c.xi, c.yi, c.body_i)) << "body " << c.body_i << " has no disc at " << c.xi << " " << c.yi;
      EXPECT_TRUE(at(c.xj, c.yj, c.body_j)) << "body " << c.body_j << " has no disc at " << c.xj << " " << c.yj;
    }
    for (const auto& p : lammps_sure)
      EXPECT_TRUE(ours_pairs.count(p)) << "LAMMPS: bodies " << p.first << ", " << p.second << " touch";
    for (const auto& p : ours_pairs)
      EXPECT_TRUE(lammps_maybe.count(p)) << "contacts.dump: bodies " << p.first << ", " << p.second << " touch";
    touching_pairs += static_cast<int>(lammps_sure.size());
  }
  EXPECT_GT(touching_pairs, 100) << "a settled bed of 60 bodies has contacts";
}

TEST(LammpsReadsTheDumps, OfTheNativeEngine) {
  const fs::path dir = MakeRun("native", "lammps_native");
  RunEngine(GRANARY_ENGINE_EXE, dir);
  if (::testing::Test::HasFatalFailure()) return;
  LammpsReadsTheRun(dir, 1e-9);
}

// output.compress: LAMMPS reruns frames.dump.gz, the analyses read it through the same reader.
TEST(LammpsReadsTheDumps, OfTheNativeEngineCompressed) {
  const fs::path dir = MakeRun("native", "lammps_native_gz", true);
  RunEngine(GRANARY_ENGINE_EXE, dir);
  if (::testing::Test::HasFatalFailure()) return;
  ASSERT_TRUE(fs::exists(dir / "frames.dump.gz"));
  LammpsReadsTheRun(dir, 1e-9);
}

// output.format "gsd": LAMMPS reads no GSD; `campaign dump` (WriteTextDumps) writes the text
// dumps that it reruns, holding the GSD frames' discs to the text format's ten digits.
TEST(LammpsReadsTheDumps, OfTheNativeEngineAsGsdAfterCampaignDump) {
  const fs::path dir = MakeRun("native", "lammps_native_gsd", false, "gsd");
  RunEngine(GRANARY_ENGINE_EXE, dir);
  if (::testing::Test::HasFatalFailure()) return;
  ASSERT_TRUE(fs::exists(dir / "frames.gsd"));
  ASSERT_FALSE(fs::exists(dir / "frames.dump"));
  const fs::path text = kTmp / "lammps_native_gsd_text";
  fs::remove_all(text);
  const TextDumps n = WriteTextDumps(dir, text);
  EXPECT_GE(n.frames, 5);
  EXPECT_EQ(n.contact_frames, n.frames);
  EXPECT_TRUE(fs::exists(text / "frames.data"));
  LammpsReadsTheRun(text, 1e-9);
  FrameReader gsd(dir / "frames.gsd"), dump(text / "frames.dump");
  int frames = 0;
  for (Frame g, t; gsd.Next(g); ++frames) {
    ASSERT_TRUE(dump.Next(t));
    EXPECT_EQ(t.timestep, g.timestep);
    ASSERT_EQ(t.discs.size(), g.discs.size());
    for (std::size_t i = 0; i < g.discs.size(); ++i) {
      EXPECT_EQ(t.discs[i].id, g.discs[i].id);
      EXPECT_EQ(t.discs[i].mol, g.discs[i].mol);
      EXPECT_NEAR(t.discs[i].x, g.discs[i].x, 1e-9 * std::max(1.0, std::abs(g.discs[i].x)));
      EXPECT_NEAR(t.discs[i].vy, g.discs[i].vy, 1e-9 * std::max(1.0, std::abs(g.discs[i].vy)));
    }
  }
  EXPECT_EQ(frames, n.frames);
}

// frames.data (docs/run-directory.md): LAMMPS reads it and reruns frames.dump with the docs'
// own input, and every disc keeps its diameter and mass — a mixture of two disc sizes and
// snowmen, where read_dump alone gives every disc diameter 1. The docs' rerun reports the discs'
// total area per frame and the touching pairs, both of which depend on the diameters.
TEST(LammpsReadsTheDumps, DiameterOfEveryDiscFromFramesData) {
  const fs::path dir = kTmp / "lammps_frames_data";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const json j = {{"run_id", "frames_data"},
                  {"seed", 7},
                  {"silo", {{"width", 12}, {"base_outlets", {{{"center", 0}, {"width", 6}}}}}},
                  {"bodies",
                   {{"count", 60},
                    {"species",
                     {{{"name", "big"}, {"shape", "disc"}, {"fraction", 0.4}, {"diameter", 1.0}},
                      {{"name", "small"}, {"shape", "disc"}, {"fraction", 0.3}, {"diameter", 0.6}},
                      {{"shape", "snowman"}, {"fraction", 0.3}, {"diameter", 0.7}, {"big_diameter", 1.2}}}}}},
                  {"bed", {{"settle_ke_per_body", 1e-5}, {"max_settle_time", 20}}},
                  {"discharge", {{"mode", "remove"}, {"max_time", 3}, {"clog_window", 3}}},
                  {"output", {{"checkpoint_interval", 0}, {"frame_interval", 0.5}, {"contact_forces", true}}}};
  std::ofstream(dir / "run.json") << j.dump(2);
  RunEngine(GRANARY_ENGINE_EXE, dir);
  if (::testing::Test::HasFatalFailure()) return;
  ASSERT_TRUE(fs::exists(dir / "frames.data"));

  // The input exactly as docs/run-directory.md gives it (the block after "<!-- rerun-input -->").
  std::ifstream doc(fs::path(GRANARY_SOURCE_DIR) / "docs" / "run-directory.md");
  std::string line, input;
  bool marker = false, inside = false;
  while (std::getline(doc, line)) {
    if (line == "<!-- rerun-input -->")
      marker = true;
    else if (marker && !inside && line == "```")
      inside = true;
    else if (inside && line == "```")
      break;
    else if (inside)
      input += line + "\n";
  }
  ASSERT_FALSE(input.empty()) << "docs/run-directory.md has no rerun input";
  std::ofstream(dir / "rerun.in") << input;
  const std::string lmp = Lammps();
  ASSERT_FALSE(lmp.empty()) << "LAMMPS (lmp) not found: install Debian's package lammps (scripts/setup.sh does)";
  bp::ipstream out;
  bp::child c(lmp, "-in", "rerun.in", "-log", "log.rerun", "-echo", "none", (bp::std_out & bp::std_err) > out,
              bp::start_dir(dir.string()));
  std::string all;
  while (std::getline(out, line)) all += line + "\n";
  c.wait();
  ASSERT_EQ(c.exit_code(), 0) << all;

  std::vector<Frame> frames;
  FrameReader reader(dir / "frames.dump");
  for (Frame f; reader.Next(f);) frames.push_back(f);
  std::vector<ContactFrame> contacts;
  ContactReader creader(dir / "contacts.dump");
  for (ContactFrame f; creader.Next(f);) contacts.push_back(f);
  const std::vector<Block> discs = ReadBlocks(dir / "rerun_discs.dump");
  const std::vector<Block> pairs = ReadBlocks(dir / "rerun_pairs.dump");
  ASSERT_GE(frames.size(), 5u);
  ASSERT_EQ(discs.size(), frames.size()) << "LAMMPS reran every frame";
  ASSERT_EQ(pairs.size(), frames.size());
  ASSERT_EQ(contacts.size(), frames.size());
  EXPECT_LT(frames.back().discs.size(), frames.front().discs.size()) << "bodies left: trim yes deleted them";
  std::set<double> radii;
  int touching = 0;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const Frame& ours = frames[k];
    SCOPED_TRACE("frame at t = " + std::to_string(ours.time));
    ASSERT_EQ(discs[k].rows.size(), ours.discs.size());
    std::map<long long, const Disc*> by_id;
    for (const Disc& d : ours.discs) by_id[d.id] = &d;
    const int c_id = discs[k].Col("id"), c_r = discs[k].Col("radius"), c_m = discs[k].Col("mass"),
              c_x = discs[k].Col("x");
    for (const auto& row : discs[k].rows) {
      const auto it = by_id.find(std::llround(row[c_id]));
      ASSERT_NE(it, by_id.end());
      const Disc& d = *it->second;
      EXPECT_NEAR(row[c_r], d.radius, 1e-9 * d.radius);
      EXPECT_NEAR(row[c_m], d.mass, 1e-9 * d.mass);
      EXPECT_EQ(row[c_x], d.x);
      radii.insert(std::round(row[c_r] * 1000) / 1000);
    }
    // The pairs of bodies LAMMPS finds touching (distance below the sum of their radii) are
    // the pair rows of contacts.dump.
    std::set<std::pair<long long, long long>> sure, maybe, ours_pairs;
    const int c_a = pairs[k].Col("c_touching[1]"), c_b = pairs[k].Col("c_touching[2]"),
              c_d = pairs[k].Col("c_distance");
    for (const auto& row : pairs[k].rows) {
      const Disc& a = *by_id.at(std::llround(row[c_a]));
      const Disc& b = *by_id.at(std::llround(row[c_b]));
      if (a.mol == b.mol) continue;
      const double reach = a.radius + b.radius;
      if (row[c_d] < reach - 1e-6) sure.insert(std::minmax(a.mol, b.mol));
      if (row[c_d] < reach + 1e-6) maybe.insert(std::minmax(a.mol, b.mol));
    }
    for (const ContactRow& r : contacts[k].contacts)
      if (r.body_j >= 0) ours_pairs.insert(std::minmax(r.body_i, r.body_j));
    for (const auto& p : sure)
      EXPECT_TRUE(ours_pairs.count(p)) << "LAMMPS: bodies " << p.first << ", " << p.second << " touch";
    for (const auto& p : ours_pairs)
      EXPECT_TRUE(maybe.count(p)) << "contacts.dump: bodies " << p.first << ", " << p.second << " touch";
    touching += static_cast<int>(sure.size());
  }
  EXPECT_EQ(radii, (std::set<double>{0.3, 0.35, 0.5, 0.6})) << "two disc sizes and the snowmen's two";
  EXPECT_GT(touching, 100);
}

TEST(LammpsReadsTheDumps, OfLiggghtsCompressed) {
  const fs::path dir = MakeRun("liggghts", "lammps_liggghts_gz", true);
  RunEngine(GRANARY_LIGGGHTS_EXE, dir);
  if (::testing::Test::HasFatalFailure()) return;
  ASSERT_TRUE(fs::exists(dir / "contacts.dump.gz"));
  LammpsReadsTheRun(dir, 1e-4);
}

TEST(LammpsReadsTheDumps, OfLiggghts) {
  const fs::path dir = MakeRun("liggghts", "lammps_liggghts");
  RunEngine(GRANARY_LIGGGHTS_EXE, dir);
  if (::testing::Test::HasFatalFailure()) return;
  LammpsReadsTheRun(dir, 1e-4);
}

}  // namespace
