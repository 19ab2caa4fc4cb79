// Shirley & Chiu's concentric map ("A Low Distortion Map Between Disk and Square",
// JGT 1997): the unit square onto the unit disc, area-preserving (a region of the square
// maps to a region of the disc with pi times its area), continuous, and bijective on the
// interiors. Concentric squares go to concentric circles, so a point's radius depends only
// on its Chebyshev distance from the square's centre: r = max(|2x - 1|, |2y - 1|).
//
// Angles are returned in [0, 2 pi); the cut phi = 0 is the half-line y = 1/2, x > 1/2.
#pragma once

#include <cmath>

namespace lp {

struct DiscPoint {
  double r = 0;    // [0, 1]
  double phi = 0;  // [0, 2 pi)
};

inline DiscPoint concentric_square_to_disc(double x, double y) {
  const double a = 2 * x - 1, b = 2 * y - 1;
  if (a == 0 && b == 0) return {0, 0};
  double r, phi;
  if (std::fabs(a) > std::fabs(b)) {
    r = a;
    phi = (M_PI / 4) * (b / a);
  } else {
    r = b;
    phi = M_PI / 2 - (M_PI / 4) * (a / b);
  }
  if (r < 0) {
    r = -r;
    phi += M_PI;
  }
  // phi is now in [-pi/4, 7 pi/4]; fold into [0, 2 pi).
  if (phi < 0) phi += 2 * M_PI;
  if (phi >= 2 * M_PI) phi -= 2 * M_PI;
  return {r, phi};
}

// Inverse of concentric_square_to_disc: (r, phi) with r in [0, 1], any phi.
inline void concentric_disc_to_square(double r, double phi, double* x, double* y) {
  phi = std::fmod(phi, 2 * M_PI);
  if (phi < 0) phi += 2 * M_PI;
  if (phi >= 7 * M_PI / 4) phi -= 2 * M_PI;  // [-pi/4, 7 pi/4)
  double a, b;
  if (phi < M_PI / 4) {  // right wedge: a = r > |b|
    a = r;
    b = a * phi * (4 / M_PI);
  } else if (phi < 3 * M_PI / 4) {  // top wedge: b = r >= |a|
    b = r;
    a = b * (M_PI / 2 - phi) * (4 / M_PI);
  } else if (phi < 5 * M_PI / 4) {  // left wedge: a = -r
    a = -r;
    b = a * (phi - M_PI) * (4 / M_PI);
  } else {  // bottom wedge: b = -r
    b = -r;
    a = b * (3 * M_PI / 2 - phi) * (4 / M_PI);
  }
  *x = (a + 1) / 2;
  *y = (b + 1) / 2;
}

}  // namespace lp
