// Power-preserving resampling between layouts (see resample.h).
//
// Pass 1 supersamples every destination pixel (k x k sub-samples of equal solid angle)
// and accumulates, per source pixel s, W_s = the solid angle of the samples of valid
// destination pixels that landed in s. Source pixels no sample hit are then given whole
// to the destination pixel holding their centre. Pass 2 spreads each source pixel's
// power T_s = L_s * Omega_s * f_s over its samples in proportion to their solid angles,
// where f_s is the fraction of s inside the destination's domain (1 unless the
// destination is a hemisphere). Summation is in double and in an order that does not
// depend on the number of threads, so results are reproducible.
#include "core/resample.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/error.h"

extern "C" {
#include <chealpix.h>
}

namespace lp {
namespace {

constexpr int kMaxSamplesPerEdge = 16;

double theta_span(Layout layout) { return layout == Layout::Hemisphere ? M_PI / 2 : M_PI; }

bool is_power_of_two(int n) { return n > 0 && (n & (n - 1)) == 0; }

int next_power_of_two(int n) {
  int p = 1;
  while (p < n) p *= 2;
  return p;
}

bool is_identity(const Mat3& r) {
  const Mat3 id{};
  return r.m == id.m;
}

// Directions of the k x k equal-solid-angle sub-samples of one pixel. Latlong and
// hemisphere pixels are split uniformly in phi and in cos(theta) (equal-area sub-cells,
// direction at the sub-cell centre); healpix pixels into their NESTED children at
// nside * k (k a power of two).
class SubSampler {
 public:
  SubSampler(const EnvMap& map, int k) : map_(map), k_(k) {
    if (map.layout == Layout::Healpix) {
      fine_nside_ = int64_t(map.nside) * k;
      return;
    }
    const size_t n = size_t(map.width) * size_t(k);
    cos_phi_.resize(n);
    sin_phi_.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const double phi = 2 * M_PI * (double(i) + 0.5) / double(n);
      cos_phi_[i] = std::cos(phi);
      sin_phi_[i] = std::sin(phi);
    }
  }

  int samples_per_pixel() const { return k_ * k_; }

  // Writes samples_per_pixel() unit directions to out.
  void directions(size_t pixel, Vec3* out) const {
    if (map_.layout == Layout::Healpix) {
      const int64_t first = int64_t(pixel) * k_ * k_;
      for (int i = 0; i < k_ * k_; ++i) {
        double v[3];
        pix2vec_nest64(fine_nside_, first + i, v);
        out[i] = {v[0], v[1], v[2]};
      }
      return;
    }
    const size_t u = pixel % size_t(map_.width), row = pixel / size_t(map_.width);
    const double span = theta_span(map_.layout);
    const double c0 = std::cos(span * double(row) / map_.height);
    const double c1 = std::cos(span * double(row + 1) / map_.height);
    const double dc = (c1 - c0) / k_;
    const double* cp = &cos_phi_[u * size_t(k_)];
    const double* sp = &sin_phi_[u * size_t(k_)];
    for (int j = 0; j < k_; ++j) {
      const double c = c0 + (j + 0.5) * dc;
      const double s = std::sqrt(std::max(0.0, 1 - c * c));
      for (int i = 0; i < k_; ++i) out[j * k_ + i] = {s * cp[i], s * sp[i], c};
    }
  }

 private:
  const EnvMap& map_;
  int k_;
  int64_t fine_nside_ = 0;
  std::vector<double> cos_phi_, sin_phi_;
};

// Samples per destination pixel edge so that samples are no larger than a typical
// source pixel (ratio of mean pixel solid angles), capped; a power of two for healpix.
int choose_samples_per_edge(const EnvMap& src, const EnvMap& dst) {
  const double src_area = layout_solid_angle(src.layout) / double(src.pixel_count());
  const double dst_area = layout_solid_angle(dst.layout) / double(dst.pixel_count());
  int k = int(std::ceil(std::sqrt(dst_area / src_area) - 1e-9));
  k = std::clamp(k, 1, kMaxSamplesPerEdge);
  if (dst.layout == Layout::Healpix) k = next_power_of_two(k);
  return k;
}

// Upper bound on the angular radius (centre to farthest point) of a source pixel.
double pixel_radius_bound(const EnvMap& map) {
  if (map.layout == Layout::Healpix) return 2.0 * std::sqrt(4 * M_PI / double(map.pixel_count()));
  return theta_span(map.layout) / map.height + 2 * M_PI / map.width;
}

// Fraction of every source pixel that lies in the upper hemisphere of the world
// (z_world > 0) -- the domain of a hemisphere destination. Pixels far from the horizon
// are 0 or 1; pixels near it are measured with 16 x 16 equal-area sub-samples, a
// sub-sample exactly on the horizon counting half (so a healpix pixel centred on the
// equator, which is symmetric about it, gets exactly 1/2).
std::vector<double> upper_fraction(const EnvMap& src, const Mat3& world_from_source) {
  const size_t n = src.pixel_count();
  std::vector<double> f(n);
  const Vec3 up{world_from_source(2, 0), world_from_source(2, 1), world_from_source(2, 2)};
  const double radius = pixel_radius_bound(src);
  const double margin = radius >= M_PI / 2 ? 2.0 : std::sin(radius);
  constexpr int m = 16;
  const SubSampler sub(src, m);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<Vec3> dirs(m * m);
    for (size_t s = r.begin(); s != r.end(); ++s) {
      const double h = dot(up, pixel_direction(src, s));
      if (h > margin) {
        f[s] = 1;
      } else if (h < -margin) {
        f[s] = 0;
      } else {
        sub.directions(s, dirs.data());
        double count = 0;
        for (const Vec3& d : dirs) {
          const double z = dot(up, d);
          count += z > 1e-12 ? 1.0 : z >= -1e-12 ? 0.5 : 0.0;
        }
        f[s] = count / (m * m);
      }
    }
  });
  return f;
}

// Destination pixels are processed in blocks: rows for latlong/hemisphere, blocks of
// pixels for healpix.
struct Blocks {
  size_t count = 0, pixels_per_block = 0, pixels = 0;
  // First pixel of block b; first(count) is the end of the last block.
  size_t first(size_t b) const { return std::min(pixels, b * pixels_per_block); }
};

Blocks make_blocks(const EnvMap& dst) {
  Blocks b;
  b.pixels = dst.pixel_count();
  b.pixels_per_block = dst.layout == Layout::Healpix ? 256 : size_t(dst.width);
  b.count = (b.pixels + b.pixels_per_block - 1) / b.pixels_per_block;
  return b;
}

}  // namespace

EnvMap resample(const EnvMap& src, Layout layout, int width, int height, const ResampleOptions& options) {
  EnvMap dst = make_envmap(layout, width, height);
  dst.units = src.units;
  const size_t nsrc = src.pixel_count(), ndst = dst.pixel_count();
  if (nsrc == 0 || src.rgb.size() != 3 * nsrc)
    throw InputError(fmt::format("cannot resample an empty or malformed {} map", to_string(src.layout)));
  if (!src.valid.empty() && src.valid.size() != nsrc)
    throw InputError("cannot resample: validity mask size does not match the map");
  if (options.samples_per_edge < 0 || options.samples_per_edge > 256)
    throw InputError(fmt::format("samples per edge must be 0 (automatic) to 256, got {}", options.samples_per_edge));
  if (layout == Layout::Healpix && options.samples_per_edge != 0 && !is_power_of_two(options.samples_per_edge))
    throw InputError(fmt::format("samples per edge for a healpix destination must be a power of two, got {}",
                                 options.samples_per_edge));
  if (!(options.min_valid_fraction >= 0 && options.min_valid_fraction <= 1))
    throw InputError(fmt::format("min valid fraction must be in [0, 1], got {}", options.min_valid_fraction));
  if (!is_rotation(options.world_from_source))
    throw InputError("resample rotation (world_from_source) is not a proper rotation matrix");

  const Mat3& world_from_source = options.world_from_source;
  const Mat3 source_from_world = transpose(world_from_source);
  const bool identity = is_identity(world_from_source);
  const int k = options.samples_per_edge > 0 ? options.samples_per_edge : choose_samples_per_edge(src, dst);
  const SubSampler sampler(dst, k);
  const int spp = sampler.samples_per_pixel();
  const double needed = options.min_valid_fraction * spp - 1e-9;
  const Blocks blocks = make_blocks(dst);

  // Source pixel hit by a sample, or -1 outside the source domain / on invalid pixels.
  auto locate = [&](size_t pixel, Vec3* dirs, int64_t* hits) {
    sampler.directions(pixel, dirs);
    int valid = 0;
    for (int i = 0; i < spp; ++i) {
      const std::optional<size_t> s = pixel_at(src, identity ? dirs[i] : source_from_world * dirs[i]);
      hits[i] = s && src.is_valid(*s) ? int64_t(*s) : -1;
      valid += hits[i] >= 0;
    }
    return valid;
  };

  // Pass 1: W_s over a fixed number of chunks (each with its own buffer), summed in order.
  const size_t max_buffer_bytes = size_t(256) << 20;
  const size_t chunks = std::clamp<size_t>(max_buffer_bytes / (sizeof(double) * nsrc), 1,
                                           std::min<size_t>(4, blocks.count));
  std::vector<std::vector<double>> partial(chunks, std::vector<double>(nsrc, 0.0));
  std::vector<uint8_t> dst_valid(ndst, 0);
  tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
    std::vector<Vec3> dirs(spp);
    std::vector<int64_t> hits(spp);
    std::vector<double>& w_sum = partial[c];
    const size_t b0 = blocks.count * c / chunks, b1 = blocks.count * (c + 1) / chunks;
    for (size_t p = blocks.first(b0); p < blocks.first(b1); ++p) {
      if (locate(p, dirs.data(), hits.data()) < needed) continue;
      dst_valid[p] = 1;
      const double w = pixel_solid_angle(dst, p) / spp;
      for (int i = 0; i < spp; ++i)
        if (hits[i] >= 0) w_sum[size_t(hits[i])] += w;
    }
  });
  std::vector<double> weight = std::move(partial[0]);
  if (chunks > 1) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nsrc, 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t s = r.begin(); s != r.end(); ++s)
        for (size_t c = 1; c < chunks; ++c) weight[s] += partial[c][s];
    });
  }
  partial.clear();
  partial.shrink_to_fit();

  // Power each source pixel owes the destination: all of it, or the part inside the
  // destination's domain when that is the upper hemisphere.
  std::vector<double> fraction;
  if (layout == Layout::Hemisphere) fraction = upper_fraction(src, world_from_source);
  auto target = [&](size_t s) {
    return pixel_solid_angle(src, s) * (fraction.empty() ? 1.0 : fraction[s]);
  };

  // Missed source pixels (no sample of a valid destination pixel landed in them) go
  // whole to the destination pixel holding their centre. Serial: rare and racy.
  std::vector<double> power(3 * ndst, 0.0);
  for (size_t s = 0; s < nsrc; ++s) {
    if (weight[s] > 0 || !src.is_valid(s)) continue;
    const float* l = src.pixel(s);
    if (l[0] == 0 && l[1] == 0 && l[2] == 0) continue;
    const double t = target(s);
    if (t <= 0) continue;
    const Vec3 d = identity ? pixel_direction(src, s) : world_from_source * pixel_direction(src, s);
    const std::optional<size_t> p = pixel_at(dst, d);
    if (!p || !dst_valid[*p]) continue;
    for (int c = 0; c < 3; ++c) power[3 * *p + c] += double(l[c]) * t;
  }

  // weight becomes the scale T_s / W_s applied to each sample's solid angle.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nsrc, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t s = r.begin(); s != r.end(); ++s) weight[s] = weight[s] > 0 ? target(s) / weight[s] : 0.0;
  });

  // Pass 2: destination power and radiance, race-free per destination pixel.
  dst.valid.assign(ndst, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks.count), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<Vec3> dirs(spp);
    std::vector<int64_t> hits(spp);
    for (size_t p = blocks.first(r.begin()); p < blocks.first(r.end()); ++p) {
      if (!dst_valid[p]) continue;
      locate(p, dirs.data(), hits.data());
      const double area = pixel_solid_angle(dst, p);
      const double w = area / spp;
      double* acc = &power[3 * p];
      for (int i = 0; i < spp; ++i) {
        if (hits[i] < 0) continue;
        const size_t s = size_t(hits[i]);
        const double share = w * weight[s];
        const float* l = src.pixel(s);
        for (int c = 0; c < 3; ++c) acc[c] += double(l[c]) * share;
      }
      float* out = dst.pixel(p);
      for (int c = 0; c < 3; ++c) out[c] = float(acc[c] / area);
      dst.valid[p] = 1;
    }
  });
  if (std::all_of(dst.valid.begin(), dst.valid.end(), [](uint8_t v) { return v != 0; })) dst.valid.clear();
  return dst;
}

EnvMap rotate(const EnvMap& src, const Mat3& world_from_map) {
  ResampleOptions options;
  options.world_from_source = world_from_map;
  const int width = src.layout == Layout::Healpix ? src.nside : src.width;
  return resample(src, src.layout, width, src.height, options);
}

}  // namespace lp
