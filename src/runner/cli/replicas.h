// Adaptive replicas (docs/campaign-spec.md "Replicas"): the runner's side of
// rundir/replica_rule.h. The decision is the rule's pure DecideReplicas(); this file feeds it
// what the database and the analyses know of each point, and `campaign run` applies it.
#pragma once

#include <iosfwd>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "rundir/replica_rule.h"
#include "runner/scheduler.h"
#include "runner/store.h"

namespace granary::runner::cli {

struct PointReplicaState {
  std::string point_id;
  nlohmann::json point;  // sweep-axis values
  std::string engine;
  int done = 0;
  PointReplicas counts;
  ReplicaDecision decision;
};

// Every point of the adaptive campaign in `store`, judged now: its runs in the database and
// the point metrics of its done runs (analysed, each run's cache first). With `settled` (the
// runner), only the points whose runs have all ended and that are not in `settled` (already
// met, at max or unknown) are analysed; the others get no metrics and no decision. Empty for
// a campaign with a fixed number of replicas.
std::vector<PointReplicaState> ReplicaStates(Store& store, const std::set<std::string>* settled, bool write_cache);

// What `campaign run` calls after each finished run (CampaignRunOptions::add_runs): plans the replicas
// the decision asks for and reports each point's verdict once. Returns how many runs it added.
// `reported` keeps the points already reported as met, at max or unknown across calls.
int AddReplicas(Store& store, RunObserver& observer, std::set<std::string>& reported);

// Per point, how far its metrics are from their targets, for `campaign status` (--json).
nlohmann::json ReplicaProgressJson(const std::vector<PointReplicaState>& states, const ReplicaRule& rule);
void PrintReplicaProgress(std::ostream& out, const std::vector<PointReplicaState>& states, const ReplicaRule& rule);

}  // namespace granary::runner::cli
