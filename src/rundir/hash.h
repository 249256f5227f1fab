// A stable 64-bit hash (FNV-1a) for ids and fingerprints that must never change across
// platforms and builds: run ids, point ids, cached-bed names, cached analysis results.
#pragma once

#include <cstdint>
#include <string>

namespace granary {

std::uint64_t Fnv1a64(const std::string& data);
// 16 lower-case hex digits of fnv1a64.
std::string HashHex(const std::string& data);

}  // namespace granary
