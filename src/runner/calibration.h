// The engine's speed on this machine, for the estimate (estimate.h): `granary-engine bench`
// on lone discs and on dumbbells, one thread, run once per machine and build and cached
// (docs/cli.md "The estimate").
#pragma once

#include <functional>
#include <string>

#include "runner/estimate.h"

namespace granary::runner {

// Where calibrations are cached: $GRANARY_CALIBRATION_DIR, else $XDG_CACHE_HOME/granary/
// calibration, else ~/.cache/granary/calibration.
std::string CalibrationDir();

// What a calibration is valid for: this host, its CPU model, this build (version, commit)
// and the engine executable (path, size, modification time). Its hash names the cache file.
std::string CalibrationKey(const std::string& engine_exe);

// The cached calibration for `engine_exe` on this machine, or one measured now (and cached)
// when there is none; `say` gets one line before a measurement starts. Never throws: when the
// bench cannot run, the result is invalid and its source says why.
Calibration ObtainCalibration(const std::string& engine_exe, const std::function<void(const std::string&)>& say);

// Only the cached one (invalid, with a source saying so, when there is none).
Calibration CachedCalibration(const std::string& engine_exe);

class Store;
struct RunRow;

// The estimate as `campaign plan` and `campaign status` show it: the calibration for the
// native engine in `exe_dir` (cached; measured now when `measure` and none is), scaled by the
// done runs in `store` (nullptr: none); runs whose bed is already in the bed cache do not
// prepare it.
CampaignEstimate EstimateRuns(const std::vector<PlannedRun>& runs, Store* store, const std::string& exe_dir, int jobs,
                              bool measure, const std::function<void(const std::string&)>& say);

// The runs of the campaign in `store` that are not done, as planned runs (for the estimate).
// What the estimator needs of a stored run.
PlannedRun ToPlannedRun(const RunRow& r);
std::vector<PlannedRun> RunsLeft(Store& store);

}  // namespace granary::runner
