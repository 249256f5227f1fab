// See util.h.
#include "runner/util.h"

#include "rundir/run_spec.h"

#include <algorithm>
#include <cstdio>
#include <limits>

namespace granary::runner {

std::string Nearest(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_d = std::numeric_limits<std::size_t>::max();
  for (const auto& c : candidates) {
    const std::size_t d = granary::EditDistance(word, c);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  if (best.empty() || best_d > std::max<std::size_t>(2, best.size() / 3)) return "";
  return best;
}

std::uint64_t ReplicaSeed(std::uint64_t campaign_seed, int replica) {
  std::uint64_t z = campaign_seed + 0x9e3779b97f4a7c15ull * (static_cast<std::uint64_t>(replica) + 1);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return (z % 2147483646ull) + 1;
}

}  // namespace granary::runner
