// Validation (ctest label `validation`, excluded by default): flow rate against outlet width
// for dumbbells in reinject mode. The thesis (ch. 5, modified Beverloo law) finds
// Q ∝ (W/d)^{1.5 + X_db/2}, i.e. (W/d)^2 for pure dumbbells, so Q(14)/Q(8) = 3.06; plain
// 2-D Beverloo with k = 1 would give 2.53. About 70 and 210 exits are counted, so the
// ratio is known to ~13 % (Poisson); the bounds are ~2 sigma.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/run.h"

namespace granary::engine {
namespace {
namespace fs = std::filesystem;

double SteadyFlowRate(double outlet) {
  const fs::path dir = fs::path(GRANARY_ENGINE_TEST_TMP) / ("beverloo-" + std::to_string(static_cast<int>(outlet)));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const nlohmann::json spec = {{"run_id", "beverloo"},
                               {"seed", std::uint64_t{21}},
                               {"silo", {{"width", 40.0}, {"base_outlets", {{{"center", 0.0}, {"width", outlet}}}}}},
                               {"bodies", {{"count", 400}}},
                               {"bed",
                                {{"settle_ke_per_body", 1e-4},
                                 {"cache_file", (fs::path(GRANARY_ENGINE_TEST_TMP) / "bed-beverloo.json").string()}}},
                               {"discharge", {{"mode", "reinject"}, {"max_time", 20.0}, {"stop_on_clog", false}}},
                               {"output", {{"checkpoint_interval", 0.0}}}};
  std::ofstream(dir / "run.json") << spec.dump();
  RunOptions o;
  o.quiet = true;
  o.threads = 1;
  RunDirectory(dir.string(), o);
  std::ifstream in(dir / "events.csv");
  std::string line;
  std::getline(in, line);
  int n = 0;
  while (std::getline(in, line)) n += std::stod(line.substr(0, line.find(','))) >= 5.0;
  return n / 15.0;
}

TEST(Validation, BeverlooScalingOfDumbbellFlow) {
  const double q8 = SteadyFlowRate(8.0), q14 = SteadyFlowRate(14.0);
  ASSERT_GT(q8, 1.0);
  const double ratio = q14 / q8;
  EXPECT_GT(ratio, 2.4) << "q8=" << q8 << " q14=" << q14;
  EXPECT_LT(ratio, 3.8) << "q8=" << q8 << " q14=" << q14;
}

}  // namespace
}  // namespace granary::engine
