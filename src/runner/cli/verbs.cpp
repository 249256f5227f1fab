// The verb table and the dispatcher of the `campaign` command line (run_cli in runner/cli.h).
// A verb is a function returning its row, in its family's file of this folder; adding one is
// that file (or a function in one) and a row below.
#include "runner/cli.h"

#include <cstdlib>
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

#include "rundir/version.h"
#include "runner/campaign_db.h"
#include "runner/cli/common.h"
#include "runner/scheduler.h"
#include "runner/store.h"
#include "runner/util.h"

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

// The rows, in the order `campaign --help` lists them; each is defined in its verb's file.
Verb PlanVerb();        // plan.cpp
Verb RunVerb();         // run.cpp
Verb StatusVerb();      // status.cpp
Verb ScanVerb();        // maintenance.cpp
Verb ReportVerb();      // report.cpp
Verb ExportVerb();      // report.cpp
Verb CompareVerb();     // report.cpp
Verb FieldsVerb();      // pictures.cpp
Verb ShowVerb();        // status.cpp
Verb CleanVerb();       // maintenance.cpp
Verb DumpVerb();        // frames.cpp
Verb SchemaVerb();      // maintenance.cpp
Verb CompletionVerb();  // maintenance.cpp
Verb SnapshotVerb();    // pictures.cpp
Verb MovieVerb();       // pictures.cpp

const std::vector<Verb>& Verbs() {
  static const std::vector<Verb> kVerbs = {PlanVerb(),   RunVerb(),     StatusVerb(),     ScanVerb(),     ReportVerb(),
                                           ExportVerb(), CompareVerb(), FieldsVerb(),     ShowVerb(),     CleanVerb(),
                                           DumpVerb(),   SchemaVerb(),  CompletionVerb(), SnapshotVerb(), MovieVerb()};
  return kVerbs;
}

const std::vector<FlagSpec>& FlagsOf(const std::string& verb) {
  for (const Verb& v : Verbs())
    if (verb == v.name) return v.flags;
  throw std::logic_error("no verb " + verb);
}

namespace {

// Candidates for the word at `cword` of `words` (words[0] is the program), one per line;
// "__files__" asks the shell for file names. Never fails: completion must stay quiet.
void Complete(int cword, const std::vector<std::string>& words, std::ostream& out) {
  auto say = [&](const std::string& w) { out << w << "\n"; };
  if (cword <= 1 || words.size() < 2) {
    for (const Verb& v : Verbs()) say(v.name);
    say("--help");
    say("--version");
    return;
  }
  const Verb* verb = nullptr;
  for (const Verb& v : Verbs())
    if (words[1] == v.name) verb = &v;
  if (!verb) return;
  const std::string cur = static_cast<std::size_t>(cword) < words.size() ? words[static_cast<std::size_t>(cword)] : "";
  const std::string prev = words[static_cast<std::size_t>(cword) - 1];
  // The database the command line names, for run ids and filters.
  std::string db = "granary.db";
  for (std::size_t i = 2; i + 1 < words.size(); ++i)
    if (words[i] == "--db") db = words[i + 1];
  auto runs_of_db = [&](bool with_params) {
    std::vector<RunRow> runs;
    try {
      if (fs::is_regular_file(db)) {
        Store store(db, Store::ReadOnly{});
        runs = LoadRuns(store, with_params);
      }
    } catch (const std::exception&) {
    }
    return runs;
  };
  const auto flag =
      std::find_if(verb->flags.begin(), verb->flags.end(), [&](const FlagSpec& f) { return prev == "--" + f.name; });
  if (flag != verb->flags.end() && flag->takes_value) {
    const std::string name = flag->name;
    if (name == "engine") {
      say("native");
      say("liggghts");
      say("lammps");
    } else if (name == "color") {
      for (const char* c : {"species", "speed", "rotation", "force"}) say(c);
    } else if (name == "only") {
      std::set<std::string> seen;
      for (const RunRow& r : runs_of_db(false)) {
        seen.insert(r.run_id);
        for (const auto& [axis, value] : r.point.items()) seen.insert(axis + "=" + value.dump());
      }
      for (const auto& w : seen) say(w);
    } else if (name == "db" || name == "out") {
      say("__files__");
    }
    return;
  }
  if (cur.rfind("-", 0) == 0) {
    for (const FlagSpec& f : verb->flags) say("--" + f.name);
    return;
  }
  switch (verb->operand) {
    case Operand::kRun:
      for (const RunRow& r : runs_of_db(false)) say(r.run_id);
      break;
    case Operand::kFile: say("__files__"); break;
    case Operand::kShell: say("bash"); break;
    case Operand::kNone: break;
  }
}

std::string MainHelp() {
  std::string h =
      "usage: campaign VERB [flags]   (campaign VERB --help for its flags)\n"
      "Granary campaign manager: plan, run and report sweeps of 2-D silo discharge simulations.\n\nverbs:\n";
  std::size_t width = 0;
  for (const auto& v : Verbs()) width = std::max(width, std::string(v.name).size());
  for (const auto& v : Verbs())
    h += "  " + std::string(v.name) + std::string(width + 2 - std::string(v.name).size(), ' ') + v.summary + "\n";
  h += "\nexit codes: 0 ok, 1 runs failed, 2 usage or spec error, 3 storage (database or run directories),\n"
       "130 interrupted (docs/cli.md)\n";
  return h;
}

}  // namespace
}  // namespace granary::runner::cli

namespace granary::runner {

using cli::UsageError;
using cli::Verb;

int RunCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    (args.empty() ? err : out) << cli::MainHelp();
    return args.empty() ? static_cast<int>(ExitCode::kUsage) : 0;
  }
  if (args[0] == "__complete") {  // asked by the bash completion script; not a verb of its own
    const int cword = args.size() > 1 ? std::atoi(args[1].c_str()) : 0;
    cli::Complete(cword, std::vector<std::string>(args.begin() + std::min<std::size_t>(2, args.size()), args.end()),
                  out);
    return 0;
  }
  if (args[0] == "--version") {
    out << "campaign " << GRANARY_VERSION << " (" << granary::GitCommit() << ")\n";
    return 0;
  }
  const Verb* verb = nullptr;
  std::vector<std::string> names;
  for (const auto& v : cli::Verbs()) {
    names.push_back(v.name);
    if (args[0] == v.name) verb = &v;
  }
  if (!verb) {
    const std::string best = Nearest(args[0], names);
    err << "campaign: unknown verb \"" << args[0] << "\"" << (best.empty() ? "" : "; did you mean \"" + best + "\"?")
        << "\n"
        << cli::MainHelp();
    return static_cast<int>(ExitCode::kUsage);
  }
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  if (std::find(rest.begin(), rest.end(), "--help") != rest.end() ||
      std::find(rest.begin(), rest.end(), "-h") != rest.end()) {
    out << verb->help;
    return 0;
  }
  try {
    return verb->run(rest, out, err);
  } catch (const UsageError& e) {
    err << "error: " << e.what() << "\n";
    return static_cast<int>(ExitCode::kUsage);
  } catch (const SpecError& e) {
    err << "error: " << e.what() << "\n";
    return static_cast<int>(ExitCode::kUsage);
  } catch (const StoreError& e) {
    err << "error: " << e.what() << "\n";
    return static_cast<int>(ExitCode::kStorage);
  } catch (const std::invalid_argument& e) {  // e.g. an engine executable that does not exist
    err << "error: " << e.what() << "\n";
    return static_cast<int>(ExitCode::kUsage);
  } catch (const std::exception& e) {
    err << "error: " << e.what() << "\n";
    return static_cast<int>(ExitCode::kRunsFailed);
  }
}

}  // namespace granary::runner
