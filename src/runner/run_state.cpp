// See run_state.h.
#include "runner/run_state.h"

#include <ostream>
#include <stdexcept>

namespace granary::runner {

namespace {
constexpr std::pair<RunState, const char*> kNames[] = {
    {RunState::kPlanned, "planned"}, {RunState::kRunning, "running"},         {RunState::kDone, "done"},
    {RunState::kFailed, "failed"},   {RunState::kInterrupted, "interrupted"}, {RunState::kRetired, "retired"},
};
}  // namespace

const char* ToString(RunState state) {
  for (const auto& [s, name] : kNames)
    if (s == state) return name;
  return "?";
}

RunState RunStateFromString(std::string_view text) {
  for (const auto& [s, name] : kNames)
    if (text == name) return s;
  throw std::runtime_error("unknown run state \"" + std::string(text) + "\" in the database");
}

std::ostream& operator<<(std::ostream& out, RunState state) { return out << ToString(state); }

}  // namespace granary::runner
