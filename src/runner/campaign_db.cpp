// See campaign_db.h.
#include "runner/campaign_db.h"

#include <cmath>
#include <limits>
#include "rundir/files.h"
#include "rundir/layout.h"
#include "rundir/version.h"

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <chrono>
#include <filesystem>
#include <functional>

namespace granary::runner {

namespace fs = std::filesystem;
using nlohmann::json;

double NowSeconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

double LeaseStaleSeconds() {
  static const double kSeconds = [] {
    const char* env = std::getenv("GRANARY_LEASE_SECONDS");
    char* end = nullptr;
    const double v = env ? std::strtod(env, &end) : 0.0;
    return env && end != env && *end == '\0' && v > 0 ? v : 60.0;
  }();
  return kSeconds;
}

Holder ThisProcessHolder() {
  static const Holder kHolder = [] {
    char host[256] = {0};
    gethostname(host, sizeof host - 1);
    Holder h;
    h.host = host;
    h.pid = static_cast<int>(getpid());
    h.id = h.host + ":" + std::to_string(h.pid) + ":" + std::to_string(static_cast<long long>(NowSeconds() * 1000));
    return h;
  }();
  return kHolder;
}

std::vector<PlannedRun> WithAddedReplicas(Store& store, const CampaignSpec& spec, std::vector<PlannedRun> runs) {
  std::set<std::string> live;
  Statement q = store.Prepare("SELECT run_id FROM runs WHERE state != 'retired'");
  while (q.Step()) live.insert(q.Text(0));
  std::erase_if(runs, [&](const PlannedRun& r) { return r.replica >= spec.replicas && !live.count(r.run_id); });
  return runs;
}

int AddPlannedRuns(Store& store, const std::vector<PlannedRun>& runs, const std::string& runs_root) {
  Transaction tx(store);
  std::int64_t next_seq = 0;
  {
    Statement q = store.Prepare("SELECT COALESCE(MAX(seq), -1) + 1 FROM runs");
    q.Step();
    next_seq = q.Integer(0);
  }
  Statement state = store.Prepare("SELECT state FROM runs WHERE run_id = ?1");
  Statement insert = store.Prepare(
      "INSERT INTO runs (run_id, seq, point_id, point, replica, params, state, engine, granary_version, "
      "git_commit, run_dir) VALUES (?1, ?2, ?3, ?4, ?5, ?6, 'planned', ?7, ?8, ?9, ?10)");
  Statement revive =
      store.Prepare("UPDATE runs SET state = COALESCE(retired_from, 'planned'), retired_from = NULL WHERE run_id = ?1");
  int changed = 0;
  for (const PlannedRun& r : runs) {
    state.Reset();
    state.Bind(1, r.run_id);
    if (state.Step()) {
      if (state.Text(0) == "retired") {
        revive.Reset();
        revive.Bind(1, r.run_id).Run();
        ++changed;
      }
      continue;
    }
    insert.Reset();
    insert.Bind(1, r.run_id).Bind(2, next_seq++).Bind(3, r.point_id).Bind(4, r.point_json).Bind(5, r.replica);
    insert.Bind(6, r.params_json).Bind(7, r.engine).Bind(8, GRANARY_VERSION).Bind(9, granary::GitCommit());
    insert.Bind(10, (std::filesystem::path(runs_root) / r.run_id).string());
    insert.Run();
    ++changed;
  }
  tx.Commit();
  return changed;
}

PlanSummary PlanCampaign(Store& store, const CampaignSpec& spec, const std::vector<PlannedRun>& runs,
                         const std::string& runs_root, bool dry_run) {
  PlanSummary sum;
  sum.total = static_cast<int>(runs.size());
  sum.axes = spec.axes;
  std::set<std::string> ids;
  std::set<std::string> point_ids;
  for (const auto& r : runs) {
    if (!ids.insert(r.run_id).second) {
      throw SpecError("/sweep", "two sweep points resolve to the same run (point " + r.point.dump() + ", replica " +
                                    std::to_string(r.replica) + "); remove the duplicate");
    }
    if (!point_ids.insert(r.point_id).second) continue;  // axis values: once per point
    for (const auto& axis : spec.axes) {
      if (!r.point.contains(axis)) continue;
      auto& vals = sum.axis_values[axis];
      if (std::find(vals.begin(), vals.end(), r.point[axis]) == vals.end()) vals.push_back(r.point[axis]);
    }
  }
  sum.points = static_cast<int>(point_ids.size());

  Transaction tx(store);
  std::map<std::string, RunState> existing;  // run_id -> state
  {
    Statement q = store.Prepare("SELECT run_id, state FROM runs ORDER BY seq");
    while (q.Step()) existing[q.Text(0)] = RunStateFromString(q.Text(1));
  }
  std::int64_t next_seq = 0;
  {
    Statement q = store.Prepare("SELECT COALESCE(MAX(seq), -1) + 1 FROM runs");
    q.Step();
    next_seq = q.Integer(0);
  }
  for (const auto& r : runs) {
    auto it = existing.find(r.run_id);
    if (it == existing.end())
      ++sum.added;
    else if (it->second == RunState::kRetired)
      ++sum.revived;
    else
      ++sum.unchanged;
  }
  for (const auto& [id, state] : existing) {
    if (!ids.count(id) && state != RunState::kRetired) ++sum.retired;
  }
  // Extensions: an old native run, not running, whose spec the new one extends.
  {
    std::map<std::string, std::pair<std::string, json>> candidates;  // spec without the limits -> (id, dir)
    auto without_limits = [](json j) {
      j.erase("run_id");
      if (j.contains("bed") && j["bed"].is_object()) j["bed"].erase("cache_file");
      for (const std::string& key : ExtendableKeys()) {
        const json::json_pointer p(key);
        if (j.contains(p)) j[p] = nullptr;
      }
      return j.dump();
    };
    Statement q = store.Prepare("SELECT run_id, params, run_dir, state FROM runs WHERE engine = 'native' ORDER BY seq");
    while (q.Step()) {
      if (ids.count(q.Text(0)) || q.Text(3) == "running") continue;
      std::error_code ec;
      if (!fs::is_directory(q.Text(2), ec)) continue;  // nothing to continue from (an earlier extension moved it)
      json params = json::parse(q.Text(1));
      std::string key = without_limits(params);
      candidates[std::move(key)] = {q.Text(0), {{"params", std::move(params)}, {"dir", q.Text(2)}}};
    }
    for (const auto& r : runs) {
      if (existing.count(r.run_id) || r.engine != "native" || candidates.empty()) continue;
      const json params = r.Params();
      const auto it = candidates.find(without_limits(params));
      if (it == candidates.end() || !Extends(it->second.second["params"], params)) continue;
      const PlanSummary::Extension e{it->second.first, r.run_id};
      const std::string old_dir = it->second.second["dir"].get<std::string>();
      if (const std::string holder = RunDirectoryHolder(old_dir); !holder.empty()) {
        sum.not_extended.push_back({e, "its directory is locked by " + holder});
      } else {
        sum.extended.push_back(e);
      }
      candidates.erase(it);
    }
  }
  if (dry_run) return sum;  // the transaction rolls back

  Statement campaign = store.Prepare(
      "INSERT INTO campaign (id, name, spec, spec_hash, axes, granary_version, git_commit, planned_at) "
      "VALUES (1, ?1, ?2, ?3, ?4, ?5, ?6, ?7) ON CONFLICT (id) DO UPDATE SET name = ?1, spec = ?2, "
      "spec_hash = ?3, axes = ?4, granary_version = ?5, git_commit = ?6, planned_at = ?7");
  campaign.Bind(1, spec.name).Bind(2, spec.raw.dump()).Bind(3, spec.SpecHash()).Bind(4, json(spec.axes).dump());
  campaign.Bind(5, GRANARY_VERSION).Bind(6, granary::GitCommit()).Bind(7, NowSeconds()).Run();

  Statement insert = store.Prepare(
      "INSERT INTO runs (run_id, seq, point_id, point, replica, params, state, engine, granary_version, "
      "git_commit, run_dir) VALUES (?1, ?2, ?3, ?4, ?5, ?6, 'planned', ?7, ?8, ?9, ?10)");
  Statement revive =
      store.Prepare("UPDATE runs SET state = COALESCE(retired_from, 'planned'), retired_from = NULL WHERE run_id = ?1");
  // A running run is retired with its lease: its runner stops the engine and records nothing,
  // and if the run comes back it continues from its checkpoint.
  Statement retire = store.Prepare(
      "UPDATE runs SET retired_from = CASE state WHEN 'running' THEN 'interrupted' ELSE state END, "
      "state = 'retired', lease_holder = NULL, lease_host = NULL, lease_pid = NULL, lease_heartbeat = NULL "
      "WHERE run_id = ?1 AND state != 'retired'");
  for (const auto& r : runs) {
    auto it = existing.find(r.run_id);
    if (it == existing.end()) {
      insert.Reset();
      insert.Bind(1, r.run_id).Bind(2, next_seq++).Bind(3, r.point_id).Bind(4, r.point_json).Bind(5, r.replica);
      insert.Bind(6, r.params_json).Bind(7, r.engine).Bind(8, GRANARY_VERSION).Bind(9, granary::GitCommit());
      insert.Bind(10, (std::filesystem::path(runs_root) / r.run_id).string());
      insert.Run();
    } else if (it->second == RunState::kRetired) {
      revive.Reset();
      revive.Bind(1, r.run_id).Run();
    }
  }
  // Retiring never deletes: a finished run keeps its results and comes back if re-planned.
  for (const auto& [id, state] : existing) {
    if (!ids.count(id) && state != RunState::kRetired) {
      retire.Reset();
      retire.Bind(1, id).Run();
    }
  }
  // An extended run's directory moves to the run that continues it; the old run, left without
  // one, would start over if a later plan brought it back.
  Statement forget = store.Prepare(
      "UPDATE runs SET retired_from = 'planned', attempts = 0, started_at = NULL, ended_at = NULL, wall_s = NULL, "
      "end_reason = NULL, failure = NULL, progress = NULL, summary = NULL WHERE run_id = ?1 AND state = 'retired'");
  Statement forget_results = store.Prepare("DELETE FROM results WHERE run_id = ?1");
  std::vector<std::pair<fs::path, fs::path>> moved;
  try {
    for (auto it = sum.extended.begin(); it != sum.extended.end();) {
      const fs::path to = fs::path(runs_root) / it->to;
      Statement dir = store.Prepare("SELECT run_dir FROM runs WHERE run_id = ?1");
      dir.Bind(1, it->from);
      const fs::path old_dir = dir.Step() ? fs::path(dir.Text(0)) : fs::path(runs_root) / it->from;
      std::error_code ec;
      if (fs::exists(to, ec)) {
        sum.not_extended.push_back({*it, "the new run's directory " + to.string() + " exists already"});
        it = sum.extended.erase(it);
        continue;
      }
      fs::rename(old_dir, to, ec);
      if (ec) {
        sum.not_extended.push_back({*it, "cannot move " + old_dir.string() + ": " + ec.message()});
        it = sum.extended.erase(it);
        continue;
      }
      moved.emplace_back(old_dir, to);
      // Not complete for the new spec: the runner must run it, not ingest the old summary.
      fs::remove(to / rundir::kDoneFile, ec);
      forget.Reset();
      forget.Bind(1, it->from).Run();
      forget_results.Reset();
      forget_results.Bind(1, it->from).Run();
      ++it;
    }
    tx.Commit();
  } catch (...) {
    std::error_code ec;
    for (auto m = moved.rbegin(); m != moved.rend(); ++m) fs::rename(m->second, m->first, ec);
    throw;
  }
  return sum;
}

std::optional<CampaignRow> LoadCampaign(Store& store) {
  Statement q =
      store.Prepare("SELECT name, spec, spec_hash, axes, granary_version, git_commit FROM campaign WHERE id = 1");
  if (!q.Step()) return std::nullopt;
  CampaignRow c;
  c.name = q.Text(0);
  c.spec = json::parse(q.Text(1));
  c.spec_hash = q.Text(2);
  c.axes = json::parse(q.Text(3)).get<std::vector<std::string>>();
  c.granary_version = q.Text(4);
  c.git_commit = q.Text(5);
  return c;
}

namespace {

constexpr char kRunColumns[] =
    "SELECT run_id, seq, point_id, point, replica, params, state, attempts, engine, COALESCE(engine_version, ''), "
    "COALESCE(host, ''), COALESCE(started_at, 0), COALESCE(ended_at, 0), COALESCE(wall_s, 0), "
    "COALESCE(end_reason, ''), run_dir, COALESCE(failure, ''), COALESCE(lease_holder, ''), progress, "
    "COALESCE(lease_host, ''), COALESCE(lease_pid, 0), COALESCE(lease_heartbeat, 0), COALESCE(job_array, 0), "
    "COALESCE(job_index, -1), COALESCE(job_arrays.job_id, ''), COALESCE(job_arrays.dir, ''), "
    "COALESCE(job_arrays.name, ''), COALESCE(job_state, ''), COALESCE(job_arrays.script, '') FROM runs "
    "LEFT JOIN job_arrays ON job_arrays.id = runs.job_array ";

RunRow ReadRow(const Statement& q, bool with_params) {
  RunRow r;
  r.run_id = q.Text(0);
  r.seq = q.Integer(1);
  r.point_id = q.Text(2);
  r.point = json::parse(q.Text(3));
  r.replica = static_cast<int>(q.Integer(4));
  if (with_params) r.params = json::parse(q.Text(5));
  r.state = RunStateFromString(q.Text(6));
  r.attempts = static_cast<int>(q.Integer(7));
  r.engine = q.Text(8);
  r.engine_version = q.Text(9);
  r.host = q.Text(10);
  r.started_at = q.Real(11);
  r.ended_at = q.Real(12);
  r.wall_s = q.Real(13);
  r.end_reason = q.Text(14);
  r.run_dir = q.Text(15);
  r.failure = q.Text(16);
  r.lease_holder = q.Text(17);
  if (!q.IsNull(18)) r.progress = json::parse(q.Text(18), nullptr, false);
  r.lease_host = q.Text(19);
  r.lease_pid = static_cast<int>(q.Integer(20));
  r.lease_heartbeat = q.Real(21);
  r.job_array = q.Integer(22);
  r.job_index = static_cast<int>(q.Integer(23));
  r.job_id = q.Text(24);
  r.job_dir = q.Text(25);
  r.job_name = q.Text(26);
  r.job_state = q.Text(27);
  r.job_script = q.Text(28);
  return r;
}

bool PidAlive(int pid) { return pid > 0 && (kill(pid, 0) == 0 || errno != ESRCH); }

}  // namespace

std::map<std::string, json> LoadResults(Store& store, const std::string& run_id) {
  Statement q = store.Prepare("SELECT key, value, text FROM results WHERE run_id = ?1 ORDER BY key");
  q.Bind(1, run_id);
  std::map<std::string, json> out;
  while (q.Step()) out[q.Text(0)] = q.IsNull(1) ? json(q.Text(2)) : json(q.Real(1));
  return out;
}

std::vector<std::pair<json, json>> LoadFinished(Store& store) {
  Statement q = store.Prepare(
      "SELECT params, summary FROM runs WHERE summary IS NOT NULL AND end_reason IS NOT NULL ORDER BY seq");
  std::vector<std::pair<json, json>> out;
  while (q.Step()) {
    json summary = json::parse(q.Text(1), nullptr, false);
    if (summary.is_object() && summary.contains("timing")) out.emplace_back(json::parse(q.Text(0)), std::move(summary));
  }
  return out;
}

std::vector<RunRow> FindRuns(Store& store, const std::string& prefix, bool with_params) {
  // Ids are lower-case hex: a prefix range on the primary key, no LIKE escaping needed.
  Statement q =
      store.Prepare((std::string(kRunColumns) + "WHERE substr(run_id, 1, length(?1)) = ?1 ORDER BY seq").c_str());
  q.Bind(1, prefix);
  std::vector<RunRow> rows;
  while (q.Step()) rows.push_back(ReadRow(q, with_params));
  return rows;
}

void ForgetRetiredResults(Store& store, const std::string& run_id) {
  Transaction tx(store);
  Statement u = store.Prepare(
      "UPDATE runs SET retired_from = 'planned', attempts = 0, started_at = NULL, ended_at = NULL, wall_s = NULL, "
      "end_reason = NULL, failure = NULL, progress = NULL, summary = NULL WHERE run_id = ?1 AND state = 'retired'");
  u.Bind(1, run_id).Run();
  Statement d = store.Prepare("DELETE FROM results WHERE run_id = ?1");
  d.Bind(1, run_id).Run();
  tx.Commit();
}

bool LeaseExpired(const RunRow& row, const std::string& host, double now) {
  if (row.state != RunState::kRunning) return false;
  return now - row.lease_heartbeat > LeaseStaleSeconds() || (row.lease_host == host && !PidAlive(row.lease_pid));
}

std::vector<RunRow> LoadRuns(Store& store, bool with_params) {
  Statement q = store.Prepare((std::string(kRunColumns) + "ORDER BY seq").c_str());
  std::vector<RunRow> rows;
  while (q.Step()) rows.push_back(ReadRow(q, with_params));
  return rows;
}

int RecoverExpiredLeases(Store& store, const Holder& me, double now) {
  Transaction tx(store);
  Statement q = store.Prepare(
      "SELECT run_id, COALESCE(lease_host, ''), COALESCE(lease_pid, 0), COALESCE(lease_heartbeat, 0), "
      "COALESCE(lease_holder, '') FROM runs WHERE state = 'running' AND job_array IS NULL ORDER BY seq");
  std::vector<std::string> expired;
  while (q.Step()) {
    const std::string holder = q.Text(4);
    if (holder == me.id) continue;
    const bool stale = now - q.Real(3) > LeaseStaleSeconds();
    const bool gone = q.Text(1) == me.host && !PidAlive(static_cast<int>(q.Integer(2)));
    if (stale || gone) expired.push_back(q.Text(0));
  }
  Statement u = store.Prepare(
      "UPDATE runs SET state = 'interrupted', failure = ?2, lease_holder = NULL, lease_host = NULL, "
      "lease_pid = NULL, lease_heartbeat = NULL WHERE run_id = ?1");
  for (const auto& id : expired) {
    u.Reset();
    u.Bind(1, id).Bind(2, "runner lost (lease expired); continues from its checkpoint").Run();
  }
  tx.Commit();
  return static_cast<int>(expired.size());
}

std::optional<RunRow> ClaimNext(Store& store, const Holder& me, double now,
                                const std::function<bool(const RunRow&)>& accept, const std::set<std::string>& skip) {
  Transaction tx(store);
  Statement q = store.Prepare(
      (std::string(kRunColumns) + "WHERE state IN ('planned', 'interrupted', 'failed') ORDER BY seq").c_str());
  std::optional<RunRow> found;
  while (q.Step()) {
    if (skip.count(q.Text(0))) continue;
    RunRow r = ReadRow(q, true);
    if (accept && !accept(r)) continue;
    found = std::move(r);
    break;
  }
  if (!found) return std::nullopt;
  Statement u = store.Prepare(
      "UPDATE runs SET state = 'running', attempts = attempts + 1, host = ?2, started_at = ?3, ended_at = NULL, "
      "lease_holder = ?4, lease_host = ?2, lease_pid = ?5, lease_heartbeat = ?3, granary_version = ?6, "
      "git_commit = ?7, job_array = NULL, job_index = NULL, job_state = NULL "
      "WHERE run_id = ?1 AND state IN ('planned', 'interrupted', 'failed')");
  u.Bind(1, found->run_id).Bind(2, me.host).Bind(3, now).Bind(4, me.id).Bind(5, me.pid);
  u.Bind(6, GRANARY_VERSION).Bind(7, granary::GitCommit()).Run();
  if (sqlite3_changes(store.Handle()) != 1) return std::nullopt;
  tx.Commit();
  found->state = RunState::kRunning;
  found->attempts += 1;
  found->started_at = now;
  return found;
}

int RequeueDoneRuns(Store& store, const std::vector<std::string>& run_ids, const std::string& reason) {
  Transaction tx(store);
  Statement u = store.Prepare(
      "UPDATE runs SET state = 'planned', failure = ?2, end_reason = NULL, summary = NULL, ended_at = NULL, "
      "wall_s = NULL WHERE run_id = ?1 AND state = 'done'");
  Statement del = store.Prepare("DELETE FROM results WHERE run_id = ?1");
  int n = 0;
  for (const auto& id : run_ids) {
    u.Reset();
    u.Bind(1, id).Bind(2, reason).Run();
    if (sqlite3_changes(store.Handle()) != 1) continue;
    ++n;
    del.Reset();
    del.Bind(1, id).Run();
  }
  tx.Commit();
  return n;
}

std::set<std::string> Heartbeat(Store& store, const Holder& me, double now,
                                const std::map<std::string, json>& progress_by_run) {
  Transaction tx(store);
  Statement u = store.Prepare("UPDATE runs SET lease_heartbeat = ?2 WHERE lease_holder = ?1 AND state = 'running'");
  u.Bind(1, me.id).Bind(2, now).Run();
  Statement p =
      store.Prepare("UPDATE runs SET progress = ?2 WHERE run_id = ?1 AND lease_holder = ?3 AND state = 'running'");
  for (const auto& [id, prog] : progress_by_run) {
    p.Reset();
    p.Bind(1, id).Bind(2, prog.dump()).Bind(3, me.id).Run();
  }
  std::set<std::string> held;
  Statement q = store.Prepare("SELECT run_id FROM runs WHERE lease_holder = ?1 AND state = 'running'");
  q.Bind(1, me.id);
  while (q.Step()) held.insert(q.Text(0));
  tx.Commit();
  return held;
}

std::map<std::string, json> FlattenScalars(const json& summary) {
  std::map<std::string, json> out;
  std::function<void(const json&, const std::string&)> walk = [&](const json& j, const std::string& prefix) {
    for (const auto& [key, value] : j.items()) {
      const std::string name = prefix.empty() ? key : prefix + "/" + key;
      if (prefix.empty() && key == "spec") continue;
      if (value.is_object())
        walk(value, name);
      else if (value.is_number() || value.is_string() || value.is_boolean())
        out[name] = value;
    }
  };
  if (summary.is_object()) walk(summary, "");
  return out;
}

namespace {

// The scalars of summary.json as the run's results, replacing any earlier ones.
void StoreResults(Store& store, const std::string& run_id, const json& summary) {
  Statement del = store.Prepare("DELETE FROM results WHERE run_id = ?1");
  del.Bind(1, run_id).Run();
  Statement ins = store.Prepare("INSERT INTO results (run_id, key, value, text) VALUES (?1, ?2, ?3, ?4)");
  for (const auto& [key, value] : FlattenScalars(summary)) {
    ins.Reset();
    ins.Bind(1, run_id).Bind(2, key);
    if (value.is_number())
      ins.Bind(3, value.get<double>()).BindNull(4);
    else if (value.is_boolean())
      ins.Bind(3, value.get<bool>() ? 1.0 : 0.0).BindNull(4);
    else
      ins.BindNull(3).Bind(4, value.get<std::string>());
    ins.Run();
  }
}

}  // namespace

bool RecordDone(Store& store, const std::string& run_id, const std::string& holder, const json& summary, double now,
                double wall_s) {
  Transaction tx(store);
  Statement u = store.Prepare(
      "UPDATE runs SET state = 'done', ended_at = ?2, wall_s = ?3, end_reason = ?4, engine_version = ?5, "
      "summary = ?6, failure = NULL, lease_holder = NULL, lease_host = NULL, lease_pid = NULL, "
      "lease_heartbeat = NULL WHERE run_id = ?1 AND state = 'running' AND lease_holder = ?7");
  u.Bind(1, run_id).Bind(2, now).Bind(3, wall_s).Bind(4, summary.value("end_reason", std::string()));
  u.Bind(5, summary.value("engine_version", std::string())).Bind(6, summary.dump()).Bind(7, holder).Run();
  if (sqlite3_changes(store.Handle()) != 1) return false;  // rolled back: not ours any more
  StoreResults(store, run_id, summary);
  tx.Commit();
  return true;
}

bool RecordEnd(Store& store, const std::string& run_id, const std::string& holder, RunState state,
               const std::string& reason, double now, double wall_s) {
  Transaction tx(store);
  Statement u = store.Prepare(
      "UPDATE runs SET state = ?2, failure = ?3, ended_at = ?4, wall_s = ?5, end_reason = ?6, lease_holder = NULL, "
      "lease_host = NULL, lease_pid = NULL, lease_heartbeat = NULL "
      "WHERE run_id = ?1 AND state = 'running' AND lease_holder = ?7");
  const std::string word = ToString(state);
  u.Bind(1, run_id).Bind(2, word).Bind(3, reason).Bind(4, now).Bind(5, wall_s).Bind(6, word).Bind(7, holder).Run();
  if (sqlite3_changes(store.Handle()) != 1) return false;
  tx.Commit();
  return true;
}

void StoreMetrics(Store& store, const std::vector<RunMetrics>& runs, double now) {
  static constexpr char kDelete[] = "DELETE FROM metrics WHERE run_id = ?1 AND analysis = ?2";
  static constexpr char kInsert[] =
      "INSERT INTO metrics (run_id, analysis, metric, value, se, unit) VALUES (?1, ?2, ?3, ?4, ?5, ?6)";
  static constexpr char kAnalysis[] =
      "INSERT OR REPLACE INTO analyses (run_id, analysis, version, options, analysed_at) VALUES (?1, ?2, ?3, ?4, ?5)";
  Transaction tx(store);
  Statement del = store.Prepare(kDelete), ins = store.Prepare(kInsert), ana = store.Prepare(kAnalysis);
  for (const RunMetrics& r : runs) {
    del.Reset();
    del.Bind(1, r.run_id).Bind(2, r.analysis).Run();
    for (const MetricRow& m : r.metrics) {
      ins.Reset();
      ins.Bind(1, r.run_id).Bind(2, r.analysis).Bind(3, m.name).Bind(6, m.unit);
      if (std::isfinite(m.value))
        ins.Bind(4, m.value);
      else
        ins.BindNull(4);
      if (std::isfinite(m.se))
        ins.Bind(5, m.se);
      else
        ins.BindNull(5);
      ins.Run();
    }
    ana.Reset();
    ana.Bind(1, r.run_id).Bind(2, r.analysis).Bind(3, r.version).Bind(4, r.options.dump()).Bind(5, now).Run();
  }
  tx.Commit();
}

void ForgetMetrics(Store& store, const std::vector<std::string>& run_ids) {
  if (run_ids.empty()) return;
  Transaction tx(store);
  Statement metrics = store.Prepare("DELETE FROM metrics WHERE run_id = ?1");
  Statement analyses = store.Prepare("DELETE FROM analyses WHERE run_id = ?1");
  for (const std::string& id : run_ids) {
    metrics.Reset();
    metrics.Bind(1, id).Run();
    analyses.Reset();
    analyses.Bind(1, id).Run();
  }
  tx.Commit();
}

void RecordJobArray(Store& store, const Holder& me, const JobArray& array, double now) {
  Transaction tx(store);
  Statement a = store.Prepare(
      "INSERT INTO job_arrays (dir, script, name, array, job_id, submitted_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  a.Bind(1, array.dir).Bind(2, array.script).Bind(3, array.name).Bind(4, array.array);
  if (array.job_id.empty())
    a.BindNull(5);
  else
    a.Bind(5, array.job_id);
  a.Bind(6, now).Run();
  const std::int64_t id = sqlite3_last_insert_rowid(store.Handle());
  Statement u = store.Prepare(
      "UPDATE runs SET job_array = ?2, job_index = ?3, job_state = 'PENDING' "
      "WHERE run_id = ?1 AND state = 'running' AND lease_holder = ?4");
  for (const auto& [run_id, index] : array.runs) {
    u.Reset();
    u.Bind(1, run_id).Bind(2, id).Bind(3, index).Bind(4, me.id).Run();
  }
  tx.Commit();
}

std::map<std::string, std::vector<RunMetrics>> LoadMetrics(Store& store) {
  static constexpr char kSelect[] =
      "SELECT m.run_id, m.analysis, a.version, m.metric, m.value, m.se, m.unit FROM metrics m "
      "JOIN analyses a ON a.run_id = m.run_id AND a.analysis = m.analysis ORDER BY m.run_id, m.analysis, m.rowid";
  std::map<std::string, std::vector<RunMetrics>> out;
  Statement q = store.Prepare(kSelect);
  while (q.Step()) {
    std::vector<RunMetrics>& list = out[q.Text(0)];
    if (list.empty() || list.back().analysis != q.Text(1))
      list.push_back({q.Text(0), q.Text(1), static_cast<int>(q.Integer(2)), nullptr, {}});
    const double nan = std::numeric_limits<double>::quiet_NaN();
    list.back().metrics.push_back({q.Text(3), q.Text(6), q.IsNull(4) ? nan : q.Real(4), q.IsNull(5) ? nan : q.Real(5)});
  }
  return out;
}

void RecordJobId(Store& store, const std::string& script, const std::string& job_id) {
  Statement u = store.Prepare("UPDATE job_arrays SET job_id = ?2 WHERE script = ?1");
  u.Bind(1, script).Bind(2, job_id).Run();
}

void RecordJobStates(Store& store, const std::map<std::string, std::string>& state_by_run) {
  if (state_by_run.empty()) return;
  Transaction tx(store);
  Statement u = store.Prepare("UPDATE runs SET job_state = ?2 WHERE run_id = ?1 AND job_array IS NOT NULL");
  for (const auto& [run_id, state] : state_by_run) {
    u.Reset();
    u.Bind(1, run_id).Bind(2, state).Run();
  }
  tx.Commit();
}

std::vector<RunRow> AdoptQueuedRuns(Store& store, const Holder& me, double now) {
  Transaction tx(store);
  std::vector<RunRow> adopted;
  {
    Statement q = store.Prepare(
        (std::string(kRunColumns) + "WHERE state = 'running' AND job_array IS NOT NULL ORDER BY seq").c_str());
    while (q.Step()) {
      RunRow r = ReadRow(q, true);
      if (r.lease_holder == me.id) continue;
      if (!r.lease_holder.empty() && !LeaseExpired(r, me.host, now)) continue;  // watched by a live runner
      adopted.push_back(std::move(r));
    }
  }
  Statement u = store.Prepare(
      "UPDATE runs SET lease_holder = ?2, lease_host = ?3, lease_pid = ?4, lease_heartbeat = ?5 "
      "WHERE run_id = ?1 AND state = 'running' AND job_array IS NOT NULL");
  for (auto& r : adopted) {
    u.Reset();
    u.Bind(1, r.run_id).Bind(2, me.id).Bind(3, me.host).Bind(4, me.pid).Bind(5, now).Run();
    r.lease_holder = me.id;
    r.lease_host = me.host;
    r.lease_pid = me.pid;
    r.lease_heartbeat = now;
  }
  tx.Commit();
  return adopted;
}

int ReleaseQueuedRuns(Store& store, const Holder& me) {
  Statement u = store.Prepare(
      "UPDATE runs SET lease_holder = NULL, lease_host = NULL, lease_pid = NULL, lease_heartbeat = NULL "
      "WHERE lease_holder = ?1 AND state = 'running' AND job_array IS NOT NULL");
  u.Bind(1, me.id).Run();
  return sqlite3_changes(store.Handle());
}

bool SettleRun(Store& store, const RunRow& seen, RunState state, const std::string& reason, const json* summary,
               double wall_s, double now) {
  Transaction tx(store);
  Statement u = store.Prepare(
      "UPDATE runs SET state = ?2, failure = ?3, end_reason = ?4, ended_at = ?5, wall_s = ?6, "
      "engine_version = COALESCE(?7, engine_version), summary = COALESCE(?8, summary), job_state = NULL, "
      "lease_holder = NULL, lease_host = NULL, lease_pid = NULL, lease_heartbeat = NULL "
      "WHERE run_id = ?1 AND state = ?9 AND COALESCE(lease_holder, '') = ?10");
  const std::string word = ToString(state);
  u.Bind(1, seen.run_id).Bind(2, word);
  if (summary) {
    u.BindNull(3)
        .Bind(4, summary->value("end_reason", std::string()))
        .Bind(7, summary->value("engine_version", std::string()));
    u.Bind(8, summary->dump());
  } else {
    u.Bind(3, reason).Bind(4, word).BindNull(7).BindNull(8);
  }
  u.Bind(5, now).Bind(6, wall_s).Bind(9, std::string(ToString(seen.state))).Bind(10, seen.lease_holder).Run();
  if (sqlite3_changes(store.Handle()) != 1) return false;
  if (summary) {
    StoreResults(store, seen.run_id, *summary);
  }
  tx.Commit();
  return true;
}

}  // namespace granary::runner
