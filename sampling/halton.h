// The 2D Halton sequence with bases 2 and 3 (Havran 2005 section 3.2): progressive, so
// the first k points of any prefix are well stratified, and point i is the same for
// every frame, which makes i a stable light id.
#pragma once

#include <cstdint>

namespace lp {

// Radical inverse of i in the given base, in [0, 1).
inline double radical_inverse(uint64_t i, uint32_t base) {
  const double inv = 1.0 / base;
  double f = inv, r = 0;
  while (i > 0) {
    r += f * double(i % base);
    i /= base;
    f *= inv;
  }
  return r;
}

// Point i (0-based) of the 2D Halton sequence, bases (2, 3). Index 0 is (0, 0); samplers
// start at 1 so that no point sits on the domain's corner.
inline void halton2(uint64_t i, double* u, double* v) {
  *u = radical_inverse(i, 2);
  *v = radical_inverse(i, 3);
}

}  // namespace lp
