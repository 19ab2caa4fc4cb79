// Hemigon: Havran's inverse transform on the hemisphere (see sampling/hemigon.h for the
// warp and the exact density it samples).
//
// Sampler:
//   - `hemisphere` maps are warped directly (the live case, 360 x 90 from a fisheye).
//   - Other layouts are resampled (power-preserving) to an upper hemisphere map and, unless
//     options.upper_only, a lower one: the source turned by a 180 deg rotation about +X
//     (world_from_source = Rx(180) = diag(1, -1, -1)), so a lower-map direction
//     (x, y, z) is the world direction (x, -y, -z). The polar size follows the input's
//     pixel size (latlong W x H -> W x H/2; healpix: pixels of about the same angular
//     size), at least 360 x 90 and at most 8192 x 2048. A latlong map whose grid is already
//     the two hemispheres' (W a power of two from 512, H = W/2: see rows_are_halves) is not
//     resampled: its rows are the halves' rows (1024 x 512: prepare 4.5 -> 0.74 ms).
//   - Full sphere: one Halton sequence (bases 2, 3; indices 1..n; id = index). With
//     q = P_upper / P (luminance powers), a point with first coordinate x < q goes to the
//     upper hemisphere as (x / q, y), otherwise to the lower as ((x - q) / (1 - q), y).
//     Each hemisphere gets the Halton points of a sub-box of the square (still well
//     stratified), about q n of them, every prefix stays progressive and ids are stable.
//   - Equal power: each light carries P / n of luminance; rgb is the colour of the sampled
//     density at the light (the interpolated radiance, normalised to luminance 1) times
//     P / n; solid_angle = (P / n) / f, the solid angle that carries 1/n of the power at
//     that radiance. Finally the per-channel totals are matched to the map's power.
#include "sampling/hemigon.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>

#include "core/error.h"
#include "core/resample.h"
#include "sampling/concentric_map.h"
#include "sampling/halton.h"
#include "sampling/methods.h"
#include "sampling/power.h"
#include "sampling/row_sweep.h"

namespace lp {

void HemigonWarp::build(const EnvMap& map, bool borrow) {
  if (map.layout != Layout::Hemisphere)
    throw InputError(fmt::format("hemigon: the warp needs a hemisphere map, got {}", describe_size(map)));
  std::vector<Row> rows(size_t(map.height));
  const size_t w = size_t(map.width);
  for (size_t v = 0; v < rows.size(); ++v)
    rows[v] = {map.rgb.data() + 3 * v * w, map.valid.empty() ? nullptr : map.valid.data() + v * w, false};
  build(map.width, map.height, rows.data(), true, borrow);
}

const float* HemigonWarp::pixel(int v, int u) const {
  if (borrowed_.empty()) return rgb_.data() + 3 * (size_t(v) * size_t(width_) + size_t(u));
  static constexpr float kBlack[3] = {0, 0, 0};  // an invalid pixel, as the copy zeroes it
  const Row& row = borrowed_[size_t(v)];
  const size_t su = size_t(row.reversed ? width_ - 1 - u : u);
  return row.valid && !row.valid[su] ? kBlack : row.rgb + 3 * su;
}

void HemigonWarp::build(int W, int H, const Row* rows, bool rgb_power, bool borrow, double* row_sums) {
  width_ = W;
  height_ = H;
  dphi_ = 2 * M_PI / W;
  const size_t npix = size_t(W) * size_t(H);
  if (borrow) {
    borrowed_.assign(rows, rows + H);
  } else {
    borrowed_.clear();
    rgb_.resize(3 * npix);
  }
  cum_.resize(size_t(H) * size_t(W + 1));
  bounds_.resize(size_t(H) + 2);
  seg_cum_.resize(size_t(H) + 2);
  row_density_.resize(size_t(H));
  power_ = 0;
  rgb_power_ = {0, 0, 0};

  // Ring boundaries in s = 1 - cos(theta) = 2 sin^2(theta / 2) (accurate near the pole).
  auto s_at = [H](int v) {
    if (v >= H) return 1.0;
    const double half = 0.5 * (M_PI / 2) * double(v) / H;
    return 2 * std::sin(half) * std::sin(half);
  };
  // Rows in blocks of eight: the colours (invalid pixels zeroed), luminances, channel sums
  // and the rows' running luminance sums (each the same chain as a row alone: invalid
  // pixels add an exact 0), each from a vector kernel of sampling/row_sweep.h.
  constexpr int kBlock = 8;
  lum_.resize(size_t(kBlock) * size_t(W));
  // Borrowed rows that are masked or reversed are summed from their colours as the copy has
  // them, written to a block-sized scratch (in cache) instead of the whole map's copy.
  if (borrow && rgb_power) scratch_.resize(size_t(kBlock) * 3 * size_t(W));
  double s0 = 0;
  for (int v0 = 0; v0 < H; v0 += kBlock) {
    const int K = std::min(kBlock, H - v0);
    const float* colour[kBlock];
    const float* lum[kBlock];
    double* cum[kBlock];
    for (int k = 0; k < K; ++k) {
      const int v = v0 + k;
      const bool as_is = !rows[v].valid && !rows[v].reversed;  // the copy would equal the row
      float* dst = !borrow                   ? rgb_.data() + 3 * size_t(v) * size_t(W)
                   : rgb_power && !as_is ? scratch_.data() + 3 * size_t(k) * size_t(W)
                                         : nullptr;
      float* y = lum_.data() + size_t(k) * size_t(W);
      colour[k] = dst ? dst : rows[v].rgb;
      lum[k] = y;
      cum[k] = cum_.data() + size_t(v) * size_t(W + 1);
      if (detail::colour_and_luminance_row(rows[v].rgb, rows[v].valid, size_t(W), rows[v].reversed, dst, y)) {
        for (int u = 0; u < W; ++u) {  // name the first pixel, as the pixel-by-pixel loop did
          const int su = rows[v].reversed ? W - 1 - u : u;
          const float* p = rows[v].rgb + 3 * su;
          const bool ok = !rows[v].valid || rows[v].valid[su];
          if (ok && !(luminance(p[0], p[1], p[2]) >= 0))
            throw InputError(fmt::format("hemigon: pixel ({}, {}) is NaN or negative", u, v));
        }
      }
    }
    double sums[kBlock][6] = {};
    if (rgb_power) detail::add_channel_sums(colour, size_t(K), size_t(W), false, &sums[0][0]);
    if (row_sums) {
      const float* stored[kBlock];
      for (int k = 0; k < K; ++k) stored[k] = rows[v0 + k].rgb;
      double own[kBlock][6] = {};
      detail::add_channel_sums(stored, size_t(K), size_t(W), false, &own[0][0]);
      for (int k = 0; k < K; ++k)
        for (int c = 0; c < 3; ++c) row_sums[3 * size_t(v0 + k) + size_t(c)] = own[k][c];
    }
    detail::running_sums_rows(lum, size_t(K), size_t(W), cum);
    for (int k = 0; k < K; ++k) {
      const int v = v0 + k;
      const double acc_k = cum[k][W];
      const double s1 = s_at(v + 1);
      const double ds = s1 - s0;  // pixel solid angle / dphi
      row_density_[size_t(v)] = dphi_ * acc_k;
      power_ += dphi_ * acc_k * ds;
      for (int c = 0; c < 3; ++c) rgb_power_[size_t(c)] += dphi_ * ds * sums[k][c];
      s0 = s1;
    }
  }

  // Knots k_v in s where ring v's value is taken; f is linear in s between knots and
  // constant from the last knot to the horizon. The hats of the rings (1 at their knot,
  // linear to 0 at the neighbouring knots) sum to one, so constant maps stay constant;
  // the knots are chosen so that each hat integrates to its ring's width ds_v, so every
  // pixel keeps its power exactly: k_0 = 0 (the pole), k_1 = 2 s_1, and
  // k_v+1 = k_v-1 + 2 ds_v. They lie within 1/6 ring of the ring midpoints (exactly at
  // theta ~ sqrt(v (v+1)) dtheta near the pole) and are increasing for every H tried
  // (2..3000); if rounding ever broke that, the midpoints are used instead.
  if (knots_height_ != H) {
    knots_.resize(size_t(H));
    knots_[0] = 0;
    if (H > 1) knots_[1] = 2 * s_at(1);
    for (int v = 1; v + 1 < H; ++v) knots_[size_t(v) + 1] = knots_[size_t(v) - 1] + 2 * (s_at(v + 1) - s_at(v));
    bool ok = true;
    for (int v = 0; v + 1 < H; ++v) ok = ok && knots_[size_t(v)] < knots_[size_t(v) + 1];
    ok = ok && knots_[size_t(H) - 1] < 1;
    if (!ok)
      for (int v = 0; v < H; ++v) knots_[size_t(v)] = 0.5 * (s_at(v) + s_at(v + 1));
    knots_height_ = H;
  }
  // Segments j = 0..H: [bounds_j, bounds_j+1] between rings max(j - 1, 0) and min(j, H - 1).
  bounds_[0] = 0;
  for (int v = 0; v < H; ++v) bounds_[size_t(v) + 1] = knots_[size_t(v)];
  bounds_[size_t(H) + 1] = 1;
  seg_cum_[0] = 0;
  for (int j = 0; j <= H; ++j) {
    const double a = row_density_[size_t(std::max(j - 1, 0))], b = row_density_[size_t(std::min(j, H - 1))];
    seg_cum_[size_t(j) + 1] = seg_cum_[size_t(j)] + 0.5 * (a + b) * (bounds_[size_t(j) + 1] - bounds_[size_t(j)]);
  }
}

HemigonWarp::Sample HemigonWarp::warp(double x, double y) const {
  const int W = width_, H = height_;
  const DiscPoint disc = concentric_square_to_disc(std::clamp(x, 0.0, 1.0), std::clamp(y, 0.0, 1.0));
  const double xi1 = std::min(1.0, disc.r * disc.r), xi2 = disc.phi / (2 * M_PI);

  // Marginal: s from xi1 through the piecewise quadratic CDF.
  const double total = seg_cum_[size_t(H) + 1];
  const double R = std::min(xi1 * total, total);
  int j = 0;
  double xs = 0;  // offset of s inside segment j
  if (R > 0) {
    int lo = 0, hi = H + 1;  // seg_cum_[lo] < R <= seg_cum_[hi]
    while (hi - lo > 1) {
      const int mid = (lo + hi) / 2;
      if (seg_cum_[size_t(mid)] >= R)
        hi = mid;
      else
        lo = mid;
    }
    j = lo;
    const int rlo = std::max(j - 1, 0), rhi = std::min(j, H - 1);
    const double a = row_density_[size_t(rlo)], b = row_density_[size_t(rhi)];
    const double L = bounds_[size_t(j) + 1] - bounds_[size_t(j)];
    const double rem = R - seg_cum_[size_t(j)];
    // a x + (b - a) x^2 / (2 L) = rem, in the form that stays stable for b ~ a and a ~ 0.
    const double g = (b - a) / L;
    const double den = a + std::sqrt(std::max(0.0, a * a + 2 * g * rem));
    xs = den > 0 ? std::clamp(2 * rem / den, 0.0, L) : 0.0;
  }
  const double L = bounds_[size_t(j) + 1] - bounds_[size_t(j)];
  const double s = std::clamp(bounds_[size_t(j)] + xs, 0.0, 1.0);
  const double t = L > 0 ? xs / L : 0.0;
  const int rlo = std::max(j - 1, 0), rhi = std::min(j, H - 1);
  const double wlo = rlo == rhi ? 1.0 : 1 - t, whi = rlo == rhi ? 0.0 : t;

  // Conditional: phi from xi2 through the blend of the two rings' running sums.
  const double* clo = cum_.data() + size_t(rlo) * size_t(W + 1);
  const double* chi = cum_.data() + size_t(rhi) * size_t(W + 1);
  auto G = [&](int u) { return wlo * clo[u] + whi * chi[u]; };
  const double gw = G(W);
  int u = 0;
  double phi;
  if (!(gw > 0)) {  // only reachable on a black map or by rounding at a zero-density edge
    phi = xi2 * 2 * M_PI;
    u = std::min(int(xi2 * W), W - 1);
  } else {
    const double target = std::min(xi2 * gw, gw);
    double frac = 0;
    if (target > 0) {
      int lo = 0, hi = W;  // G(lo) < target <= G(hi)
      while (hi - lo > 1) {
        const int mid = (lo + hi) / 2;
        if (G(mid) >= target)
          hi = mid;
        else
          lo = mid;
      }
      u = lo;
      const double g0 = G(u), g1 = G(u + 1);
      frac = g1 > g0 ? std::clamp((target - g0) / (g1 - g0), 0.0, 1.0) : 0.0;
    }
    phi = (double(u) + frac) * dphi_;
  }

  Sample out;
  const double ct = 1 - s, st = std::sqrt(std::max(0.0, s * (2 - s)));
  out.direction = {st * std::cos(phi), st * std::sin(phi), ct};
  const float* plo = pixel(rlo, u);
  const float* phi_px = pixel(rhi, u);
  for (int c = 0; c < 3; ++c) out.rgb[c] = wlo * double(plo[c]) + whi * double(phi_px[c]);
  out.luminance = luminance(out.rgb.data());
  return out;
}

// ---------------------------------------------------------------------------------------
// Lloyd relaxation of Halton points on the unit square (toroidal domain).

namespace {

std::vector<std::array<double, 2>> relax_halton(int n) {
  std::vector<std::array<double, 2>> p(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) halton2(uint64_t(i) + 1, &p[size_t(i)][0], &p[size_t(i)][1]);
  // Discrete Lloyd on the torus: the Voronoi cell of each site is the set of grid-cell
  // centres nearest to it (wrapped distances); the site moves to their centroid. About 64+
  // grid cells per site. The torus, not the bounded square: a bounded relaxation lines
  // rows of points up along the square's edges, which the concentric map sends to single
  // rings near the horizon; on grace that tripled the diffuse error (4.1 % vs 1.5 % at
  // n = 1024, upper hemisphere).
  const int S = std::clamp(int(std::ceil(8 * std::sqrt(double(n)))), 256, 2048);
  const int G = std::max(1, int(std::sqrt(n / 2.0)));  // bucket grid, ~2 sites per bucket
  const double cell = 1.0 / G;
  auto wrap_cell = [G](int c) { return ((c % G) + G) % G; };
  auto wrap_delta = [](double d) { return d > 0.5 ? d - 1 : (d < -0.5 ? d + 1 : d); };  // |d| < 1 -> [-1/2, 1/2]
  std::vector<int> start(size_t(G) * G + 1), order(static_cast<size_t>(n)), bucket(static_cast<size_t>(n));
  std::vector<double> sx(static_cast<size_t>(n)), sy(static_cast<size_t>(n)), cnt(static_cast<size_t>(n));
  constexpr int kIterations = 40;
  for (int it = 0; it < kIterations; ++it) {
    std::fill(start.begin(), start.end(), 0);
    for (int i = 0; i < n; ++i) {
      const int cx = std::min(G - 1, int(p[size_t(i)][0] * G)), cy = std::min(G - 1, int(p[size_t(i)][1] * G));
      bucket[size_t(i)] = cy * G + cx;
      ++start[size_t(bucket[size_t(i)]) + 1];
    }
    for (size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
    {
      std::vector<int> fill(start.begin(), start.end() - 1);
      for (int i = 0; i < n; ++i) order[size_t(fill[size_t(bucket[size_t(i)])]++)] = i;
    }
    std::fill(sx.begin(), sx.end(), 0.0);
    std::fill(sy.begin(), sy.end(), 0.0);
    std::fill(cnt.begin(), cnt.end(), 0.0);
    for (int gy = 0; gy < S; ++gy) {
      const double py = (gy + 0.5) / S;
      const int cy = std::min(G - 1, int(py * G));
      for (int gx = 0; gx < S; ++gx) {
        const double px = (gx + 0.5) / S;
        const int cx = std::min(G - 1, int(px * G));
        double best = 1e300;
        int bi = -1;
        for (int k = 0;; ++k) {
          if (G <= 3 && k > 0) break;  // k = 0 below scans every site when the grid is tiny
          for (int yy = cy - k; yy <= cy + k; ++yy) {
            const bool edge_row = yy == cy - k || yy == cy + k;
            for (int xx = cx - k; xx <= cx + k; xx += (edge_row || k == 0) ? 1 : 2 * k) {
              const int c = wrap_cell(yy) * G + wrap_cell(xx);
              const bool all = G <= 3;
              for (int q = all ? 0 : start[size_t(c)]; q < (all ? n : start[size_t(c) + 1]); ++q) {
                const int i = order[size_t(q)];
                const double dx = wrap_delta(p[size_t(i)][0] - px), dy = wrap_delta(p[size_t(i)][1] - py);
                const double d2 = dx * dx + dy * dy;
                if (d2 < best) {
                  best = d2;
                  bi = i;
                }
              }
            }
          }
          // Sites in ring k + 1 are at least k cells away; past 2k + 1 >= G every cell
          // has been visited.
          if (bi >= 0 && best <= (k * cell) * (k * cell)) break;
          if (2 * k + 1 >= G) break;
        }
        sx[size_t(bi)] += wrap_delta(px - p[size_t(bi)][0]);
        sy[size_t(bi)] += wrap_delta(py - p[size_t(bi)][1]);
        cnt[size_t(bi)] += 1;
      }
    }
    for (int i = 0; i < n; ++i) {
      if (!(cnt[size_t(i)] > 0)) continue;
      double x = p[size_t(i)][0] + sx[size_t(i)] / cnt[size_t(i)], y = p[size_t(i)][1] + sy[size_t(i)] / cnt[size_t(i)];
      x -= std::floor(x);
      y -= std::floor(y);
      p[size_t(i)] = {x, y};
    }
  }
  return p;
}

}  // namespace

const std::vector<std::array<double, 2>>& lloyd_relaxed_halton(int n) {
  static std::mutex mutex;
  static std::map<int, std::vector<std::array<double, 2>>> cache;  // node-based: references stay valid
  if (n <= 0) throw InputError(fmt::format("hemigon: the number of lights must be positive, got {}", n));
  std::lock_guard<std::mutex> lock(mutex);
  auto it = cache.find(n);
  if (it == cache.end()) it = cache.emplace(n, relax_halton(n)).first;
  return it->second;
}

// ---------------------------------------------------------------------------------------

namespace {

// core/envmap.h's total_power of an unmasked row grid, with the same sums (per row in pixel
// order, then the rows in order, each times its pixel solid angle) from the vector kernel.
std::array<double, 3> row_grid_total_power(const EnvMap& map) {
  const size_t w = size_t(map.width);
  std::array<double, 3> total{0, 0, 0};
  constexpr int kBlock = 8;
  for (int r0 = 0; r0 < map.height; r0 += kBlock) {
    const int k_end = std::min(kBlock, map.height - r0);
    const float* rows[kBlock];
    for (int k = 0; k < k_end; ++k) rows[k] = map.rgb.data() + 3 * size_t(r0 + k) * w;
    double sums[kBlock][6] = {};
    detail::add_channel_sums(rows, size_t(k_end), w, false, &sums[0][0]);
    for (int k = 0; k < k_end; ++k) {
      const double dw = pixel_solid_angle(map, size_t(r0 + k) * w);
      for (int c = 0; c < 3; ++c) total[size_t(c)] += dw * sums[k][c];
    }
  }
  return total;
}

// The map's power per channel (total_power), after require_samplable's checks without a
// second pass: only a map that fails them is read again, for its message.
std::array<double, 3> samplable_total_power(const EnvMap& map) {
  if (map.pixel_count() == 0) require_samplable(map, "hemigon");
  const bool plain_rows = map.layout != Layout::Healpix && map.valid.empty() && map.rgb.size() == 3 * map.pixel_count();
  const std::array<double, 3> total = plain_rows ? row_grid_total_power(map) : total_power(map);
  const double p = luminance(total.data());
  if (!std::isfinite(p) || !(p > 0)) require_samplable(map, "hemigon");  // throws its message
  return total;
}

// samplable_total_power of an unmasked latlong map from its halves' row sums (HemigonWarp::build's
// row_sums: the upper half's rows 0 .. h - 1, then the lower half's, whose row v is the map's
// row height - 1 - v): the same additions in the same order as row_grid_total_power.
std::array<double, 3> power_from_halves_rows(const EnvMap& map, const std::vector<double>& sums) {
  const size_t w = size_t(map.width), h = size_t(map.height) / 2;
  std::array<double, 3> total{0, 0, 0};
  for (size_t r = 0; r < size_t(map.height); ++r) {
    const double* s = sums.data() + 3 * (r < h ? r : h + (size_t(map.height) - 1 - r));
    const double dw = pixel_solid_angle(map, r * w);
    for (int c = 0; c < 3; ++c) total[size_t(c)] += dw * s[c];
  }
  const double p = luminance(total.data());
  if (!std::isfinite(p) || !(p > 0)) require_samplable(map, "hemigon");  // throws its message
  return total;
}

// True when the hemisphere grid w x h is the latlong's own grid cut at the horizon, so that
// the exact path of resample(latlong, hemisphere, w, h) copies each of the top h rows (and,
// turned by Rx(180), each bottom row upside down and right to left): same width, half the
// height, a power-of-two width (every column boundary u / w exact in binary: no column
// overlaps its neighbour), and the row boundaries' cosines equal to the bit, computed as
// core/resample.cpp computes them (cos(span * v / height)). Each pixel is then
// float(L * a / a') with a, a' the same area to a few double ulps: L itself (a -0 comes out
// +0: equal as a number, kept as -0 here). For the lower half the resample compares
// -cos(pi - x) with cos(x), which differ in the last bit at about two boundaries in three,
// so it gives each pixel ~1e-16 of its neighbour row's radiance as well; the copy leaves
// that rounding out (see docs/sampling.md).
bool rows_are_halves(const EnvMap& map, int w, int h) {
  if (map.layout != Layout::LatLong || map.width != w || map.height != 2 * h || (w & (w - 1)) != 0) return false;
  static std::mutex mutex;
  static std::map<int, bool> checked;  // by latlong height
  std::lock_guard lock(mutex);
  auto it = checked.find(map.height);
  if (it != checked.end()) return it->second;
  bool same = true;
  for (int v = 0; v <= h && same; ++v) same = std::cos(M_PI * double(v) / map.height) == std::cos((M_PI / 2) * double(v) / h);
  checked.emplace(map.height, same);
  return same;
}

class HemigonSampler final : public Sampler {
 public:
  explicit HemigonSampler(const SamplerOptions& options) : options_(options) {}
  Method method() const override { return Method::Hemigon; }

  void prepare(const EnvMap& map) override {
    if (map.layout == Layout::Hemisphere) {  // fast path: no full pass beyond the CDFs
      half_[0].build(map, /*borrow=*/true);
      has_lower_ = false;
      target_ = half_[0].rgb_power();
    } else {
      int w = 0, h = 0;
      if (map.layout == Layout::LatLong) {
        w = map.width;
        h = (map.height + 1) / 2;
      } else {
        const double pixel = std::sqrt(4 * M_PI / double(map.pixel_count()));
        h = int(std::ceil((M_PI / 2) / pixel));
        w = 4 * h;
      }
      w = std::clamp(w, 360, 8192);
      h = std::clamp(h, 90, 2048);
      // An unmasked latlong map taken as its halves' rows gives its power from those rows'
      // sums, taken as the builds read them (the same sums as total_power's, in the same
      // order): no pass of its own over the map (a tenth of this prepare with caches evicted).
      const bool halves = rows_are_halves(map, w, h);
      const bool power_from_rows = halves && map.valid.empty() && !options_.upper_only &&
                                   map.rgb.size() == 3 * map.pixel_count();
      std::array<double, 3> total{0, 0, 0};
      if (!power_from_rows) total = samplable_total_power(map);
      if (halves) {
        // The resample below would copy each pixel (the grids coincide): take the rows as
        // they are, the lower half upside down and right to left (Rx(180): theta -> pi -
        // theta, phi -> -phi), without the two resampled maps.
        const size_t W = size_t(map.width);
        const bool masked = !map.valid.empty();
        rows_.resize(size_t(h));
        if (power_from_rows) row_sums_.resize(3 * size_t(map.height));
        try {
          for (int half = 0; half < (options_.upper_only ? 1 : 2); ++half) {
            for (int v = 0; v < h; ++v) {
              const size_t row = half == 0 ? size_t(v) : size_t(map.height - 1 - v);
              rows_[size_t(v)] = {map.rgb.data() + 3 * row * W, masked ? map.valid.data() + row * W : nullptr, half == 1};
            }
            // Both halves: the target is the map's power, not the halves' channel sums.
            // The lower half's row v is the map's row height - 1 - v: its sums go there.
            double* sums = nullptr;
            if (power_from_rows) sums = half == 0 ? row_sums_.data() : row_sums_.data() + 3 * size_t(h);
            half_[half].build(w, h, rows_.data(), options_.upper_only, /*borrow=*/true, sums);
          }
        } catch (const InputError&) {
          if (power_from_rows) require_samplable(map, "hemigon");  // the message a map that fails its checks gets
          throw;
        }
        if (power_from_rows) total = power_from_halves_rows(map, row_sums_);
      } else {
        upper_ = resample(map, Layout::Hemisphere, w, h);
        half_[0].build(upper_, /*borrow=*/true);
        if (!options_.upper_only) {
          ResampleOptions ro;
          ro.world_from_source = Mat3{{1, 0, 0, 0, -1, 0, 0, 0, -1}};  // Rx(180), its own inverse
          lower_ = resample(map, Layout::Hemisphere, w, h, ro);
          half_[1].build(lower_, /*borrow=*/true);
        }
      }
      has_lower_ = !options_.upper_only;
      target_ = options_.upper_only ? half_[0].rgb_power() : total;
    }
    power_ = half_[0].power() + (has_lower_ ? half_[1].power() : 0.0);
    if (!std::isfinite(power_)) throw InputError("hemigon: the map has non-finite pixels");
    if (!(power_ > 0))
      throw InputError(has_lower_ || map.layout == Layout::Hemisphere
                           ? "hemigon: the map is black (zero power): there is no light to sample"
                           : "hemigon: the upper hemisphere is black (zero power): there is no light to sample");
    upper_share_ = half_[0].power() / power_;
    prepared_ = true;
  }

  std::vector<Light> place(int n) override {
    if (n <= 0) throw InputError(fmt::format("hemigon: the number of lights must be positive, got {}", n));
    if (!prepared_) throw std::logic_error("hemigon: place() before prepare()");
    const std::vector<std::array<double, 2>>* relaxed = options_.lloyd_relaxed ? &lloyd_relaxed_halton(n) : nullptr;
    const double per_light = power_ / n;
    const double q = has_lower_ ? upper_share_ : 1.0;
    std::vector<Light> lights(static_cast<size_t>(n));
    for (int k = 1; k <= n; ++k) {
      double x, y;
      if (relaxed) {
        x = (*relaxed)[size_t(k) - 1][0];
        y = (*relaxed)[size_t(k) - 1][1];
      } else {
        halton2(uint64_t(k), &x, &y);
      }
      int half = 0;
      if (x < q) {
        x /= q;
      } else {
        half = 1;
        x = (x - q) / (1 - q);
      }
      const HemigonWarp::Sample smp = half_[half].warp(x, y);
      Light& l = lights[size_t(k) - 1];
      l.id = uint64_t(k);
      l.direction = half == 0 ? smp.direction : Vec3{smp.direction.x, -smp.direction.y, -smp.direction.z};
      if (smp.luminance > 0) {
        const double s = per_light / smp.luminance;
        l.rgb = {smp.rgb[0] * s, smp.rgb[1] * s, smp.rgb[2] * s};
        l.solid_angle = s;
      } else {  // rounding onto a zero-density edge: grey (luminance 1), no extent
        l.rgb = {per_light, per_light, per_light};
        l.solid_angle = 0;
      }
    }
    match_total_power(lights, target_);
    return lights;
  }

 private:
  SamplerOptions options_;
  HemigonWarp half_[2];
  EnvMap upper_, lower_;                 // resampled halves, when the rows are not the halves
  std::vector<HemigonWarp::Row> rows_;   // the halves' rows, when they are
  std::vector<double> row_sums_;          // their channel sums (power_from_halves_rows)
  bool has_lower_ = false;
  bool prepared_ = false;
  double power_ = 0, upper_share_ = 1;
  std::array<double, 3> target_{0, 0, 0};
};

}  // namespace

std::unique_ptr<Sampler> make_hemigon_sampler(const SamplerOptions& options) {
  return std::make_unique<HemigonSampler>(options);
}

}  // namespace lp
