// The `granary-engine` command line: verbs `run` and `bench`, each with --help. Returns the
// process exit code; main() only forwards argv.
#pragma once

#include <string>
#include <vector>

namespace granary::engine {

int EngineMain(const std::vector<std::string>& args);

}  // namespace granary::engine
