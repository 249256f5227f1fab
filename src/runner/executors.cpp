// The executor table (executors.h).
#include "runner/executors.h"

#include "rundir/run_spec.h"
#include "runner/slurm_executor.h"

namespace granary::runner {

const std::vector<ExecutorRow>& executor_table() {
  static const std::vector<ExecutorRow> table = {local_executor_row(), slurm_executor_row()};
  return table;
}

const ExecutorRow* find_executor(const std::string& name) {
  for (const ExecutorRow& row : executor_table())
    if (name == row.name) return &row;
  return nullptr;
}

const ExecutorRow& executor_of_block(const nlohmann::json& block, const std::string& path) {
  const ExecutorRow* row = block.is_object() && block.contains("type") && block["type"].is_string()
                               ? find_executor(block["type"].get<std::string>())
                               : nullptr;
  if (!row) {
    throw SpecError(path + "/type", "must be " + executor_names(true) + " (got " +
                                        (block.is_object() && block.contains("type") ? block["type"].dump() : "nothing") + ")");
  }
  return *row;
}

std::string executor_names(bool quote) {
  const std::vector<ExecutorRow>& table = executor_table();
  const std::string q = quote ? "\"" : "";
  std::string out;
  for (std::size_t k = 0; k < table.size(); ++k)
    out += (k == 0 ? "" : k + 1 == table.size() ? " or " : ", ") + q + table[k].name + q;
  return out;
}

}  // namespace granary::runner
