// The coarse-grained fields analysis (key "fields", thesis ch. 4-6, eqs. 4.1-4.8): the
// time-averaged maps of cg_fields.h over each run's frames, merged over the replicas of a
// sweep point, their means over the region next to every outlet, the time series of the speed
// there, and one frame's force chains. Off unless the campaign spec has /report/fields (true
// or an object; docs/analyses.md "Coarse-grained fields" lists the options).
#pragma once

#include <array>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/analysis.h"
#include "analysis/cg_fields.h"
#include "analysis/region.h"
#include "analysis/report_document.h"

namespace granary::analysis {

struct FieldsOptions {
  std::vector<CgField> maps;  // default: ThesisMaps()
  CgOptions cg;               // cg.window empty: each run's silo (cg_run_window)
  // Which frames: the flow analysis' steady window; all after /report/window/start_time; those
  // split into flowing and clogged (the clogged states of the exit stream); or [from, to].
  enum class Frames { kSteady, kAll, kSplit, kRange };
  Frames frames = Frames::kSteady;
  double from = 0.0, to = 0.0;  // kRange
  bool series = true;           // the speed above each outlet against time (fig. 7.2)
  bool force_chains = true;     // one frame's contact network (fig. 4.16)
  RegionSize region;            // the region next to each outlet (default: ch. 4's; ReadRegionSize)
  FieldsOptions();
  nlohmann::json ToJson() const;  // canonical: the cache key's part
};

// The thesis' maps (figs. 4.10-4.17): phi, |v| (with arrows), Omega, Omega_fl^2, T_g, P, |tau|, mu.
std::vector<CgField> ThesisMaps();
// Whether the options need contacts.dump (a stress map or force chains).
bool FieldsNeedContacts(const FieldsOptions& options);

// Reads /report/fields: true (the defaults), false or absent (nullopt: off), or an object.
// Throws OptionError naming the JSON path, the bad value and what is allowed.
std::optional<FieldsOptions> ReadFieldsOptions(const nlohmann::json& options, const std::string& path);

// A campaign spec whose /report/fields needs contact forces (a stress map, force chains) gets
// /base/output/contact_forces = true where it is unset; returns the spec to plan. Throws
// OptionError naming the JSON path where the spec turns them off or writes no frames
// (/base/output/frame_interval unset or 0, or set so by a sweep axis).
nlohmann::json WithFieldsOutput(const nlohmann::json& campaign_spec);

std::unique_ptr<Analysis> MakeFieldsAnalysis(const nlohmann::json& options, const std::string& path);

// The region next to an outlet in silo coordinates: above a base outlet, beside a lateral one
// (the region analysis' rectangle, ch. 5a R1).
Rect OutletRegion(const OutletGeometry& outlet, const RegionSize& size);

// The silo of a run spec drawn over a map: walls with the outlets' gaps as polylines, up to
// `top`, and the obstacles as circles.
struct SiloDrawing {
  std::vector<std::vector<std::array<double, 2>>> lines;
  std::vector<std::array<double, 3>> circles;
};
SiloDrawing MakeSiloDrawing(const nlohmann::json& spec, double top);

// Per-run sums as JSON (a result's "parts") and back; sums of a sweep point's replicas are
// merged by add_common_rows.
nlohmann::json SumsToJson(const CgSums& sums);
CgSums SumsFromJson(const nlohmann::json& j);
// Adds `other` to `sums` over the rows both have (the same columns and spacing: the window's
// bottom and sides come from the spec, its top from each run's bed); false if the columns differ.
bool AddCommonRows(CgSums& sums, const CgSums& other);

}  // namespace granary::analysis
