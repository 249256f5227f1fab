// `campaign run`, and the running `campaign compare` shares with it.
#pragma once

#include <iosfwd>
#include <string>

#include "runner/cli/common.h"
#include "runner/scheduler.h"
#include "runner/executors.h"

namespace granary::runner::cli {

// The directory of this executable, where granary-engine and granary-liggghts are built.
std::string ExeDir();

// The flags `run` and `compare` share: --jobs, --threads-per-run, --time-limit, --retries.
CampaignRunOptions RunOptionsFrom(const Args& a);

// Runs the campaign in `db` with a console display; Ctrl-C / SIGTERM stop it cleanly. The runs
// go to the executor `setup` makes (nullptr: the local pool, --jobs at once).
int RunAll(const std::string& db, const CampaignRunOptions& options, std::ostream& out,
           const ExecutorSetup* setup = nullptr);

}  // namespace granary::runner::cli
