// See hash.h.
#include "rundir/hash.h"

#include <cstdio>

namespace granary {

std::uint64_t Fnv1a64(const std::string& data) {
  std::uint64_t h = 14695981039346656037ull;  // FNV offset basis
  for (unsigned char c : data) {
    h ^= c;
    h *= 1099511628211ull;  // FNV prime
  }
  return h;
}

std::string HashHex(const std::string& data) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(Fnv1a64(data)));
  return buf;
}

}  // namespace granary
