// The `campaign` command line: verbs plan, run, status, report from one table, each with
// --help; an unknown verb or flag gets a "did you mean". main() only calls run_cli.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace granary::runner {

// Returns the process exit code (ExitCode values: 0, 1, 2, 130).
int run_cli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace granary::runner
