// The discharge driver: outlets open at t = 0, exits become events, reinjection or
// removal, clog detection, outputs and checkpoints (docs/run-directory.md).
#include "engine/run.h"

#include <omp.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/arches.h"
#include "engine/bed.h"
#include "engine/dump_format.h"
#include "engine/random.h"
#include "silo/silo_outline.h"
#include "engine/stall_world.h"
#include "rundir/stop.h"
#include "engine/world.h"
#include "rundir/clogs.h"
#include "rundir/contacts.h"
#include "rundir/files.h"
#include "rundir/frames.h"
#include "rundir/progress.h"
#include "rundir/run_directory.h"
#include "rundir/summary.h"
#include "rundir/unclogs.h"
#include "rundir/version.h"

namespace granary::engine {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;
// checkpoint.bin: kCheckpointMagic, the format version, the payload's size and CRC-32, then
// the payload (docs/engine.md "Checkpoints and continuing").
constexpr char kCheckpointMagic[] = "GRANARY-CHECKPOINT";
// 5: the bed's packing fraction and surface after its height; 4 (without them) still read.
constexpr std::uint32_t kCheckpointVersion = 5;
constexpr std::uint32_t kOldestCheckpointVersion = 4;
constexpr char kCheckpointFile[] = "checkpoint.bin";
constexpr char kPreviousCheckpointFile[] = "checkpoint.prev.bin";

// A checkpoint that cannot be used (corrupt, truncated, another format): the run falls back
// to the previous one or starts over.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Stop requests (stop.h): the signal, and whether the discharge loop is there to honour it.
volatile std::sig_atomic_t g_stop_signal = 0;
volatile std::sig_atomic_t g_stop_accepted = 0;

extern "C" void EngineOnStopSignal(int signal) {
  if (g_stop_accepted) {
    g_stop_signal = signal;
  } else {  // nothing to checkpoint yet (bed preparation): the signal's own action, now
    std::signal(signal, SIG_DFL);
    std::raise(signal);
  }
}
constexpr int kClogCheckEvery = 100;
constexpr double kHangingGapInDiameters =
    1.0;  // stall.h; measured margins in docs/engine.md  // steps between clog checks once no exit for clog_window

double Seconds(Clock::time_point since) { return std::chrono::duration<double>(Clock::now() - since).count(); }

// Binary (de)serialisation of the checkpoint: native doubles, so a continued run is bitwise
// the same as an uninterrupted one on the same machine. Out and In are the two archives
// that one Serialize per checkpointed type visits (a field is written and read by the same
// line): numbers as their bytes, bools as one byte, strings and vectors of plain values as
// a 64-bit length and their bytes.
template <typename T>
struct IsVector : std::false_type {};
template <typename T>
struct IsVector<std::vector<T>> : std::true_type {};

class Out {
 public:
  template <typename T>
  void Put(const T& v) {
    buf_.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  template <typename T>
  void PutVec(const std::vector<T>& v) {
    Put<std::uint64_t>(v.size());
    buf_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  void PutStr(const std::string& s) {
    Put<std::uint64_t>(s.size());
    buf_ += s;
  }
  const std::string& Str() const { return buf_; }

  // The archive interface of Serialize: a writer writes every field of the current version.
  template <typename... T>
  void operator()(T&... fields) {
    (Field(fields), ...);
  }
  std::uint32_t Version() const { return kCheckpointVersion; }
  bool More() const { return true; }

 private:
  template <typename T>
  void Field(T& v) {
    if constexpr (std::is_same_v<T, bool>)
      Put(static_cast<std::uint8_t>(v));
    else if constexpr (std::is_arithmetic_v<T>)
      Put(v);
    else if constexpr (std::is_same_v<T, std::string>)
      PutStr(v);
    else if constexpr (IsVector<T>::value)
      PutVec(v);
    else
      Serialize(*this, v);
  }

 private:
  std::string buf_;
};

class In {
 public:
  In(std::string buf, std::string name) : buf_(std::move(buf)), name_(std::move(name)) {}
  template <typename T>
  T Get() {
    Need(sizeof(T));
    T v;
    std::memcpy(&v, buf_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  template <typename T>
  std::vector<T> GetVec() {
    const auto n = Get<std::uint64_t>();
    Need(n * sizeof(T));
    std::vector<T> v(n);
    std::memcpy(v.data(), buf_.data() + pos_, n * sizeof(T));
    pos_ += n * sizeof(T);
    return v;
  }
  std::string GetStr() {
    const auto n = Get<std::uint64_t>();
    Need(n);
    std::string s = buf_.substr(pos_, n);
    pos_ += n;
    return s;
  }
  std::string Rest() const { return buf_.substr(pos_); }
  bool AtEnd() const { return pos_ >= buf_.size(); }

  // The archive interface of Serialize: a reader reads the fields of `version`; fields
  // after a `More()` that is false keep the values they had.
  void SetVersion(std::uint32_t version) { version_ = version; }
  template <typename... T>
  void operator()(T&... fields) {
    (Field(fields), ...);
  }
  std::uint32_t Version() const { return version_; }
  bool More() const { return !AtEnd(); }

 private:
  template <typename T>
  void Field(T& v) {
    if constexpr (std::is_same_v<T, bool>)
      v = Get<std::uint8_t>() != 0;
    else if constexpr (std::is_arithmetic_v<T>)
      v = Get<T>();
    else if constexpr (std::is_same_v<T, std::string>)
      v = GetStr();
    else if constexpr (IsVector<T>::value)
      v = GetVec<typename T::value_type>();
    else
      Serialize(*this, v);
  }
  void Need(std::size_t n) const {
    if (pos_ + n > buf_.size()) throw CheckpointError("checkpoint " + name_ + " is truncated");
  }
  std::string buf_;
  std::string name_;
  std::size_t pos_ = 0;
  std::uint32_t version_ = kCheckpointVersion;
};

// The discharge's own state that its checkpoints hold (Discharge keeps it as a base, so its
// members read as the driver's own).
struct CheckpointedState {
  // Counters.
  std::int64_t step_ = 0;
  std::int64_t last_exit_step_ = 0;
  std::int64_t disc_steps_ = 0;
  std::vector<std::int64_t> exits_per_outlet_;
  int clogs_ = 0;
  bool in_clog_ = false;
  // The unclog protocol: attempts on the current clog, clogs broken, the step of the last
  // attempt (-1: none), arch bodies taken out in remove mode. (Its own random numbers, for
  // the kicks, are Discharge::unclog_rng_, so that reinjection draws the same numbers
  // whether a run unclogs or not.)
  int unclog_attempts_ = 0;
  int unclogged_ = 0;
  std::int64_t last_unclog_step_ = -1;
  int unclog_removed_ = 0;
  // remove_arch: the arch of the clog just counted, found from the contact forces of that
  // step before the lists are rebuilt (which clears them).
  std::vector<std::int64_t> clog_arch_;
  // Periodic reinjection: bodies counted but still falling to the bottom of the box, and the
  // box height they jump up by.
  std::vector<std::uint8_t> falling_;
  double periodic_height_ = 0;
  // Bodies of the bed that an obstacle overlaps, taken out at t = 0.
  int cleared_by_obstacles_ = 0;
  // Bed provenance.
  std::string bed_file_;
  bool bed_prepared_here_ = false;
  double bed_height_ = 0, bed_settle_time_ = 0, bed_wall_s_ = 0;
  double bed_phi_ = std::numeric_limits<double>::quiet_NaN();  // NaN: continued from a version-4 checkpoint
  double bed_surface_ = std::numeric_limits<double>::quiet_NaN();
};

// Everything a checkpoint holds: the run.json it belongs to, the discharge's state, the wall
// time of the sessions so far, the random streams, the world, and how far the outputs had
// got (a continued run cuts them back there).
struct Checkpoint {
  std::string spec;
  CheckpointedState state;
  double discharge_wall = 0;
  std::string rng, unclog_rng;
  WorldSnapshot world;
  std::int64_t events_offset = 0, frames_offset = 0, contacts_offset = 0, unclogs_offset = 0;
};

// The checkpoint format (checkpoint.bin's payload), written by Out and read by In: the
// fields in their order on disk, so a new field is one line here (at the end, behind a
// version or `More()` test, for the older checkpoints that lack it).
template <class Archive>
void Serialize(Archive& ar, WorldSnapshot& w) {
  ar(w.tmpl, w.active, w.x, w.y, w.theta, w.c, w.s, w.vx, w.vy, w.w, w.fx, w.fy, w.torque);
  ar(w.pairs, w.walls, w.outlets_open, w.rebuild_predicted);
}

template <class Archive>
void Serialize(Archive& ar, Checkpoint& k) {
  CheckpointedState& s = k.state;
  ar(k.spec, s.step_, s.last_exit_step_, s.disc_steps_, s.exits_per_outlet_, s.clogs_, s.in_clog_);
  ar(s.bed_file_, s.bed_prepared_here_, s.bed_height_, s.bed_settle_time_, s.bed_wall_s_);
  if (ar.Version() >= 5) ar(s.bed_phi_, s.bed_surface_);
  ar(k.discharge_wall, k.rng, k.world, k.events_offset, k.frames_offset, k.contacts_offset);
  ar(s.falling_, s.periodic_height_, s.cleared_by_obstacles_);
  // The unclog state last: a checkpoint of an engine from before it reads without it.
  if (ar.More())
    ar(s.unclog_attempts_, s.unclogged_, s.last_unclog_step_, s.unclog_removed_, k.unclog_rng, k.unclogs_offset);
  if (ar.More()) ar(s.clog_arch_);
}

}  // namespace

// The state of a discharge, everything a checkpoint must hold (CheckpointedState and the
// members Checkpoint names).
class Discharge : private CheckpointedState {
 public:
  Discharge(const RunSpec& spec, fs::path dir, RunOptions options)
      : spec_(spec),
        dir_(std::move(dir)),
        options_(options),
        rng_(spec.seed ^ 0x9e3779b97f4a7c15ULL),
        unclog_rng_(spec.seed ^ 0xc2b2ae3d27d4eb4fULL) {}

  RunResult Run();
  // The bed placed as the discharge starts from it (obstacles cleared), as one frame at t = 0.
  StartState WriteStartFrame(const fs::path& file);

 private:
  // Bodies of `species` at rest, outlets open; or the bodies of `snapshot`.
  void BuildWorld(const std::vector<int>& species, const WorldSnapshot* snapshot = nullptr);
  void StartFresh();
  void PlaceBed();  // the bed obtained and placed, outlets open, obstacles cleared (step 0)
  void LoadCheckpoint(const fs::path& file);
  bool ContinueFromACheckpoint();
  void WriteCheckpoint();
  void FillFrame(rundir::Frame& f);
  void FillContacts(rundir::ContactFrame& f);
  void WriteFrame();
  // A contact frame goes with every contact_interval-th frame (counted from step 0, so a
  // continued run writes the same ones).
  bool ContactsDue() const { return contacts_.IsOpen() && (step_ / frame_every_) % spec_.output.contact_interval == 0; }
  void WriteContacts();
  void WriteClog();
  void HandleExits();
  int OutletOf(int b) const;
  void Reinject(int b);
  struct Landing {
    double y = 0, vy = 0;
    int on_body = -1;
  };
  Landing LandingOn(int b, double x) const;
  bool Periodic() const {
    return spec_.discharge.mode == DischargeMode::kReinject &&
           spec_.discharge.reinject_position == ReinjectPosition::kPeriodic;
  }
  bool Stalled();
  bool RollsOutSoon(int b) const;
  bool StallIsAClog() const;
  bool Unclogging() const { return spec_.discharge.on_clog == OnClog::kUnclog; }
  // One attempt at breaking the current clog (on_clog "unclog"), written to unclogs.csv.
  // remove_arch takes out `arch` when given (the arch found when the clog was counted), else
  // the arch the contacts of this step show.
  void Unclog(const std::vector<std::int64_t>* arch = nullptr);
  void Kick(std::vector<std::int64_t>& kicked);  // the kick method, also remove_arch's fallback
  // The bodies of the arches sealing the outlets, as the arch analysis finds them.
  std::vector<std::int64_t> ArchBodies();
  void WriteSummary(const std::string& end_reason);
  void ReportProgress(const rundir::Progress& progress, bool quiet) const {
    rundir::WriteProgress(dir_, progress, !quiet);
  }
  // The dump box, fixed for the whole run (dump_format.h).
  void DumpBox(double (&box)[3][2]) const;

  RunSpec spec_;
  fs::path dir_;
  RunOptions options_;
  Rng rng_;
  Rng unclog_rng_;  // the unclog protocol's kicks (CheckpointedState)
  std::unique_ptr<World> world_;
  double energy_unit_ = 1.0;
  double hw_ = 50.0;
  double r_max_ = 0.5;
  std::string bed_refused_;           // a bad cached bed file refused (and prepared again) in this session
  double discharge_wall_before_ = 0;  // wall time of earlier sessions
  bool continued_ = false;
  std::string extended_from_;                     // the run id whose checkpoint this run continued with a larger limit
  std::vector<std::string> refused_checkpoints_;  // why, for summary.json
  // Outputs.
  rundir::EventWriter events_;
  rundir::FrameWriter frames_;
  rundir::ContactWriter contacts_;
  // The configuration and contact forces at every clog; a continued run cuts them back to
  // its checkpoint's step (clogs.h), so the checkpoint carries nothing for them.
  rundir::ClogWriter clogs_out_;
  rundir::UnclogWriter unclogs_out_;
  std::int64_t frame_every_ = 0, checkpoint_every_ = 0;
  std::vector<World::ContactView> contact_buf_;
  rundir::Frame frame_buf_;
  bool warned_outside_box_ = false;
  std::vector<std::uint8_t> in_contact_;      // bodies in contact in the last force pass, for Reinject
  std::vector<std::uint8_t> alone_on_floor_;  // Stalled: bodies alone on the floor (stall_world.h)
  rundir::ContactFrame contact_frame_buf_;
  Clock::time_point session_start_ = Clock::now();
};

void Discharge::BuildWorld(const std::vector<int>& species, const WorldSnapshot* snapshot) {
  std::vector<silo::ShapeTemplate> templates = MakeTemplates(spec_);
  const double wall_height = spec_.silo.height > 0 ? spec_.silo.height : kTallWall;
  WorldParams params = ParamsFromSpec(spec_);
  if (options_.parallel_min_discs >= 0) params.parallel_min_discs = options_.parallel_min_discs;
  if (options_.force_block >= 1) params.force_block = options_.force_block;
  world_ = std::make_unique<World>(params, templates, silo::BuildGeometry(spec_.silo, wall_height));
  double mean_mass = 0;
  for (int s : species) mean_mass += templates[static_cast<std::size_t>(s)].mass;
  mean_mass /= static_cast<double>(species.size());
  energy_unit_ = mean_mass * spec_.gravity;
  hw_ = spec_.silo.width / 2;
  for (const auto& t : templates)
    for (double r : t.r) r_max_ = std::max(r_max_, r);
  if (snapshot) {
    world_->Restore(*snapshot);
  } else {
    for (int s : species) world_->AddBody(s, 0, 0, 0);
  }
  exits_per_outlet_.assign(world_->Geometry().outlets.size(), 0);
  falling_.assign(static_cast<std::size_t>(world_->BodyCount()), 0);
  const double ed = spec_.discharge.exit_distance;
  world_->SetExitBox(-hw_ - ed, hw_ + ed, -ed);  // the exit lines of OutletOf
  if (!snapshot) world_->OpenOutlets();
}

void Discharge::StartFresh() {
  // A checkpoint of an earlier attempt must never be continued from after this start.
  fs::remove(dir_ / kCheckpointFile);
  fs::remove(dir_ / kPreviousCheckpointFile);
  PlaceBed();
  events_ = rundir::EventWriter::Create(dir_ / rundir::kEventsFile);
  clogs_out_ = rundir::ClogWriter::Create(dir_);
  if (Unclogging()) unclogs_out_ = rundir::UnclogWriter::Create(dir_ / rundir::kUnclogsFile);
  const bool gz = spec_.output.compress;
  if (frame_every_ > 0) frames_ = rundir::FrameWriter::Create(dir_ / rundir::FramesFileName(spec_.output), gz);
  if (frame_every_ > 0 && spec_.output.contact_forces)
    contacts_ = rundir::ContactWriter::Create(dir_ / rundir::ContactsFileName(spec_.output), gz);
  if (frame_every_ > 0) {
    WriteFrame();
    if (ContactsDue()) WriteContacts();
  }
}

void Discharge::PlaceBed() {
  const auto t0 = Clock::now();
  ObtainedBed ob;
  if (spec_.bed.settled_by == BedSettler::kLammps) {
    // Only `start-frame` gets here (validate: only a LAMMPS run settles in LAMMPS): the loose
    // placement LAMMPS settles, neither cached nor prepared.
    ob.bed = LoosePlacement(spec_);
  } else {
    ob = ObtainBed(spec_, dir_.string(), [&](double f, double t) {
      ReportProgress({"bed", f, t, 0, 0, Seconds(t0)}, options_.quiet);
    });
  }
  bed_file_ = ob.file;
  bed_prepared_here_ = ob.prepared_here;
  bed_height_ = ob.bed.height;
  bed_settle_time_ = ob.bed.settle_time;
  bed_wall_s_ = ob.wall_s;
  bed_refused_ = ob.refused;
  // A bed lower than 10 d has no band to measure its packing fraction in (MeasureBed).
  const BedShape shape = MeasureBed(ob.bed, spec_);
  if (shape.phi > 0) bed_phi_ = shape.phi;
  bed_surface_ = shape.surface;
  BuildWorld(ob.bed.species);
  World& w = *world_;
  for (int b = 0; b < w.BodyCount(); ++b)
    w.PlaceBody(b, ob.bed.x[b], ob.bed.y[b], ob.bed.theta[b], ob.bed.vx[b], ob.bed.vy[b], ob.bed.omega[b]);
  // The bed was prepared without obstacles (it is shared by runs that differ only in their
  // outlets or obstacles, docs/model.md): a body an obstacle overlaps is taken out, or the
  // overlap would fire it off at t = 0.
  for (int i = 0; i < w.DiscCount(); ++i) {
    const int b = w.disc_body_[i];
    if (!w.body_active_[b]) continue;
    for (const Obstacle& o : spec_.silo.obstacles) {
      if (std::hypot(w.disc_x_[i] - o.x, w.disc_y_[i] - o.y) < w.disc_radius_[i] + o.diameter / 2) {
        w.Deactivate(b);
        ++cleared_by_obstacles_;
        break;
      }
    }
  }
  // The bed's wall contacts move to the segments of this silo (none over an open gap).
  std::vector<HistoryEntry> walls;
  for (const HistoryEntry& h : ob.bed.wall_history) {
    const int e = silo::SegmentUnder(w.Geometry(), static_cast<silo::Side>(h.j), w.disc_x_[h.i], w.disc_y_[h.i]);
    if (e >= 0) walls.push_back({h.i, e, h.sx, h.sy});
  }
  std::stable_sort(walls.begin(), walls.end(),
                   [](const HistoryEntry& a, const HistoryEntry& b) { return a.i != b.i ? a.i < b.i : a.j < b.j; });
  std::vector<HistoryEntry> pairs;
  for (const HistoryEntry& h : ob.bed.pair_history)
    if (w.body_active_[w.disc_body_[h.i]] && w.body_active_[w.disc_body_[h.j]]) pairs.push_back(h);
  std::erase_if(walls, [&](const HistoryEntry& h) { return !w.body_active_[w.disc_body_[h.i]]; });
  w.ImportHistory(pairs, walls);
  w.ComputeForces();
  if (Periodic()) {
    // The LIGGGHTS backend's box (input_script.cpp): bottom kPeriodicFall below the counting
    // plane, top 2 bounding radii + periodic_headroom above the highest disc centre.
    double top = -1e300, bound = 0;
    for (int i = 0; i < w.DiscCount(); ++i) top = std::max(top, w.disc_y_[i]);
    for (const auto& t : w.Templates()) bound = std::max(bound, t.bound_radius);
    periodic_height_ =
        (top + 2 * bound + spec_.discharge.periodic_headroom) + (spec_.discharge.exit_distance + kPeriodicFall);
  }
}

StartState Discharge::WriteStartFrame(const fs::path& file) {
  PlaceBed();
  rundir::FrameWriter out = rundir::FrameWriter::Create(file);
  FillFrame(frame_buf_);
  out.Write(frame_buf_);
  out.Close();
  return {bed_file_,   bed_prepared_here_, bed_height_,          bed_settle_time_,
          bed_wall_s_, bed_refused_,       cleared_by_obstacles_};
}

void Discharge::WriteCheckpoint() {
  Checkpoint k;
  // Both this run and a run continued from this checkpoint rebuild the lists here.
  k.world = world_->Snapshot();
  k.spec = spec_.ToJson().dump();
  k.state = *this;
  k.discharge_wall = discharge_wall_before_ + Seconds(session_start_);
  k.rng = rng_.Save();
  k.unclog_rng = unclog_rng_.Save();
  k.events_offset = events_.Offset();
  k.frames_offset = frames_.Offset();
  k.contacts_offset = contacts_.Offset();
  k.unclogs_offset = unclogs_out_.Offset();
  Out o;
  Serialize(o, k);
  Out file;
  file.PutStr(kCheckpointMagic);
  file.Put(kCheckpointVersion);
  file.Put<std::uint64_t>(o.Str().size());
  file.Put(Crc32(o.Str()));
  // The last two are kept: a checkpoint found corrupt falls back to the one before.
  if (fs::exists(dir_ / kCheckpointFile)) fs::rename(dir_ / kCheckpointFile, dir_ / kPreviousCheckpointFile);
  WriteAtomically(dir_ / kCheckpointFile, file.Str() + o.Str());
}

// Reads `file` completely before it changes anything: a CheckpointError leaves the run as
// it was, to fall back to another checkpoint or start over.
void Discharge::LoadCheckpoint(const fs::path& file) {
  std::ifstream f(file, std::ios::binary);
  if (!f) throw CheckpointError("cannot read checkpoint " + file.string());
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string name = file.filename().string();
  In header(ss.str(), name);
  std::string magic;
  try {
    magic = header.GetStr();
  } catch (const CheckpointError&) {
  }
  if (magic != kCheckpointMagic) {
    if (magic.rfind(kCheckpointMagic, 0) == 0)
      throw CheckpointError(name + " is format " + magic + ", an older engine's; this engine reads version " +
                            std::to_string(kCheckpointVersion));
    throw CheckpointError(name + " is not a granary checkpoint");
  }
  const auto version = header.Get<std::uint32_t>();
  if (version < kOldestCheckpointVersion || version > kCheckpointVersion)
    throw CheckpointError(name + " has format version " + std::to_string(version) + "; this engine reads versions " +
                          std::to_string(kOldestCheckpointVersion) + " to " + std::to_string(kCheckpointVersion));
  const auto size = header.Get<std::uint64_t>();
  const auto crc = header.Get<std::uint32_t>();
  const std::string payload = header.Rest();
  if (payload.size() != size)
    throw CheckpointError(name + " is truncated or padded: " + std::to_string(payload.size()) +
                          " bytes of payload, the header says " + std::to_string(size));
  if (const std::uint32_t actual = Crc32(payload); actual != crc) {
    char msg[128];
    std::snprintf(msg, sizeof msg, " is corrupt: CRC-32 of its payload is %08x, its header says %08x", actual, crc);
    throw CheckpointError(name + msg);
  }
  In in(payload, name);
  in.SetVersion(version);
  Checkpoint k;
  Serialize(in, k);
  const CheckpointedState& loaded = k.state;
  std::string extended_from;
  if (k.spec != spec_.ToJson().dump()) {
    // A finished run planned again with a larger limit (granary::extends) continues from here.
    const nlohmann::json saved = nlohmann::json::parse(k.spec, nullptr, false);
    if (!granary::Extends(saved, spec_.ToJson()))
      throw std::runtime_error("checkpoint " + file.string() +
                               " belongs to a different run.json; remove it to start over");
    extended_from = saved.value("run_id", std::string("?"));
  }
  if (Unclogging() && k.unclog_rng.empty())
    throw CheckpointError(name + " was written without the unclog protocol's state");
  if (Unclogging()) {
    std::error_code ec;
    const fs::path out = dir_ / rundir::kUnclogsFile;
    const auto have = fs::exists(out) ? fs::file_size(out, ec) : 0;
    if (k.unclogs_offset > 0 && (ec || have < static_cast<std::uintmax_t>(k.unclogs_offset)))
      throw CheckpointError(name + " expects " + std::to_string(k.unclogs_offset) + " bytes of " +
                            rundir::kUnclogsFile + ", the file has " + std::to_string(have));
  }
  if (loaded.step_ > std::llround(spec_.discharge.max_time / spec_.time_step))
    throw CheckpointError(name + " is at step " + std::to_string(loaded.step_) + ", past this run's max_time");
  // The outputs must still hold what the checkpoint saw (truncating a shorter file would pad it).
  const bool gz = spec_.output.compress;
  const char* outputs[3] = {rundir::kEventsFile, rundir::FramesFileName(spec_.output),
                            rundir::ContactsFileName(spec_.output)};
  const std::int64_t offsets[3] = {k.events_offset, k.frames_offset, k.contacts_offset};
  for (int o = 0; o < 3; ++o) {
    const fs::path out = dir_ / outputs[o];
    std::error_code ec;
    const auto have = fs::exists(out) ? fs::file_size(out, ec) : 0;
    if (offsets[o] > 0 && (ec || have < static_cast<std::uintmax_t>(offsets[o])))
      throw CheckpointError(name + " expects " + std::to_string(offsets[o]) + " bytes of " + outputs[o] +
                            ", the file has " + std::to_string(have));
  }
  try {
    BuildWorld(k.world.tmpl, &k.world);
  } catch (const std::invalid_argument& e) {
    throw CheckpointError(name + ": " + e.what());
  }
  if (loaded.exits_per_outlet_.size() != exits_per_outlet_.size() || loaded.falling_.size() != falling_.size())
    throw CheckpointError(name + ": outlet or body count does not match the run");
  static_cast<CheckpointedState&>(*this) = loaded;
  discharge_wall_before_ = k.discharge_wall;
  rng_.Load(k.rng);
  if (Unclogging()) {
    unclog_rng_.Load(k.unclog_rng);
    unclogs_out_ = rundir::UnclogWriter::ContinueAt(dir_ / rundir::kUnclogsFile, k.unclogs_offset);
  }
  events_ = rundir::EventWriter::ContinueAt(dir_ / rundir::kEventsFile, k.events_offset);
  clogs_out_ = rundir::ClogWriter::ContinueAfter(dir_, step_);
  if (frame_every_ > 0)
    frames_ = rundir::FrameWriter::ContinueAt(dir_ / rundir::FramesFileName(spec_.output), k.frames_offset, gz);
  if (frame_every_ > 0 && spec_.output.contact_forces)
    contacts_ = rundir::ContactWriter::ContinueAt(dir_ / rundir::ContactsFileName(spec_.output), k.contacts_offset, gz);
  continued_ = true;
  extended_from_ = extended_from;
}

// The newest usable checkpoint, else the one before; a refused one is kept aside as
// <name>.corrupt and named in stderr and summary.json. False: start over.
bool Discharge::ContinueFromACheckpoint() {
  for (const char* name : {kCheckpointFile, kPreviousCheckpointFile}) {
    const fs::path file = dir_ / name;
    if (!fs::exists(file)) continue;
    try {
      LoadCheckpoint(file);
      if (!refused_checkpoints_.empty())
        std::fprintf(stderr, "granary-engine: continuing from the previous checkpoint (%s)\n", name);
      return true;
    } catch (const CheckpointError& e) {
      refused_checkpoints_.push_back(e.what());
      std::fprintf(stderr, "granary-engine: refusing checkpoint: %s\n", e.what());
      fs::rename(file, file.string() + ".corrupt");
      world_.reset();
    }
  }
  if (!refused_checkpoints_.empty())
    std::fprintf(stderr, "granary-engine: no usable checkpoint; starting the run over\n");
  return false;
}

int Discharge::OutletOf(int b) const {
  const World& w = *world_;
  const double x = w.body_x_[b], y = w.body_y_[b];
  const double ed = spec_.discharge.exit_distance;
  if (!(y < -ed || x > hw_ + ed || x < -hw_ - ed)) return -1;
  const auto& outlets = w.Geometry().outlets;
  int best = 0;
  double best_d = 1e300;
  for (std::size_t k = 0; k < outlets.size(); ++k) {
    const double dd = std::hypot(x - outlets[k].cx, y - outlets[k].cy);
    if (dd < best_d) {
      best_d = dd;
      best = static_cast<int>(k);
    }
  }
  return best;
}

void Discharge::Reinject(int b) {
  World& w = *world_;
  const silo::ShapeTemplate& tp = w.Templates()[static_cast<std::size_t>(w.body_template_[b])];
  const double rb = tp.bound_radius;
  // On top of the bed: a column whose top is a return still falling (no contact, or faster
  // than a body that has fallen its own size) is drawn again, up to kReinjectDraws times. Put
  // on such a body, it would be followed by the next return in its column before it lands, and
  // the returns would stack up into a rain while the bed drains.
  constexpr int kReinjectDraws = 16;
  const double falling_speed = std::sqrt(2 * spec_.gravity * 2 * rb);
  double x = 0;
  Landing at{};
  for (int draw = 0; draw < kReinjectDraws; ++draw) {
    x = rng_.Uniform(-hw_ + rb, hw_ - rb);
    at = LandingOn(b, x);
    if (at.on_body < 0 || (in_contact_[static_cast<std::size_t>(at.on_body)] && at.vy > -falling_speed)) break;
  }
  const double th = rng_.Uniform(0.0, 2.0 * std::numbers::pi);
  // It moves down at least as fast as what it lands on, so it does not fall behind a sinking
  // surface either.
  w.PlaceBody(b, x, at.y, th, 0.0, std::min(-spec_.discharge.reinject_speed, at.vy), 0.0);
}

// Where body b, put at x, overlaps nothing below it: above every disc of the column that
// could touch it (bodies still falling out of the silo do not count), the body that disc
// belongs to and its vertical velocity (-1 and 0 on an empty column).
Discharge::Landing Discharge::LandingOn(int b, double x) const {
  const World& w = *world_;
  const double rb = w.Templates()[static_cast<std::size_t>(w.body_template_[b])].bound_radius;
  double top = 0.0, vy = 0.0;
  int on = -1;
  for (int i = 0; i < w.DiscCount(); ++i) {
    const int ob = w.disc_body_[i];
    if (ob == b || !w.body_active_[ob] || falling_[ob]) continue;
    if (std::fabs(w.disc_x_[i] - x) < rb + w.disc_radius_[i] && w.disc_y_[i] + w.disc_radius_[i] > top) {
      top = w.disc_y_[i] + w.disc_radius_[i];
      vy = w.body_vy_[ob];
      on = ob;
    }
  }
  return {top + rb + 0.05, vy, on};
}

void Discharge::HandleExits() {
  World& w = *world_;
  // In most steps nothing exits: the step's drift has checked the exit lines (falling bodies
  // jump back below them too), and then a straight pass (it vectorizes) with the tests of
  // the loop below says whether any body needs it.
  if (!w.BeyondExitBox()) return;
  const double ed = spec_.discharge.exit_distance, fall_y = -(ed + kPeriodicFall);
  int any = 0;
  for (int b = 0; b < w.BodyCount(); ++b) {
    const double x = w.body_x_[b], y = w.body_y_[b];
    const bool falling = falling_[b] != 0, beyond = (y < -ed) | (x > hw_ + ed) | (x < -hw_ - ed);
    any |= (w.body_active_[b] != 0) & ((falling & (y < fall_y)) | (!falling & beyond));
  }
  if (!any) return;
  const double t = static_cast<double>(step_) * spec_.time_step;
  bool contacts_marked = false;
  for (int b = 0; b < w.BodyCount(); ++b) {
    if (!w.body_active_[b]) continue;
    if (falling_[b]) {
      // Counted already; through the bottom of the periodic box it comes back at the top,
      // at the same x and with its velocity.
      if (w.body_y_[b] < -(spec_.discharge.exit_distance + kPeriodicFall)) {
        // Where a heap has grown above the box top (returns pile up over the outlet), the
        // body lands on it instead: LIGGGHTS resolves that overlap through the periodic
        // boundary, this engine has no images across it.
        const double x = w.body_x_[b];
        const double y = std::max(w.body_y_[b] + periodic_height_, LandingOn(b, x).y);
        w.PlaceBody(b, x, y, w.body_angle_[b], w.body_vx_[b], w.body_vy_[b], w.body_spin_[b]);
        falling_[b] = 0;
      }
      continue;
    }
    const int k = OutletOf(b);
    if (k < 0) continue;
    const silo::ShapeTemplate& tp = w.Templates()[static_cast<std::size_t>(w.body_template_[b])];
    events_.Write({t, b, tp.name, tp.mass, k});
    ++exits_per_outlet_[static_cast<std::size_t>(k)];
    last_exit_step_ = step_;
    if (in_clog_ && unclog_attempts_ > 0) ++unclogged_;  // the flow resumed after an attempt
    unclog_attempts_ = 0;
    in_clog_ = false;
    if (Periodic()) {
      falling_[b] = 1;
    } else if (spec_.discharge.mode == DischargeMode::kReinject) {
      // Placing a body moves no force of the last pass, so one marking serves every return.
      if (!contacts_marked) w.MarkBodiesInContact(in_contact_);
      contacts_marked = true;
      Reinject(b);
    } else {
      w.Deactivate(b);
    }
  }
}

// No exit for clog_window and kinetic energy per body near the outlets below the threshold.
// "Near" an outlet of width W: within W along it and up to 2W into the silo (docs/engine.md).
// Bodies alone on the floor (stall_world.h) moving only along it, and not about to roll out of
// an outlet within clog_window, are left out: they are the stagnant remainder of a drained
// floor, not a flow. They are looked for only when the bodies near the outlets as a whole are
// not at rest, so a stall judged before is judged at the same step.
bool Discharge::Stalled() {
  const World& w = *world_;
  const double threshold = spec_.discharge.clog_ke_per_body;
  auto near_outlet = [&](int b) {
    for (const silo::OutletFrame& o : w.Geometry().outlets) {
      const double px = w.body_x_[b] - o.cx, py = w.body_y_[b] - o.cy;
      const double s = px * o.ax + py * o.ay, h = px * o.nx + py * o.ny;
      if (std::fabs(s) < o.width && h > -spec_.discharge.exit_distance && h < 2 * o.width) return true;
    }
    return false;
  };
  auto energy = [&](int b) {
    return 0.5 * w.body_mass_[b] * (w.body_vx_[b] * w.body_vx_[b] + w.body_vy_[b] * w.body_vy_[b]) +
           0.5 * w.body_inertia_[b] * w.body_spin_[b] * w.body_spin_[b];
  };
  double ke = 0;
  int n = 0;
  for (int b = 0; b < w.BodyCount(); ++b) {
    if (!w.body_active_[b] || !near_outlet(b)) continue;
    ke += energy(b);
    ++n;
  }
  if (n == 0 || ke / n / energy_unit_ < threshold) return true;
  MarkBodiesAloneOnTheFloor(w, contact_buf_, alone_on_floor_);
  ke = 0;
  n = 0;
  for (int b = 0; b < w.BodyCount(); ++b) {
    if (!w.body_active_[b] || !near_outlet(b)) continue;
    if (alone_on_floor_[static_cast<std::size_t>(b)] &&
        0.5 * w.body_mass_[b] * w.body_vy_[b] * w.body_vy_[b] / energy_unit_ < threshold && !RollsOutSoon(b))
      continue;
    ke += energy(b);
    ++n;
  }
  return n == 0 || ke / n / energy_unit_ < threshold;
}

// Whether body b, moving along the floor at its present speed, reaches the floor-level end of
// an outlet within clog_window: then it is still leaving, as a body of the flow would.
bool Discharge::RollsOutSoon(int b) const {
  const World& w = *world_;
  const double vx = w.body_vx_[b];
  for (const silo::OutletFrame& o : w.Geometry().outlets) {
    for (const double end : {-0.5, 0.5}) {
      const double ex = o.cx + end * o.width * o.ax, ey = o.cy + end * o.width * o.ay;
      if (ey != 0.0) continue;  // not at the floor's height
      const double gap = ex - w.body_x_[b];
      if (gap * vx > 0 && std::fabs(gap) < std::fabs(vx) * spec_.discharge.clog_window) return true;
    }
  }
  return false;
}

// A stall is a clog when an arch seals an outlet from the material above it, whether the arch
// spans the opening or the passages beside an obstacle; otherwise the silo has discharged what
// can flow out (stall.h).
bool Discharge::StallIsAClog() const {
  const std::vector<bool> sealed = SealedOutlets(*world_);
  return std::find(sealed.begin(), sealed.end(), true) != sealed.end();
}

std::vector<std::int64_t> Discharge::ArchBodies() {
  const World& w = *world_;
  rundir::ClogState clog;
  FillFrame(clog.frame);
  FillContacts(clog.contacts);
  std::vector<std::int64_t> ids;
  for (const analysis::Arch& arch : analysis::AnalyseClog(clog, w.Geometry()).arches)
    for (const analysis::ArchBody& b : arch.bodies) ids.push_back(b.id);
  if (ids.empty()) {
    // Sealed, but no chain of bodies from support to support (an arch resting on bodies the
    // probe does not reach): the bodies along the edge of the free space under the outlets.
    const SiloDiscs s = DiscsInSilo(w);
    const double probe = silo::PassageProbe(s.discs, s.body_of);
    for (int o = 0; o < static_cast<int>(w.Geometry().outlets.size()); ++o)
      for (const silo::CavityBound& e : silo::CavityUnder(w.Geometry(), s.discs, probe, o).edge)
        if (e.kind == silo::CavityBound::Kind::kDisc) ids.push_back(s.body_of[static_cast<std::size_t>(e.index)]);
  }
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

// remove_arch: the arch's bodies go back on top (reinject mode) or out of the silo (remove
// mode; they are not exits); when there is no arch to take out, the fallback (a kick, or
// nothing). The row of unclogs.csv names what was done: a fallback kick is a "kick" row.
void Discharge::Unclog(const std::vector<std::int64_t>* arch) {
  World& w = *world_;
  const granary::Unclog& u = spec_.discharge.unclog;
  ++unclog_attempts_;
  last_unclog_step_ = step_;
  rundir::UnclogEvent e;
  e.time = static_cast<double>(step_) * spec_.time_step;
  e.step = step_;
  e.clog = clogs_;
  e.attempt = unclog_attempts_;
  e.method = ToString(u.method);
  if (u.method == UnclogMethod::kRemoveArch) {
    e.bodies = arch != nullptr ? *arch : ArchBodies();
    if (e.bodies.empty() && u.fallback == UnclogFallback::kKick) {
      e.method = ToString(UnclogMethod::kKick);
      Kick(e.bodies);
    } else if (spec_.discharge.mode == DischargeMode::kReinject) {
      w.MarkBodiesInContact(in_contact_);
      for (std::int64_t b : e.bodies) Reinject(static_cast<int>(b));
    } else {
      for (std::int64_t b : e.bodies) w.Deactivate(static_cast<int>(b));
      unclog_removed_ += static_cast<int>(e.bodies.size());
    }
  } else {
    Kick(e.bodies);
  }
  unclogs_out_.Write(e);
}

// Every body whose centre is within kick_radius of an outlet's centre gets kick_speed in a
// direction drawn uniformly within 45 degrees of the upward vertical, in body order (the same
// numbers at any thread count); their ids appended to `kicked`.
void Discharge::Kick(std::vector<std::int64_t>& kicked) {
  World& w = *world_;
  const granary::Unclog& u = spec_.discharge.unclog;
  for (int b = 0; b < w.BodyCount(); ++b) {
    if (!w.body_active_[b]) continue;
    for (const silo::OutletFrame& o : w.Geometry().outlets) {
      const double radius = u.kick_radius > 0 ? u.kick_radius : o.width;
      if (std::hypot(w.body_x_[b] - o.cx, w.body_y_[b] - o.cy) > radius) continue;
      const double angle = unclog_rng_.Uniform(-0.25 * std::numbers::pi, 0.25 * std::numbers::pi);
      w.SetVelocity(b, u.kick_speed * std::sin(angle), u.kick_speed * std::cos(angle), w.body_spin_[b]);
      kicked.push_back(b);
      break;
    }
  }
}

// From the bed and the spec alone, so a continued run writes the same box.
void Discharge::DumpBox(double (&box)[3][2]) const {
  double bound = 0;
  for (const auto& t : world_->Templates()) bound = std::max(bound, t.bound_radius);
  NativeDumpBox(spec_, bed_height_, bound, box);
}

void Discharge::FillFrame(rundir::Frame& f) {
  const World& w = *world_;
  f.timestep = step_;
  f.time = static_cast<double>(step_) * spec_.time_step;
  DumpBox(f.box);
  f.discs.clear();
  for (int i = 0; i < w.DiscCount(); ++i) {
    const int b = w.disc_body_[i];
    if (!w.body_active_[b]) continue;
    // The disc centre moves with the rigid body: v + omega x r.
    const double rx = w.disc_x_[i] - w.body_x_[b], ry = w.disc_y_[i] - w.body_y_[b];
    f.discs.push_back({i + 1, b, w.body_template_[b] + 1, w.disc_x_[i], w.disc_y_[i], w.disc_radius_[i],
                       w.disc_mass_[i], w.body_vx_[b] - w.body_spin_[b] * ry, w.body_vy_[b] + w.body_spin_[b] * rx,
                       w.body_spin_[b]});
    // LAMMPS drops an atom outside a fixed box: never silently.
    const bool outside = w.disc_x_[i] < f.box[0][0] || w.disc_x_[i] > f.box[0][1] || w.disc_y_[i] < f.box[1][0] ||
                         w.disc_y_[i] > f.box[1][1];
    if (outside && !warned_outside_box_) {
      std::fprintf(stderr,
                   "warning: the frame at t = %.6g has disc %d at (%.6g, %.6g), outside the dump box "
                   "[%.6g, %.6g] x [%.6g, %.6g]; LAMMPS drops such atoms\n",
                   f.time, i + 1, w.disc_x_[i], w.disc_y_[i], f.box[0][0], f.box[0][1], f.box[1][0], f.box[1][1]);
      warned_outside_box_ = true;
    }
  }
}

void Discharge::WriteFrame() {
  FillFrame(frame_buf_);
  frames_.Write(frame_buf_);
}

void Discharge::FillContacts(rundir::ContactFrame& f) {
  const World& w = *world_;
  w.CollectContacts(contact_buf_);
  f.timestep = step_;
  f.time = static_cast<double>(step_) * spec_.time_step;
  DumpBox(f.box);
  f.contacts.clear();
  for (const auto& c : contact_buf_) {
    const int bj = c.disc_j >= 0 ? w.disc_body_[c.disc_j] : -1;
    const double xj = c.disc_j >= 0 ? w.disc_x_[c.disc_j] : c.cx, yj = c.disc_j >= 0 ? w.disc_y_[c.disc_j] : c.cy;
    f.contacts.push_back(
        {w.disc_body_[c.disc_i], bj, w.disc_x_[c.disc_i], w.disc_y_[c.disc_i], xj, yj, c.cx, c.cy, c.fx, c.fy});
  }
}

void Discharge::WriteContacts() {
  FillContacts(contact_frame_buf_);
  contacts_.Write(contact_frame_buf_);
}

void Discharge::WriteClog() {
  rundir::ClogState clog;
  FillFrame(clog.frame);
  FillContacts(clog.contacts);
  clogs_out_.Write(clog);
}

void Discharge::WriteSummary(const std::string& end_reason) {
  const World& w = *world_;
  std::int64_t exited = 0;
  for (auto e : exits_per_outlet_) exited += e;
  const double discharge_wall = discharge_wall_before_ + Seconds(session_start_);
  rundir::Summary s;
  s.engine = "native";
  s.engine_version = GRANARY_VERSION;
  s.granary_commit = granary::GitCommit();
  s.run_id = spec_.run_id;
  s.spec = spec_.ToJson();
  s.end_reason = end_reason;
  s.bodies = w.BodyCount() - cleared_by_obstacles_;  // in the silo at t = 0
  if (!spec_.silo.obstacles.empty()) s.cleared_by_obstacles = cleared_by_obstacles_;
  s.exited = static_cast<int>(exited);
  s.remaining = w.ActiveCount();
  for (auto e : exits_per_outlet_) s.exits_per_outlet.push_back(static_cast<int>(e));
  s.t_end = static_cast<double>(step_) * spec_.time_step;
  s.steps = step_;
  s.clogs = clogs_;
  if (Unclogging()) {
    s.unclogs = unclogged_;
    if (spec_.discharge.mode == DischargeMode::kRemove) s.unclog_removed = unclog_removed_;
  }
  s.bed = {bed_file_, bed_height_, bed_prepared_here_, bed_settle_time_, bed_refused_, {}, {}};
  if (std::isfinite(bed_phi_)) s.bed.packing_fraction = bed_phi_;
  if (std::isfinite(bed_surface_)) s.bed.surface = bed_surface_;
  s.timing = rundir::Timing{
      bed_wall_s_ + discharge_wall,
      bed_wall_s_,
      discharge_wall,
      discharge_wall > 0 ? static_cast<double>(disc_steps_) / discharge_wall : 0.0,
      omp_get_max_threads(),
      discharge_wall > 0 ? static_cast<double>(w.DiscCount()) * static_cast<double>(step_) / discharge_wall : 0.0};
  s.continued_from_checkpoint = continued_;
  s.extended_from = extended_from_;
  s.refused_checkpoints = refused_checkpoints_;
  rundir::WriteSummary(dir_, s);
}

RunResult Discharge::Run() {
  session_start_ = Clock::now();
  const double dt = spec_.time_step;
  frame_every_ =
      spec_.output.frame_interval > 0 ? std::max<std::int64_t>(1, std::llround(spec_.output.frame_interval / dt)) : 0;
  checkpoint_every_ = spec_.output.checkpoint_interval > 0
                          ? std::max<std::int64_t>(1, std::llround(spec_.output.checkpoint_interval / dt))
                          : 0;
  const std::int64_t max_steps = std::llround(spec_.discharge.max_time / dt);
  const std::int64_t clog_steps = std::llround(spec_.discharge.clog_window / dt);
  if (!ContinueFromACheckpoint()) {
    StartFresh();
    session_start_ = Clock::now();
  }
  {
    // The geometry beside the frames, walls as high as the frames' box when the spec leaves them
    // automatic.
    double box[3][2];
    DumpBox(box);
    WriteAtomically(dir_ / rundir::kSiloFile,
                    silo::SiloVtk(silo::OutlineOf(spec_.silo, spec_.silo.height > 0 ? spec_.silo.height : box[1][1])));
  }
  World& w = *world_;
  std::string end_reason;
  if (continued_ && Unclogging() && in_clog_ && unclog_attempts_ == 0) {
    // Continued from the checkpoint of a run that ended at max_clogs (only that leaves a clog
    // of an unclogging run without an attempt): what this step does with the limit now — unclog
    // (a larger max_clogs) or end again — then the frame of this step, which the checkpoint was
    // written before, so the outputs are those of a run that never stopped here.
    if (clogs_ >= spec_.discharge.unclog.max_clogs)
      end_reason = "max_clogs";
    else
      Unclog(clog_arch_.empty() ? nullptr : &clog_arch_);
    if (frame_every_ > 0 && step_ % frame_every_ == 0) {
      WriteFrame();
      if (ContactsDue()) WriteContacts();
    }
  }
  auto last_report = Clock::now();
  const std::int64_t first_step = step_;
  g_stop_accepted = 1;  // from here a stop request is honoured with a checkpoint
  struct Unaccept {
    ~Unaccept() { g_stop_accepted = 0; }
  } unaccept;
  while (end_reason.empty()) {
    if (step_ >= max_steps) {
      end_reason = "time_limit";
      break;
    }
    if (w.ActiveCount() == 0) {
      end_reason = "discharged";
      break;
    }
    // Up to the next step at which the checks below may act (clog checks and progress every
    // kClogCheckEvery steps, frames, checkpoints, limits); Steps returns early at a step
    // where a body leaves, so each check sees the step it saw with one step at a time.
    std::int64_t n = std::min(max_steps - step_, kClogCheckEvery - step_ % kClogCheckEvery);
    for (const std::int64_t every : {frame_every_, checkpoint_every_})
      if (every > 0) n = std::min(n, every - step_ % every);
    for (const std::int64_t after : {options_.stop_after_steps, options_.abort_after_steps})
      if (after >= 0) n = std::min(n, std::max<std::int64_t>(1, first_step + after - step_));
    // The discs these steps compute: bodies leave only at the last of them (Steps returns there).
    const int discs = w.ActiveDiscCount();
    const int taken = w.Steps(static_cast<int>(n));
    step_ += taken;
    disc_steps_ += static_cast<std::int64_t>(taken) * discs;
    HandleExits();
    // A clog is a stall after an exit; after an unclog attempt that no body has left since,
    // a stall is that clog again: another attempt, not another clog.
    const std::int64_t quiet_from = std::max(last_exit_step_, last_unclog_step_);
    if (step_ - quiet_from >= clog_steps && step_ % kClogCheckEvery == 0 && (!in_clog_ || unclog_attempts_ > 0) &&
        Stalled()) {
      if (spec_.discharge.mode == DischargeMode::kRemove && !StallIsAClog()) {
        end_reason = "discharged";
      } else if (!in_clog_) {
        ++clogs_;
        in_clog_ = true;  // counted once until the next exit
        WriteClog();
        if (spec_.discharge.on_clog == OnClog::kStop) end_reason = "clogged";
        if (Unclogging()) {
          // The lists rebuilt at every clog, as the last checkpoint below rebuilds them: then a run
          // continued from a smaller max_clogs and a run planned with the larger one have
          // rebuilt at the same steps, and give the same bits. The arch is found before: a
          // rebuild clears the contact forces it is found from.
          clog_arch_.clear();
          if (spec_.discharge.unclog.method == UnclogMethod::kRemoveArch) clog_arch_ = ArchBodies();
          world_->RebuildNow();
          if (clogs_ >= spec_.discharge.unclog.max_clogs) {
            end_reason = "max_clogs";
            // A last checkpoint, before this step's frame: the run planned again with a larger
            // max_clogs (granary::extends) continues from here and unclogs this clog as a run
            // planned with that limit does at this step (below, after the continue).
            WriteCheckpoint();
          } else {
            Unclog(&clog_arch_);
          }
        }
      } else if (unclog_attempts_ >= spec_.discharge.unclog.max_attempts) {
        end_reason = "clogged";  // the protocol could not break it
      } else {
        Unclog();
      }
    }
    if (frame_every_ > 0 && step_ % frame_every_ == 0) {
      WriteFrame();
      if (ContactsDue()) WriteContacts();
    }
    if (checkpoint_every_ > 0 && step_ % checkpoint_every_ == 0 && end_reason.empty()) WriteCheckpoint();
    if (options_.stop_after_steps >= 0 && step_ - first_step >= options_.stop_after_steps) g_stop_signal = SIGTERM;
    if (g_stop_signal != 0 && end_reason.empty()) {
      // Stopped on request: checkpoint here, then end (a continued run gives the same bits).
      WriteCheckpoint();
      g_stop_accepted = 0;
      const int signal = g_stop_signal;
      g_stop_signal = 0;
      char at[96];
      std::snprintf(at, sizeof at, " at t = %.6g (step %lld); checkpoint written", static_cast<double>(step_) * dt,
                    static_cast<long long>(step_));
      throw Stopped(signal, "stopped by " + SignalName(signal) + at);
    }
    if (options_.abort_after_steps >= 0 && step_ - first_step >= options_.abort_after_steps) {
      RunResult r;
      r.end_reason = "aborted";
      r.steps = step_;
      r.continued = continued_;
      return r;
    }
    if (step_ % 200 == 0 && Seconds(last_report) >= options_.progress_every_s) {
      last_report = Clock::now();
      std::int64_t exited = 0;
      for (auto e : exits_per_outlet_) exited += e;
      ReportProgress(
          {"discharge", static_cast<double>(step_) / static_cast<double>(std::max<std::int64_t>(1, max_steps)),
           static_cast<double>(step_) * dt, spec_.discharge.max_time, static_cast<int>(exited),
           discharge_wall_before_ + Seconds(session_start_)},
          options_.quiet);
    }
  }
  g_stop_accepted = 0;  // the outputs are being finished: a stop now ends the run at once
  std::int64_t exited = 0;
  for (auto e : exits_per_outlet_) exited += e;
  events_.Close();
  frames_.Close();
  contacts_.Close();
  clogs_out_.Close();
  unclogs_out_.Close();
  ReportProgress({"discharge", 1.0, static_cast<double>(step_) * dt, spec_.discharge.max_time, static_cast<int>(exited),
                  discharge_wall_before_ + Seconds(session_start_)},
                 true);
  WriteSummary(end_reason);
  rundir::WriteDone(dir_, end_reason);
  RunResult r;
  r.end_reason = end_reason;
  r.exited = static_cast<int>(exited);
  r.steps = step_;
  r.t_end = static_cast<double>(step_) * dt;
  r.continued = continued_;
  return r;
}

RunResult RunDirectory(const std::string& dir, const RunOptions& options) {
  if (options.threads > 0) omp_set_num_threads(options.threads);
  const fs::path d(dir);
  // One writer per directory: before anything in it is read or touched.
  const RunDirectoryLock lock(d);
  const RunSpec spec = rundir::ReadRunSpec(d);
  if (spec.engine != "native")
    throw std::runtime_error((d / rundir::kRunSpecFile).string() + ": engine is \"" + spec.engine +
                             "\", not \"native\"");
  fs::remove(d / rundir::kDoneFile);
  Discharge discharge(spec, d, options);
  return discharge.Run();
}

StartState WriteStartFrame(const std::string& dir, const std::string& file, const RunOptions& options) {
  if (options.threads > 0) omp_set_num_threads(options.threads);
  const RunSpec spec = rundir::ReadRunSpec(fs::path(dir));
  Discharge discharge(spec, fs::path(dir), options);
  return discharge.WriteStartFrame(file);
}

void InstallStopHandlers() {
  struct sigaction sa {};
  sa.sa_handler = EngineOnStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
}

}  // namespace granary::engine
