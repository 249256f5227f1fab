// Small pure helpers of the runner: a stable 64-bit hash for run ids, "did you mean"
// suggestions, JSON Pointer escaping and seeds derived from the campaign seed.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rundir/hash.h"

namespace granary::runner {

// FNV-1a 64-bit: stable across platforms and builds (run ids must never change).
using granary::Fnv1a64;
using granary::HashHex;

// The candidate nearest to `word` by edit distance, or "" if none is close enough.
std::string Nearest(const std::string& word, const std::vector<std::string>& candidates);

// Seed of replica `replica`: a SplitMix64 mix of the campaign seed and the replica index,
// kept in [1, 2^31) so that every engine accepts it. Depends on nothing else, so runs that
// differ only in outlets share a prepared bed.
std::uint64_t ReplicaSeed(std::uint64_t campaign_seed, int replica);

}  // namespace granary::runner
