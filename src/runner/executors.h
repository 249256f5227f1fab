// The executors `campaign run` can use, one row each (after the verb table, cli/verbs.cpp): the
// name --executor and the spec's {"executor": {"type": ...}} give, its lines of `campaign run
// --help`, the flags only it takes, and how it is set up from them. Each executor's file pair
// declares its row (LocalExecutorRow() in executor.h, SlurmExecutorRow() in
// slurm_executor.h); executors.cpp lists them. Adding an executor is one file pair and one row.
#pragma once

#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "runner/executor.h"
#include "runner/scheduler.h"

namespace granary::runner {

class Store;
namespace cli {
struct Args;
}

// One executor set up for one `campaign run` from its flags and the spec's block.
class ExecutorSetup {
 public:
  virtual ~ExecutorSetup() = default;
  // Before anything runs, with the campaign's database open: what the executor needs to know
  // of the campaign (Slurm: its name, each run's estimate for the arrays' --time). It may set
  // the run options it decides (Slurm: the threads per run are its --cpus-per-run).
  virtual void Prepare(Store& /*store*/, CampaignRunOptions& /*options*/, std::ostream& /*out*/) {}
  // When the flags asked for a dry run: prints what would be started and returns the exit
  // code, starting nothing. nullopt: run for real.
  virtual std::optional<int> DryRun(Store& /*store*/, const CampaignRunOptions& /*options*/, std::ostream& /*out*/) {
    return std::nullopt;
  }
  virtual std::unique_ptr<Executor> Make(const CampaignRunOptions& options) const = 0;
};

struct ExecutorRow {
  const char* name;     // --executor NAME; the spec's executor/type
  const char* summary;  // after NAME in `campaign run --help`
  // The flags of `campaign run` only this executor takes (another executor refuses them), and
  // their lines of `campaign run --help`.
  std::vector<std::pair<std::string, bool>> flags;  // name, takes a value
  const char* flags_help;
  // Reads its flags (`block`: the spec's executor block, or nullptr) into a setup; throws
  // cli::UsageError naming the flag.
  std::unique_ptr<ExecutorSetup> (*setup)(const cli::Args& flags, const nlohmann::json* block, const std::string& db,
                                          const CampaignRunOptions& options);
};

// The row the spec's executor block names (its "type"); SpecError under `path` otherwise.
const ExecutorRow& ExecutorOfBlock(const nlohmann::json& block, const std::string& path);

// Every executor; the first is the default.
const std::vector<ExecutorRow>& ExecutorRows();
// The row named `name`, or nullptr.
const ExecutorRow* FindExecutor(const std::string& name);
// "\"local\" or \"slurm\"", for messages (`quote`: with the quotes).
std::string ExecutorNames(bool quote);

}  // namespace granary::runner
