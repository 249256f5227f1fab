// The resolved specification of one run: the contract between the campaign runner,
// the native engine and the LIGGGHTS backend. The runner expands a campaign into
// RunSpecs and writes each as `run.json` into the run's directory; an engine reads it.
// JSON layout, defaults and allowed values: docs/run-spec.md. Physics: docs/model.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "rundir/spec_table.h"

namespace granary {

// A spec error names the JSON path (JSON Pointer, e.g. "/silo/base_outlets/0/width"),
// the bad value and what is allowed. `what()` is "PATH: MESSAGE".
class SpecError : public std::runtime_error {
 public:
  SpecError(std::string path, std::string message);
  const std::string& Path() const { return path_; }
  const std::string& Message() const { return message_; }

 private:
  std::string path_;
  std::string message_;
};

enum class Shape { kDisc, kDumbbell, kSnowman, kRod };

// One kind of body in the mixture. Every body is a rigid clump of discs (docs/model.md).
struct Species {
  std::string name;  // label in events and dumps; default: "disc", "dumbbell", "snowman", "rod<n>"
  Shape shape = Shape::kDumbbell;
  double fraction = 1.0;      // number fraction among all bodies (fractions must sum to 1)
  double diameter = 1.0;      // disc: D; dumbbell: d; snowman: D_s (small disc); rod: each disc
  double big_diameter = 1.0;  // snowman only: D_b (D_b/D_s in [1, 2])
  int n = 2;                  // rod only: number of touching discs in a line
};

struct Bodies {
  int count = 1000;              // total number of bodies in the bed
  std::vector<Species> species;  // default: one species of dumbbells
  double density = 1.0;          // areal density rho: disc mass = rho * pi * r^2
};

struct BaseOutlet {
  double center = 0.0;  // x of the outlet centre (base at y = 0)
  double width = 10.0;  // W
};

enum class Wall { kLeft, kRight };

struct SideOutlet {
  Wall wall = Wall::kRight;
  double bottom = 3.5;  // height of the outlet's lower edge above the base
  double width = 25.0;
};

struct Obstacle {
  double x = 0.0;  // centre (silo coordinates: origin at the centre of the base)
  double y = 10.0;
  double diameter = 6.0;
};

struct Silo {
  double width = 100.0;                  // side walls at x = +-width/2
  double height = 0.0;                   // side-wall height; 0 = automatic (tall enough for the bed)
  std::vector<BaseOutlet> base_outlets;  // default: one outlet of width 10 at x = 0
  std::vector<SideOutlet> side_outlets;
  std::vector<Obstacle> obstacles;
};

// LAMMPS caps spring + damping at mu|F_n|; LIGGGHTS 3.8 caps only the spring part.
enum class TangentialCap { kLammps, kLiggghts };
// The normal-force model (docs/model.md "Contact law"): Hertz F_n ~ delta^1.5 (LAMMPS
// gran/hertz/history) or a linear spring-dashpot (LAMMPS gran/hooke/history).
enum class NormalModel { kHertz, kHooke };

struct Contact {
  double kn = 2.0e6;
  double kt = 2.45e6;
  double gamma_n = 1000.0;
  double gamma_t = 1000.0;
  double mu = 0.5;       // body-body friction
  double mu_wall = 0.5;  // body-wall and body-obstacle friction (defaults to mu)
  NormalModel normal_model = NormalModel::kHertz;
  TangentialCap tangential_cap = TangentialCap::kLammps;
  bool clip_normal = false;  // clip attractive F_n to zero (off: LAMMPS default)
};

// When the native bed preparation places the next batch: once the previous one has landed
// (its kinetic energy per body has risen above and fallen back below kBedLandedKePerBody, at
// most the fixed wait), or after the fixed wait sqrt(2 h / g) + 1 for a batch region of height h.
enum class NextBatch { kLanded, kFixed };
// Who settles a LAMMPS run's bed (docs/lammps.md "The bed"): the native engine (the bed a
// native run of the same seed discharges, cached) or LAMMPS itself, from a loose placement.
enum class BedSettler { kNative, kLammps };

struct Bed {
  int batch_size = 500;              // bodies inserted per batch
  double settle_ke_per_body = 1e-6;  // settled when kinetic energy per body (units m g d) is below this
  double max_settle_time = 200.0;    // give up settling after this much simulated time
  // Time step of the native engine's bed preparation; 0 = kBedTimeStepFactor x time_step
  // (BedTimeStep()). A bed at rest does not depend on it; docs/engine.md says why 8x is safe.
  double time_step = 0.0;
  NextBatch next_batch = NextBatch::kLanded;    // native engine only
  BedSettler settled_by = BedSettler::kNative;  // LAMMPS backend only: who settles its bed
  std::string cache_file;  // resolved by the runner: where the prepared bed is (or is to be) stored;
                           // empty = prepare inside the run directory (bed.json)
};

enum class DischargeMode { kRemove, kReinject };
// Where a reinjected body comes back: at a random free place on top of the bed (the thesis),
// or through a periodic boundary in y, at the same x with its velocity (LIGGGHTS' way).
enum class ReinjectPosition { kRandom, kPeriodic };
// The periodic box of ReinjectPosition::kPeriodic, the same in both engines: from
// kPeriodicFall below the counting plane up to `periodic_headroom` + 2 bounding radii above the
// highest disc centre of the bed at t = 0.
constexpr double kPeriodicFall = 3.0;

// What the engine does at a clog (docs/run-spec.md): stop the run; wait for the flow to
// resume by itself until max_time; or break the arch (Unclog) and go on.
enum class OnClog { kStop, kWait, kUnclog };
// How a clog is broken: the bodies of the arch that seals the outlet are taken out (the arch
// analysis' judgement), or the bodies near the outlet get a random upward velocity (a blow).
enum class UnclogMethod { kRemoveArch, kKick };
// What remove_arch does when it finds no arch to take out (a stall whose outlet no arch seals,
// e.g. bodies hanging into the opening from its edge onto a body below): nothing (the attempt
// removes nothing, and after max_attempts such attempts the run ends clogged), or a kick.
enum class UnclogFallback { kNone, kKick };

struct Unclog {
  UnclogMethod method = UnclogMethod::kRemoveArch;
  int max_clogs = 100;       // the run ends at this clog, which it does not break
  int max_attempts = 10;     // attempts on one clog before the run ends clogged
  double kick_speed = 1.0;   // kick: speed given to each body, in sqrt(g d)
  double kick_radius = 0.0;  // kick: bodies whose centre is within this of an outlet's centre; 0 = its width
  UnclogFallback fallback = UnclogFallback::kNone;  // remove_arch only
};

struct Discharge {
  DischargeMode mode = DischargeMode::kRemove;
  double max_time = 100.0;         // stop at this simulated time after opening
  OnClog on_clog = OnClog::kStop;  // the JSON's stop_on_clog true/false is kStop/kWait
  Unclog unclog;                   // OnClog::kUnclog only
  bool StopOnClog() const { return on_clog == OnClog::kStop; }
  double clog_window = 5.0;        // a clog: no exit through any outlet for this long ...
  double clog_ke_per_body = 1e-4;  // ... and kinetic energy per body near the outlets below this
  double reinject_speed = 0.0;     // reinject mode: speed (downwards) given to a reinjected body
  ReinjectPosition reinject_position = ReinjectPosition::kRandom;
  double periodic_headroom = 1.0;  // periodic box: room above the bed (LIGGGHTS' reinjection)
  double exit_distance = 2.0;      // a body has left when its centre is this far past the outlet plane
};

// How frames and contact frames are written: LAMMPS text dumps (frames.dump, contacts.dump,
// gzipped with output.compress) or GSD (frames.gsd, contacts.gsd; docs/run-directory.md).
enum class FrameFormat { kText, kGsd };

struct Output {
  double frame_interval = 0.0;  // simulated time between frames (0 = no frames)
  bool contact_forces = false;  // also write contact-force frames at frame_interval
  int contact_interval = 1;     // ... at every contact_interval-th frame only
  bool compress = false;        // frames.dump.gz, contacts.dump.gz instead of frames.dump, contacts.dump
  FrameFormat format = FrameFormat::kText;
  double checkpoint_interval = 10.0;  // simulated time between checkpoints (0 = none)
};

// The native bed preparation's default step, in run time steps (Bed::time_step = 0).
inline constexpr double kBedTimeStepFactor = 8.0;
// NextBatch::kLanded: a batch has landed when its kinetic energy per body, having risen above
// this, is again below it (units: the mean body's m g d). Falling, a batch of the bench bed
// carries 4-9 m g d per body; landed, below 0.1 (the few bodies its impact throws up).
inline constexpr double kBedLandedKePerBody = 0.25;

struct RunSpec {
  std::string run_id;             // stable id set by the runner (hash of the resolved parameters)
  std::uint64_t seed = 1;         // bed and reinjection randomness
  std::string engine = "native";  // "native", "liggghts" or "lammps"
  double time_step = 1e-4;
  double gravity = 1.0;
  Silo silo;
  Bodies bodies;
  Contact contact;
  Bed bed;
  Discharge discharge;
  Output output;

  // Parse and validate completely; throws SpecError naming the JSON path.
  // Missing keys take the defaults above; unknown keys are errors with the nearest valid key.
  static RunSpec FromJson(const nlohmann::json& j);
  // Canonical JSON with every default filled in (sorted keys, as nlohmann::json stores them).
  nlohmann::json ToJson() const;
  // The JSON of everything that determines the prepared bed (bodies, silo width, bed procedure,
  // contact, time step, gravity, seed) but not the outlets or obstacles; hash it to name a cached bed.
  nlohmann::json BedKey() const;
  // The native engine's bed-preparation time step: bed.time_step, or kBedTimeStepFactor x
  // time_step when that is 0.
  double BedTimeStep() const { return bed.time_step > 0 ? bed.time_step : kBedTimeStepFactor * time_step; }
};

// Semantic checks beyond types (geometry fits, fractions sum to 1, ...); from_json calls it.
void Validate(const RunSpec& spec);
// What the LIGGGHTS backend cannot do (Validate() applies it to specs whose engine is
// "liggghts"; the backend applies it to whatever spec it is given).
void ValidateForLiggghts(const RunSpec& spec);
// What the LAMMPS backend cannot do (applied like validate_for_liggghts, docs/lammps.md).
void ValidateForLammps(const RunSpec& spec);

// Every key of a run spec with its type, default, range and meaning: what from_json accepts
// and checks, and what `campaign schema` tells editors (spec_table.h).
// The keys a finished run can be extended in (docs/run-spec.md "Extending a run"): a run
// planned with a larger value is the same run continued further, so the native engine
// continues it from the old run's last checkpoint to the new limit, with the same bits as a
// run planned with the new limit from the start. Each is a limit a run ends at; one entry here
// is all a new limit needs.
const std::vector<std::string>& ExtendableKeys();

// Is the run spec `to` the run spec `from` continued further: equal except their run ids, bed
// cache files and the extendable keys, each of which `to` has at least as large (and one
// larger)? Both are resolved run specs (RunSpec::ToJson()).
bool Extends(const nlohmann::json& from, const nlohmann::json& to);

const SpecTable& RunSpecTable();

// The first character of a name that a name must not hold, described ("U+2028 LINE
// SEPARATOR", "U+0000 NUL", "a comma"), or "" if there is none: control characters (C0,
// DEL, C1 such as U+0085), line and paragraph separators, bidirectional and zero-width
// format characters, the byte-order mark; `extra` adds ASCII characters (",").
std::string ForbiddenCharacterIn(const std::string& name, const std::string& extra = "");

// Levenshtein distance, for "did you mean" suggestions (spec keys, CLI verbs).
std::size_t EditDistance(const std::string& a, const std::string& b);

std::string ToString(Shape shape);
std::string ToString(DischargeMode mode);
std::string ToString(ReinjectPosition position);
std::string ToString(FrameFormat format);
std::string ToString(NormalModel model);
std::string ToString(TangentialCap cap);
std::string ToString(NextBatch next);
std::string ToString(BedSettler settler);
std::string ToString(OnClog on_clog);
std::string ToString(UnclogMethod method);
std::string ToString(UnclogFallback fallback);

}  // namespace granary
