// `campaign export`: a campaign's metrics as one tidy table, one row per used run or per sweep
// point: the run's (point's) identity, each swept parameter as a column named by its one short
// name (axes.h: "W", "D_b"; numbers stay numbers), each derived axis of /axes, then every metric of every registered
// analysis with its standard error (and, per point, n). Pure: from an analysed campaign.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/campaign_analysis.h"

namespace granary::analysis {

struct ExportTable {
  std::vector<std::string> columns;
  std::vector<std::vector<nlohmann::json>> rows;  // numbers, strings or null (missing)
};

enum class ExportLevel { kRun, kPoint };

ExportTable MakeExportTable(const CampaignAnalysis& analysis, ExportLevel level);
// CSV with a header line; numbers to full precision, missing values empty.
std::string ToCsv(const ExportTable& table);
// An array of objects, one per row, keys in column order (missing values null).
nlohmann::ordered_json to_json(const ExportTable& table);

}  // namespace granary::analysis
