// What the verbs of the `campaign` command line share: the flag parser, the verb table's row,
// the usage error, and small helpers for the database and for printing runs. Each verb family
// lives in its own file of this folder and declares its rows there (verbs.cpp lists them).
#pragma once

#include <functional>
#include <iosfwd>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "runner/campaign_db.h"
#include "runner/run_filter.h"
#include "runner/store.h"

namespace granary::runner::cli {

class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parsed flags of one verb: --name value, --name=value, or --name for booleans. A flag given
// twice keeps both values (--only); Get() gives the last.
struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::vector<std::string>> flags;
  bool Has(const std::string& f) const { return flags.count(f) > 0; }
  std::string Get(const std::string& f, const std::string& def) const {
    auto it = flags.find(f);
    return it == flags.end() ? def : it->second.back();
  }
  std::vector<std::string> All(const std::string& f) const {
    auto it = flags.find(f);
    return it == flags.end() ? std::vector<std::string>{} : it->second;
  }
  double Number(const std::string& f, double def) const {
    if (!Has(f)) return def;
    const std::string& v = flags.at(f).back();
    try {
      std::size_t used = 0;
      const double x = std::stod(v, &used);
      if (used != v.size() || !std::isfinite(x)) throw std::invalid_argument(v);
      return x;
    } catch (const std::exception&) {
      throw UsageError("--" + f + ": must be a number (got \"" + v + "\")");
    }
  }
  int Integer(const std::string& f, int def, int min) const {
    const double x = Number(f, def);
    if (x != std::floor(x) || x < min || x > 1e6) {
      throw UsageError("--" + f + ": must be an integer >= " + std::to_string(min) + " (got \"" + Get(f, "") + "\")");
    }
    return static_cast<int>(x);
  }
};

struct FlagSpec {
  std::string name;
  bool takes_value;
};

// What the positional argument of a verb is, for bash completion.
enum class Operand { kNone, kFile, kRun, kShell };

// One row of the verb table: what `campaign --help`, `campaign VERB --help`, the parser and
// bash completion know of a verb.
struct Verb {
  const char* name;
  const char* summary;
  const char* help;
  std::function<int(const std::vector<std::string>&, std::ostream&, std::ostream&)> run;
  std::vector<FlagSpec> flags;  // what Parse accepts and bash completion offers
  Operand operand = Operand::kNone;
};

// Every verb, in the order `campaign --help` lists them (verbs.cpp).
const std::vector<Verb>& Verbs();

Args Parse(const std::vector<std::string>& argv, const std::vector<FlagSpec>& known, const std::string& verb);
// The flags of a verb, from the verb table.
const std::vector<FlagSpec>& FlagsOf(const std::string& verb);
Args Parse(const std::vector<std::string>& argv, const std::string& verb);

std::string DbPath(const Args& a);
std::filesystem::path DbDir(const std::string& db);
std::string Duration(double s);
std::string CompactPoint(const nlohmann::json& point);
// The same with each axis by its short name where `short_names` (pointer -> name) has one.
std::string CompactPoint(const nlohmann::json& point, const std::map<std::string, std::string>& short_names);
// pointer -> short name ("W", "X_db", ...) of every sweep axis of a campaign spec as given, the
// names the report, --only and the export use; empty if the analyses are not built in or the
// spec's axes do not resolve.
std::map<std::string, std::string> ShortAxisNames(const nlohmann::json& campaign_spec);
std::string Bar(double fraction, int width);

// The database of an existing campaign (only `plan` and `compare` create one): a missing file,
// a directory, an empty file or a file that is not a campaign database is said plainly.
// `read_only_ok`: the verb only reads (status, show, report, export), so a database nobody may
// write here (a read-only directory or mount) is opened read-only instead of failing.
std::unique_ptr<Store> OpenCampaignDb(const std::string& db, const std::string& verb, bool read_only_ok = false);

// The --only filters of a verb, resolved and checked against the campaign's runs.
RunFilter ResolveOnly(const Args& a, const CampaignRow& campaign, const std::vector<RunRow>& runs);

// A run's progress.json as one short line: phase, bar, percent, simulated time, exits, and
// with `eta` the discharge's ETA from the engine's own wall time at the fraction it reported
// (steady between two reports: a clock that ran on while the fraction stood still made it
// count up); none in the bed phase, whose length is not known ahead.
std::string ProgressText(const nlohmann::json& progress, bool eta);

}  // namespace granary::runner::cli
