// Sums of lobes of t = n.d over a map's pixels, ring by ring (core/pixel_rings.h): what the
// accuracy reference (core/accuracy.cpp) is made of. For a direction n and a ring (z, r),
// the pixel at azimuth phi has t = a + r (nx cos phi + ny sin phi), a = nz z: linear in
// (1, cos phi, sin phi). So
//   diffuse   the sum of w t over the arc where t > 0 is a S0 + r nx Sc + r ny Ss, from
//             per-ring prefix sums S0, Sc, Ss of w, w cos phi, w sin phi: O(1) per ring;
//   shadowed  the same over the intersection of that arc with a cap's arc (the cap's rim
//             decided per pixel exactly as the definition does): O(1) per ring;
//   glossy    t^s is not linear in t: for an integer s <= kMaxHarmonicExponent through the
//             lobe's harmonics in azimuth, from per-ring prefix sums of w cos(m phi),
//             w sin(m phi): O(s^2) per ring; for a larger s (a narrow lobe) pixel by pixel
//             over the short arc where t^s >= kLobeTail.
// w = luminance * solid angle of every valid pixel, in double: every sum equals the plain
// pixel-by-pixel one up to rounding, but for the narrow lobes' tail
// (tests/core/accuracy_reference_test.cpp holds them to the plain sums).
#pragma once

#include <memory>
#include <vector>

#include "core/envmap.h"
#include "core/pixel_rings.h"
#include "core/vec3.h"

namespace lp {

// Pixels with t^s < kLobeTail are left out of the lobes summed pixel by pixel. Each
// contributes less than kLobeTail (s+1)/(2 pi) w to the normalised Phong lobe, so a value
// drops by at most kLobeTail (s+1)/(2 pi) W (W the map's luminance power), while the mean of
// the values over the lattice is about W / (4 pi) (the lobe integrates to 1): at most
// 2 (s+1) kLobeTail = 2e-8 of the mean for s = 100, far below any error the yardstick
// reports (1e-3 .. 1e-1). It keeps the s = 100 lobe within 37 deg of its axis (t > 0.79).
constexpr double kLobeTail = 1e-10;

// Integer exponents up to this go through harmonics: their rounding, bounded by
// (|a| + b)^s <= 2^(s/2) times the ring's power, stays below 1e-13 of it.
constexpr unsigned kMaxHarmonicExponent = 16;
bool is_harmonic(double exponent);

// One map on its rings: weights in ring order and, per ring, prefix sums of w, w cos phi,
// w sin phi (count + 1 entries, from base[ring]; the three side by side, so that an arc's
// sum reads two cache lines).
struct RingPrefix {
  double s0 = 0, sc = 0, ss = 0;
};
struct RingSums {
  std::shared_ptr<const RingLayout> layout;
  std::vector<double> w;
  std::vector<RingPrefix> prefix;
  std::vector<size_t> base;
};

// Fills `s` for one map, reusing its buffers: a sequence's frames (eval temporal, the
// frame pipeline's --n auto) would otherwise fault in ~16 MB of fresh pages per 1024x512
// frame, which cost more than the integration itself.
void fill_ring_sums(const EnvMap& map, RingSums& s);

// A direction seen from the rings: t = a(ring) + r (d.x cos phi + d.y sin phi).
struct RingAxis {
  Vec3 d;
  double rho = 0, phi = 0;  // length and azimuth of d's horizontal part
  explicit RingAxis(Vec3 v);
};

// The arc of a ring where t >= t_min (t_min >= 0 for a lobe clamped at 0): empty, whole,
// or the azimuths within acos((t_min - a) / b) of the axis.
RingArc arc_above(const PixelRing& ring, const RingAxis& axis, double t_min);

// Sum of w t over an arc of ring k, t = a + bx cos phi + by sin phi.
inline double linear_sum(const RingSums& s, size_t k, RingArc arc, double a, double bx, double by) {
  const RingPrefix* p = s.prefix.data() + s.base[k];
  const size_t n = s.layout->rings[k].count;
  auto part = [&](size_t from, size_t to) {
    return a * (p[to].s0 - p[from].s0) + bx * (p[to].sc - p[from].sc) + by * (p[to].ss - p[from].ss);
  };
  const size_t end = arc.start + arc.length;
  return end <= n ? part(arc.start, end) : part(arc.start, n) + part(0, end - n);
}

// Sum of w max(0, t)^exponent over an arc of ring k, pixel by pixel.
double power_sum(const RingSums& s, size_t k, RingArc arc, double a, double bx, double by, double exponent);

// The pixels of ring k inside the cap {d : c.d >= cos_half}, c = cap.d.
RingArc cap_arc(const EnvMap& map, const RingLayout& L, size_t k, const RingAxis& cap, double cos_half);

// glossy[e][k] += sum of w max(0, t)^s_e (unnormalised) for every harmonic exponent s_e and
// direction k, over the arcs lit[ring * directions + k] where t > 0. `by_ring` is scratch.
void harmonic_lobe_sums(const RingSums& sums, const std::vector<Vec3>& dirs, const std::vector<RingArc>& lit,
                        const std::vector<double>& exponents, std::vector<std::vector<double>>& glossy,
                        std::vector<double>& by_ring);

}  // namespace lp
