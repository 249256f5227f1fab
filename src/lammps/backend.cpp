// The LAMMPS backend (backend.h): the native bed, the discharge on LAMMPS, conversion into the
// run directory.
#include "lammps/backend.h"

#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <regex>
#include <set>
#include <sstream>
#include <unordered_map>

#include <boost/process.hpp>

#include "silo/geometry.h"
#include "silo/silo_outline.h"
#include "silo/stall.h"
#include "external/driver.h"
#include "lammps/input_script.h"
#include "rundir/clogs.h"
#include "rundir/contacts.h"
#include "rundir/events.h"
#include "rundir/files.h"
#include "rundir/frames.h"
#include "rundir/layout.h"
#include "rundir/progress.h"
#include "rundir/run_directory.h"
#include "rundir/summary.h"
#include "rundir/version.h"

namespace granary::lammps {

namespace fs = std::filesystem;
namespace bp = boost::process;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;
using external::ChildRun;
using external::Diagnostics;
using external::NearestImage;
using external::NewestCheckpoint;
using external::NextDumpBlock;
using external::PruneCheckpoints;
using external::Tokens;
using external::TruncateDump;

namespace {

constexpr char kStartFrame[] = "start.dump";        // the native bed as the discharge starts from it
constexpr char kStateFile[] = "lammps_state.json";  // bed provenance, clogs, wall time across sessions

double Seconds(Clock::time_point since) { return std::chrono::duration<double>(Clock::now() - since).count(); }

// LAMMPS on `input` in `dir`, one process or `threads` MPI ranks, each through exec-helper.
ChildRun RunLammps(const std::string& exe, int threads, const fs::path& dir, const std::string& input,
                   const std::string& log, const fs::path& control, double silence_limit,
                   const std::function<void(const std::string&)>& on_line) {
  // LAMMPS writes its screen through stdio, fully buffered into a pipe: line-buffered, its
  // progress lines come when printed and none is lost when it is killed.
  std::vector<std::string> lmp = {exe};
  if (const std::string stdbuf = bp::search_path("stdbuf").string(); !stdbuf.empty()) lmp = {stdbuf, "-oL", exe};
  external::Command c;
  try {
    c = external::LaunchCommand(lmp, threads, dir, external::HelperExe("granary-lammps"));
  } catch (const std::runtime_error& e) {
    throw LammpsError(e.what());
  }
  c.args.insert(c.args.end(), {"-in", input, "-log", log, "-echo", "none", "-nocite"});
  try {
    return external::RunChild(c.program, c.args, {dir, control, silence_limit, "LAMMPS", "granary-lammps", dir / log},
                              on_line);
  } catch (const std::runtime_error& e) {
    throw LammpsError(e.what());
  }
}

[[noreturn]] void Fail(const std::string& what, const ChildRun& r, const fs::path& log) {
  throw LammpsError(what + " (" + r.How("LAMMPS") + ")" + Diagnostics(r, log, "LAMMPS"));
}

// granary-engine, which prepares (or finds in its cache) the native bed.
std::string FindEngine(const std::string& preferred) {
  std::string exe = preferred;
  if (exe.empty()) {
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    if (!ec && fs::exists(self.parent_path() / "granary-engine"))
      exe = (self.parent_path() / "granary-engine").string();
  }
  if (exe.empty())
    if (const char* env = std::getenv("GRANARY_ENGINE"); env && *env) exe = env;
  if (exe.empty()) exe = bp::search_path("granary-engine").string();
  if (exe.empty() || !fs::exists(exe))
    throw LammpsError("granary-engine not found" + (exe.empty() ? std::string() : " (\"" + exe + "\")") +
                      ": the LAMMPS backend starts from the native engine's bed; build it beside granary-lammps or "
                      "set GRANARY_ENGINE");
  return exe;
}

// The native bed of DIR/run.json as one frame (granary-engine start-frame), with its provenance.
json ObtainStart(const fs::path& dir, const BackendOptions& options) {
  const std::string engine = FindEngine(options.engine);
  json provenance;
  ChildRun r;
  try {
    r = external::RunChild(engine, {"start-frame", dir.string(), (dir / kStartFrame).string()},
                           {dir, {}, options.silence_limit, "granary-engine", "granary-lammps", {}},
                           [&](const std::string& line) {
                             if (!line.empty() && line[0] == '{') provenance = json::parse(line, nullptr, false);
                           });
  } catch (const std::runtime_error& e) {
    throw LammpsError(e.what());
  }
  if (external::StopSignal() != 0)
    throw Stopped(external::StopSignal(), "stopped while the native engine prepared the bed");
  if (r.exit_code != 0 || r.signal != 0 || !r.stop_reason.empty() || !provenance.is_object() ||
      !fs::exists(dir / kStartFrame))
    throw LammpsError("the native engine could not provide the bed (" + r.How("granary-engine") + ")" +
                      Diagnostics(r, {}, "granary-engine"));
  return provenance;
}

rundir::Frame ReadStart(const fs::path& dir, const RunSpec& spec) {
  rundir::FrameReader in(dir / kStartFrame, spec.bodies.density);
  rundir::Frame f;
  if (!in.Next(f) || f.discs.empty())
    throw LammpsError("the start frame " + (dir / kStartFrame).string() + " is empty");
  return f;
}

struct Event {
  long long step;
  long long body;
  int species;
  int outlet;
};

// Exits from the exit-line dump: a body is counted at the first look that finds its centre of
// mass past an exit line (remove), or at each look that finds it one more box height below
// the line than before (reinject: its unwrapped centre of mass). Outlet: the nearest outlet
// centre, as the native engine.
std::vector<Event> ReadEvents(const fs::path& file, const RunSpec& spec, const Setup& setup,
                              const std::map<long long, int>& species_of) {
  std::vector<Event> events;
  if (!fs::exists(file)) return events;
  const silo::SiloGeometry g = silo::BuildGeometry(spec.silo, setup.y_hi + 10);
  const double ed = spec.discharge.exit_distance, ly = setup.y_hi - setup.y_lo;
  std::map<long long, long long> passes;
  std::ifstream in(file);
  long long step = 0, n = 0;
  std::string line;
  while (NextDumpBlock(in, step, n)) {
    std::set<long long> seen;
    for (long long i = 0; i < n && std::getline(in, line); ++i) {
      const auto t = Tokens(line);
      if (t.size() < 4) throw std::runtime_error("malformed line in " + file.string() + ": " + line);
      const long long body = std::stoll(t[1]) - 1;
      if (!seen.insert(body).second) continue;
      const double x = std::stod(t[2]);
      double y = std::stod(t[3]);
      long long k = 1;
      if (setup.periodic) {
        k = static_cast<long long>(std::floor((-ed - y) / ly)) + 1;
        y -= ly * std::floor((y - setup.y_lo) / ly);
      }
      long long& done = passes[body];
      for (; done < k; ++done) {
        int best = 0;
        double best_d = std::numeric_limits<double>::max();
        for (std::size_t o = 0; o < g.outlets.size(); ++o) {
          const double d = std::hypot(x - g.outlets[o].cx, y - g.outlets[o].cy);
          if (d < best_d) {
            best_d = d;
            best = static_cast<int>(o);
          }
        }
        const auto sp = species_of.find(body);
        events.push_back({step, body, sp == species_of.end() ? 0 : sp->second, best});
      }
    }
  }
  return events;
}

// The frames' box: LAMMPS' box, with room in y for clumps put back together across the
// periodic boundary.
void SetBox(const Setup& s, double (&box)[3][2]) {
  const double b2 = s.periodic ? 2 * s.bound_radius : 0.0;
  box[0][0] = s.x_lo;
  box[0][1] = s.x_hi;
  box[1][0] = s.y_lo - b2;
  box[1][1] = s.y_hi + b2;
  box[2][0] = -0.5;
  box[2][1] = 0.5;
}

// One block of a custom dump (id mol type x y radius vx vy omegaz) as a run-directory frame.
void ReadFrameBlock(std::istream& in, long long n, long long step, const RunSpec& spec, const Setup& setup,
                    rundir::Frame& frame) {
  std::string line;
  const double rho = spec.bodies.density, ly = setup.y_hi - setup.y_lo;
  std::map<long long, double> first_y;
  SetBox(setup, frame.box);
  frame.timestep = step;
  frame.time = static_cast<double>(step) * spec.time_step;
  frame.discs.clear();
  for (long long i = 0; i < n && std::getline(in, line); ++i) {
    const auto t = Tokens(line);
    if (t.size() < 9) throw std::runtime_error("malformed LAMMPS dump line: " + line);
    const double r = std::stod(t[5]);
    const long long body = std::stoll(t[1]) - 1;
    double y = std::stod(t[4]);
    if (setup.periodic) {
      const auto [it, first] = first_y.emplace(body, y);
      if (!first) y = NearestImage(y, it->second, ly);
    }
    frame.discs.push_back({std::stoll(t[0]), body, std::stoi(t[2]), std::stod(t[3]), y, r,
                           rho * std::numbers::pi * r * r, std::stod(t[6]), std::stod(t[7]), std::stod(t[8])});
  }
  std::sort(frame.discs.begin(), frame.discs.end(),
            [](const rundir::Disc& a, const rundir::Disc& b) { return a.id < b.id; });
}

// The rows of the next block of a LAMMPS dump, which must be at `step` (the contact dumps are
// written at the frames' steps).
std::vector<std::vector<std::string>> RowsAt(std::istream& in, const fs::path& file, long long step) {
  long long at = 0, n = 0;
  if (!NextDumpBlock(in, at, n) || at != step)
    throw std::runtime_error(file.string() + " has no block at step " + std::to_string(step) +
                             " (its blocks must be at the frames' steps)");
  std::vector<std::vector<std::string>> rows;
  std::string line;
  for (long long i = 0; i < n && std::getline(in, line); ++i) rows.push_back(Tokens(line));
  return rows;
}

// One contact frame from LAMMPS' pair and wall rows of `frame`'s step (input_script.h
// kPairsDump, kWallsDump), as the native engine writes it: each touching pair of discs of
// different bodies once, the force on i (normal + tangential), the disc centres as in the
// frame (pairs across the periodic boundary unwrapped), the contact point on disc i's surface
// towards j; then each disc-wall contact with the force on the disc and the contact point on
// the wall. Contacts with no force (exactly touching) are left out, as the native engine does.
void ContactFrameOf(const rundir::Frame& frame, const std::vector<std::vector<std::string>>& pairs,
                    const std::vector<std::vector<std::string>>& walls, const Setup& setup, rundir::ContactFrame& out) {
  std::unordered_map<long long, const rundir::Disc*> disc;
  for (const rundir::Disc& d : frame.discs) disc.emplace(d.id, &d);
  auto at = [&](const std::string& id) -> const rundir::Disc& {
    const auto it = disc.find(std::llround(std::stod(id)));
    if (it == disc.end())
      throw std::runtime_error("LAMMPS' contacts at step " + std::to_string(frame.timestep) + " name disc " + id +
                               ", which the frame does not have");
    return *it->second;
  };
  const double ly = setup.y_hi - setup.y_lo;
  out.timestep = frame.timestep;
  out.time = frame.time;
  std::copy(&frame.box[0][0], &frame.box[0][0] + 6, &out.box[0][0]);
  out.contacts.clear();
  for (const auto& t : pairs) {
    if (t.size() < 6)
      throw std::runtime_error("malformed LAMMPS pair contact row at step " + std::to_string(frame.timestep));
    const rundir::Disc& a = at(t[0]);
    const rundir::Disc& b = at(t[1]);
    if (a.mol == b.mol) continue;  // excluded from LAMMPS' lists (neigh_modify exclude molecule/intra)
    const double fx = std::stod(t[2]) + std::stod(t[4]), fy = std::stod(t[3]) + std::stod(t[5]);
    if (fx == 0.0 && fy == 0.0) continue;
    const double xj = b.x, yj = setup.periodic ? NearestImage(b.y, a.y, ly) : b.y;
    const double dx = xj - a.x, dy = yj - a.y, r = std::hypot(dx, dy);
    out.contacts.push_back({a.mol, b.mol, a.x, a.y, xj, yj, a.x + a.radius * dx / r, a.y + a.radius * dy / r, fx, fy});
  }
  const std::size_t fixes = setup.wall_fixes.size();
  for (const auto& t : walls) {
    if (t.size() < 3 + 4 * fixes)
      throw std::runtime_error("malformed LAMMPS wall contact row at step " + std::to_string(frame.timestep));
    const rundir::Disc& d = at(t[0]);
    // The frame may have moved the disc by a box height (a clump put back together).
    const double shift = d.y - std::stod(t[2]);
    for (std::size_t k = 0; k < fixes; ++k) {
      const double fx = std::stod(t[3 + 4 * k]), fy = std::stod(t[4 + 4 * k]);
      if (fx == 0.0 && fy == 0.0) continue;
      const double cx = std::stod(t[5 + 4 * k]), cy = std::stod(t[6 + 4 * k]) + shift;
      out.contacts.push_back({d.mol, -1, d.x, d.y, cx, cy, cx, cy, fx, fy});
    }
  }
}

// frames.lammps into the frames file and, with output/contact_forces, the two contact dumps
// into the contacts file, frame by frame.
void ConvertFrames(const fs::path& dir, const RunSpec& spec, const Setup& setup) {
  const bool gz = spec.output.compress;
  std::ifstream in(dir / kFramesDump);
  rundir::FrameWriter out = rundir::FrameWriter::Create(dir / (gz ? rundir::kFramesGzFile : rundir::kFramesFile), gz);
  const bool contacts = spec.output.contact_forces;
  std::ifstream pairs, walls;
  rundir::ContactWriter contacts_out;
  if (contacts) {
    pairs.open(dir / kPairsDump);
    walls.open(dir / kWallsDump);
    contacts_out = rundir::ContactWriter::Create(dir / (gz ? rundir::kContactsGzFile : rundir::kContactsFile), gz);
  }
  long long step = 0, n = 0;
  rundir::Frame frame;
  rundir::ContactFrame contact_frame;
  while (NextDumpBlock(in, step, n)) {
    ReadFrameBlock(in, n, step, spec, setup, frame);
    out.Write(frame);
    if (contacts) {
      ContactFrameOf(frame, RowsAt(pairs, dir / kPairsDump, step), RowsAt(walls, dir / kWallsDump, step), setup,
                     contact_frame);
      contacts_out.Write(contact_frame);
    }
  }
  out.Close();
  if (contacts) contacts_out.Close();
}

fs::path ClogFile(const fs::path& dir, long long step, const char* ext = ".atoms") {
  return dir / (std::string(kClogFilePrefix) + std::to_string(step) + ext);
}
void RemoveClogFiles(const fs::path& dir, long long step) {
  for (const char* ext : {".atoms", ".pairs", ".walls"}) fs::remove(ClogFile(dir, step, ext));
}
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

// The configurations and contacts kept at the clogs into the run directory's clog files.
void ConvertClogs(const fs::path& dir, const std::vector<long long>& steps, const RunSpec& spec, const Setup& setup) {
  rundir::ClogWriter out = rundir::ClogWriter::Create(dir);
  rundir::ClogState clog;
  for (long long step : steps) {
    std::ifstream atoms(ClogFile(dir, step));
    long long dumped = 0, n = 0;
    if (!atoms || !NextDumpBlock(atoms, dumped, n))
      throw std::runtime_error("the configuration of the clog at step " + std::to_string(step) + " is missing (" +
                               ClogFile(dir, step).string() + ")");
    ReadFrameBlock(atoms, n, step, spec, setup, clog.frame);
    std::ifstream pairs(ClogFile(dir, step, ".pairs")), walls(ClogFile(dir, step, ".walls"));
    ContactFrameOf(clog.frame, RowsAt(pairs, ClogFile(dir, step, ".pairs"), dumped),
                   RowsAt(walls, ClogFile(dir, step, ".walls"), dumped), setup, clog.contacts);
    clog.contacts.timestep = step;
    out.Write(clog);
  }
  out.Close();
}

struct Disc {
  long long id, mol;
  int type;
  double x, y, r;
};
std::vector<Disc> ReadFinal(const fs::path& file) {
  std::ifstream in(file);
  std::vector<Disc> out;
  long long step = 0, n = 0;
  if (!in || !NextDumpBlock(in, step, n)) throw std::runtime_error("missing or empty " + file.string());
  std::string line;
  for (long long i = 0; i < n && std::getline(in, line); ++i) {
    const auto t = Tokens(line);
    if (t.size() < 6) throw std::runtime_error("malformed line in " + file.string() + ": " + line);
    out.push_back(
        {std::stoll(t[0]), std::stoll(t[1]), std::stoi(t[2]), std::stod(t[3]), std::stod(t[4]), std::stod(t[5])});
  }
  return out;
}

// A stall in remove mode is a clog when an arch seals an outlet from the material above: the
// native engine's judgement (silo/stall.h) on LAMMPS' final positions.
bool StallIsAClog(const RunSpec& spec, const std::vector<Disc>& left) {
  std::vector<silo::DiscAt> discs;
  std::vector<std::int64_t> body_of;
  double top = 0;
  for (const Disc& d : left) {
    discs.push_back({d.x, d.y, d.r});
    body_of.push_back(d.mol);
    top = std::max(top, d.y + d.r);
  }
  const std::vector<bool> sealed =
      silo::SealedOutlets(silo::BuildGeometry(spec.silo, top + 1), discs, silo::PassageProbe(discs, body_of));
  return std::find(sealed.begin(), sealed.end(), true) != sealed.end();
}

std::string LammpsVersion(const fs::path& log) {
  std::ifstream in(log);
  std::string line;
  if (std::getline(in, line)) {
    static const std::regex kV(R"(LAMMPS \(([^)]+)\))");
    std::smatch m;
    if (std::regex_search(line, m, kV)) return m[1];
  }
  return "unknown";
}

void WriteInputsInto(const fs::path& dir, const RunSpec& spec, const Setup& setup, const rundir::Frame& start,
                     const DischargeStart& ds) {
  if (!ds.continue_run) WriteAtomically(dir / kDataFile, DataFile(setup, start));
  WriteAtomically(dir / "discharge.in", DischargeScript(spec, setup, ds));
  WriteAtomically(dir / kControlFile, "variable stop_requested equal 0\n");
}

// bed/settled_by "lammps": LAMMPS settles the loose placement the native engine wrote as the
// start frame (outlets closed), and the settled bed becomes the start frame, at t = 0.
json SettleInLammps(const fs::path& dir, const RunSpec& spec, const std::string& exe, const BackendOptions& options,
                    const json& placed) {
  const rundir::Frame loose = ReadStart(dir, spec);
  const Setup s = SettleSetup(spec, loose);
  double top = 0;
  for (const rundir::Disc& d : loose.discs) top = std::max(top, d.y + d.radius);
  // Not settled before the highest body could have fallen to the base (the native batches' wait).
  const double fall_time = std::sqrt(2.0 * top / spec.gravity) + 1.0;
  WriteAtomically(dir / kLooseDataFile, DataFile(s, loose));
  WriteAtomically(dir / "settle.in", SettleScript(spec, s, fall_time));
  const auto t0 = Clock::now();
  double settled_t = -1, ke = -1;
  const ChildRun r = RunLammps(
      exe, options.threads, dir, "settle.in", "log.settle", {}, options.silence_limit, [&](const std::string& line) {
        const auto t = Tokens(line);
        if (t.size() > 2 && t[0] == "GRANARY_SETTLED") {
          settled_t = std::stod(t[1]);
          ke = std::stod(t[2]);
        } else if (t.size() == 5 && std::isdigit(static_cast<unsigned char>(t[0][0])) &&
                   t[1].find_first_not_of("0123456789.eE+-") == std::string::npos) {
          const double time = std::stod(t[1]);  // a thermo line: step time atoms ke_per_body cpu
          rundir::WriteProgress(dir, {"bed", std::min(1.0, time / spec.bed.max_settle_time), time, 0.0, 0, Seconds(t0)},
                                !options.quiet);
        }
      });
  if (external::StopSignal() != 0)
    throw Stopped(external::StopSignal(), "stopped while LAMMPS settled the bed (not checkpointed)");
  if (r.exit_code != 0 || r.signal != 0 || !r.stop_reason.empty() || settled_t < 0 || !fs::exists(dir / kSettledDump))
    Fail("LAMMPS failed while settling the bed", r, dir / "log.settle");
  std::ifstream in(dir / kSettledDump);
  long long step = 0, n = 0;
  if (!NextDumpBlock(in, step, n)) throw LammpsError("LAMMPS wrote an empty " + std::string(kSettledDump));
  rundir::Frame bed;
  ReadFrameBlock(in, n, 0, spec, s, bed);
  double height = 0;
  for (const rundir::Disc& d : bed.discs) height = std::max(height, d.y + d.radius);
  rundir::FrameWriter out = rundir::FrameWriter::Create(dir / kStartFrame);
  out.Write(bed);
  out.Close();
  return {{"settled_by", "lammps"},
          {"bed_file", ""},
          {"prepared_here", true},
          {"height", height},
          {"settle_time", settled_t},
          {"ke_per_body", ke},
          {"settled", ke >= 0 && ke < spec.bed.settle_ke_per_body},
          {"cleared_by_obstacles", placed.value("cleared_by_obstacles", 0)}};
}

BackendResult RunLocked(const fs::path& dir, const BackendOptions& options);

}  // namespace

std::string FindLammps(const std::string& preferred) {
  std::string exe = preferred;
  if (exe.empty())
    if (const char* env = std::getenv("GRANARY_LAMMPS"); env && *env) exe = env;
  if (exe.empty()) exe = bp::search_path("lmp").string();
  if (exe.empty() || !fs::exists(exe))
    throw LammpsError("LAMMPS executable not found" + (exe.empty() ? std::string() : " (\"" + exe + "\")") +
                      ": install Debian's package lammps (scripts/setup.sh does), or set GRANARY_LAMMPS");
  return exe;
}

std::vector<std::string> WriteInputs(const std::string& dir_name, const BackendOptions& options) {
  const fs::path dir = fs::absolute(dir_name);
  const RunSpec spec = rundir::ReadRunSpec(dir);
  ValidateForLammps(spec);
  ObtainStart(dir, options);
  const rundir::Frame start = ReadStart(dir, spec);
  WriteInputsInto(dir, spec, MakeSetup(spec, start), start, DischargeStart{});
  return {kStartFrame, kDataFile, "discharge.in", kControlFile};
}

void RequestStop(int signal) { external::RequestStop(signal); }

BackendResult RunDirectory(const std::string& dir_name, const BackendOptions& options) {
  const RunDirectoryLock lock(fs::absolute(dir_name));
  return RunLocked(fs::absolute(dir_name), options);
}

namespace {

BackendResult RunLocked(const fs::path& dir, const BackendOptions& options) {
  const RunSpec spec = rundir::ReadRunSpec(dir);
  ValidateForLammps(spec);
  const std::string exe = FindLammps(options.lammps);
  fs::remove(dir / rundir::kDoneFile);

  BackendResult result;
  const external::Checkpoint ckpt = NewestCheckpoint(dir);
  const fs::path state_file = dir / kStateFile;
  json state;
  DischargeStart start;
  double wall_before = 0;
  const auto t_session = Clock::now();
  if (ckpt.step >= 0 && fs::exists(state_file) && fs::exists(dir / kStartFrame)) {
    state = json::parse(ReadWholeFile(state_file));
    result.continued = true;
    start.continue_run = true;
    start.restart_file = ckpt.file.filename().string();  // "checkpoint.<digits>.restart": no spec text
    TruncateDump(dir / kExitsDump, ckpt.step);
    // LAMMPS writes the checkpoint step's frame again when it starts from the checkpoint.
    for (const char* dump : {kFramesDump, kPairsDump, kWallsDump}) TruncateDump(dir / dump, ckpt.step - 1);
    wall_before = state.value("discharge_wall_s", 0.0);
    std::vector<long long> kept;
    for (long long c : state.value("clog_steps", std::vector<long long>{}))
      if (c <= ckpt.step) kept.push_back(c);
    state["clog_steps"] = kept;
    RemoveClogFilesAfter(dir, ckpt.step);
  } else {
    for (const fs::path& f :
         {fs::path(kExitsDump), fs::path(kFramesDump), fs::path(kPairsDump), fs::path(kWallsDump),
          fs::path(rundir::kContactsFile), fs::path(rundir::kContactsGzFile), fs::path(kFinalDump),
          fs::path(rundir::kEventsFile), fs::path(rundir::kFramesFile), fs::path(rundir::kFramesGzFile),
          fs::path(rundir::kClogFramesFile), fs::path(rundir::kClogContactsFile), fs::path(kStartFrame)})
      fs::remove(dir / f);
    RemoveClogFilesAfter(dir, -1);
    PruneCheckpoints(dir, 0);
    const auto t0 = Clock::now();
    rundir::WriteProgress(dir, {"bed", 0.0, 0.0, 0.0, 0, 0.0}, !options.quiet);
    json bed = ObtainStart(dir, options);
    if (spec.bed.settled_by == BedSettler::kLammps) bed = SettleInLammps(dir, spec, exe, options, bed);
    state = {{"bed", bed}, {"bed_wall_s", Seconds(t0)}, {"discharge_wall_s", 0.0}, {"clog_steps", json::array()}};
    WriteAtomically(state_file, state.dump() + "\n");
  }
  const rundir::Frame start_frame = ReadStart(dir, spec);
  const Setup setup = MakeSetup(spec, start_frame);
  std::map<long long, int> species_of;
  std::map<int, double> body_mass;
  for (const rundir::Disc& d : start_frame.discs) species_of[d.mol] = d.type - 1;
  {
    std::map<long long, double> mass;
    for (const rundir::Disc& d : start_frame.discs) mass[d.mol] += d.mass;
    for (const auto& [mol, m] : mass) body_mass.emplace(species_of[mol], m);
  }
  if (start.continue_run) {
    // The step of the last exit before the checkpoint, as the script counts it (at the end of
    // the chunk that saw it), and whether a clog was counted since.
    const std::vector<Event> before = ReadEvents(dir / kExitsDump, spec, setup, species_of);
    const long long chunk =
        std::max<long long>(1, std::llround(std::min(0.5, spec.discharge.clog_window / 4) / spec.time_step));
    if (!before.empty()) start.last_exit_step = std::min(ckpt.step, (before.back().step + chunk - 1) / chunk * chunk);
    for (long long c : state["clog_steps"].get<std::vector<long long>>())
      if (c >= start.last_exit_step) start.in_clog = true;
  }
  WriteAtomically(dir / rundir::kSiloFile,
                  silo::SiloVtk(silo::OutlineOf(spec.silo, spec.silo.height > 0 ? spec.silo.height : setup.y_hi)));
  WriteInputsInto(dir, spec, setup, start_frame, start);

  const auto t_discharge = Clock::now();
  std::string end_reason;
  long long last_step = 0;
  int progress_lines = 0;
  const std::string log = result.continued ? "log.discharge." + std::to_string(ckpt.step) : "log.discharge";
  const fs::path control = dir / kControlFile;
  const ChildRun r = RunLammps(
      exe, options.threads, dir, "discharge.in", log, control, options.silence_limit, [&](const std::string& line) {
        if (line.rfind("GRANARY_", 0) != 0) return;
        const auto t = Tokens(line);
        if (t[0] == "GRANARY_END" && t.size() > 1) end_reason = t[1];
        if (t[0] == "GRANARY_FINAL" && t.size() > 1) last_step = std::stoll(t[1]);
        if (t[0] == "GRANARY_CLOG" && t.size() > 1) {
          state["clog_steps"].push_back(std::stoll(t[1]));
          WriteAtomically(state_file, state.dump() + "\n");
        }
        if (t[0] == "GRANARY_PROGRESS" && t.size() > 2) {
          ++progress_lines;
          PruneCheckpoints(dir, 2);
          const double time = std::stod(t[1]) * spec.time_step;
          rundir::WriteProgress(dir,
                                {"discharge", time / spec.discharge.max_time, time, spec.discharge.max_time,
                                 static_cast<int>(std::stoll(t[2])), wall_before + Seconds(t_discharge)},
                                !options.quiet);
          state["discharge_wall_s"] = wall_before + Seconds(t_discharge);
          WriteAtomically(state_file, state.dump() + "\n", Durability::kVisible);
        }
      });
  if (r.stopped) {
    state["discharge_wall_s"] = wall_before + Seconds(t_discharge);
    WriteAtomically(state_file, state.dump() + "\n");
    throw Stopped(
        external::StopSignal() != 0 ? external::StopSignal() : SIGTERM,
        "stopped on request; checkpointed by LAMMPS (" + NewestCheckpoint(dir).file.filename().string() + ")");
  }
  if (external::StopSignal() != 0)
    throw Stopped(external::StopSignal(),
                  "stopped on request before LAMMPS checkpointed" + Diagnostics(r, dir / log, "LAMMPS"));
  if (r.exit_code != 0 || r.signal != 0 || !r.stop_reason.empty() || end_reason.empty() ||
      !fs::exists(dir / kFinalDump)) {
    // A checkpoint cut short by a kill fails at read_restart: drop it, go on from the one before.
    if (result.continued && progress_lines == 0 && r.stop_reason.empty() && r.signal == 0) {
      std::fprintf(stderr, "granary-lammps: cannot continue from %s; trying an earlier checkpoint\n",
                   ckpt.file.filename().c_str());
      fs::rename(ckpt.file, fs::path(ckpt.file.string() + ".corrupt"));
      state["refused_checkpoints"].push_back(ckpt.file.filename().string() + ": LAMMPS could not continue from it");
      WriteAtomically(state_file, state.dump() + "\n");
      return RunLocked(dir, options);
    }
    Fail("LAMMPS failed during the discharge", r, dir / log);
  }
  const double discharge_wall = wall_before + Seconds(t_discharge);
  if (end_reason == "stalled") {
    end_reason = "discharged";
    if (StallIsAClog(spec, ReadFinal(dir / kFinalDump))) {
      state["clog_steps"].push_back(last_step);
      if (spec.discharge.StopOnClog()) {
        end_reason = "clogged";
      } else {  // go on through the clog from the restart the script wrote at the stall
        state["discharge_wall_s"] = discharge_wall;
        state["relaunched_at_step"] = last_step;
        WriteAtomically(state_file, state.dump() + "\n");
        return RunLocked(dir, options);
      }
    } else {
      RemoveClogFiles(dir, last_step);
    }
  } else if (end_reason == "clogged") {
    state["clog_steps"].push_back(last_step);
  }

  // Convert into the run-directory format.
  const std::vector<Event> events = ReadEvents(dir / kExitsDump, spec, setup, species_of);
  std::vector<rundir::ExitEvent> exits;
  std::vector<int> per_outlet(spec.silo.base_outlets.size() + spec.silo.side_outlets.size(), 0);
  for (const Event& e : events) {
    if (e.step > last_step) continue;
    exits.push_back({static_cast<double>(e.step) * spec.time_step, e.body,
                     spec.bodies.species[static_cast<std::size_t>(e.species)].name, body_mass[e.species], e.outlet});
    ++per_outlet[static_cast<std::size_t>(e.outlet)];
  }
  rundir::WriteEvents(dir / rundir::kEventsFile, exits);
  if (spec.output.frame_interval > 0 && fs::exists(dir / kFramesDump)) ConvertFrames(dir, spec, setup);
  const std::vector<long long> clog_steps = state.value("clog_steps", std::vector<long long>{});
  ConvertClogs(dir, clog_steps, spec, setup);

  // Bodies in the silo at the end: not yet deleted, and not past an exit line either.
  std::set<long long> remaining;
  for (const Disc& d : ReadFinal(dir / kFinalDump)) remaining.insert(d.mol - 1);
  for (const rundir::ExitEvent& e : exits) remaining.erase(e.body);
  const long long session_steps = last_step - (result.continued ? ckpt.step : 0);
  const double session_wall = discharge_wall - wall_before;
  result.end_reason = end_reason;
  result.exited = static_cast<int>(exits.size());
  result.steps = last_step;

  rundir::Summary summary;
  summary.engine = "lammps";
  summary.engine_version = LammpsVersion(dir / "log.discharge");
  summary.granary_version = GRANARY_VERSION;
  summary.granary_commit = granary::GitCommit();
  summary.run_id = spec.run_id;
  summary.spec = spec.ToJson();
  summary.end_reason = end_reason;
  summary.bodies = setup.bodies;
  const json bed = state.value("bed", json::object());
  if (!spec.silo.obstacles.empty()) summary.cleared_by_obstacles = bed.value("cleared_by_obstacles", 0);
  summary.exited = result.exited;
  summary.remaining = spec.discharge.mode == DischargeMode::kRemove ? static_cast<int>(remaining.size()) : setup.bodies;
  summary.exits_per_outlet = per_outlet;
  summary.t_end = static_cast<double>(last_step) * spec.time_step;
  summary.clogs = static_cast<int>(clog_steps.size());
  summary.steps = last_step;
  summary.tangential_cap = "lammps";  // LAMMPS caps spring + damping, whatever the spec asks
  if (spec.discharge.mode == DischargeMode::kReinject) summary.reinject_position = "periodic";
  summary.bed = {bed.value("bed_file", ""),
                 bed.value("height", 0.0),
                 bed.value("prepared_here", false),
                 bed.value("settle_time", 0.0),
                 bed.value("refused", std::string()),
                 {},
                 {}};
  const double bed_wall = state.value("bed_wall_s", 0.0);
  // Disc-steps of this session: the bed's discs at every step, less those of bodies gone (remove
  // mode: from each exit to the end).
  const double bed_disc_steps = static_cast<double>(start_frame.discs.size()) * static_cast<double>(session_steps);
  double disc_steps = bed_disc_steps;
  if (spec.discharge.mode == DischargeMode::kRemove) {
    std::map<long long, int> discs_of;
    for (const rundir::Disc& d : start_frame.discs) ++discs_of[d.mol];
    const long long from = result.continued ? ckpt.step : 0;
    for (const Event& e : events)
      if (e.step <= last_step) disc_steps -= discs_of[e.body] * static_cast<double>(last_step - std::max(e.step, from));
  }
  summary.timing = rundir::Timing{bed_wall + discharge_wall,
                                  bed_wall,
                                  discharge_wall,
                                  session_wall > 0 ? disc_steps / session_wall : 0.0,
                                  options.threads,
                                  session_wall > 0 ? bed_disc_steps / session_wall : 0.0};
  summary.continued_from_checkpoint = result.continued && ckpt.step != state.value("relaunched_at_step", -1LL);
  for (const auto& why : state.value("refused_checkpoints", json::array())) summary.refused_checkpoints.push_back(why);
  rundir::WriteSummary(dir, summary);
  PruneCheckpoints(dir, 0);
  rundir::WriteProgress(dir, {"discharge", 1.0, summary.t_end, spec.discharge.max_time, result.exited, discharge_wall},
                        false);
  (void)t_session;
  rundir::WriteDone(dir, end_reason);
  return result;
}

}  // namespace

}  // namespace granary::lammps
