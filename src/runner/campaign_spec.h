// The campaign spec (docs/campaign-spec.md): a base run spec, sweeps over any run-spec
// parameter (grid, zip, explicit points; axes are JSON Pointers into the run spec) and
// replicas. Parsing validates everything before anything runs; Expand() resolves every
// run with RunSpec::from_json and gives it a stable id (hash of its canonical parameters).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "rundir/replica_rule.h"
#include "rundir/run_spec.h"

namespace granary::runner {

struct CampaignSpec {
  std::string name;
  std::string description;
  std::string size;  // "quick", "medium", "full", or "" (not said): expectations judged only at full
  std::uint64_t seed = 1;
  int replicas = 1;          // planned per point (the rule's min)
  ReplicaRule replica_rule;  // `replicas` as given: fixed, or adaptive (min, max, until)
  // "native" and/or "liggghts": every sweep point is planned once per engine (a comparison).
  std::vector<std::string> engines = {"native"};
  nlohmann::json base = nlohmann::json::object();
  nlohmann::json grid = nlohmann::json::object();   // pointer -> [values]: cartesian product
  nlohmann::json zip = nlohmann::json::object();    // pointer -> [values]: paired, equal lengths
  nlohmann::json points = nlohmann::json::array();  // [{pointer: value, ...}]: explicit points
  nlohmann::json executor;                          // the "executor" block (validated), or null
  nlohmann::json raw;                               // the spec as given
  std::vector<std::string> axes;                    // grid, then zip, then point keys, in order

  // Throws SpecError naming the JSON path in the campaign spec.
  static CampaignSpec FromJson(const nlohmann::json& j);
  std::string SpecHash() const;
};

// Throws SpecError at `path`/KEY for a key of the object `j` not in `allowed` (with the
// nearest allowed key as a suggestion), or at `path` when `j` is not an object.
void CheckKeys(const nlohmann::json& j, const std::string& path, const std::vector<std::string>& allowed);

struct PlannedRun {
  std::string run_id;
  std::string point_id;    // shared by the replicas of one sweep point
  nlohmann::json point;    // {pointer: value} of the sweep axes
  std::string point_json;  // point.dump()
  int replica = 0;
  std::string params_json;  // canonical resolved run spec (run.json), as stored
  std::string engine;
  nlohmann::json Params() const { return nlohmann::json::parse(params_json); }
};

// json::dump() of a document with a few fields left open: dumped once, then filled per
// replica by string concatenation (planning 10,000 runs: docs/benchmarks.md). Fill(values)
// equals the dump of the document with field i set to the JSON text values[i].
class DumpTemplate {
 public:
  DumpTemplate(nlohmann::json doc, const std::vector<std::string>& pointers);
  std::string Fill(const std::vector<std::string>& values) const;
  bool Spliced() const { return !pieces_.empty(); }  // false: Fill() sets the fields and dumps

 private:
  nlohmann::json doc_;
  std::vector<nlohmann::json::json_pointer> pointers_;
  std::vector<std::string> pieces_;  // text between the fields, in text order
  std::vector<std::size_t> order_;   // field index of each gap between pieces
};

// The campaign spec's own keys (the run spec under /base has RunSpecTable()).
const SpecTable& CampaignSpecTable();
// The JSON Schema (draft-07) of campaign specs, from CampaignSpecTable() and
// RunSpecTable(): what `campaign schema` prints for editors.
nlohmann::json CampaignSpecSchema();

// A campaign spec's text as JSON. Throws std::invalid_argument naming `source`, the line and
// the column: for a syntax error, and for nesting deeper than kMaxSpecDepth (checked before
// parsing; a campaign spec needs fewer than 10 levels).
inline constexpr int kMaxSpecDepth = 64;
nlohmann::json ParseSpecText(const std::string& text, const std::string& source);

// The script paths of /report/python (docs/python.md) made absolute, relative to the folder of
// the spec file they were read from, so a report finds them from any working directory.
void ResolveSpecPaths(nlohmann::json& spec, const std::string& spec_file);

// How many runs the sweep expands to (points x engines x replicas), computed without
// expanding it; saturates at 2^63.
std::uint64_t PlannedRunCount(const CampaignSpec& spec);

// The default limit of Expand(): a larger sweep is refused before anything is allocated
// (`campaign plan --max-runs N` raises it).
inline constexpr std::uint64_t kDefaultMaxRuns = 100000;

// The directory of prepared beds: $GRANARY_CACHE_DIR or ~/.cache/granary/beds.
std::string DefaultCacheDir();

// Expands the sweep into runs (points in order, replicas within a point). Every run is
// validated; an error names the sweep point. bed.cache_file = <cache_dir>/<hash of bed_key>.bed.
// Throws SpecError at /sweep when the sweep has more than max_runs runs, before allocating.
// replicas_upto > spec.replicas: replicas 0..replicas_upto-1 of every point (the adaptive
// replicas a runner added; the limit counts spec.replicas).
std::vector<PlannedRun> Expand(const CampaignSpec& spec, const std::string& cache_dir,
                               std::uint64_t max_runs = kDefaultMaxRuns, int replicas_upto = 0);

// Run id of a resolved run spec: hash of its canonical JSON without run_id and cache_file.
std::string RunIdOf(const RunSpec& spec);

// The program that runs a run of `engine` (found beside `campaign`): granary-engine,
// granary-liggghts or granary-lammps, all with the command line of docs/run-directory.md.
std::string EngineProgram(const std::string& engine);

}  // namespace granary::runner
