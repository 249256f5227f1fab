// Bed preparation (docs/model.md "A run", step 1): bodies inserted at random, without
// overlap, in batches with random orientations, then settled under gravity with the outlets
// plugged. A prepared bed depends only on RunSpec::BedKey(); it is stored as JSON and
// shared between runs through bed.cache_file (written atomically under an flock).
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "rundir/run_spec.h"
#include "silo/shapes.h"
#include "engine/world.h"

namespace granary::engine {

// Side walls used while preparing a bed and, unless the spec gives a height, during the
// discharge: effectively unbounded so that the bed never depends on the silo height.
inline constexpr double kTallWall = 1.0e5;

struct BedState {
  std::vector<int> species;  // per body: species index (template)
  std::vector<double> x, y, theta, vx, vy, omega;
  // Contact history of the settled bed, so that friction keeps holding it when the
  // discharge starts: pairs by disc index (i < j), walls by disc and Side.
  std::vector<HistoryEntry> pair_history, wall_history;
  double height = 0.0;       // top of the bed: max y + r over discs
  double settle_time = 0.0;  // simulated preparation time
};

// Progress of the preparation: fraction in [0, 1] and simulated time.
using BedProgress = std::function<void(double fraction, double t)>;

std::vector<silo::ShapeTemplate> MakeTemplates(const RunSpec& spec);

// Verlet skin while preparing a bed (the run's is 0.2): the falling batches outrun a 0.2 skin
// every ~50 steps at the bed step; 0.4 halves the rebuilds (~20 % less wall time on two
// threads) and gives the same bed to the bit (Bed.TheSkinDoesNotChangeTheBed).
inline constexpr double kBedSkin = 0.4;

// The bodies of the spec placed at random, without overlaps, in one loose region (the packing
// of an insertion batch) above the base of the closed silo, at rest: the start of a bed that
// another engine settles (bed/settled_by "lammps", docs/lammps.md). No contact history.
BedState LoosePlacement(const RunSpec& spec);

// Prepares a bed from scratch (deterministic in spec.seed; `skin` only changes the speed).
BedState PrepareBed(const RunSpec& spec, const BedProgress& progress, double skin = kBedSkin);

// A bed file that cannot be used: not a bed, another format version, or its checksum does
// not match (corrupt, torn). ObtainBed puts it aside and prepares the bed again.
class BedFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The bed file: JSON with `format`, `version` 3, `key` and the bodies, and `checksum`, the
// CRC-32 of the document's dump without it.
nlohmann::json BedToJson(const BedState& bed, const RunSpec& spec);
// Reads a bed written by BedToJson; throws BedFileError for a bad file, std::runtime_error
// if it was prepared for another bed key.
BedState BedFromJson(const nlohmann::json& j, const RunSpec& spec, const std::string& file);

struct ObtainedBed {
  BedState bed;
  std::string file;
  bool prepared_here = false;
  double wall_s = 0.0;
  std::string refused;  // why a cached bed file was refused (then prepared again), or ""
};

// Loads the bed from spec.bed.cache_file (or DIR/bed.json when it is empty) if it exists;
// otherwise prepares it and writes it atomically, holding an flock on `<file>.lock`.
ObtainedBed ObtainBed(const RunSpec& spec, const std::string& run_dir, const BedProgress& progress);

// What a settled bed looks like (summary.json's bed, and for comparing preparation procedures): its top (the highest
// disc's, BedState::height), its surface (the mean over 1 d wide columns, 2 d from the walls,
// of the highest disc top in the column) and the packing fraction of the full-width band
// from 5 d above the base to 5 d below the surface (discs cut by the band count with the part
// inside).
struct BedShape {
  double top = 0.0;
  double surface = 0.0;
  double phi = 0.0;
};
BedShape MeasureBed(const BedState& bed, const RunSpec& spec);

}  // namespace granary::engine
