// The `campaign` command line: the verbs of the table in cli/verbs.cpp (one file per family
// of verbs in cli/), each with --help; an unknown verb or flag gets a "did you mean".
// main() only calls run_cli.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace granary::runner {

// Returns the process exit code (ExitCode values: 0 ok, 1 runs failed, 2 usage or spec error,
// 3 storage error, 130 interrupted; docs/cli.md).
int RunCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace granary::runner
