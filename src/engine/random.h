// The engine's random numbers: a 64-bit Mersenne twister with our own uniform mapping, so
// that a seed gives the same bed and reinjections with any standard library, and the state
// can be saved in a checkpoint exactly.
#pragma once

#include <cstdint>
#include <random>
#include <sstream>
#include <string>

namespace granary::engine {

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : gen_(seed) {}
  // Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(gen_() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  std::uint64_t Next() { return gen_(); }
  std::string Save() const {
    std::ostringstream out;
    out << gen_;
    return out.str();
  }
  void Load(const std::string& state) {
    std::istringstream in(state);
    in >> gen_;
  }

 private:
  std::mt19937_64 gen_;
};

}  // namespace granary::engine
