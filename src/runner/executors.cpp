// The executor table (executors.h).
#include "runner/executors.h"

#include "rundir/run_spec.h"
#include "runner/slurm_executor.h"

namespace granary::runner {

const std::vector<ExecutorRow>& ExecutorRows() {
  static const std::vector<ExecutorRow> kTable = {LocalExecutorRow(), SlurmExecutorRow()};
  return kTable;
}

const ExecutorRow* FindExecutor(const std::string& name) {
  for (const ExecutorRow& row : ExecutorRows())
    if (name == row.name) return &row;
  return nullptr;
}

const ExecutorRow& ExecutorOfBlock(const nlohmann::json& block, const std::string& path) {
  const ExecutorRow* row = block.is_object() && block.contains("type") && block["type"].is_string()
                               ? FindExecutor(block["type"].get<std::string>())
                               : nullptr;
  if (!row) {
    throw SpecError(path + "/type",
                    "must be " + ExecutorNames(true) + " (got " +
                        (block.is_object() && block.contains("type") ? block["type"].dump() : "nothing") + ")");
  }
  return *row;
}

std::string ExecutorNames(bool quote) {
  const std::vector<ExecutorRow>& table = ExecutorRows();
  const std::string q = quote ? "\"" : "";
  std::string out;
  for (std::size_t k = 0; k < table.size(); ++k)
    out += (k == 0 ? "" : k + 1 == table.size() ? " or " : ", ") + q + table[k].name + q;
  return out;
}

}  // namespace granary::runner
