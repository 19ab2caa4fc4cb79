// A map's pixels as rings: every layout of CONVENTIONS.md puts its pixel centres on rings
// of constant zenith angle with uniformly spaced azimuths (a latlong or hemisphere row; a
// HEALPix iso-latitude ring). Within a ring, d . n = a + b cos(phi - phi_n) depends on the
// azimuth only through one cosine, so any lobe of d . n is positive on one contiguous arc
// of the ring, and a lobe that is linear in d (the clamped cosine) sums over an arc from
// three prefix sums (w, w cos phi, w sin phi): the accuracy yardstick in O(rings) per
// direction instead of O(pixels) (core/accuracy.cpp).
// The geometry depends only on layout and size, so it is built once and shared.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/envmap.h"

namespace lp {

struct PixelRing {
  double z = 0, r = 0;        // cos and sin of the ring's zenith angle (r > 0)
  double phi0 = 0, dphi = 0;  // azimuth of the ring's pixel j: phi0 + j dphi, dphi = 2 pi / count
  size_t count = 0;
  size_t first = 0;           // the ring's pixels are [first, first + count) in ring order
  size_t table = 0;           // cos/sin of its azimuths at [table, table + count) of RingLayout
  double solid_angle = 0;     // of each of its pixels (pixel_solid_angle: equal within a ring)
};

struct RingLayout {
  std::vector<PixelRing> rings;  // by zenith angle, north first
  std::vector<uint32_t> pixel;   // ring order -> map pixel index; empty: the same (row-major maps)
  std::vector<double> cos_phi, sin_phi;  // shared by the rings with the same azimuths
  size_t pixel_count = 0;

  size_t map_index(size_t ring_order) const { return pixel.empty() ? ring_order : pixel[ring_order]; }
};

// The rings of a map's layout and size (not its pixels), cached: maps of one size share it.
std::shared_ptr<const RingLayout> ring_layout(const EnvMap& map);

// The pixels of one ring that lie on an arc of azimuths: [start, start + length) modulo
// count, length <= count. Arcs are what the integrals below sum over.
struct RingArc {
  size_t start = 0, length = 0;
};

// The pixels of a ring whose azimuth is within half_angle of phi_c (modulo 2 pi): where a
// lobe a + b cos(phi - phi_c) of the ring exceeds a threshold. A pixel within rounding of
// the rim may fall either way: callers use it where the lobe is ~0 on the rim, or test the
// rim's pixels themselves (core/ring_integrals.h, cap_arc). half_angle >= pi: the whole ring.
RingArc arc_within(const PixelRing& ring, double phi_c, double half_angle);

// Intersection of two arcs of one ring: at most two arcs.
int intersect_arcs(RingArc a, RingArc b, size_t count, RingArc out[2]);

}  // namespace lp
