// Rates of engine benchmarks (bench_log.h).
#include "external/bench_log.h"

#include <algorithm>
#include <fstream>
#include <regex>

namespace granary::external {

double BenchMedian(std::vector<double> rates) {
  if (rates.empty()) return 0.0;
  std::sort(rates.begin(), rates.end());
  const std::size_t n = rates.size();
  return n % 2 ? rates[n / 2] : 0.5 * (rates[n / 2 - 1] + rates[n / 2]);
}

double LoopTimeRate(const std::string& log_file) {
  static const std::regex kLoop(R"(Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms)");
  std::ifstream in(log_file);
  std::string line;
  double work = 0, seconds = 0;
  while (std::getline(in, line)) {
    std::smatch m;
    if (!std::regex_search(line, m, kLoop)) continue;
    seconds += std::stod(m[1]);
    work += std::stod(m[3]) * std::stod(m[4]);
  }
  return seconds > 0 ? work / seconds : 0.0;
}

}  // namespace granary::external
