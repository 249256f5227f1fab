// The LIGGGHTS backend (backend.h): bed, discharge and conversion into the run directory.
#include "liggghts/backend.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <sys/file.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <functional>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <regex>
#include <set>
#include <sstream>

#include <boost/process.hpp>

#include "silo/shapes.h"
#include "silo/silo_outline.h"
#include "silo/stall.h"
#include "external/driver.h"
#include "liggghts/input_script.h"
#include "rundir/clogs.h"
#include "rundir/contacts.h"
#include "rundir/files.h"
#include "rundir/frames.h"
#include "rundir/progress.h"
#include "rundir/run_directory.h"
#include "rundir/summary.h"
#include "rundir/version.h"

namespace granary::liggghts {

namespace fs = std::filesystem;
namespace bp = boost::process;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;
using external::ChildRun;
using external::NearestImage;
using external::NewestCheckpoint;
using external::NextDumpBlock;
using external::PruneCheckpoints;
using external::Tokens;

namespace {

double Seconds(Clock::time_point since) { return std::chrono::duration<double>(Clock::now() - since).count(); }

// Runs LIGGGHTS on `input` in `dir` (cwd), its log in `log`; calls on_line for every line
// LIGGGHTS prints that starts with "GRANARY_". A stop request makes a LIGGGHTS that reads
// `control` (the discharge) checkpoint and end at its next chunk; any other is ended at once.
// So is a LIGGGHTS that prints nothing for `silence_limit` seconds (hung). The subprocess is
// the external-engine driver's (external/driver.h), shared with the LAMMPS backend.
ChildRun RunLiggghts(const std::string& exe, int threads, const fs::path& dir, const std::string& input,
                     const std::string& log, const fs::path& control, double silence_limit,
                     const std::function<void(const std::string&)>& on_line) {
  external::Command c;
  try {
    c = external::LaunchCommand({exe}, threads, dir, external::HelperExe("granary-liggghts"));
  } catch (const std::runtime_error& e) {
    throw LiggghtsError(e.what());
  }
  c.args.insert(c.args.end(), {"-in", input, "-log", log, "-echo", "none"});
  if (threads > 1) {
    std::string line = c.program;
    for (const auto& a : c.args) line += " " + a;
    std::cout << "granary-liggghts: " << line << std::endl;
  }
  try {
    return external::RunChild(c.program, c.args,
                              {dir, control, silence_limit, "LIGGGHTS", "granary-liggghts", dir / log},
                              [&](const std::string& line) {
                                if (line.rfind("GRANARY_", 0) == 0) on_line(line);
                              });
  } catch (const LiggghtsError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw LiggghtsError(e.what());
  }
}

std::string Diagnostics(const ChildRun& r, const fs::path& log) { return external::Diagnostics(r, log, "LIGGGHTS"); }

[[noreturn]] void Fail(const std::string& what, const ChildRun& r, const fs::path& log) {
  throw LiggghtsError(what + " (" + r.How("LIGGGHTS") + ")" + Diagnostics(r, log));
}

void ReportProgress(const fs::path& dir, const std::string& phase, double fraction, double t, double t_end, int exited,
                    double wall_s, bool quiet) {
  rundir::WriteProgress(dir, {phase, fraction, t, t_end, exited, wall_s}, !quiet);
}

// A LIGGGHTS text dump of one frame written by write_dump: columns id mol type x y radius z.
struct Sphere {
  long long id;
  long long mol;
  int type;
  double x, y, radius, z;
};
std::vector<Sphere> ReadAtomsDump(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("missing " + path.string());
  std::string line;
  std::vector<Sphere> out;
  bool atoms = false;
  while (std::getline(in, line)) {
    if (line.rfind("ITEM: ATOMS", 0) == 0) {
      atoms = true;
      continue;
    }
    if (!atoms || line.empty()) continue;
    const auto t = Tokens(line);
    if (t.size() < 7) continue;
    out.push_back({std::stoll(t[0]), std::stoll(t[1]), std::stoi(t[2]), std::stod(t[3]), std::stod(t[4]),
                   std::stod(t[5]), std::stod(t[6])});
  }
  return out;
}

// Body ids (0-based, stable for the run) from the bed: multisphere bodies in `mol` order,
// then single spheres (mol 0) in atom-id order. Without clumps the dumps carry the atom id in
// the `mol` column, so every sphere is its own body.
class BodyIndex {
 public:
  explicit BodyIndex(const std::vector<Sphere>& bed) {
    for (const Sphere& s : bed) index_.emplace(Key(s.id, s.mol), 0);
    long long next = 0;
    for (auto& [key, value] : index_) value = next++;
  }
  long long Of(long long id, long long mol) const {
    const auto it = index_.find(Key(id, mol));
    return it == index_.end() ? -1 : it->second;
  }
  long long Of(const Sphere& s) const { return Of(s.id, s.mol); }
  std::size_t size() const { return index_.size(); }

 private:
  static std::pair<long long, long long> Key(long long id, long long mol) {
    return mol > 0 ? std::make_pair(mol, 0LL) : std::make_pair(std::numeric_limits<long long>::max(), id);
  }
  std::map<std::pair<long long, long long>, long long> index_;
};

// Drops exit lines after the checkpoint (continue): the steps after it run again.
// Returns the step of the last exit kept (0 if none).
long long TruncateExits(const fs::path& file, double t_ckpt, double dt) {
  if (!fs::exists(file)) return 0;
  std::ifstream in(file);
  std::string line, kept;
  long long last = 0;
  while (std::getline(in, line)) {
    const auto t = Tokens(line);
    if (line.empty() || line[0] == '#' || t.size() < 2) {
      kept += line + "\n";
      continue;
    }
    const double time = std::stod(t[1]);
    if (time > t_ckpt + 0.5 * dt) continue;
    kept += line + "\n";
    last = std::max(last, std::llround(time / dt));
  }
  in.close();
  WriteAtomically(file, kept);
  return last;
}

struct Event {
  double time;
  long long body;
  int species;
  int outlet;
};

// Exit events from the massflow files. A body's first sphere through the counting plane
// is its exit; in reinject mode a body passes the plane again only after a trip through
// the bed, so crossings by the same body within `recross` are the rest of that body.
// The files a counter wrote: FILE, or FILE.<rank> with several MPI ranks.
std::vector<fs::path> CounterFiles(const fs::path& dir, const Counter& c) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string f = e.path().filename().string();
    if (f == c.file ||
        (f.rfind(c.file + ".", 0) == 0 && f.find_first_not_of("0123456789", c.file.size() + 1) == std::string::npos))
      files.push_back(e.path());
  }
  return files;
}

std::vector<Event> ReadEvents(const fs::path& dir, const std::vector<Counter>& counters,
                              const std::map<long long, Sphere>& spheres, const BodyIndex& bodies, double recross) {
  std::vector<Event> events;
  for (const Counter& c : counters) {
    const int k = c.outlet;
    const std::vector<fs::path> files = CounterFiles(dir, c);
    for (const fs::path& f : files) {
      std::ifstream in(f);
      std::string line;
      while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#') continue;
        const auto t = Tokens(line);
        if (t.size() < 2) continue;
        const auto it = spheres.find(std::stoll(t[0]));
        if (it == spheres.end()) continue;
        events.push_back({std::stod(t[1]), bodies.Of(it->second), it->second.type - 1, k});
      }
    }
  }
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) { return a.time < b.time; });
  std::map<long long, double> last;
  std::vector<Event> out;
  for (const Event& e : events) {
    auto it = last.find(e.body);
    if (it != last.end() && e.time - it->second < recross) continue;
    last[e.body] = e.time;
    out.push_back(e);
  }
  return out;
}

// The box of frames.dump and contacts.dump: LIGGGHTS' discharge box, with room in y for the
// clumps that the conversion puts back together across the periodic boundary.
void SetBox(const SiloSetup& setup, double (&box)[3][2]) {
  const double b2 = 2 * setup.bound_radius;
  box[0][0] = setup.x_lo;
  box[0][1] = setup.x_hi;
  box[1][0] = setup.y_lo - b2;
  box[1][1] = setup.y_hi + b2;
  box[2][0] = -0.5;
  box[2][1] = 0.5;
}

// One block of a LIGGGHTS custom dump (id mol type x y radius vx vy omegaz), `n` rows read from
// `in`, as a run-directory frame at `step`.
void ReadFrameBlock(std::istream& in, long long n, long long step, const RunSpec& spec, const SiloSetup& setup,
                    const BodyIndex& bodies, double box_height, rundir::Frame& frame) {
  std::string line;
  const double rho = spec.bodies.density;
  std::map<long long, double> first_y;  // per body: where its first sphere is in this frame
  SetBox(setup, frame.box);
  frame.timestep = step;
  frame.time = static_cast<double>(step) * spec.time_step;
  frame.discs.clear();
  for (long long i = 0; i < n && std::getline(in, line); ++i) {
    const auto t = Tokens(line);
    if (t.size() < 9) throw std::runtime_error("malformed LIGGGHTS dump line: " + line);
    const double r = std::stod(t[5]);
    const long long body = bodies.Of(std::stoll(t[0]), std::stoll(t[1]));
    // LIGGGHTS wraps each sphere into the y-periodic box; a clump straddling the boundary
    // is put back together next to its first sphere, as the analyses expect whole bodies.
    double y = std::stod(t[4]);
    const auto [it, first] = first_y.emplace(body, y);
    if (!first) y = NearestImage(y, it->second, box_height);
    frame.discs.push_back({std::stoll(t[0]), body, std::stoi(t[2]), std::stod(t[3]), y, r,
                           rho * std::numbers::pi * r * r, std::stod(t[6]), std::stod(t[7]), std::stod(t[8])});
  }
}

// LIGGGHTS dump (id mol type x y radius vx vy omegaz) -> the run-directory frames format.
void ConvertFrames(const fs::path& in_path, const fs::path& out_path, const RunSpec& spec, const SiloSetup& setup,
                   const BodyIndex& bodies, double box_height) {
  std::ifstream in(in_path);
  rundir::FrameWriter out = rundir::FrameWriter::Create(out_path, spec.output.compress);
  long long step = 0, n = 0;
  rundir::Frame frame;
  while (NextDumpBlock(in, step, n)) {
    ReadFrameBlock(in, n, step, spec, setup, bodies, box_height, frame);
    out.Write(frame);
  }
  out.Close();
}

// The rows of every block of a LIGGGHTS local dump, by step.
std::map<long long, std::vector<std::string>> ReadLocalBlocks(const fs::path& path) {
  std::map<long long, std::vector<std::string>> blocks;
  std::ifstream in(path);
  std::string line;
  long long step = 0, n = 0;
  while (NextDumpBlock(in, step, n)) {
    std::vector<std::string>& rows = blocks[step];
    for (long long i = 0; i < n && std::getline(in, line); ++i) rows.push_back(line);
  }
  return blocks;
}

// One frame of LIGGGHTS' pair and wall contact rows as a run-directory contact frame: one row
// per pair of spheres of different bodies with the force on the first and the point on its
// surface towards the second (as the native engine), then one row per wall contact with the
// contact point. Pairs across the periodic boundary are unwrapped.
void ContactFrameOf(long long step, const std::vector<std::string>& pairs, const std::vector<std::string>* walls,
                    const RunSpec& spec, const SiloSetup& setup, const std::map<long long, Sphere>& spheres,
                    const BodyIndex& bodies, double box_height, rundir::ContactFrame& frame) {
  auto sphere = [&](const std::string& id) -> const Sphere& {
    const auto it = spheres.find(std::stoll(id));
    if (it == spheres.end()) throw std::runtime_error("contact dump names an unknown sphere " + id);
    return it->second;
  };
  SetBox(setup, frame.box);
  frame.timestep = step;
  frame.time = static_cast<double>(step) * spec.time_step;
  frame.contacts.clear();
  for (const std::string& line : pairs) {
    const auto t = Tokens(line);
    if (t.size() < 8) throw std::runtime_error("malformed LIGGGHTS contact line: " + line);
    const Sphere& a = sphere(t[4]);
    const Sphere& b = sphere(t[5]);
    const long long body_a = bodies.Of(a), body_b = bodies.Of(b);
    if (body_a == body_b) continue;
    const double xi = std::stod(t[0]), yi = std::stod(t[1]), xj = std::stod(t[2]);
    const double yj = NearestImage(std::stod(t[3]), yi, box_height);
    const double dx = xj - xi, dy = yj - yi, r = std::hypot(dx, dy);
    frame.contacts.push_back({body_a, body_b, xi, yi, xj, yj, xi + a.radius * dx / r, yi + a.radius * dy / r,
                              std::stod(t[6]), std::stod(t[7])});
  }
  if (!walls) return;
  for (const std::string& line : *walls) {
    const auto t = Tokens(line);
    if (t.size() < 7) throw std::runtime_error("malformed LIGGGHTS wall contact line: " + line);
    const double cx = std::stod(t[0]), cy = std::stod(t[1]);
    frame.contacts.push_back({bodies.Of(sphere(t[4])), -1, std::stod(t[2]), std::stod(t[3]), cx, cy, cx, cy,
                              std::stod(t[5]), std::stod(t[6])});
  }
}

// LIGGGHTS' local dumps of pair and wall contacts into contacts.dump (docs/run-directory.md).
void ConvertContacts(const fs::path& dir, const RunSpec& spec, const SiloSetup& setup,
                     const std::map<long long, Sphere>& spheres, const BodyIndex& bodies, double box_height) {
  const auto pairs = ReadLocalBlocks(dir / "contacts_pairs.liggghts");
  const auto walls = ReadLocalBlocks(dir / "contacts_walls.liggghts");
  rundir::ContactWriter out = rundir::ContactWriter::Create(
      dir / (spec.output.compress ? rundir::kContactsGzFile : rundir::kContactsFile), spec.output.compress);
  rundir::ContactFrame frame;
  for (const auto& [step, rows] : pairs) {
    const auto w = walls.find(step);
    ContactFrameOf(step, rows, w == walls.end() ? nullptr : &w->second, spec, setup, spheres, bodies, box_height,
                   frame);
    out.Write(frame);
  }
  out.Close();
}

// The files the discharge script keeps at a stall (input_script.h kClogFilePrefix).
fs::path ClogFile(const fs::path& dir, long long step, const char* ext) {
  return dir / (std::string(kClogFilePrefix) + std::to_string(step) + ext);
}
void RemoveClogFiles(const fs::path& dir, long long step) {
  for (const char* ext : {".atoms", ".pairs", ".walls"}) fs::remove(ClogFile(dir, step, ext));
}
// Every clog.<step>.* file (continuing: `after` = the checkpoint's step, the later ones go).
void RemoveClogFilesAfter(const fs::path& dir, long long after) {
  static const std::regex kName(R"(clog\.(\d+)\.(atoms|pairs|walls))");
  std::vector<fs::path> doomed;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::smatch m;
    const std::string f = e.path().filename().string();
    if (std::regex_match(f, m, kName) && std::stoll(m[1]) > after) doomed.push_back(e.path());
  }
  for (const fs::path& f : doomed) fs::remove(f);
}

// The configurations and contact forces kept at the clogs (steps in order) into the run
// directory's clog files (rundir/clogs.h).
void ConvertClogs(const fs::path& dir, const std::vector<long long>& steps, const RunSpec& spec, const SiloSetup& setup,
                  const std::map<long long, Sphere>& spheres, const BodyIndex& bodies, double box_height) {
  rundir::ClogWriter out = rundir::ClogWriter::Create(dir);
  rundir::ClogState clog;
  for (long long step : steps) {
    std::ifstream atoms(ClogFile(dir, step, ".atoms"));
    long long dumped = 0, n = 0;
    if (!atoms || !NextDumpBlock(atoms, dumped, n))
      throw std::runtime_error("the configuration of the clog at step " + std::to_string(step) + " is missing (" +
                               ClogFile(dir, step, ".atoms").string() + ")");
    ReadFrameBlock(atoms, n, step, spec, setup, bodies, box_height, clog.frame);
    const auto pairs = ReadLocalBlocks(ClogFile(dir, step, ".pairs"));
    const auto walls = ReadLocalBlocks(ClogFile(dir, step, ".walls"));
    static const std::vector<std::string> kNone;
    const auto p = pairs.find(dumped);
    const auto w = walls.find(dumped);
    ContactFrameOf(step, p == pairs.end() ? kNone : p->second, w == walls.end() ? nullptr : &w->second, spec, setup,
                   spheres, bodies, box_height, clog.contacts);
    out.Write(clog);
  }
  out.Close();
}

// A prepared bed for this spec: DIR/bed.restart and DIR/bed.dump, from the cache when it
// has one (keyed like the native bed, plus the obstacles, which the LIGGGHTS bed contains).
struct Bed {
  std::string file;
  bool prepared_here = false;
  double wall_s = 0, settle_time = 0, top = 0;
  std::string refused;  // why a cached bed was refused and prepared again, or ""
};

std::string CacheStem(const RunSpec& spec) {
  json key = spec.BedKey();
  key["liggghts_obstacles"] = spec.ToJson()["silo"]["obstacles"];
  if (spec.output.contact_forces && !spec.silo.obstacles.empty()) key["liggghts_obstacles_as_meshes"] = true;
  key["liggghts_side_margin"] = !spec.silo.side_outlets.empty();          // the box width depends on it
  key["liggghts_exit_distance"] = spec.discharge.exit_distance;           // and its bottom on this
  if (spec.discharge.periodic_headroom != Discharge{}.periodic_headroom)  // and its top on this
    key["liggghts_periodic_headroom"] = spec.discharge.periodic_headroom;
  const std::string text = key.dump();
  std::uint64_t h = 1469598103934665603ULL;  // FNV-1a
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ULL;
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return std::string("liggghts-bed-") + hex;
}

// A cached bed is <stem>.restart, <stem>.dump and <stem>.json, which holds the format
// version and the CRC-32 of the other two.
constexpr int kCachedBedVersion = 2;  // 2: with checksums

// Why the cached bed `stem` cannot be used, or "" if it can.
std::string CachedBedProblem(const fs::path& cache_dir, const std::string& stem) {
  json meta;
  try {
    meta = json::parse(ReadWholeFile(cache_dir / (stem + ".json")));
  } catch (const std::exception& e) {
    return stem + ".json is unreadable: " + e.what();
  }
  if (!meta.is_object() || meta.value("version", 0) != kCachedBedVersion)
    return stem + ".json has format version " + (meta.is_object() ? std::to_string(meta.value("version", 0)) : "?") +
           "; this backend reads version " + std::to_string(kCachedBedVersion) + " (with checksums)";
  for (const auto& [ext, key] : {std::pair{".restart", "restart_crc32"}, std::pair{".dump", "dump_crc32"}}) {
    const fs::path f = cache_dir / (stem + ext);
    if (!fs::exists(f)) return f.filename().string() + " is missing";
    const std::uint32_t actual = Crc32(ReadWholeFile(f));
    if (meta.value(key, std::uint32_t{0}) != actual)
      return f.filename().string() + " is corrupt (CRC-32 " + std::to_string(actual) + ", recorded " +
             std::to_string(meta.value(key, std::uint32_t{0})) + ")";
  }
  return "";
}

Bed ObtainBed(const RunSpec& spec, const SiloSetup& setup, const fs::path& dir, const std::string& exe,
              const BackendOptions& options) {
  Bed bed;
  fs::path cache_dir;
  if (!spec.bed.cache_file.empty()) cache_dir = fs::path(spec.bed.cache_file).parent_path();
  const std::string stem = CacheStem(spec);
  std::unique_ptr<FileLock> lock;
  if (!cache_dir.empty()) {
    fs::create_directories(cache_dir);
    lock = std::make_unique<FileLock>(cache_dir / (stem + ".lock"));
    if (fs::exists(cache_dir / (stem + ".restart")) && fs::exists(cache_dir / (stem + ".json"))) {
      const std::string why = CachedBedProblem(cache_dir, stem);
      if (why.empty()) {
        fs::copy_file(cache_dir / (stem + ".restart"), dir / "bed.restart", fs::copy_options::overwrite_existing);
        fs::copy_file(cache_dir / (stem + ".dump"), dir / "bed.dump", fs::copy_options::overwrite_existing);
        const json meta = json::parse(ReadWholeFile(cache_dir / (stem + ".json")));
        bed.file = (cache_dir / (stem + ".restart")).string();
        bed.settle_time = meta.value("settle_time", 0.0);
        bed.wall_s = 0;
        return bed;
      }
      // A bad cached bed is never used: it is put aside and prepared again.
      std::fprintf(stderr, "granary-liggghts: refusing the cached bed %s: %s; preparing it again\n", stem.c_str(),
                   why.c_str());
      bed.refused = why;
      for (const char* ext : {".restart", ".dump", ".json"})
        if (fs::exists(cache_dir / (stem + ext)))
          fs::rename(cache_dir / (stem + ext), cache_dir / (stem + ext + ".corrupt"));
    }
  }
  const auto t0 = Clock::now();
  WriteAtomically(dir / "bed.in", BedScript(spec, setup));
  long long inserted = -1;
  double settle_t = 0;
  const ChildRun r = RunLiggghts(exe, options.threads, dir, "bed.in", "log.bed", {}, options.silence_limit,
                                 [&](const std::string& line) {
                                   const auto t = Tokens(line);
                                   if (t[0] == "GRANARY_INSERTED" && t.size() > 1)
                                     inserted = std::llround(std::stod(t[1]));
                                   if ((t[0] == "GRANARY_BED" || t[0] == "GRANARY_BED_DONE") && t.size() > 2) {
                                     settle_t = std::stod(t[1]);
                                     ReportProgress(dir, "bed", settle_t / spec.bed.max_settle_time, settle_t,
                                                    spec.bed.max_settle_time, 0, Seconds(t0), options.quiet);
                                   }
                                 });
  if (external::StopSignal() != 0)
    throw Stopped(external::StopSignal(),
                  "stopped while preparing the bed (not checkpointed)" + Diagnostics(r, dir / "log.bed"));
  if (r.exit_code != 0 || r.signal != 0 || !r.stop_reason.empty())
    Fail("LIGGGHTS failed while preparing the bed", r, dir / "log.bed");
  if (!fs::exists(dir / "bed.restart"))
    Fail("LIGGGHTS ended without writing bed.restart while preparing the bed", r, dir / "log.bed");
  const std::vector<Sphere> spheres = ReadAtomsDump(dir / "bed.dump");
  const BodyIndex bodies(spheres);
  if (static_cast<int>(bodies.size()) != spec.bodies.count)
    throw LiggghtsError(
        "LIGGGHTS inserted " + std::to_string(bodies.size()) + " of " + std::to_string(spec.bodies.count) +
        " bodies (insert/pack found no room for the rest; spheres after insertion: " + std::to_string(inserted) +
        ")\n--- last lines of log.bed ---\n" + TailOfFile(dir / "log.bed", external::kLogTailLines));
  bed.prepared_here = true;
  bed.wall_s = Seconds(t0);
  bed.settle_time = settle_t;
  bed.file = (dir / "bed.restart").string();
  if (!cache_dir.empty()) {
    // Copy to temporary names, then rename: a reader never sees half a bed.
    for (const char* ext : {".restart", ".dump"}) {
      fs::copy_file(dir / (std::string("bed") + ext), cache_dir / (stem + ext + ".tmp"),
                    fs::copy_options::overwrite_existing);
      ReplaceAtomically(cache_dir / (stem + ext + ".tmp"), cache_dir / (stem + ext));
    }
    WriteAtomically(cache_dir / (stem + ".json"), json{{"format", "granary-liggghts-bed"},
                                                       {"version", kCachedBedVersion},
                                                       {"settle_time", settle_t},
                                                       {"bed_wall_s", bed.wall_s},
                                                       {"restart_crc32", Crc32(ReadWholeFile(dir / "bed.restart"))},
                                                       {"dump_crc32", Crc32(ReadWholeFile(dir / "bed.dump"))}}
                                                          .dump() +
                                                      "\n");
    bed.file = (cache_dir / (stem + ".restart")).string();
  }
  return bed;
}

std::string LiggghtsVersion(const fs::path& log) {
  std::ifstream in(log);
  std::string line;
  if (std::getline(in, line)) {
    static const std::regex kV(R"(Version\s+([^,)]+))");
    std::smatch m;
    if (std::regex_search(line, m, kV)) return m[1];
  }
  return "unknown";
}

// The y extent of a dump's box (third line after BOX BOUNDS... the second bounds line).
double BoxTop(const fs::path& dump) {
  std::ifstream in(dump);
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("ITEM: BOX BOUNDS", 0) == 0) {
      std::getline(in, line);
      std::getline(in, line);
      const auto t = Tokens(line);
      if (t.size() == 2) return std::stod(t[1]);
    }
  throw std::runtime_error("no box bounds in " + dump.string());
}

double TopOf(const std::vector<Sphere>& spheres) {
  double top = 0;
  for (const Sphere& s : spheres) top = std::max(top, s.y + s.radius);
  return top;
}

// A stall in remove mode is a clog when an arch seals an outlet from the material above; the same
// test as the native engine's (silo/stall.h) on LIGGGHTS' final positions.
bool StallIsAClog(const RunSpec& spec, const std::vector<Sphere>& left) {
  std::vector<silo::DiscAt> discs;
  std::vector<std::int64_t> body_of;
  double top = 0;
  for (const Sphere& s : left) {
    discs.push_back({s.x, s.y, s.radius});
    body_of.push_back(s.mol);
    top = std::max(top, s.y + s.radius);
  }
  const std::vector<bool> sealed =
      silo::SealedOutlets(silo::BuildGeometry(spec.silo, top + 1), discs, silo::PassageProbe(discs, body_of));
  return std::find(sealed.begin(), sealed.end(), true) != sealed.end();
}

RunSpec ReadSpec(const fs::path& dir) { return rundir::ReadRunSpec(dir); }

void WriteMeshes(const fs::path& dir, const SiloSetup& setup) {
  for (const MeshFile& m : setup.fill_meshes) WriteAtomically(dir / m.name, Stl(m, setup.half_z - 0.1));
  for (const MeshFile& m : setup.discharge_meshes) WriteAtomically(dir / m.name, Stl(m, setup.half_z - 0.1));
  for (const Counter& c : setup.counters) WriteAtomically(dir / c.mesh.name, Stl(c.mesh, setup.half_z - 0.1));
}

}  // namespace

std::string FindLiggghts(const std::string& preferred) {
  std::string exe = preferred;
  if (exe.empty()) {
    if (const char* env = std::getenv("GRANARY_LIGGGHTS"); env && *env) exe = env;
  }
  if (exe.empty()) exe = bp::search_path("liggghts").string();
  if (exe.empty() || !fs::exists(exe))
    throw LiggghtsError("LIGGGHTS executable not found" + (exe.empty() ? std::string() : " (\"" + exe + "\")") +
                        ": install Debian's package liggghts (scripts/setup.sh does), or set GRANARY_LIGGGHTS");
  return exe;
}

std::vector<std::string> WriteInputs(const std::string& dir_name) {
  const fs::path dir(dir_name);
  const RunSpec spec = ReadSpec(dir);
  const SiloSetup setup = MakeSetup(spec);
  WriteMeshes(dir, setup);
  WriteAtomically(dir / "bed.in", BedScript(spec, setup));
  DischargeStart start;
  WriteAtomically(dir / "discharge.in", DischargeScript(spec, setup, start));
  WriteAtomically(dir / kControlFile, "variable stop_requested equal 0\n");
  std::vector<std::string> files = {"bed.in", "discharge.in", kControlFile};
  for (const MeshFile& m : setup.fill_meshes) files.push_back(m.name);
  for (const MeshFile& m : setup.discharge_meshes)  // obstacle meshes are in both lists
    if (std::find(files.begin(), files.end(), m.name) == files.end()) files.push_back(m.name);
  for (const Counter& c : setup.counters) files.push_back(c.mesh.name);
  return files;
}

void RequestStop(int signal) { external::RequestStop(signal); }

namespace {
BackendResult RunLocked(const std::string& dir_name, const BackendOptions& options);
}

BackendResult RunDirectory(const std::string& dir_name, const BackendOptions& options) {
  // One writer per directory, held until LIGGGHTS and its ranks are gone (files.h).
  const RunDirectoryLock lock(fs::absolute(dir_name));
  return RunLocked(dir_name, options);
}

namespace {

// RunDirectory under the directory's lock (it calls itself to go on through a clog or to
// fall back to an earlier checkpoint).
BackendResult RunLocked(const std::string& dir_name, const BackendOptions& options) {
  const fs::path dir = fs::absolute(dir_name);
  const RunSpec spec = ReadSpec(dir);
  SiloSetup setup = MakeSetup(spec);
  const std::string exe = FindLiggghts(options.liggghts);
  fs::remove(dir / rundir::kDoneFile);

  BackendResult result;
  const external::Checkpoint ckpt = NewestCheckpoint(dir);
  const fs::path state_file = dir / "liggghts_state.json";  // bed provenance, kept for a continue
  json state;
  DischargeStart start;
  double discharge_wall_before = 0;
  if (ckpt.step >= 0 && fs::exists(state_file)) {
    state = json::parse(ReadWholeFile(state_file));
    result.continued = true;
    start.continue_run = true;
    start.restart_file = ckpt.file.filename().string();  // "checkpoint.<digits>.restart": no spec text
    const double t_ckpt = static_cast<double>(ckpt.step) * spec.time_step;
    for (const Counter& c : setup.counters)
      for (const fs::path& f : CounterFiles(dir, c))
        start.last_exit_step = std::max(start.last_exit_step, TruncateExits(f, t_ckpt, spec.time_step));
    external::TruncateDump(dir / "frames.liggghts", ckpt.step);
    external::TruncateDump(dir / "contacts_pairs.liggghts", ckpt.step);
    external::TruncateDump(dir / "contacts_walls.liggghts", ckpt.step);
    discharge_wall_before = state.value("discharge_wall_s", 0.0);
    // A clog counted before the checkpoint with no exit since: the next stall is the same clog.
    const long long clog_step = state.value("clog_step", -1LL);
    start.in_clog = clog_step >= start.last_exit_step && clog_step <= ckpt.step;
    // Clogs counted after the checkpoint happen again.
    if (state.contains("clog_steps")) {
      std::vector<long long> kept;
      for (long long c : state["clog_steps"].get<std::vector<long long>>())
        if (c <= ckpt.step) kept.push_back(c);
      state["clog_steps"] = kept;
    }
    RemoveClogFilesAfter(dir, ckpt.step);
  } else {
    for (const char* f : {"frames.liggghts", rundir::kEventsFile, rundir::kFramesFile, rundir::kFramesGzFile,
                          "final.dump", "contacts_pairs.liggghts", "contacts_walls.liggghts", rundir::kContactsFile,
                          rundir::kContactsGzFile, rundir::kClogFramesFile, rundir::kClogContactsFile})
      fs::remove(dir / f);
    RemoveClogFilesAfter(dir, -1);
    for (const Counter& c : setup.counters)
      for (const fs::path& f : CounterFiles(dir, c)) fs::remove(f);
    PruneCheckpoints(dir, 0);
    WriteMeshes(dir, setup);
    const Bed bed = ObtainBed(spec, setup, dir, exe, options);
    state = {{"bed_file", bed.file},       {"bed_prepared_here", bed.prepared_here},
             {"bed_wall_s", bed.wall_s},   {"settle_time", bed.settle_time},
             {"bed_refused", bed.refused}, {"bed_height", TopOf(ReadAtomsDump(dir / "bed.dump"))},
             {"discharge_wall_s", 0.0},    {"clog_steps", json::array()}};
    WriteAtomically(state_file, state.dump() + "\n");
  }

  // Discharge, in the bed's box.
  setup = MakeSetup(spec, BoxTop(dir / "bed.dump"));
  WriteMeshes(dir, setup);
  {
    // The geometry beside the frames, in the one form both engines write (LIGGGHTS' STL meshes
    // stay too).
    double box[3][2];
    SetBox(setup, box);
    WriteAtomically(dir / rundir::kSiloFile,
                    silo::SiloVtk(silo::OutlineOf(spec.silo, spec.silo.height > 0 ? spec.silo.height : box[1][1])));
  }
  WriteAtomically(dir / "discharge.in", DischargeScript(spec, setup, start));
  const auto t_discharge = Clock::now();
  std::string end_reason;
  long long last_step = 0;
  const std::string log = result.continued ? "log.discharge." + std::to_string(ckpt.step) : "log.discharge";
  std::map<long long, Sphere> spheres;  // every sphere of the bed, by LIGGGHTS atom id
  const std::vector<Sphere> bed_spheres = ReadAtomsDump(dir / "bed.dump");
  for (const Sphere& s : bed_spheres) spheres.emplace(s.id, s);
  const BodyIndex bodies(bed_spheres);
  const double recross = spec.discharge.mode == DischargeMode::kRemove ? 1e300 : 1.0;
  int progress_lines = 0;
  double box_height = setup.y_hi - setup.y_lo;  // to 6 digits until LIGGGHTS prints it
  // The stop switch LIGGGHTS reads after every chunk (input_script.cpp, docs/liggghts.md).
  const fs::path control = dir / kControlFile;
  WriteAtomically(control, "variable stop_requested equal 0\n");
  const ChildRun r = RunLiggghts(
      exe, options.threads, dir, "discharge.in", log, control, options.silence_limit, [&](const std::string& line) {
        const auto t = Tokens(line);
        if (t[0] == "GRANARY_END" && t.size() > 1) end_reason = t[1];
        if (t[0] == "GRANARY_FINAL" && t.size() > 1) last_step = std::stoll(t[1]);
        if (t[0] == "GRANARY_BOX" && t.size() > 1) box_height = std::stod(t[1]);
        if (t[0] == "GRANARY_CLOG" && t.size() > 1) {
          state["clog_steps"].push_back(std::stoll(t[1]));
          state["clog_step"] = std::stoll(t[1]);
          WriteAtomically(state_file, state.dump() + "\n");
        }
        if (t[0] == "GRANARY_PROGRESS" && t.size() > 2) {
          ++progress_lines;
          PruneCheckpoints(dir, 2);  // those LIGGGHTS finished before this chunk ended
          const double time = std::stod(t[1]) * spec.time_step;
          // LIGGGHTS' own count weights a clump's spheres by volume; the events are exact.
          const int exited = static_cast<int>(ReadEvents(dir, setup.counters, spheres, bodies, recross).size());
          ReportProgress(dir, "discharge", time / spec.discharge.max_time, time, spec.discharge.max_time, exited,
                         discharge_wall_before + Seconds(t_discharge), options.quiet);
          state["discharge_wall_s"] = discharge_wall_before + Seconds(t_discharge);
          // Every chunk: only the wall-time count would be older after a crash.
          WriteAtomically(state_file, state.dump() + "\n", Durability::kVisible);
        }
      });
  if (r.stopped) {
    state["discharge_wall_s"] = discharge_wall_before + Seconds(t_discharge);
    WriteAtomically(state_file, state.dump() + "\n");
    throw Stopped(
        external::StopSignal() != 0 ? external::StopSignal() : SIGTERM,
        "stopped on request; checkpointed by LIGGGHTS (" + NewestCheckpoint(dir).file.filename().string() + ")");
  }
  if (external::StopSignal() != 0)
    throw Stopped(external::StopSignal(),
                  "stopped on request before LIGGGHTS checkpointed" + Diagnostics(r, dir / log));
  if (r.exit_code != 0 || r.signal != 0 || end_reason.empty() || !fs::exists(dir / "final.dump")) {
    // A checkpoint cut short when the run was killed makes read_restart fail at once: drop
    // it and continue from the one before (or from the start).
    if (result.continued && progress_lines == 0) {
      std::fprintf(stderr, "granary-liggghts: cannot continue from %s; trying an earlier checkpoint\n",
                   ckpt.file.filename().c_str());
      fs::remove(ckpt.file);
      return RunLocked(dir_name, options);
    }
    Fail("LIGGGHTS failed during the discharge", r, dir / log);
  }
  const double discharge_wall = discharge_wall_before + Seconds(t_discharge);
  if (end_reason == "stalled") {
    end_reason = "discharged";
    if (StallIsAClog(spec, ReadAtomsDump(dir / "final.dump"))) {
      state["clog_steps"].push_back(last_step);
      state["clog_step"] = last_step;
      if (spec.discharge.StopOnClog()) {
        end_reason = "clogged";
      } else {  // go on through the clog from the restart the script wrote at the stall
        state["discharge_wall_s"] = discharge_wall;
        state["relaunched_at_step"] = last_step;
        WriteAtomically(state_file, state.dump() + "\n");
        return RunLocked(dir_name, options);
      }
    } else {
      RemoveClogFiles(dir, last_step);  // what the script kept of a stall that was no clog
    }
  } else if (end_reason == "clogged") {
    state["clog_steps"].push_back(last_step);  // reinject mode: the script stopped at the clog
    state["clog_step"] = last_step;
  }

  // Convert into the run-directory format.
  std::vector<silo::ShapeTemplate> templates;
  for (std::size_t k = 0; k < spec.bodies.species.size(); ++k)
    templates.push_back(silo::MakeTemplate(spec.bodies.species[k], spec.bodies.density, static_cast<int>(k)));
  const std::vector<Event> events = ReadEvents(dir, setup.counters, spheres, bodies, recross);
  std::vector<rundir::ExitEvent> exits;
  std::vector<int> per_outlet(static_cast<std::size_t>(setup.outlets), 0);
  for (const Event& e : events) {
    const silo::ShapeTemplate& tp = templates[static_cast<std::size_t>(e.species)];
    exits.push_back({e.time, e.body, tp.name, tp.mass, e.outlet});
    ++per_outlet[static_cast<std::size_t>(e.outlet)];
  }
  rundir::WriteEvents(dir / rundir::kEventsFile, exits);
  if (spec.output.frame_interval > 0 && fs::exists(dir / "frames.liggghts"))
    ConvertFrames(dir / "frames.liggghts", dir / (spec.output.compress ? rundir::kFramesGzFile : rundir::kFramesFile),
                  spec, setup, bodies, box_height);
  if (spec.output.contact_forces && spec.output.frame_interval > 0 && fs::exists(dir / "contacts_pairs.liggghts"))
    ConvertContacts(dir, spec, setup, spheres, bodies, box_height);
  ConvertClogs(dir, state.value("clog_steps", json::array()).get<std::vector<long long>>(), spec, setup, spheres,
               bodies, box_height);

  std::set<long long> remaining;
  double out_of_plane = 0;  // the quasi-2-D set-up must keep every centre in z = 0
  for (const Sphere& s : ReadAtomsDump(dir / "final.dump")) {
    remaining.insert(bodies.Of(s));
    out_of_plane = std::max(out_of_plane, std::fabs(s.z));
  }
  // Work of this session: the spheres x the steps run since the start or the checkpoint.
  const double spheres_total = static_cast<double>(spheres.size());
  const long long session_start = result.continued ? ckpt.step : 0;
  const long long session_steps = last_step - session_start;
  const double session_wall = discharge_wall - discharge_wall_before;
  // The spheres in the silo at each step of the session: in remove mode a body's spheres stop
  // counting at the step it left.
  double sphere_steps = spheres_total * static_cast<double>(session_steps);
  if (spec.discharge.mode == DischargeMode::kRemove)
    for (const Event& e : events) {
      const double left =
          std::clamp(e.time / spec.time_step, static_cast<double>(session_start), static_cast<double>(last_step));
      sphere_steps -= static_cast<double>(templates[static_cast<std::size_t>(e.species)].r.size()) *
                      (static_cast<double>(last_step) - left);
    }
  result.end_reason = end_reason;
  result.exited = static_cast<int>(events.size());
  result.steps = last_step;

  rundir::Summary summary;
  summary.engine = "liggghts";
  summary.engine_version = LiggghtsVersion(dir / "log.discharge");
  summary.granary_version = GRANARY_VERSION;
  summary.granary_commit = granary::GitCommit();
  summary.run_id = spec.run_id;
  summary.spec = spec.ToJson();
  summary.end_reason = end_reason;
  summary.bodies = spec.bodies.count;
  summary.exited = result.exited;
  summary.remaining = static_cast<int>(remaining.size());
  summary.exits_per_outlet = per_outlet;
  summary.t_end = static_cast<double>(last_step) * spec.time_step;
  summary.clogs = static_cast<int>(state.value("clog_steps", json::array()).size());
  summary.steps = last_step;
  summary.max_out_of_plane = out_of_plane;
  summary.tangential_cap = "liggghts";  // LIGGGHTS caps the spring part only, whatever the spec asks
  // Reinjection is y-periodicity here, whatever the spec asks (docs/liggghts.md).
  if (spec.discharge.mode == DischargeMode::kReinject) summary.reinject_position = "periodic";
  summary.bed = {state.value("bed_file", ""),
                 state.value("bed_height", 0.0),
                 state.value("bed_prepared_here", false),
                 state.value("settle_time", 0.0),
                 state.value("bed_refused", std::string()),
                 {},
                 {}};
  const double bed_wall = state.value("bed_wall_s", 0.0);
  summary.timing =
      rundir::Timing{bed_wall + discharge_wall,
                     bed_wall,
                     discharge_wall,
                     session_wall > 0 ? sphere_steps / session_wall : 0.0,
                     options.threads,
                     session_wall > 0 ? spheres_total * static_cast<double>(session_steps) / session_wall : 0.0};
  // Going on through a clog restarts LIGGGHTS too; only a restart after an interruption counts here.
  summary.continued_from_checkpoint = result.continued && ckpt.step != state.value("relaunched_at_step", -1LL);
  rundir::WriteSummary(dir, summary);
  PruneCheckpoints(dir, 0);
  ReportProgress(dir, "discharge", 1.0, static_cast<double>(last_step) * spec.time_step, spec.discharge.max_time,
                 result.exited, discharge_wall, true);
  rundir::WriteDone(dir, end_reason);
  return result;
}

}  // namespace

}  // namespace granary::liggghts
