// The random numbers of the Monte Carlo estimators: SplitMix64 (Steele et al. 2014).
// Why not std::mt19937_64 + std::uniform_real_distribution: the standard leaves the
// distribution's algorithm to the library, so results would differ between standard
// libraries; SplitMix64 is a few lines, passes BigCrush, has 8 bytes of state (one per
// shading point and chain costs nothing) and any 64-bit seed is a good seed, so runs are
// reproducible from (seed, stream) alone.
#pragma once

#include <array>
#include <cstdint>

namespace lp {

class Rng {
 public:
  explicit Rng(uint64_t seed, uint64_t stream = 0) : state_(seed ^ (stream * 0xD1B54A32D192ED03ull)) { next(); }
  uint64_t next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1), 53 random bits.
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }
  std::array<double, 3> uniform3() { return {uniform(), uniform(), uniform()}; }

 private:
  uint64_t state_;
};

}  // namespace lp
