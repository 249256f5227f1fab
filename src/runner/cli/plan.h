// `campaign plan`, and the planning `campaign compare` shares with it.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "runner/campaign_db.h"
#include "runner/campaign_spec.h"
#include "runner/estimate.h"
#include "runner/cli/common.h"

namespace granary::runner::cli {

// The campaign spec in the file spec_path; a file that cannot be read or parsed is a usage error.
nlohmann::json ReadSpecFile(const std::string& verb, const std::string& spec_path);
// --max-runs N (default kDefaultMaxRuns).
std::uint64_t MaxRuns(const Args& a);
// Validates the campaign spec `given` (read from spec_path), expands it and stores the runs.
// With `estimate`, also the campaign's estimate (estimate.h) on `jobs` concurrent runs.
PlanSummary PlanInto(const nlohmann::json& given, const std::string& spec_path, const std::string& db, bool dry_run,
                     std::uint64_t max_runs, CampaignSpec& spec, std::optional<CampaignEstimate>* estimate = nullptr,
                     int jobs = 1);
void PrintPlan(std::ostream& out, const CampaignSpec& spec, const PlanSummary& s, bool dry_run);

Verb PlanVerb();

}  // namespace granary::runner::cli
