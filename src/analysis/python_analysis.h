// Analyses written in Python (docs/python.md): /report/python of a campaign spec lists scripts,
// [{"key", "script", "options"}]; each becomes one analysis of the table, with its own key,
// cache file, metrics and report section, like a built-in one. The script's
// Analyse(run, options) runs in a pool of Python interpreters (python -m granary.worker), one
// request per run, from the pass' Finish(): the script reads the run directory itself through
// python/granary. A script that raises, returns something that is not {name: (value, se,
// unit)} or a NaN, or kills its interpreter fails that run's analysis only: the result keeps
// the traceback's last lines, which the report and `campaign show` print.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/analysis.h"

namespace granary::analysis {

// One analysis per entry of /report/python (`path`); none when it is absent. Script paths are
// taken as they are (the runner makes them absolute, relative to the campaign spec's folder,
// when it plans). Throws OptionError naming the entry's path: not an array, unknown keys, a key
// that is not [a-z0-9_] or is taken, a script that cannot be read.
std::vector<std::unique_ptr<Analysis>> MakePythonAnalyses(const nlohmann::json& options, const std::string& path);

// The interpreter the pool starts: $GRANARY_PYTHON, else the one the build found
// (GRANARY_PYTHON in CMake, Debian's /usr/bin/python3).
std::string PythonInterpreter();

// The failure message kept in the result of a run whose Python analysis failed, or "".
std::string PythonFailure(const nlohmann::json& result);

}  // namespace granary::analysis
