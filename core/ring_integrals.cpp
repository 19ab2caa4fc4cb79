#include "core/ring_integrals.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace lp {

void fill_ring_sums(const EnvMap& map, RingSums& s) {
  s.layout = ring_layout(map);
  const RingLayout& L = *s.layout;
  const size_t total = L.pixel_count + L.rings.size();
  s.w.resize(L.pixel_count);
  s.prefix.resize(total);
  s.base.resize(L.rings.size());
  for (size_t k = 0; k < L.rings.size(); ++k) {
    const PixelRing& ring = L.rings[k];
    const size_t b = ring.first + k;
    s.base[k] = b;
    double a0 = 0, ac = 0, as = 0;
    s.prefix[b] = {0, 0, 0};
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
      s.prefix[b + j + 1] = {a0, ac, as};
    }
  }
}

RingAxis::RingAxis(Vec3 v) : d(v), rho(std::hypot(v.x, v.y)), phi(std::atan2(v.y, v.x)) {}

RingArc arc_above(const PixelRing& ring, const RingAxis& axis, double t_min) {
  const double a = axis.d.z * ring.z, b = axis.rho * ring.r;
  if (a + b <= t_min) return {0, 0};
  if (a - b >= t_min) return {0, ring.count};
  return arc_within(ring, axis.phi, std::acos(std::clamp((t_min - a) / b, -1.0, 1.0)));
}

namespace {

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

}  // namespace

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
bool is_harmonic(double s) { return is_small_integer(s) && s <= kMaxHarmonicExponent; }

namespace {

constexpr unsigned kMaxHarmonic = kMaxHarmonicExponent;

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

}  // namespace

// The pixels of ring k inside the cap {d : c.d >= cos_half}: the arc from the ring's
// geometry, its two ends then decided pixel by pixel with the definition's own test on
// pixel_direction, so that no pixel on the rim is counted differently from the definition.
RingArc cap_arc(const EnvMap& map, const RingLayout& L, size_t k, const RingAxis& cap, double cos_half) {
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

// The glossy sums of the harmonic exponents (unnormalised), ring by ring: each ring's
// prefix rows are built once and serve every direction. Per-ring values go to `by_ring`
// and are added in ring order, so the result does not depend on the threads.
void harmonic_lobe_sums(const RingSums& sums, const std::vector<Vec3>& dirs, const std::vector<RingArc>& lit,
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
        const RingArc arc = lit[q * nd + k];
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

}  // namespace lp
