#include "core/pixel_rings.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <tuple>


namespace lp {

namespace {

// Rows of a latlong or hemisphere map: row v at theta = span (v + 1/2) / H, every row with
// the azimuths of pixel_direction (phi = 2 pi (u + 1/2) / W), so one cos/sin table.
RingLayout row_rings(const EnvMap& map) {
  RingLayout out;
  const size_t w = size_t(map.width);
  out.pixel_count = map.pixel_count();
  out.cos_phi.resize(w);
  out.sin_phi.resize(w);
  for (size_t u = 0; u < w; ++u) {
    const double phi = 2 * M_PI * (double(u) + 0.5) / map.width;
    out.cos_phi[u] = std::cos(phi);
    out.sin_phi[u] = std::sin(phi);
  }
  for (int v = 0; v < map.height; ++v) {
    const size_t first = size_t(v) * w;
    const Vec3 d = pixel_direction(map, first);
    PixelRing ring;
    ring.z = d.z;
    ring.r = std::hypot(d.x, d.y);
    ring.count = w;
    ring.dphi = 2 * M_PI / map.width;
    ring.phi0 = 0.5 * ring.dphi;
    ring.first = first;
    ring.table = 0;
    ring.solid_angle = pixel_solid_angle(map, first);
    out.rings.push_back(ring);
  }
  return out;
}

// HEALPix iso-latitude rings i = 1 .. 4 nside - 1 (Gorski et al. 2005, ApJ 622:759, eqs. 4-9):
// 4i pixels on ring i of the north cap at z = 1 - i^2 / (3 nside^2) and azimuths
// (j + 1/2) pi / (2i); 4 nside on the equatorial rings, z = 4/3 - 2i / (3 nside), azimuths
// (j + 1/2) pi / (2 nside) on rings i - nside even, (j + 1) pi / (2 nside) on odd ones; the
// south cap mirrors the north. Each centre's NESTED index is the layout's own pixel_at (a
// centre lies far from any pixel edge), and the ring's z and r are taken from its first
// pixel's pixel_direction, so that the rings hold the map's own directions.
RingLayout healpix_rings(const EnvMap& map) {
  RingLayout out;
  const int64_t nside = map.nside;
  const double n = double(nside);
  out.pixel_count = map.pixel_count();
  out.pixel.reserve(out.pixel_count);
  const double omega = 4 * M_PI / double(out.pixel_count);
  for (int64_t i = 1; i < 4 * nside; ++i) {
    const int64_t cap = i < nside ? i : i > 3 * nside ? 4 * nside - i : 0;  // 0: equatorial
    const int64_t count = cap ? 4 * cap : 4 * nside;
    const double z = cap ? (i < nside ? 1 : -1) * (1 - double(cap * cap) / (3 * n * n)) : 4.0 / 3 - 2.0 * double(i) / (3 * n);
    const double shift = cap || (i - nside) % 2 == 0 ? 0.5 : 1.0;
    PixelRing ring;
    ring.count = size_t(count);
    ring.dphi = 2 * M_PI / double(count);
    ring.phi0 = shift * ring.dphi;
    ring.first = out.pixel.size();
    ring.table = out.cos_phi.size();
    ring.solid_angle = omega;
    const double r = std::sqrt(std::max(0.0, 1 - z * z));
    for (int64_t j = 0; j < count; ++j) {
      const double phi = ring.phi0 + double(j) * ring.dphi;
      out.cos_phi.push_back(std::cos(phi));
      out.sin_phi.push_back(std::sin(phi));
      out.pixel.push_back(uint32_t(*pixel_at(map, {r * out.cos_phi.back(), r * out.sin_phi.back(), z})));
    }
    const Vec3 d = pixel_direction(map, out.pixel[ring.first]);
    ring.z = d.z;
    ring.r = std::hypot(d.x, d.y);
    out.rings.push_back(ring);
  }
  return out;
}

}  // namespace

std::shared_ptr<const RingLayout> ring_layout(const EnvMap& map) {
  // A few sizes at once (a sequence, its preview, a test's maps); the oldest goes first.
  using Key = std::tuple<Layout, int, int, int>;
  static std::mutex mutex;
  static std::vector<std::pair<Key, std::shared_ptr<const RingLayout>>> cache;
  const Key key{map.layout, map.width, map.height, map.nside};
  {
    std::lock_guard lock(mutex);
    for (const auto& [k, v] : cache)
      if (k == key) return v;
  }
  auto made = std::make_shared<const RingLayout>(map.layout == Layout::Healpix ? healpix_rings(map) : row_rings(map));
  std::lock_guard lock(mutex);
  if (cache.size() >= 4) cache.erase(cache.begin());
  cache.emplace_back(key, made);
  return made;
}

RingArc arc_within(const PixelRing& ring, double phi_c, double half_angle) {
  const size_t n = ring.count;
  if (half_angle >= M_PI) return {0, n};
  if (!(half_angle > 0)) return {0, 0};
  const double lo = std::ceil((phi_c - half_angle - ring.phi0) / ring.dphi);
  const double hi = std::floor((phi_c + half_angle - ring.phi0) / ring.dphi);
  if (hi < lo) return {0, 0};
  const double length = hi - lo + 1;
  if (length >= double(n)) return {0, n};
  const double start = lo - std::floor(lo / double(n)) * double(n);
  return {std::min(size_t(start), n - 1), size_t(length)};
}

int intersect_arcs(RingArc a, RingArc b, size_t count, RingArc out[2]) {
  int found = 0;
  const auto n = int64_t(count);
  for (int64_t shift : {-n, int64_t(0), n}) {
    const int64_t lo = std::max(int64_t(a.start), int64_t(b.start) + shift);
    const int64_t hi = std::min(int64_t(a.start + a.length), int64_t(b.start + b.length) + shift);
    if (hi > lo && found < 2) out[found++] = {size_t(lo % n), size_t(hi - lo)};
  }
  return found;
}

}  // namespace lp
