#include "runner/cli/replicas.h"

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <thread>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <map>
#include <ostream>
#include <sstream>

#include "runner/campaign_db.h"
#include "runner/campaign_spec.h"
#include "runner/cli/common.h"
#ifdef GRANARY_HAVE_ANALYSIS
#include "analysis/campaign_analysis.h"
#include "analysis/registry.h"
#endif

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// The point's runs must all have ended before it is judged: planned, running and interrupted
// runs are still to come, and a failed one runs again on the next campaign run.
bool Ended(RunState s) { return s == RunState::kDone; }

std::string Num(double x) {
  if (!std::isfinite(x)) return "n/a";
  std::ostringstream s;
  s << std::setprecision(3) << x;
  return s.str();
}

std::string Label(const PointReplicaState& p) {
  const std::string s = CompactPoint(p.point);
  return s.empty() ? "(base)" : s;
}

// "se/|avalanche_size| = 0.12 (target 0.05)" for each target, joined.
std::string TargetsText(const std::vector<TargetStatus>& targets) {
  std::string s;
  for (const TargetStatus& t : targets) {
    if (!s.empty()) s += ", ";
    s += (t.target.relative ? "se/|" + t.target.metric + "|" : "se(" + t.target.metric + ")") + " = " +
         (t.known ? Num(t.achieved) : std::string("not a metric of this campaign")) + " (target " +
         Num(t.target.value) + (t.met ? ", met)" : ")");
  }
  return s;
}

}  // namespace

std::vector<PointReplicaState> ReplicaStates(Store& store, const std::set<std::string>* settled, bool write_cache) {
  const bool undecided_only = settled != nullptr;
  std::vector<PointReplicaState> out;
  const auto campaign = LoadCampaign(store);
  if (!campaign) return out;
  const CampaignSpec spec = CampaignSpec::FromJson(campaign->spec);
  const ReplicaRule& rule = spec.replica_rule;
  if (!rule.Adaptive()) return out;
  const std::vector<RunRow> runs = LoadRuns(store, true);
  std::map<std::string, std::size_t> index;  // point_id -> out
  for (const RunRow& r : runs) {
    if (r.state == RunState::kRetired) continue;
    auto [it, fresh] = index.try_emplace(r.point_id, out.size());
    if (fresh) out.push_back({r.point_id, r.point, r.engine, 0, {}, {}});
    PointReplicaState& p = out[it->second];
    ++p.counts.planned;
    if (!Ended(r.state)) ++p.counts.unfinished;
    if (r.state == RunState::kDone) ++p.done;
  }
  std::set<std::string> analyse;
  for (const PointReplicaState& p : out) {
    if (p.done == 0) continue;
    if (undecided_only && (p.counts.unfinished > 0 || settled->count(p.point_id))) continue;
    analyse.insert(p.point_id);
  }
#ifdef GRANARY_HAVE_ANALYSIS
  if (!analyse.empty()) {
    analysis::CampaignInfo info;
    info.name = campaign->name;
    info.spec_hash = campaign->spec_hash;
    info.spec = campaign->spec;
    info.axes = campaign->axes;
    info.granary_version = campaign->granary_version;
    info.git_commit = campaign->git_commit;
    std::vector<analysis::RunRecord> records;
    for (const RunRow& r : runs) {
      if (r.state != RunState::kDone || !analyse.count(r.point_id)) continue;
      analysis::RunRecord rec;
      rec.run_id = r.run_id;
      rec.state = ToString(r.state);
      rec.engine = r.engine;
      rec.point_id = r.point_id;
      rec.replica = r.replica;
      rec.point = r.point;
      rec.spec = r.params;
      rec.run_dir = fs::absolute(r.run_dir);
      records.push_back(std::move(rec));
    }
    const analysis::AnalysisSetup setup = analysis::SetupAnalyses(campaign->spec);
    analysis::CampaignAnalysisOptions options;
    options.jobs = 1;  // beside the engines: one core
    options.write_cache = write_cache;
    const auto a = analysis::AnalyseCampaign(info, records, setup, options);
    for (std::size_t k = 0; k < a->view.points.size(); ++k) {
      const auto it = index.find(a->view.points[k].id);
      if (it == index.end()) continue;
      auto& metrics = out[it->second].counts.metrics;
      for (const analysis::PointMetric& m : a->AllPointMetrics(k)) metrics[m.name] = {m.mean, m.se, m.n};
    }
  }
#endif
  for (PointReplicaState& p : out) {
    if (undecided_only && !analyse.count(p.point_id)) continue;  // not judged now
    p.decision = DecideReplicas(rule, p.counts);
  }
  return out;
}

int AddReplicas(Store& store, RunObserver& observer, std::set<std::string>& reported) {
  const auto campaign = LoadCampaign(store);
  if (!campaign) return 0;
  const CampaignSpec spec = CampaignSpec::FromJson(campaign->spec);
  if (!spec.replica_rule.Adaptive()) return 0;
  std::vector<PointReplicaState> states;
  try {
    states = ReplicaStates(store, &reported, true);
  } catch (const std::exception& e) {
    // The runs go on; the replicas wait for the next look (a report shows the analysis' error).
    observer.OnEvent("", "replicas", std::string("the point metrics could not be computed: ") + e.what());
    return 0;
  }
  // The runs of the points that need more, with the seeds and ids the plan would give them.
  std::map<std::string, std::pair<int, int>> wanted;  // point_id -> [from, to)
  int upto = 0;
  for (const PointReplicaState& p : states) {
    const ReplicaDecision& d = p.decision;
    const std::string label = Label(p);
    if (d.verdict == ReplicaVerdict::kMore) {
      wanted[p.point_id] = {p.counts.planned, p.counts.planned + d.add};
      upto = std::max(upto, p.counts.planned + d.add);
      observer.OnEvent("", "replicas",
                       label + ": " + TargetsText(d.targets) + " after " + std::to_string(p.counts.planned) +
                           " runs: " + std::to_string(d.add) + " more planned");
    } else if ((d.verdict == ReplicaVerdict::kMet || d.verdict == ReplicaVerdict::kAtMax ||
                d.verdict == ReplicaVerdict::kUnknown) &&
               reported.insert(p.point_id).second) {
      observer.OnEvent("", "replicas",
                       label + ": " + TargetsText(d.targets) + " after " + std::to_string(p.counts.planned) +
                           " runs: " +
                           (d.verdict == ReplicaVerdict::kMet ? std::string("target met")
                            : d.verdict == ReplicaVerdict::kAtMax
                                ? "at max (" + std::to_string(spec.replica_rule.max) + ") without reaching the target"
                                : std::string("no replicas added")));
    }
  }
  if (wanted.empty()) return 0;
  // Where the point's runs keep their prepared beds and directories: as planned.
  std::map<std::string, std::pair<std::string, std::string>> places;  // point_id -> (cache dir, runs root)
  for (const RunRow& r : LoadRuns(store, true)) {
    if (!wanted.count(r.point_id) || places.count(r.point_id)) continue;
    std::string cache = DefaultCacheDir();
    if (r.params.contains("bed") && r.params["bed"].contains("cache_file") && r.params["bed"]["cache_file"].is_string())
      cache = fs::path(r.params["bed"]["cache_file"].get<std::string>()).parent_path().string();
    places[r.point_id] = {cache, fs::path(r.run_dir).parent_path().string()};
  }
  // One expansion per cache directory (one in practice).
  std::map<std::string, std::vector<PlannedRun>> by_root;
  std::map<std::string, std::vector<PlannedRun>> expanded;  // cache dir -> runs
  for (const auto& [point_id, range] : wanted) {
    const auto& [cache, root] = places[point_id];
    auto it = expanded.find(cache);
    if (it == expanded.end())
      it = expanded.emplace(cache, Expand(spec, cache, std::numeric_limits<std::uint64_t>::max(), upto)).first;
    for (const PlannedRun& r : it->second)
      if (r.point_id == point_id && r.replica >= range.first && r.replica < range.second) by_root[root].push_back(r);
  }
  // Tests only (kill -9 of the runner while it adds replicas): GRANARY_TEST_HOLD_REPLICAS=PATH
  // makes the runner say it has decided (PATH.reached) and wait for PATH before it writes.
  if (const char* hold = std::getenv("GRANARY_TEST_HOLD_REPLICAS"); hold && *hold) {
    std::ofstream(std::string(hold) + ".reached") << "decided\n";
    while (!fs::exists(hold)) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  int added = 0;
  for (const auto& [root, list] : by_root) added += AddPlannedRuns(store, list, root);
  return added;
}

json ReplicaProgressJson(const std::vector<PointReplicaState>& states, const ReplicaRule& rule) {
  json points = json::array();
  for (const PointReplicaState& p : states) {
    json targets = json::array();
    for (const TargetStatus& t : p.decision.targets) {
      const auto num = [](double x) { return std::isfinite(x) ? json(x) : json(nullptr); };
      targets.push_back({{"metric", t.target.metric},
                         {"kind", t.target.relative ? "rel_se" : "se"},
                         {"target", t.target.value},
                         {"value", num(t.estimate.value)},
                         {"se", num(t.estimate.se)},
                         {"n", t.estimate.n},
                         {"achieved", num(t.achieved)},
                         // how far: achieved / target (<= 1 met)
                         {"ratio", num(t.achieved / t.target.value)},
                         {"met", t.met},
                         {"known", t.known}});
    }
    points.push_back({{"point", p.point},
                      {"point_id", p.point_id},
                      {"engine", p.engine},
                      {"runs", p.counts.planned},
                      {"done", p.done},
                      {"unfinished", p.counts.unfinished},
                      {"verdict", ToString(p.decision.verdict)},
                      {"add", p.decision.add},
                      {"targets", targets}});
  }
  return {{"rule", rule.Text()}, {"min", rule.min}, {"max", rule.max}, {"points", points}};
}

void PrintReplicaProgress(std::ostream& out, const std::vector<PointReplicaState>& states, const ReplicaRule& rule) {
  out << "  adaptive replicas: " << rule.Text() << "\n";
  for (const PointReplicaState& p : states) {
    std::string verdict;
    switch (p.decision.verdict) {
      case ReplicaVerdict::kWaiting: verdict = std::to_string(p.counts.unfinished) + " run(s) to end first"; break;
      case ReplicaVerdict::kMet: verdict = "target met"; break;
      case ReplicaVerdict::kAtMax: verdict = "AT MAX without reaching the target"; break;
      case ReplicaVerdict::kUnknown: verdict = "a target metric is not a metric of this campaign"; break;
      case ReplicaVerdict::kMore: verdict = std::to_string(p.decision.add) + " more to plan (campaign run)"; break;
      case ReplicaVerdict::kFixed: verdict = "fixed"; break;
    }
    out << "    " << std::left << std::setw(36) << Label(p) << std::right << " " << p.done << "/" << p.counts.planned
        << " done  " << TargetsText(p.decision.targets) << "  " << verdict << "\n";
  }
}

}  // namespace granary::runner::cli
