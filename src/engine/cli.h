// The `granary-engine` command line: verbs `run` and `bench`, each with --help. Returns the
// process exit code; main() only forwards argv.
#pragma once

#include <string>
#include <vector>

namespace granary::engine {

int EngineMain(const std::vector<std::string>& args);

// A finite number > 0, or std::invalid_argument naming the flag.
double ParsePositiveNumber(const std::string& flag, const std::string& value);

}  // namespace granary::engine
