// The states of a run in the campaign database. The database keeps them as text (runs.state,
// docs/data.md); the runner uses this enum and converts only where rows are read and written.
#pragma once

#include <array>
#include <iosfwd>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace granary::runner {

enum class RunState {
  kPlanned,      // waits for a runner
  kRunning,      // a runner (or a batch queue) holds it: lease_holder
  kDone,         // finished; summary.json ingested
  kFailed,       // ended without DONE; runs again on the next campaign run
  kInterrupted,  // stopped (Ctrl-C, a lost runner, a full disk); continues from its checkpoint
  kRetired,      // no longer in the spec; its results are kept
};

// The states a campaign's runs are in, in the order status shows them (retired apart).
inline constexpr std::array<RunState, 5> kLiveRunStates = {RunState::kPlanned, RunState::kRunning, RunState::kDone,
                                                           RunState::kFailed, RunState::kInterrupted};

// The database's word for the state: "planned", "running", "done", "failed", "interrupted", "retired".
const char* ToString(RunState state);
// The state the database's word names; throws std::runtime_error for any other text.
RunState RunStateFromString(std::string_view text);
std::ostream& operator<<(std::ostream& out, RunState state);

// A state the next campaign run starts (planned, interrupted or failed).
inline bool Runnable(RunState s) {
  return s == RunState::kPlanned || s == RunState::kInterrupted || s == RunState::kFailed;
}

// In JSON (status --json, show --json, scan --json) a state is its database word.
NLOHMANN_JSON_SERIALIZE_ENUM(RunState, {{RunState::kPlanned, "planned"},
                                        {RunState::kRunning, "running"},
                                        {RunState::kDone, "done"},
                                        {RunState::kFailed, "failed"},
                                        {RunState::kInterrupted, "interrupted"},
                                        {RunState::kRetired, "retired"}})

}  // namespace granary::runner
