// `campaign run`, and the running `campaign compare` shares with it.
#pragma once

#include <iosfwd>
#include <string>

#include "runner/cli/common.h"
#include "runner/scheduler.h"
#include "runner/slurm_executor.h"

namespace granary::runner::cli {

// The directory of this executable, where granary-engine and granary-liggghts are built.
std::string ExeDir();

// The flags `run` and `compare` share: --jobs, --threads-per-run, --time-limit, --retries.
RunOptions RunOptionsFrom(const Args& a);

// Runs the campaign in `db` with a console display; Ctrl-C / SIGTERM stop it cleanly. With
// `slurm`, the runs go to Slurm.
int RunAll(const std::string& db, const RunOptions& options, std::ostream& out, const SlurmSettings* slurm = nullptr);

}  // namespace granary::runner::cli
