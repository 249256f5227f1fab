// The stored native-engine campaigns of tests/data/regression as the analyses see them:
// campaign.json (the campaign as its database held it) and its runs under runs/<id>/.
#pragma once

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "analysis/campaign_view.h"

namespace granary::analysis::testing {

struct StoredCampaign {
  CampaignInfo info;
  std::vector<RunRecord> runs;
};

inline StoredCampaign Load(const std::filesystem::path& dir) {
  std::ifstream in(dir / "campaign.json");
  const nlohmann::json c = nlohmann::json::parse(in);
  StoredCampaign s;
  s.info.name = c.at("name");
  s.info.spec = c.at("spec");
  s.info.axes = c.at("axes").get<std::vector<std::string>>();
  for (const auto& r : c.at("runs")) {
    RunRecord rec;
    rec.run_id = r.at("run_id");
    rec.point_id = r.at("point_id");
    rec.point = r.at("point");
    rec.replica = r.at("replica");
    rec.engine = r.at("engine");
    rec.state = r.at("state");
    rec.run_dir = dir / "runs" / rec.run_id;
    std::ifstream spec(rec.run_dir / "run.json");
    rec.spec = nlohmann::json::parse(spec);
    s.runs.push_back(rec);
  }
  return s;
}

}  // namespace granary::analysis::testing
