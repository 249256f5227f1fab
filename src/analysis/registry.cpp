// The analyses' table (registry.h) and the reading of /report.
#include "analysis/registry.h"

#include <algorithm>
#include <mutex>

#include "analysis/arches_analysis.h"
#include "analysis/avalanche_analysis.h"
#include "analysis/clogging_index_analysis.h"
#include "analysis/contacts_analysis.h"
#include "analysis/fields_analysis.h"
#include "analysis/flow_analysis.h"
#include "analysis/intermittency_analysis.h"
#include "analysis/options.h"
#include "analysis/orientation_analysis.h"
#include "analysis/profile_analysis.h"
#include "analysis/python_analysis.h"
#include "analysis/region_analysis.h"

namespace granary::analysis {
namespace {

std::mutex& ExtraMutex() {
  static std::mutex m;
  return m;
}
std::vector<AnalysisEntry>& ExtraRows() {
  static std::vector<AnalysisEntry> rows;
  return rows;
}

// Keys of /report read by the pass itself, shared by the analyses.
constexpr const char* kPassKeys[] = {"window", "clog_gap", "frame_stride", "max_frames"};

FlowWindowRule ReadWindow(const nlohmann::json& v, const std::string& path) {
  FlowWindowRule w;
  OptionObject(v, path,
               {"start_time", "start_fraction", "shallow_fraction", "min_events", "stop_at_first_clog",
                "min_exits_before_clog"});
  constexpr double kBig = 1e300;
  for (const auto& [k, x] : v.items()) {
    const std::string p = path + "/" + k;
    if (k == "start_time") w.start_time = OptionNumber(x, p, 0.0, kBig);
    if (k == "start_fraction") w.start_fraction = OptionNumber(x, p, 0.0, 1.0);
    if (k == "shallow_fraction") w.shallow_fraction = OptionNumber(x, p, 0.0, 1.0);
    if (k == "min_events") w.min_events = OptionInteger(x, p, 2, 1000000000);
    if (k == "stop_at_first_clog") w.stop_at_first_clog = OptionBool(x, p);
    if (k == "min_exits_before_clog") w.min_exits_before_clog = OptionInteger(x, p, 0, 1000000000);
  }
  return w;
}

}  // namespace

const std::vector<AnalysisEntry>& BuiltinAnalyses() {
  // Report order. One row per analysis.
  static const std::vector<AnalysisEntry> kTable = {
      {"flow", MakeFlowAnalysis, {}, {"q_count", "q_mass", "q_count_outlet*", "q_mass_outlet*"}},
      {"profile", MakeProfileAnalysis, {}, {"v_max", "v_max_outlet*"}},
      {"region",
       MakeRegionAnalysis,
       {},
       {"phi", "tg_translational", "tg_full", "phi_outlet*", "tg_translational_outlet*", "tg_full_outlet*"}},
      {"clogging_index",
       MakeCloggingIndexAnalysis,
       {},
       {"psi", "n_stagnant", "clogged_runs", "discharged_runs", "discarded_runs", "unfinished_runs", "psi_low",
        "psi_high", "clogged", "undischarged"}},
      {"avalanches",
       MakeAvalancheAnalysis,
       {},
       {"avalanche_size", "avalanches", "clogs", "avalanche_size_outlet*", "avalanches_outlet*"}},
      {"intermittency",
       MakeIntermittencyAnalysis,
       {},
       {"t_flowing", "t_clogged", "unclog_rate", "t_flowing_outlet*", "t_clogged_outlet*", "unclog_rate_outlet*"}},
      {"arches",
       MakeArchesAnalysis,
       {},
       {"arches", "obstacle_arches", "arch_n", "arch_width", "arch_width_sd", "arch_height", "arch_height_sd",
        "arch_perimeter", "arch_c_over_p", "arch_elongated_fraction", "arch_pressure"}},
      {"contacts", MakeContactsAnalysis, {}, {"contact_ss", "contact_ls", "contact_ll", "contact_other"}},
      {"orientation", MakeOrientationAnalysis, {}, {"flow_frames", "order_parameter_*"}},
      {"fields", MakeFieldsAnalysis, {}, {"cg_*"}},
      {"python", nullptr, MakePythonAnalyses},
  };
  return kTable;
}

bool OffersMetric(const AnalysisEntry& row, const std::string& name) {
  return std::any_of(row.metrics.begin(), row.metrics.end(), [&](const std::string& m) {
    if (!m.empty() && m.back() == '*')
      return name.size() >= m.size() && name.compare(0, m.size() - 1, m, 0, m.size() - 1) == 0;
    return name == m;
  });
}

std::vector<AnalysisEntry> RegisteredAnalyses() {
  std::vector<AnalysisEntry> rows = BuiltinAnalyses();
  std::lock_guard<std::mutex> lock(ExtraMutex());
  rows.insert(rows.end(), ExtraRows().begin(), ExtraRows().end());
  return rows;
}

ScopedAnalysis::ScopedAnalysis(AnalysisEntry entry) : key_(entry.key) {
  std::lock_guard<std::mutex> lock(ExtraMutex());
  ExtraRows().push_back(std::move(entry));
}

ScopedAnalysis::~ScopedAnalysis() {
  std::lock_guard<std::mutex> lock(ExtraMutex());
  std::erase_if(ExtraRows(), [&](const AnalysisEntry& e) { return e.key == key_; });
}

std::vector<const Analysis*> AnalysisSetup::List() const {
  std::vector<const Analysis*> out;
  for (const auto& a : analyses) out.push_back(a.get());
  return out;
}

AnalysisSetup SetupAnalyses(const nlohmann::json& campaign_spec) {
  const std::vector<AnalysisEntry> rows = RegisteredAnalyses();
  nlohmann::json report = nlohmann::json::object();
  if (campaign_spec.is_object() && campaign_spec.contains("report")) {
    report = campaign_spec.at("report");
    if (!report.is_object()) throw OptionError("/report", report, "must be an object");
  }
  AnalysisSetup setup;
  std::string known;
  for (const char* k : kPassKeys) known += (known.empty() ? "" : ", ") + std::string(k);
  known += ", figures";
  for (const AnalysisEntry& e : rows) known += ", " + e.key;
  for (const auto& [key, v] : report.items()) {
    const std::string path = "/report/" + key;
    if (key == "window") {
      setup.pass.window = ReadWindow(v, path);
    } else if (key == "clog_gap") {
      setup.pass.clog_gap = OptionNumber(v, path, 0.0, 1e300);
    } else if (key == "frame_stride") {
      setup.pass.frame_stride = OptionInteger(v, path, 1, 1000000000);
    } else if (key == "max_frames") {
      setup.pass.max_frames = OptionInteger(v, path, 0, 1000000000);
    } else if (key == "figures") {
      continue;  // the figure layer (figures.h) reads it
    } else if (key == "models") {
      throw OptionError(path, v, "fit models are options of the flow analysis now: /report/flow/models");
    } else if (key == "min_exits_before_clog") {
      throw OptionError(path, v, "moved to /report/window/min_exits_before_clog");
    } else if (std::none_of(rows.begin(), rows.end(),
                            [&wanted = key](const AnalysisEntry& e) { return e.key == wanted; })) {
      throw OptionError(path, v, "unknown key (known: " + known + ")");
    }
  }
  // An analysis that is off unless asked for (fields) makes nothing without its options.
  for (const AnalysisEntry& e : rows) {
    const nlohmann::json options = report.contains(e.key) ? report.at(e.key) : nlohmann::json();
    if (e.make_all) {
      for (auto& a : e.make_all(options, "/report/" + e.key)) {
        // One key, one cache file and one set of metric columns per analysis.
        for (const auto& other : setup.analyses)
          if (other->Key() == a->Key())
            throw OptionError("/report/" + e.key, a->Key(),
                              "keys that no other analysis has (" + a->Key() + " is taken)");
        setup.analyses.push_back(std::move(a));
      }
    } else if (auto a = e.make(options, "/report/" + e.key)) {
      setup.analyses.push_back(std::move(a));
    }
  }
  const CampaignAxes axes = CampaignAxes::OfCampaignSpec(campaign_spec);
  for (const auto& a : setup.analyses) a->UseAxes(axes);
  return setup;
}

}  // namespace granary::analysis
