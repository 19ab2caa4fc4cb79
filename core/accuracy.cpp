#include "core/accuracy.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>
#define LP_HAVE_MXCSR 1
#endif

#include "core/healpix.h"

namespace lp {

namespace {

// ---------------------------------------------------------------------------------------
// The pixel table the reference integrates: every valid pixel with a non-zero weight
// w = luminance * solid angle, as float structure-of-arrays. Pixels are grouped into
// spatially coherent blocks (one coarse HEALPix cell each, padded with w = 0 to a multiple
// of kLanes), and every block carries a bounding cone, so whole blocks that face away from
// a normal (or lie far outside a glossy lobe) are skipped without touching their pixels.
// ---------------------------------------------------------------------------------------

constexpr int kLanes = 8;  // float accumulators per reduction: SSE2 does them as 2 x 4

struct Block {
  size_t begin = 0, end = 0;  // [begin, end) into the arrays; (end - begin) % kLanes == 0
  Vec3 centre;                // unit
  double radius = 0;          // max angle (rad) from centre to any pixel of the block
  double cos_radius = -1, sin_radius = 0;
};

struct PixelSet {
  std::vector<float> x, y, z, w;  // w normalised: w = weight / scale, so max w = 1
  std::vector<Block> blocks;
  double scale = 0;  // multiply a float sum of w by this to get luminance power
  size_t max_block = 0;
};

void pad_to_lanes(PixelSet& s) {
  while (s.x.size() % kLanes) {
    s.x.push_back(0);
    s.y.push_back(0);
    s.z.push_back(1);
    s.w.push_back(0);
  }
}

void close_block(PixelSet& s, size_t begin) {
  pad_to_lanes(s);
  const size_t end = s.x.size();
  if (end == begin) return;
  Block b;
  b.begin = begin;
  b.end = end;
  double cx = 0, cy = 0, cz = 0;
  for (size_t i = begin; i < end; ++i) {
    if (s.w[i] == 0) continue;
    cx += s.x[i];
    cy += s.y[i];
    cz += s.z[i];
  }
  const double len = std::sqrt(cx * cx + cy * cy + cz * cz);
  if (len < 1e-9) {
    b.centre = {0, 0, 1};
    b.radius = M_PI;  // no useful bound
  } else {
    b.centre = {cx / len, cy / len, cz / len};
    double min_cos = 1;
    for (size_t i = begin; i < end; ++i)
      if (s.w[i] != 0)
        min_cos = std::min(min_cos, b.centre.x * s.x[i] + b.centre.y * s.y[i] + b.centre.z * s.z[i]);
    // A little slack covers float rounding of the stored directions.
    b.radius = std::min(M_PI, std::acos(std::clamp(min_cos, -1.0, 1.0)) + 1e-4);
  }
  b.cos_radius = std::cos(b.radius);
  b.sin_radius = std::sin(b.radius);
  s.max_block = std::max(s.max_block, end - begin);
  s.blocks.push_back(b);
}

// All pixels with w != 0, grouped by coarse HEALPix cell (~1000 pixels per cell).
PixelSet make_pixel_set(const EnvMap& map) {
  const PixelTable table = make_pixel_table(map);
  const size_t n = map.pixel_count();
  std::vector<double> weight(n, 0.0);
  double wmax = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!map.is_valid(i)) continue;
    const float* p = map.pixel(i);
    weight[i] = double(luminance(p[0], p[1], p[2])) * double(table.solid_angle[i]);
    wmax = std::max(wmax, std::fabs(weight[i]));
  }
  PixelSet s;
  s.scale = wmax > 0 ? wmax : 1;

  int nside = 1;
  while (12.0 * (2 * nside) * (2 * nside) * 1024.0 <= double(n)) nside *= 2;
  const size_t cells = 12 * size_t(nside) * size_t(nside);
  std::vector<uint32_t> cell(n);
  std::vector<size_t> count(cells + 1, 0);
  for (size_t i = 0; i < n; ++i) {
    if (weight[i] == 0) continue;
    const int64_t c = healpix_pixel(nside, {table.x[i], table.y[i], table.z[i]});
    cell[i] = uint32_t(c);
    ++count[size_t(c) + 1];
  }
  std::partial_sum(count.begin(), count.end(), count.begin());
  std::vector<uint32_t> order(count[cells]);
  {
    std::vector<size_t> next(count.begin(), count.end() - 1);
    for (size_t i = 0; i < n; ++i)
      if (weight[i] != 0) order[next[cell[i]]++] = uint32_t(i);
  }
  const size_t reserve = order.size() + cells * kLanes;
  s.x.reserve(reserve);
  s.y.reserve(reserve);
  s.z.reserve(reserve);
  s.w.reserve(reserve);
  for (size_t c = 0; c < cells; ++c) {
    const size_t begin = s.x.size();
    for (size_t k = count[c]; k < count[c + 1]; ++k) {
      const size_t i = order[k];
      s.x.push_back(table.x[i]);
      s.y.push_back(table.y[i]);
      s.z.push_back(table.z[i]);
      s.w.push_back(float(weight[i] / s.scale));
    }
    close_block(s, begin);
  }
  return s;
}

// The pixels of `all` inside the cap {d : d.c >= cos_half}, keeping the blocks. Blocks that
// lie wholly inside the cap are not copied but listed in `whole` (indices into all.blocks),
// so that their sums, already known from the full pass, can be reused.
PixelSet pixels_in_cap(const PixelSet& all, Vec3 c, double half_angle, std::vector<size_t>& whole) {
  const double cos_half = std::cos(half_angle);
  PixelSet s;
  s.scale = all.scale;
  whole.clear();
  for (size_t bi = 0; bi < all.blocks.size(); ++bi) {
    const Block& b = all.blocks[bi];
    const double a = std::acos(std::clamp(dot(c, b.centre), -1.0, 1.0));
    if (a - b.radius > half_angle) continue;  // block entirely outside the cap
    if (a + b.radius < half_angle) {          // entirely inside (radius carries 1e-4 slack)
      whole.push_back(bi);
      continue;
    }
    const size_t begin = s.x.size();
    for (size_t i = b.begin; i < b.end; ++i) {
      if (all.w[i] == 0) continue;
      if (c.x * all.x[i] + c.y * all.y[i] + c.z * all.z[i] < cos_half) continue;
      s.x.push_back(all.x[i]);
      s.y.push_back(all.y[i]);
      s.z.push_back(all.z[i]);
      s.w.push_back(all.w[i]);
    }
    close_block(s, begin);
  }
  return s;
}

// Sum of a[i] * b[i] over n (a multiple of kLanes) with kLanes float accumulators, a form
// GCC vectorises at -O3 without -ffast-math (no reassociation of one accumulator).
inline float dot_sum(const float* __restrict a, const float* __restrict b, size_t n) {
  float acc[kLanes] = {0, 0, 0, 0, 0, 0, 0, 0};
  for (size_t i = 0; i < n; i += kLanes)
    for (int j = 0; j < kLanes; ++j) acc[j] += a[i + j] * b[i + j];
  return ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]));
}

// p[i] = t[i]^s for an integer s >= 1, by repeated squaring over whole arrays.
void integer_power(const float* __restrict t, float* __restrict p, float* __restrict base, size_t n,
                   unsigned s) {
  for (size_t i = 0; i < n; ++i) base[i] = t[i];
  bool first = true;
  while (true) {
    if (s & 1u) {
      if (first) {
        for (size_t i = 0; i < n; ++i) p[i] = base[i];
        first = false;
      } else {
        for (size_t i = 0; i < n; ++i) p[i] *= base[i];
      }
    }
    s >>= 1;
    if (!s) break;
    for (size_t i = 0; i < n; ++i) base[i] *= base[i];
  }
}

bool is_small_integer(double s) { return s >= 1 && s <= 65536 && s == std::floor(s); }

// Below this a block's largest possible lobe value t^s is dropped: with w <= 1 per pixel
// that is far below float resolution of any sum that matters (and keeps clear of denormals).
constexpr double kNegligible = 1e-30;

// Flush denormals to zero for the duration of a scope (x86); t^100 of small t would
// otherwise make the inner loops crawl. Denormal contributions are < 1e-38 of the
// normalised weights, far below anything the yardstick resolves.
class FlushDenormals {
 public:
#ifdef LP_HAVE_MXCSR
  FlushDenormals() : saved_(_mm_getcsr()) { _mm_setcsr(saved_ | 0x8040u); }
  ~FlushDenormals() { _mm_setcsr(saved_); }

 private:
  unsigned saved_;
#endif
};

// For each direction k in [first, last): diffuse[k] = sum w max(0, n.d) and, for each
// exponent e, glossy[e][k] = sum w max(0, n.d)^s_e (unnormalised, in units of the set's
// normalised w; the caller multiplies by scale and the lobe's constant).
// When `per_block` is given, it also receives each block's diffuse sum at [block * dirs.size() + k].
void integrate(const PixelSet& s, const std::vector<Vec3>& dirs, size_t first, size_t last,
               const std::vector<double>& exponents, double* diffuse, std::vector<double*>& glossy,
               double* per_block = nullptr) {
  FlushDenormals ftz;
  // A block's lobe values are all negligible when its largest cosine t_max < t_min(s).
  std::vector<double> t_min(exponents.size());
  for (size_t e = 0; e < exponents.size(); ++e) t_min[e] = std::pow(kNegligible, 1.0 / exponents[e]);
  const size_t nb = s.max_block;
  std::vector<float> t(nb), p(nb), base(nb);
  for (size_t k = first; k < last; ++k) {
    diffuse[k] = 0;
    for (double* g : glossy) g[k] = 0;
  }
  const size_t nd = dirs.size();
  if (per_block)
    for (size_t bi = 0; bi < s.blocks.size(); ++bi)
      for (size_t k = first; k < last; ++k) per_block[bi * nd + k] = 0;
  for (size_t bi = 0; bi < s.blocks.size(); ++bi) {
    const Block& b = s.blocks[bi];
    const size_t n = b.end - b.begin;
    const float* __restrict x = s.x.data() + b.begin;
    const float* __restrict y = s.y.data() + b.begin;
    const float* __restrict z = s.z.data() + b.begin;
    const float* __restrict w = s.w.data() + b.begin;
    for (size_t k = first; k < last; ++k) {
      const Vec3 d = dirs[k];
      // With a the angle from d to the block's centre, every pixel is at least a - radius
      // away: the block is wholly behind when a >= pi/2 + radius, i.e. cos a <= -sin radius.
      const double ca = std::clamp(dot(d, b.centre), -1.0, 1.0);
      if (ca <= -b.sin_radius) continue;
      const float nx = float(d.x), ny = float(d.y), nz = float(d.z);
      float* __restrict tt = t.data();
      for (size_t i = 0; i < n; ++i) {
        const float v = nx * x[i] + ny * y[i] + nz * z[i];
        tt[i] = v > 0.0f ? v : 0.0f;
      }
      const double block_sum = double(dot_sum(w, tt, n));
      diffuse[k] += block_sum;
      if (per_block) per_block[bi * nd + k] = block_sum;
      // Largest cosine in the block: cos(a - radius), or 1 when d points into the block.
      const double max_t = ca >= b.cos_radius
                               ? 1.0
                               : ca * b.cos_radius + std::sqrt(std::max(0.0, 1 - ca * ca)) * b.sin_radius;
      for (size_t e = 0; e < exponents.size(); ++e) {
        const double sexp = exponents[e];
        if (max_t < t_min[e]) continue;
        if (is_small_integer(sexp)) {
          integer_power(tt, p.data(), base.data(), n, unsigned(sexp));
        } else {
          for (size_t i = 0; i < n; ++i) p[i] = std::pow(tt[i], float(sexp));
        }
        glossy[e][k] += double(dot_sum(w, p.data(), n));
      }
    }
  }
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

  const PixelSet all = make_pixel_set(map);

  // Diffuse and glossy together, in chunks of directions: each chunk streams the pixel
  // blocks once and reuses each block (in cache) for all of its directions.
  // The per-block diffuse sums are kept for the shadowed pass (blocks wholly inside a cap).
  std::vector<double> per_block(options.shadowed ? all.blocks.size() * nd : 0);
  double* per_block_data = options.shadowed ? per_block.data() : nullptr;
  const size_t chunk = 8;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, (nd + chunk - 1) / chunk, 1), [&](const auto& r) {
    std::vector<double*> g(ne);
    for (size_t e = 0; e < ne; ++e) g[e] = ref.glossy[e].data();
    for (size_t c = r.begin(); c != r.end(); ++c)
      integrate(all, ref.directions, c * chunk, std::min(nd, (c + 1) * chunk), options.glossy_exponents,
                ref.diffuse.data(), g, per_block_data);
  });
  for (size_t k = 0; k < nd; ++k) ref.diffuse[k] *= all.scale;
  for (size_t e = 0; e < ne; ++e) {
    const double norm = all.scale * (options.glossy_exponents[e] + 1) / (2 * M_PI);
    for (double& v : ref.glossy[e]) v *= norm;
  }

  if (options.shadowed) {
    ref.caps = occluder_caps(options.caps, options.cap_seed);
    const size_t nc = ref.caps.size();
    ref.shadowed.assign(nc, std::vector<double>(nd, 0.0));
    const double half = options.cap_half_angle_deg * M_PI / 180.0;
    // Shadowed = diffuse - (irradiance from the pixels inside the cap). Blocks wholly inside
    // the cap reuse their sums from the full pass; only blocks on the rim are integrated again.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nc, 1), [&](const auto& r) {
      std::vector<double> in_cap(nd);
      std::vector<double*> none;
      std::vector<size_t> whole;
      for (size_t c = r.begin(); c != r.end(); ++c) {
        const PixelSet rim = pixels_in_cap(all, ref.caps[c], half, whole);
        integrate(rim, ref.directions, 0, nd, {}, in_cap.data(), none);
        for (size_t bi : whole)
          for (size_t k = 0; k < nd; ++k) in_cap[k] += per_block[bi * nd + k];
        for (size_t k = 0; k < nd; ++k)
          ref.shadowed[c][k] = std::max(0.0, ref.diffuse[k] - in_cap[k] * all.scale);
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
