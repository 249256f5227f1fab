// See common.h.
#include "runner/cli/common.h"

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

#include "runner/util.h"
#ifdef GRANARY_HAVE_ANALYSIS
#include "analysis/axes.h"
#endif

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

Args Parse(const std::vector<std::string>& argv, const std::vector<FlagSpec>& known, const std::string& verb) {
  Args a;
  std::vector<std::string> names;
  for (const auto& k : known) names.push_back(k.name);
  for (std::size_t i = 0; i < argv.size(); ++i) {
    const std::string& s = argv[i];
    if (s.rfind("--", 0) != 0 || s == "--") {
      a.positional.push_back(s);
      continue;
    }
    std::string name = s.substr(2);
    std::string value;
    bool inline_value = false;
    if (auto eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
      inline_value = true;
    }
    auto it = std::find_if(known.begin(), known.end(), [&](const FlagSpec& f) { return f.name == name; });
    if (it == known.end()) {
      const std::string best = Nearest(name, names);
      throw UsageError("campaign " + verb + ": unknown flag --" + name +
                       (best.empty() ? "" : "; did you mean --" + best + "?") + " (see campaign " + verb + " --help)");
    }
    if (it->takes_value && !inline_value) {
      if (i + 1 >= argv.size()) throw UsageError("--" + name + ": needs a value");
      value = argv[++i];
    }
    a.flags[name].push_back(value);
  }
  return a;
}

Args Parse(const std::vector<std::string>& argv, const std::string& verb) { return Parse(argv, FlagsOf(verb), verb); }

std::string DbPath(const Args& a) { return a.Get("db", "granary.db"); }

fs::path DbDir(const std::string& db) {
  const fs::path p = fs::absolute(db).parent_path();
  return p;
}

std::string Duration(double s) {
  if (!(s >= 0) || !std::isfinite(s)) return "?";
  const long t = std::lround(s);
  std::ostringstream o;
  if (t >= 3600)
    o << t / 3600 << "h" << std::setw(2) << std::setfill('0') << (t % 3600) / 60 << "m";
  else if (t >= 60)
    o << t / 60 << "m" << std::setw(2) << std::setfill('0') << t % 60 << "s";
  else
    o << t << "s";
  return o.str();
}

std::string CompactPoint(const json& point) { return CompactPoint(point, {}); }

std::map<std::string, std::string> ShortAxisNames(const json& campaign_spec) {
  std::map<std::string, std::string> names;
#ifdef GRANARY_HAVE_ANALYSIS
  try {
    const analysis::CampaignAxes axes = analysis::CampaignAxes::OfCampaignSpec(campaign_spec);
    for (const std::string& pointer : axes.Sweep()) names[pointer] = axes.ShortName(pointer);
  } catch (const std::exception&) {
    names.clear();  // plan reports what is wrong with the axes; the labels fall back to pointers
  }
#else
  (void)campaign_spec;
#endif
  return names;
}

std::string CompactPoint(const json& point, const std::map<std::string, std::string>& short_names) {
  std::string out;
  for (const auto& [key, value] : point.items()) {
    if (!out.empty()) out += " ";
    if (const auto named = short_names.find(key); named != short_names.end()) {
      out += named->second + "=" + value.dump();
      continue;
    }
    const auto slash = key.rfind('/');
    std::string label = key.substr(slash + 1);
    // "/silo/base_outlets/0/width" -> "base_outlets/0/width" is clearer than "width".
    if (!label.empty() && std::isdigit(static_cast<unsigned char>(label[0])))
      label = key;
    else if (slash != std::string::npos && slash > 0) {
      const auto prev = key.rfind('/', slash - 1);
      const std::string parent = key.substr(prev + 1, slash - prev - 1);
      if (!parent.empty() && std::isdigit(static_cast<unsigned char>(parent[0]))) label = key.substr(1);
    }
    out += label + "=" + value.dump();
  }
  return out.empty() ? "-" : out;
}

std::string Bar(double fraction, int width) {
  const int filled = static_cast<int>(std::lround(std::clamp(fraction, 0.0, 1.0) * width));
  std::string bar(static_cast<std::size_t>(width) + 2, '.');
  bar.front() = '[';
  bar.back() = ']';
  for (int i = 0; i < filled; ++i) bar[static_cast<std::size_t>(i) + 1] = '#';
  return bar;
}

std::unique_ptr<Store> OpenCampaignDb(const std::string& db, const std::string& verb, bool read_only_ok) {
  if (!fs::exists(db)) {
    throw UsageError("campaign " + verb + ": no database " + db + " (campaign plan SPEC --db " + db + " makes one)");
  }
  std::error_code ec;
  if (!fs::is_directory(db) && fs::file_size(db, ec) == 0 && !ec) {
    throw StoreError(SQLITE_NOTADB, "database " + db +
                                        " is empty (0 bytes): whatever campaign it held is lost (was it "
                                        "truncated, or copied while the disk was full?); plan a campaign into it again "
                                        "with campaign plan SPEC --db " +
                                        db);
  }
  const fs::path dir = fs::path(db).parent_path().empty() ? fs::path(".") : fs::path(db).parent_path();
  if (read_only_ok && !fs::is_directory(db) && (::access(db.c_str(), W_OK) != 0 || ::access(dir.c_str(), W_OK) != 0))
    return std::make_unique<Store>(db, Store::ReadOnly{});
  try {
    return std::make_unique<Store>(db);
  } catch (const StoreError& e) {
    // Not a campaign database at all (a directory, another file): the user gave the wrong path.
    if (e.Code() == SQLITE_NOTADB || fs::is_directory(db)) throw UsageError("campaign " + verb + ": " + e.what());
    throw;
  }
}

RunFilter ResolveOnly(const Args& a, const CampaignRow& campaign, const std::vector<RunRow>& runs) {
  try {
    return ResolveFilters(a.All("only"), campaign, runs);
  } catch (const FilterError& e) {
    throw UsageError(e.what());
  }
}

std::string ProgressText(const json& progress, bool eta) {
  double f = 0;
  std::string phase = "starting";
  std::ostringstream o;
  if (progress.is_object()) {
    f = std::clamp(progress.value("fraction", 0.0), 0.0, 1.0);
    phase = progress.value("phase", std::string("?"));
  }
  o << std::left << std::setw(9) << phase << " " << Bar(f, 20) << " " << std::right << std::setw(3)
    << std::lround(f * 100) << "%";
  if (progress.is_object() && progress.contains("t") && progress.at("t").is_number()) {
    // The bed phase has no end time (t_end 0): its simulated time alone.
    const double t_end =
        progress.contains("t_end") && progress.at("t_end").is_number() ? progress.at("t_end").get<double>() : 0.0;
    o << "  t " << std::fixed << std::setprecision(1) << progress.at("t").get<double>();
    if (t_end > 0) o << "/" << t_end;
    o.unsetf(std::ios::fixed);
  }
  if (progress.is_object() && progress.contains("exited") && progress.at("exited").is_number())
    o << "  " << progress.at("exited").get<long long>() << " exits";
  if (eta && phase == "discharge") {
    const double wall = progress.value("wall_s", 0.0);
    o << "  ETA " << (f > 0.01 && wall > 0 ? Duration(wall * (1 - f) / f) : std::string("?"));
  }
  return o.str();
}

}  // namespace granary::runner::cli
