#include "core/accuracy.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/pixel_rings.h"

namespace lp {

namespace {

// ---------------------------------------------------------------------------------------
// The reference integrates the map on its rings (core/pixel_rings.h). For a direction n and
// a ring (z, r), the pixel at azimuth phi has t = n.d = a + r (nx cos phi + ny sin phi) with
// a = nz z: linear in (1, cos phi, sin phi). So
//   diffuse   sum over the arc where t > 0 of w t = a S0 + r nx Sc + r ny Ss, from prefix
//             sums S0, Sc, Ss of w, w cos phi, w sin phi: O(1) per ring, exact;
//   shadowed  the same over the intersection of that arc with the cap's arc on the ring
//             (the cap's rim decided per pixel as the definition does): O(1) per ring;
//   glossy    t^s is not linear in t: for an integer s <= 16 (the s = 10 lobe) through the
//             lobe's harmonics in azimuth, from per-ring prefix sums of w cos(m phi),
//             w sin(m phi): O(s^2) per ring, exact; for a larger s (the s = 100 lobe, a
//             narrow one) pixel by pixel over the short arc where t^s >= kTail.
// w = luminance * solid angle, in double; every value equals the pixel-by-pixel sums of the
// definition up to rounding (tests/core/accuracy_reference_test.cpp holds it to the plain
// sums), except the narrow lobes' tail below.
// ---------------------------------------------------------------------------------------

// Pixels with t^s < kTail are left out of the lobes summed pixel by pixel. Each contributes less than kTail (s+1)/(2 pi) w,
// so a value drops by at most kTail (s+1)/(2 pi) W (W the map's luminance power), while the
// mean of the values over the lattice is about W / (4 pi) (the lobe integrates to 1): at
// most 2 (s+1) kTail = 2e-8 of the mean for s = 100, far below any error the yardstick
// reports (1e-3 .. 1e-1). It keeps the s = 100 lobe within 37 deg of its axis (t > 0.79).
constexpr double kTail = 1e-10;

// One map on its rings: weights in ring order and, per ring, prefix sums of w, w cos phi,
// w sin phi (count + 1 entries each, from base[ring]).
struct RingSums {
  std::shared_ptr<const RingLayout> layout;
  std::vector<double> w, s0, sc, ss;
  std::vector<size_t> base;
};

// Fills `s` for one map, reusing its buffers: a sequence's frames (eval temporal, the
// frame pipeline's --n auto) would otherwise fault in ~16 MB of fresh pages per 1024x512
// frame, which cost more than the integration itself.
void fill_ring_sums(const EnvMap& map, RingSums& s) {
  s.layout = ring_layout(map);
  const RingLayout& L = *s.layout;
  const size_t total = L.pixel_count + L.rings.size();
  s.w.resize(L.pixel_count);
  s.s0.resize(total);
  s.sc.resize(total);
  s.ss.resize(total);
  s.base.resize(L.rings.size());
  for (size_t k = 0; k < L.rings.size(); ++k) {
    const PixelRing& ring = L.rings[k];
    const size_t b = ring.first + k;
    s.base[k] = b;
    double a0 = 0, ac = 0, as = 0;
    s.s0[b] = s.sc[b] = s.ss[b] = 0;
    for (size_t j = 0; j < ring.count; ++j) {
      const size_t i = L.map_index(ring.first + j);
      double w = 0;
      if (map.is_valid(i)) {
        const float* p = map.pixel(i);
        w = double(luminance(p[0], p[1], p[2])) * ring.solid_angle;
      }
      s.w[ring.first + j] = w;
      a0 += w;
      ac += w * L.cos_phi[ring.table + j];
      as += w * L.sin_phi[ring.table + j];
      s.s0[b + j + 1] = a0;
      s.sc[b + j + 1] = ac;
      s.ss[b + j + 1] = as;
    }
  }
}

// Buffers a thread keeps between calls, up to maps of 2^21 pixels (~70 MB); larger maps
// get fresh ones.
struct Scratch {
  RingSums sums;
  std::vector<RingArc> lit;
  std::vector<double> by_ring;
};
constexpr size_t kKeptPixels = size_t(1) << 21;

// Sum of w t over an arc of ring k, t = a + bx cos phi + by sin phi.
double linear_sum(const RingSums& s, size_t k, RingArc arc, double a, double bx, double by) {
  const size_t b = s.base[k], n = s.layout->rings[k].count;
  auto part = [&](size_t from, size_t to) {
    return a * (s.s0[b + to] - s.s0[b + from]) + bx * (s.sc[b + to] - s.sc[b + from]) +
           by * (s.ss[b + to] - s.ss[b + from]);
  };
  const size_t end = arc.start + arc.length;
  return end <= n ? part(arc.start, end) : part(arc.start, n) + part(0, end - n);
}

// A direction seen from the rings: t = a(ring) + r (bx cos phi + by sin phi).
struct Axis {
  Vec3 d;
  double rho = 0, phi = 0;  // length and azimuth of d's horizontal part
  explicit Axis(Vec3 v) : d(v), rho(std::hypot(v.x, v.y)), phi(std::atan2(v.y, v.x)) {}
};

// The arc of a ring where t >= t_min (t_min >= 0 for a lobe clamped at 0): empty, whole,
// or the azimuths within acos((t_min - a) / b) of the axis.
RingArc arc_above(const PixelRing& ring, const Axis& axis, double t_min) {
  const double a = axis.d.z * ring.z, b = axis.rho * ring.r;
  if (a + b <= t_min) return {0, 0};
  if (a - b >= t_min) return {0, ring.count};
  return arc_within(ring, axis.phi, std::acos(std::clamp((t_min - a) / b, -1.0, 1.0)));
}

bool is_small_integer(double s) { return s >= 1 && s <= 65536 && s == std::floor(s); }

// max(0, t) without a branch, exactly (t + t = 2t and the halving are exact), so that the
// loops below vectorise (GCC keeps a conditional as control flow).
inline double clamp_at_zero(double t) { return 0.5 * (t + std::fabs(t)); }

template <unsigned S>
inline double integer_power(double t) {
  if constexpr (S == 0) {
    return 1.0;
  } else if constexpr (S % 2) {
    return t * integer_power<S - 1>(t);
  } else {
    const double h = integer_power<S / 2>(t);
    return h * h;
  }
}

// Sum of w t^100 over at most 256 pixels (the yardstick's narrow lobe, the costliest loop
// of the reference): the terms in one loop and their sum with four accumulators, both of
// which GCC vectorises (one accumulator it may not reorder without -ffast-math); built
// twice, for AVX2 and the baseline, and chosen at run time (GCC's target_clones).
__attribute__((target_clones("avx2", "default")))
double power100_sum(const double* __restrict w, const double* __restrict c, const double* __restrict sn, size_t m,
                    double a, double bx, double by) {
  double p[256];
  for (size_t i = 0; i < m; ++i) p[i] = w[i] * integer_power<100>(clamp_at_zero(a + bx * c[i] + by * sn[i]));
  double acc[4] = {0, 0, 0, 0};
  size_t i = 0;
  for (; i + 4 <= m; i += 4)
    for (int q = 0; q < 4; ++q) acc[q] += p[i + q];
  for (; i < m; ++i) acc[0] += p[i];
  return (acc[0] + acc[1]) + (acc[2] + acc[3]);
}

// Sum of w t^s over an arc, t = a + bx cos phi + by sin phi clamped at 0: fused for the
// yardstick's s = 100; otherwise in chunks whose loops GCC vectorises (an integer power by
// repeated squaring over the whole chunk).
double power_sum(const RingSums& s, size_t k, RingArc arc, double a, double bx, double by, double exponent) {
  const RingLayout& L = *s.layout;
  const PixelRing& ring = L.rings[k];
  constexpr size_t kChunk = 256;
  double t[kChunk], p[kChunk];
  const bool integer = is_small_integer(exponent);
  double sum = 0;
  size_t j = arc.start, left = arc.length;
  while (left > 0) {
    const size_t m = std::min({left, ring.count - j, kChunk});
    const double* __restrict c = L.cos_phi.data() + ring.table + j;
    const double* __restrict sn = L.sin_phi.data() + ring.table + j;
    const double* __restrict w = s.w.data() + ring.first + j;
    left -= m;
    j = (j + m) % ring.count;
    if (exponent == 100) {
      sum += power100_sum(w, c, sn, m, a, bx, by);
      continue;
    }
    for (size_t i = 0; i < m; ++i) t[i] = clamp_at_zero(a + bx * c[i] + by * sn[i]);
    if (integer) {
      unsigned e = unsigned(exponent);
      bool first = true;
      while (true) {
        if (e & 1u) {
          if (first) {
            for (size_t i = 0; i < m; ++i) p[i] = t[i];
            first = false;
          } else {
            for (size_t i = 0; i < m; ++i) p[i] *= t[i];
          }
        }
        e >>= 1;
        if (!e) break;
        for (size_t i = 0; i < m; ++i) t[i] *= t[i];
      }
    } else {
      for (size_t i = 0; i < m; ++i) p[i] = std::pow(t[i], exponent);
    }
    double acc[4] = {0, 0, 0, 0};
    size_t i = 0;
    for (; i + 4 <= m; i += 4)
      for (int q = 0; q < 4; ++q) acc[q] += w[i + q] * p[i + q];
    for (; i < m; ++i) acc[0] += w[i] * p[i];
    sum += (acc[0] + acc[1]) + (acc[2] + acc[3]);
  }
  return sum;
}

// ---------------------------------------------------------------------------------------
// Wide glossy lobes through harmonics. For an integer s, (a + b cos x)^s is a trigonometric
// polynomial of degree s: sum_m c_m cos(m x). On a ring, x = phi - phi_n, so the lobe summed
// over the arc where t > 0 is
//   c_0 C_0 + sum_{m >= 1} c_m (cos(m phi_n) C_m + sin(m phi_n) S_m),
// C_m, S_m the sums of w cos(m phi), w sin(m phi) over the arc: from per-ring prefix sums,
// O(s^2) per (direction, ring) instead of O(pixels on the arc). Exact but for rounding,
// which |c_m| <= (|a| + b)^s <= 2^(s/2) bounds: 1e-16 * 2^(s/2) of the ring's power, so
// only exponents up to kMaxHarmonic go this way (the narrow s = 100 lobe is summed pixel
// by pixel on its short arcs).
// ---------------------------------------------------------------------------------------
constexpr unsigned kMaxHarmonic = 16;

bool is_harmonic(double s) { return is_small_integer(s) && s <= kMaxHarmonic; }

// cos(m x) coefficients c_0..c_s of (a + b cos x)^s, by multiplying out one factor at a
// time on the symmetric exponential form (d_m = d_-m, c_0 = d_0, c_m = 2 d_m).
void lobe_harmonics(double a, double b, unsigned s, double* c) {
  double d[kMaxHarmonic + 2] = {1.0};
  const double h = 0.5 * b;
  for (unsigned n = 1; n <= s; ++n) {
    double prev = d[1];  // d_{-1} = d_1
    for (unsigned m = 0; m <= n; ++m) {
      const double cur = d[m];
      d[m] = a * cur + h * (prev + d[m + 1]);
      prev = cur;
    }
  }
  c[0] = d[0];
  for (unsigned m = 1; m <= s; ++m) c[m] = 2 * d[m];
}

// Prefix sums over one ring of w cos(m phi), w sin(m phi), m = 0..M, as rows of 2M + 1
// (C_0, C_1, S_1, ..., C_M, S_M); row j holds the sums over pixels [0, j).
struct HarmonicRing {
  size_t M = 0, width = 0;
  std::vector<double> rows;
  // The cos/sin(m phi) table of the ring's azimuths, kept while rings share them (every
  // row of a latlong map).
  std::vector<double> table;
  size_t table_key = SIZE_MAX, table_count = 0;

  void fill(const RingSums& s, size_t k, size_t max_m) {
    const RingLayout& L = *s.layout;
    const PixelRing& ring = L.rings[k];
    M = max_m;
    width = 2 * M + 1;
    if (table_key != ring.table || table_count != ring.count || table.size() != ring.count * width) {
      table.resize(ring.count * width);
      for (size_t j = 0; j < ring.count; ++j) {
        double* t = &table[j * width];
        const double c1 = L.cos_phi[ring.table + j], s1 = L.sin_phi[ring.table + j];
        t[0] = 1;
        double cm = 1, sm = 0;
        for (size_t m = 1; m <= M; ++m) {
          const double cn = cm * c1 - sm * s1, sn = sm * c1 + cm * s1;
          cm = cn, sm = sn;
          t[2 * m - 1] = cm;
          t[2 * m] = sm;
        }
      }
      table_key = ring.table;
      table_count = ring.count;
    }
    rows.resize((ring.count + 1) * width);
    std::fill(rows.begin(), rows.begin() + ptrdiff_t(width), 0.0);
    const double* w = s.w.data() + ring.first;
    for (size_t j = 0; j < ring.count; ++j) {
      const double* __restrict t = &table[j * width];
      const double* __restrict from = &rows[j * width];
      double* __restrict to = &rows[(j + 1) * width];
      const double wj = w[j];
      for (size_t m = 0; m < width; ++m) to[m] = from[m] + wj * t[m];
    }
  }

  // sum_m c_m (cos(m phi_n) C_m + sin(m phi_n) S_m) over an arc, cs = (1, cos phi_n,
  // sin phi_n, cos 2 phi_n, ...) in the rows' order.
  double lobe_sum(RingArc arc, size_t count, const double* c, unsigned s, const double* cs) const {
    auto part = [&](size_t from, size_t to) {
      const double* lo = &rows[from * width];
      const double* hi = &rows[to * width];
      double v = c[0] * (hi[0] - lo[0]);
      for (unsigned m = 1; m <= s; ++m)
        v += c[m] * (cs[2 * m - 1] * (hi[2 * m - 1] - lo[2 * m - 1]) + cs[2 * m] * (hi[2 * m] - lo[2 * m]));
      return v;
    };
    const size_t end = arc.start + arc.length;
    return end <= count ? part(arc.start, end) : part(arc.start, count) + part(0, end - count);
  }
};

// The pixels of ring k inside the cap {d : c.d >= cos_half}: the arc from the ring's
// geometry, its two ends then decided pixel by pixel with the definition's own test on
// pixel_direction, so that no pixel on the rim is counted differently from the definition.
RingArc cap_arc(const EnvMap& map, const RingLayout& L, size_t k, const Axis& cap, double cos_half) {
  const PixelRing& ring = L.rings[k];
  const double a = cap.d.z * ring.z, b = cap.rho * ring.r;
  constexpr double kSlack = 1e-9;  // far above rounding of a, b; below it the ends are tested
  if (a + b < cos_half - kSlack) return {0, 0};
  if (a - b > cos_half + kSlack) return {0, ring.count};
  const auto n = int64_t(ring.count);
  auto wrap = [n](int64_t j) { return size_t(((j % n) + n) % n); };
  auto inside = [&](int64_t j) {
    return dot(cap.d, pixel_direction(map, L.map_index(ring.first + wrap(j)))) >= cos_half;
  };
  int64_t lo = 0, hi = n - 1;
  if (b > 1e-12) {
    const double half = std::acos(std::clamp((cos_half - a) / b, -1.0, 1.0));
    lo = int64_t(std::ceil((cap.phi - half - ring.phi0) / ring.dphi)) - 1;
    hi = int64_t(std::floor((cap.phi + half - ring.phi0) / ring.dphi)) + 1;
    if (hi - lo + 1 > n) {  // the whole ring but perhaps a pixel or two opposite the centre
      lo = int64_t(std::lround((cap.phi - ring.phi0) / ring.dphi)) - n / 2;
      hi = lo + n - 1;
    }
  }
  while (lo <= hi && !inside(lo)) ++lo;
  while (hi >= lo && !inside(hi)) --hi;
  if (hi < lo) return {0, 0};
  return {wrap(lo), size_t(hi - lo + 1)};
}

double rel_rms(const std::vector<double>& ref, const std::vector<double>& est) {
  double sq = 0, mean = 0;
  for (size_t k = 0; k < ref.size(); ++k) {
    const double d = est[k] - ref[k];
    sq += d * d;
    mean += ref[k];
  }
  if (ref.empty()) return 0;
  sq /= double(ref.size());
  mean /= double(ref.size());
  if (mean <= 0) return sq == 0 ? 0.0 : INFINITY;  // black reference: any light is wrong
  return std::sqrt(sq) / mean;
}

uint64_t splitmix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double unit_double(uint64_t& state) { return double(splitmix64(state) >> 11) * 0x1.0p-53; }

// The glossy sums of the harmonic exponents (unnormalised), ring by ring: each ring's
// prefix rows are built once and serve every direction. Per-ring values go to `by_ring`
// and are added in ring order, so the result does not depend on the threads.
void glossy_by_harmonics(const RingSums& sums, const std::vector<Vec3>& dirs, const std::vector<RingArc>& lit,
                         const std::vector<double>& exponents, std::vector<std::vector<double>>& glossy,
                         std::vector<double>& by_ring) {
  std::vector<size_t> which;
  size_t max_m = 0;
  for (size_t e = 0; e < exponents.size(); ++e)
    if (is_harmonic(exponents[e])) which.push_back(e), max_m = std::max(max_m, size_t(exponents[e]));
  if (which.empty()) return;
  const RingLayout& L = *sums.layout;
  const size_t nr = L.rings.size(), nd = dirs.size(), width = 2 * max_m + 1;
  // cos/sin(m phi_n) of every direction, in the rows' order.
  std::vector<double> cs(nd * width), rho(nd);
  for (size_t k = 0; k < nd; ++k) {
    const double phi = std::atan2(dirs[k].y, dirs[k].x);
    rho[k] = std::hypot(dirs[k].x, dirs[k].y);
    cs[k * width] = 1;
    for (size_t m = 1; m <= max_m; ++m) {
      cs[k * width + 2 * m - 1] = std::cos(double(m) * phi);
      cs[k * width + 2 * m] = std::sin(double(m) * phi);
    }
  }
  by_ring.resize(which.size() * nr * nd);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nr, 4), [&](const auto& range) {
    thread_local HarmonicRing h;
    double c[kMaxHarmonic + 1];
    for (size_t q = range.begin(); q != range.end(); ++q) {
      const PixelRing& ring = L.rings[q];
      h.fill(sums, q, max_m);
      for (size_t k = 0; k < nd; ++k) {
        const RingArc arc = lit[k * nr + q];
        const double a = dirs[k].z * ring.z, b = rho[k] * ring.r;
        for (size_t i = 0; i < which.size(); ++i) {
          double v = 0;
          if (arc.length) {
            const auto s = unsigned(exponents[which[i]]);
            lobe_harmonics(a, b, s, c);
            v = h.lobe_sum(arc, ring.count, c, s, &cs[k * width]);
          }
          by_ring[(i * nr + q) * nd + k] = v;
        }
      }
    }
  });
  for (size_t i = 0; i < which.size(); ++i)
    for (size_t q = 0; q < nr; ++q)
      for (size_t k = 0; k < nd; ++k) glossy[which[i]][k] += by_ring[(i * nr + q) * nd + k];
}

}  // namespace

std::vector<Vec3> fibonacci_sphere(int count) {
  std::vector<Vec3> out;
  if (count <= 0) return out;
  out.reserve(size_t(count));
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < count; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / count;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = k * golden;
    out.push_back({r * std::cos(phi), r * std::sin(phi), z});
  }
  return out;
}

std::vector<Vec3> occluder_caps(int count, uint64_t seed) {
  std::vector<Vec3> out;
  uint64_t state = seed;
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - 2.0 * unit_double(state);
    const double phi = 2.0 * M_PI * unit_double(state);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    out.push_back({r * std::cos(phi), r * std::sin(phi), z});
  }
  return out;
}

double phong_lobe(double cos_angle, double exponent) {
  if (!(cos_angle > 0)) return 0;
  return (exponent + 1) / (2 * M_PI) * std::pow(cos_angle, exponent);
}

AccuracyReference make_accuracy_reference(const EnvMap& map, const AccuracyOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  AccuracyReference ref;
  ref.options = options;
  ref.directions = fibonacci_sphere(options.directions);
  const size_t nd = ref.directions.size();
  const size_t ne = options.glossy_exponents.size();
  ref.diffuse.assign(nd, 0.0);
  ref.glossy.assign(ne, std::vector<double>(nd, 0.0));
  if (nd == 0) return ref;

  thread_local Scratch kept;
  Scratch fresh;
  Scratch& scratch = map.pixel_count() <= kKeptPixels ? kept : fresh;
  fill_ring_sums(map, scratch.sums);
  const RingSums& sums = scratch.sums;
  const RingLayout& L = *sums.layout;
  const size_t nr = L.rings.size();
  std::vector<double> t_min(ne);
  for (size_t e = 0; e < ne; ++e) {
    const double s = options.glossy_exponents[e];
    t_min[e] = s > 0 ? std::pow(kTail, 1.0 / s) : 0.0;
  }
  // The arcs where each direction's cosine is positive, kept for the shadowed pass.
  std::vector<RingArc>& lit = scratch.lit;
  lit.resize(nd * nr);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nd, 8), [&](const auto& range) {
    for (size_t k = range.begin(); k != range.end(); ++k) {
      const Axis axis(ref.directions[k]);
      double diffuse = 0;
      for (size_t q = 0; q < nr; ++q) {
        const PixelRing& ring = L.rings[q];
        const double a = axis.d.z * ring.z, bx = ring.r * axis.d.x, by = ring.r * axis.d.y;
        const RingArc arc = arc_above(ring, axis, 0.0);
        lit[k * nr + q] = arc;
        if (arc.length == 0) continue;
        diffuse += linear_sum(sums, q, arc, a, bx, by);
        for (size_t e = 0; e < ne; ++e) {
          if (is_harmonic(options.glossy_exponents[e])) continue;  // below, ring by ring
          const RingArc lobe = t_min[e] > 0 ? arc_above(ring, axis, t_min[e]) : arc;
          if (lobe.length) ref.glossy[e][k] += power_sum(sums, q, lobe, a, bx, by, options.glossy_exponents[e]);
        }
      }
      ref.diffuse[k] = diffuse;
    }
  });
  glossy_by_harmonics(sums, ref.directions, lit, options.glossy_exponents, ref.glossy, scratch.by_ring);
  for (size_t e = 0; e < ne; ++e) {
    const double norm = (options.glossy_exponents[e] + 1) / (2 * M_PI);
    for (double& v : ref.glossy[e]) v *= norm;
  }

  if (options.shadowed) {
    ref.caps = occluder_caps(options.caps, options.cap_seed);
    const size_t nc = ref.caps.size();
    ref.shadowed.assign(nc, std::vector<double>(nd, 0.0));
    const double cos_half = std::cos(options.cap_half_angle_deg * M_PI / 180.0);
    // Shadowed = diffuse - the irradiance from the pixels inside the cap: on each ring the
    // lit arc of the direction intersected with the cap's arc.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nc, 1), [&](const auto& range) {
      std::vector<std::pair<size_t, RingArc>> in_cap;
      for (size_t c = range.begin(); c != range.end(); ++c) {
        const Axis cap(ref.caps[c]);
        in_cap.clear();
        for (size_t q = 0; q < nr; ++q)
          if (const RingArc arc = cap_arc(map, L, q, cap, cos_half); arc.length) in_cap.emplace_back(q, arc);
        for (size_t k = 0; k < nd; ++k) {
          const Vec3 n = ref.directions[k];
          double occluded = 0;
          for (const auto& [q, arc] : in_cap) {
            const PixelRing& ring = L.rings[q];
            RingArc parts[2];
            const int found = intersect_arcs(lit[k * nr + q], arc, ring.count, parts);
            for (int i = 0; i < found; ++i)
              occluded += linear_sum(sums, q, parts[i], n.z * ring.z, ring.r * n.x, ring.r * n.y);
          }
          ref.shadowed[c][k] = std::max(0.0, ref.diffuse[k] - occluded);
        }
      }
    });
  }
  ref.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return ref;
}

LightError light_error(const AccuracyReference& reference, std::span<const Light> lights) {
  return light_error(reference, lights, Sh9{});
}

LightError light_error(const AccuracyReference& reference, std::span<const Light> lights, const Sh9& ambient) {
  const AccuracyOptions& opt = reference.options;
  const auto& dirs = reference.directions;
  const size_t nd = dirs.size();
  std::vector<double> lum(lights.size());
  for (size_t i = 0; i < lights.size(); ++i) lum[i] = lights[i].luminance();

  LightError err;
  std::vector<double> est(nd);
  for (size_t k = 0; k < nd; ++k) {
    double e = 0;
    for (size_t i = 0; i < lights.size(); ++i) e += lum[i] * std::max(0.0, dot(dirs[k], lights[i].direction));
    est[k] = e + luminance(sh9_irradiance(ambient, dirs[k]).data());
  }
  err.diffuse = rel_rms(reference.diffuse, est);

  const std::vector<double> diffuse_lights = est;
  for (size_t g = 0; g < reference.glossy.size() && g < opt.glossy_exponents.size(); ++g) {
    const double s = opt.glossy_exponents[g];
    for (size_t k = 0; k < nd; ++k) {
      double e = 0;
      for (size_t i = 0; i < lights.size(); ++i) e += lum[i] * phong_lobe(dot(dirs[k], lights[i].direction), s);
      est[k] = e + luminance(sh9_phong(ambient, dirs[k], s).data());
    }
    err.glossy.push_back(rel_rms(reference.glossy[g], est));
  }

  if (opt.shadowed && !reference.shadowed.empty()) {
    // Shadowed = all lights (and the ambient) minus the lights inside the cap.
    const double cos_half = std::cos(opt.cap_half_angle_deg * M_PI / 180.0);
    double sum = 0;
    std::vector<size_t> inside;
    for (size_t c = 0; c < reference.shadowed.size(); ++c) {
      const Vec3 cap = reference.caps[c];
      inside.clear();
      for (size_t i = 0; i < lights.size(); ++i)
        if (dot(cap, lights[i].direction) >= cos_half) inside.push_back(i);
      for (size_t k = 0; k < nd; ++k) {
        double e = 0;
        for (size_t i : inside) e += lum[i] * std::max(0.0, dot(dirs[k], lights[i].direction));
        est[k] = std::max(0.0, diffuse_lights[k] - e);
      }
      sum += rel_rms(reference.shadowed[c], est);
    }
    err.shadowed = sum / double(reference.shadowed.size());
  }
  return err;
}

double map_irradiance(const EnvMap& map, Vec3 normal) {
  double sum = 0;
  const size_t n = map.pixel_count();
  for (size_t i = 0; i < n; ++i) {
    if (!map.is_valid(i)) continue;
    const float* p = map.pixel(i);
    const double y = luminance(p[0], p[1], p[2]);
    if (y == 0) continue;
    const double c = dot(normal, pixel_direction(map, i));
    if (c > 0) sum += y * pixel_solid_angle(map, i) * c;
  }
  return sum;
}

double lights_irradiance(std::span<const Light> lights, Vec3 normal) {
  double sum = 0;
  for (const Light& l : lights) sum += l.luminance() * std::max(0.0, dot(normal, l.direction));
  return sum;
}

double map_glossy(const EnvMap& map, Vec3 reflection, double exponent) {
  double sum = 0;
  const size_t n = map.pixel_count();
  for (size_t i = 0; i < n; ++i) {
    if (!map.is_valid(i)) continue;
    const float* p = map.pixel(i);
    const double y = luminance(p[0], p[1], p[2]);
    if (y == 0) continue;
    sum += y * pixel_solid_angle(map, i) * phong_lobe(dot(reflection, pixel_direction(map, i)), exponent);
  }
  return sum;
}

}  // namespace lp
