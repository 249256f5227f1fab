// `campaign scan`, `clean`, `schema` and `completion`: keeping a campaign and its tools in order.
// Flags in docs/cli.md.

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "runner/campaign_db.h"
#include "runner/campaign_spec.h"
#include "runner/cli/common.h"
#include "runner/inspect.h"
#include "runner/scan.h"
#include "runner/scheduler.h"
#include "runner/executor.h"
#include "runner/util.h"

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char kScanHelp[] =
    "usage: campaign scan [--db FILE] [--dry-run] [--json] [--verify]\n"
    "Rebuild every run's state from its run directory (DONE and summary.json: done, ingested), and\n"
    "for runs in a Slurm queue from one squeue call (a task that left the queue ended as its\n"
    "directory says). Safe at any time, also while jobs run; runs a live runner holds are\n"
    "reported, not written. The way to collect a campaign submitted with --detach.\n"
    "  --dry-run    show what would change, write nothing\n"
    "  --json       {\"runs\", \"counts\", \"agrees\", \"changes\": [{\"run_id\", \"from\", \"to\", \"reason\", \"written\"}],\n"
    "               \"lost\": [run ids of done runs whose directory was deleted]}\n"
    "  --verify     also check every done run's files against the manifest its engine wrote\n"
    "               (every checksum and count, every byte read): damaged runs are listed with\n"
    "               each file and what differs; with --json, \"verify\": {\"whole\", \"damaged\":\n"
    "               [{\"run_id\", \"problems\": [{\"file\", \"what\"}]}], \"not_verifiable\"}\n"
    "Exit: 0 (also when states changed), 4 --verify found damaged runs, 2 usage error, 3 storage\n"
    "error (database unreadable or unwritable).\n";

// scan --verify: every done run's every checksum; the damaged ones with what differs.
int VerifyCampaign(Store& store, bool as_json, std::ostream& out, std::ostream& err, json* doc) {
  const std::vector<RunRow> runs = LoadRuns(store, false);
  const bool tty = &err == &std::cerr && isatty(STDERR_FILENO);
  const auto checks = CheckDoneRuns(runs, rundir::VerifyLevel::kChecksums, [&](int done, int total) {
    if (tty)
      err << "\rverifying runs " << Bar(static_cast<double>(done) / std::max(1, total), 30) << " " << done << "/"
          << total << (done == total ? "\n" : "") << std::flush;
  });
  const IntegrityCounts counts = CountIntegrity(checks);
  if (as_json) {
    json damaged = json::array();
    for (const auto& [id, v] : checks) {
      if (v.integrity != rundir::Integrity::kDamaged) continue;
      json problems = json::array();
      for (const auto& p : v.problems) problems.push_back({{"file", p.file}, {"what", p.what}});
      damaged.push_back({{"run_id", id}, {"problems", problems}});
    }
    (*doc)["verify"] = {{"whole", counts.whole}, {"damaged", damaged}, {"not_verifiable", counts.not_verifiable}};
  } else {
    out << "  verified " << checks.size() << " done run(s) against their manifests: " << counts.whole << " whole, "
        << counts.damaged << " damaged, " << counts.not_verifiable << " not verifiable (written before manifests)\n";
    for (const auto& [id, v] : checks) {
      if (v.integrity != rundir::Integrity::kDamaged) continue;
      out << "  damaged " << id << ":\n";
      for (const auto& p : v.problems) out << "    " << p.file << ": " << p.what << "\n";
    }
  }
  return counts.damaged > 0 ? kExitDamagedRuns : 0;
}

int Scan(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args a = Parse(argv, "scan");
  if (!a.positional.empty()) throw UsageError("campaign scan: unexpected argument \"" + a.positional[0] + "\"");
  const std::string db = DbPath(a);
  const auto opened = OpenCampaignDb(db, "scan");
  Store& store = *opened;
  if (!LoadCampaign(store)) throw UsageError("campaign scan: " + db + " holds no campaign");
  const ScanReport r = ScanCampaign(store, DefaultBatchQueue(), a.Has("dry-run"));
  if (a.Has("json")) {
    json changes = json::array();
    for (const auto& c : r.changes) {
      changes.push_back({{"run_id", c.run_id},
                         {"from", ToString(c.from)},
                         {"to", ToString(c.to)},
                         {"reason", c.reason},
                         {"written", c.written}});
    }
    json doc = {
        {"runs", r.runs}, {"counts", r.counts}, {"agrees", r.changes.empty()}, {"changes", changes}, {"lost", r.lost}};
    if (!r.queue_error.empty()) doc["queue_error"] = r.queue_error;
    const int code = a.Has("verify") ? VerifyCampaign(store, true, out, err, &doc) : 0;
    out << doc.dump(2) << "\n";
    return code;
  }
  out << "campaign scan: " << r.runs << " runs;";
  for (const auto& [state, n] : r.counts) out << " " << state << " " << n;
  out << "\n";
  if (!r.queue_error.empty())
    out << "  squeue did not answer (" << r.queue_error << "): queued runs left as they were\n";
  if (r.changes.empty()) out << "  the database agrees with the run directories\n";
  if (!r.lost.empty()) {
    out << "  " << r.lost.size() << " done run(s) have no run directory (first " << r.lost.front()
        << "): left done, their results are in the database only (campaign run --rerun-lost runs them again)\n";
  }
  for (const auto& c : r.changes) {
    out << "  " << c.run_id << "  " << c.from << " -> " << c.to
        << (c.written          ? ""
            : a.Has("dry-run") ? " (dry run)"
                               : " (not written)")
        << (c.reason.empty() ? "" : ": " + c.reason.substr(0, c.reason.find('\n'))) << "\n";
  }
  return a.Has("verify") ? VerifyCampaign(store, false, out, err, nullptr) : 0;
}

const char kCleanHelp[] =
    "usage: campaign clean [--retired] [--failed] [--beds] [--locks] [--frames] [--dry-run] [--db FILE] [--json]\n"
    "Give disk space back: remove the directories of retired runs (no longer in the spec), lock\n"
    "files nobody holds and, when asked, failed runs' directories and cached beds. Says what it\n"
    "removed and how much space that freed. Without a choice: --retired --locks.\n"
    "  --retired  directories of retired runs; if a later plan brings one back, it runs again\n"
    "  --failed   directories of failed runs (they start afresh on the next campaign run)\n"
    "  --beds     cached beds that only this campaign's done or retired runs use (other campaigns'\n"
    "             beds are never touched; a bed needed again is prepared again)\n"
    "  --locks    lock files (bed cache, run directories of runs not running) that nobody holds\n"
    "  --frames   frames and contact frames of done runs whose analyses are cached (campaign report\n"
    "             first); recorded in each run's manifest.json. The cached results still report;\n"
    "             an analysis not cached then (new options, new analysis) needs the run run again\n"
    "  --dry-run  say what would be removed and how much it would free; remove nothing\n"
    "Never touches done, planned, running or interrupted runs' directories.\n"
    "Exit: 0, 2 usage error, 3 storage error.\n";

int Clean(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "clean");
  if (!a.positional.empty()) throw UsageError("campaign clean: unexpected argument \"" + a.positional[0] + "\"");
  const std::string db = DbPath(a);
  const auto opened = OpenCampaignDb(db, "clean");
  Store& store = *opened;
  CleanOptions o;
  const bool chosen = a.Has("retired") || a.Has("failed") || a.Has("beds") || a.Has("locks") || a.Has("frames");
  o.retired = !chosen || a.Has("retired");
  o.locks = !chosen || a.Has("locks");
  o.failed = a.Has("failed");
  o.beds = a.Has("beds");
  o.frames = a.Has("frames");
  o.cache_dir = DefaultCacheDir();
  // A running runner may be writing into failed runs' directories (retries).
  if (o.failed)
    for (const RunRow& r : LoadRuns(store, false))
      if (r.state == RunState::kRunning && !LeaseExpired(r, ThisProcessHolder().host, NowSeconds()))
        throw UsageError("campaign clean --failed: a campaign run is running on " + db +
                         " (it retries failed runs); clean when it has finished");
  std::vector<std::string> frames_kept;
  const std::vector<CleanItem> items = PlanClean(store, o, &frames_kept);
  const bool dry = a.Has("dry-run");
  std::map<std::string, std::pair<int, std::uintmax_t>> by_kind;
  std::uintmax_t total = 0;
  for (const CleanItem& it : items) {
    by_kind[it.kind].first += 1;
    by_kind[it.kind].second += it.bytes;
    total += it.bytes;
  }
  const std::uintmax_t freed = dry ? 0 : ExecuteClean(store, items);
  if (a.Has("json")) {
    json list = json::array();
    for (const CleanItem& it : items)
      list.push_back({{"kind", it.kind}, {"path", it.path.string()}, {"run_id", it.run_id}, {"bytes", it.bytes}});
    json j = {{"dry_run", dry}, {"items", list}, {"bytes", total}, {"freed_bytes", freed}};
    if (o.frames) j["frames_kept"] = frames_kept;
    out << j.dump(2) << "\n";
    return 0;
  }
  out << "campaign clean" << (dry ? " (dry run: nothing removed)" : "") << "\n";
  const std::pair<const char*, const char*> kinds[] = {{"retired", "retired runs' directories"},
                                                       {"failed", "failed runs' directories"},
                                                       {"bed", "cached beds"},
                                                       {"lock", "lock files nobody holds"},
                                                       {"frames", "frames of analysed runs"}};
  for (const auto& [kind, label] : kinds) {
    const bool asked = (std::string(kind) == "retired" && o.retired) || (std::string(kind) == "failed" && o.failed) ||
                       (std::string(kind) == "bed" && o.beds) || (std::string(kind) == "lock" && o.locks) ||
                       (std::string(kind) == "frames" && o.frames);
    if (!asked) continue;
    const auto& [n, bytes] = by_kind[kind];
    out << "  " << std::left << std::setw(28) << label << std::right << std::setw(5) << n << "  " << std::setw(10)
        << HumanBytes(bytes) << "\n";
  }
  if (o.frames) {
    std::set<std::string> runs, cached;
    for (const CleanItem& it : items)
      if (it.kind == "frames" && runs.insert(it.run_id).second)
        for (const std::string& k : CachedAnalyses(it.path.parent_path())) cached.insert(k);
    if (!runs.empty()) {
      out << "  the reports of these " << runs.size() << " run(s) keep their cached analyses:";
      for (const std::string& k : cached) out << " " << k;
      out << "\n  no longer computable for them (they need the frames): any other analysis, and these with new "
             "options or a new version; the report then says so and names the run\n";
    }
    for (const std::string& k : frames_kept) out << "  kept the frames of " << k << "\n";
  }
  if (dry) {
    out << "would free " << HumanBytes(total) << "\n";
  } else {
    out << "freed " << HumanBytes(freed) << "\n";
  }
  return 0;
}

// ---------------------------------------------------------------- schema, completion
const char kSchemaHelp[] =
    "usage: campaign schema [--out FILE]\n"
    "Print the JSON Schema of campaign specs: every key, its type, default, range and meaning,\n"
    "generated from the tables the validator reads (docs/campaign-spec.md). An editor that\n"
    "knows it checks a spec as it is typed and completes its keys (VS Code: docs/campaign-spec.md,\n"
    "\"Editing specs\"). The repository keeps a copy in docs/campaign.schema.json.\n"
    "  --out FILE   write it to FILE instead of stdout\n"
    "Exit: 0, 1 FILE cannot be written, 2 usage error.\n";

int Schema(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "schema");
  if (!a.positional.empty()) throw UsageError("campaign schema: unexpected argument \"" + a.positional[0] + "\"");
  const std::string text = CampaignSpecSchema().dump(2) + "\n";
  if (!a.Has("out")) {
    out << text;
    return 0;
  }
  const std::string file = a.Get("out", "");
  std::ofstream f(file);
  f << text;
  if (!f) throw std::runtime_error("campaign schema: cannot write " + file);
  out << "schema: " << file << "\n";
  return 0;
}

const char kCompletionHelp[] =
    "usage: campaign completion bash\n"
    "Print the bash completion of campaign: verbs, each verb's flags, run ids and --only filters\n"
    "from the database (--db, or granary.db here), engines and colours. To use it now:\n"
    "  source <(campaign completion bash)\n"
    "and for every shell, put that line into ~/.bashrc (or the output into\n"
    "/etc/bash_completion.d/campaign).\n"
    "Exit: 0, 2 usage error (a shell other than bash).\n";

// The script: bash asks the binary (`campaign __complete CWORD WORDS...`), so completion knows
// exactly the verbs and flags that the parser accepts and the run ids in the database.
const char kBashCompletion[] = R"(# bash completion for campaign (Granary): source <(campaign completion bash)
_campaign() {
  local IFS=$'\n'
  local words
  words=$("${COMP_WORDS[0]}" __complete "$COMP_CWORD" "${COMP_WORDS[@]}" 2>/dev/null) || return
  if [[ "$words" == "__files__" ]]; then
    COMPREPLY=($(compgen -f -- "${COMP_WORDS[COMP_CWORD]}"))
    compopt -o filenames 2>/dev/null
    return
  fi
  COMPREPLY=($(compgen -W "$words" -- "${COMP_WORDS[COMP_CWORD]}"))
}
complete -F _campaign campaign
)";

int Completion(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "completion");
  if (a.positional.size() != 1 || a.positional[0] != "bash")
    throw UsageError("campaign completion: give the shell: campaign completion bash");
  out << kBashCompletion;
  return 0;
}

}  // namespace

Verb ScanVerb() {
  return {"scan",
          "rebuild run states from the run directories (and the Slurm queue)",
          kScanHelp,
          Scan,
          {{"db", true}, {"dry-run", false}, {"json", false}, {"verify", false}, {"help", false}}};
}

Verb CleanVerb() {
  return {"clean",
          "remove retired (and failed) runs' directories, unused beds, stale locks, analysed frames",
          kCleanHelp,
          Clean,
          {{"db", true},
           {"retired", false},
           {"failed", false},
           {"beds", false},
           {"locks", false},
           {"frames", false},
           {"dry-run", false},
           {"json", false},
           {"help", false}}};
}

Verb SchemaVerb() {
  return {"schema",
          "the JSON Schema of campaign specs (for editors)",
          kSchemaHelp,
          Schema,
          {{"out", true}, {"help", false}}};
}

Verb CompletionVerb() {
  return {"completion",   "bash completion of verbs, flags and run ids", kCompletionHelp, Completion, {{"help", false}},
          Operand::kShell};
}

}  // namespace granary::runner::cli
