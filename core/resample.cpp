// Power-preserving resampling between layouts (see resample.h).
//
// Row grids (latlong/hemisphere) under identity, a yaw, Rx(180) or yaw * Rx(180) take
// the exact path (resample_exact): separable box filtering in (phi, cos theta) with exact
// overlap areas from per-row and per-column overlap lists. Everything else:
//
// Pass 1 supersamples every destination pixel (k x k sub-samples of equal solid angle),
// locates each sample in the source and stores, per destination pixel, how many of its
// samples landed in which source pixel. W_s is the solid angle of the samples of valid
// destination pixels that landed in source pixel s. Source pixels no sample hit are
// given whole to the destination pixel holding their centre. Pass 2 spreads each source
// pixel's power L_s * Omega_s * f_s over its samples in proportion to their solid angles
// (f_s: the fraction of s inside the destination's domain, 1 unless the destination is
// a hemisphere), so total power is exact. Before that, a few rounds of row balancing
// (iterative proportional fitting) rescale each destination pixel's sample weights so
// that a constant map comes out close to constant even where W_s is a coarse estimate
// of Omega_s; the last step is always the column normalisation, which keeps power exact.
// Summation is in double and in an order that does not depend on the number of
// threads, so results are reproducible.
#include "core/resample.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>

#include "core/error.h"

#include "core/healpix.h"

namespace lp {
namespace {

constexpr int kMaxSamplesPerEdge = 16;
// Automatic samples per edge: samples of a quarter of a typical source pixel's solid
// angle (so "no larger than a source pixel" with room to spare). With only about one
// sample per source pixel, W_s is too noisy and a smooth map comes out blotchy.
constexpr double kOversample = 2.0;
// Rounds of row balancing before the final (power-exact) column normalisation.
constexpr int kBalanceRounds = 8;

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
      for (int i = 0; i < k_ * k_; ++i) out[i] = healpix_direction(fine_nside_, first + i);
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

// Samples per destination pixel edge from the ratio of mean pixel solid angles, so that
// samples are a quarter of a typical source pixel; capped; a power of two for healpix.
int choose_samples_per_edge(const EnvMap& src, const EnvMap& dst) {
  const double src_area = layout_solid_angle(src.layout) / double(src.pixel_count());
  const double dst_area = layout_solid_angle(dst.layout) / double(dst.pixel_count());
  int k = int(std::ceil(kOversample * std::sqrt(dst_area / src_area) - 1e-9));
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

// ---- Exact path for row grids under a yaw and/or the half-turn about X -------------
//
// Latlong and hemisphere pixels are rectangles in (phi, cos theta). A rotation about +Z
// shifts phi, and Rx(180) = diag(1, -1, -1) maps (phi, cos theta) to (-phi, -cos theta),
// so under R = Rz(yaw) or R = Rz(yaw) Rx(180) a source pixel is still a rectangle in the
// world's (phi, cos theta), and its overlap with a destination pixel is exactly
// (phi overlap, with wrap-around) x (cos theta overlap). The destination value is the
// box filter with these exact areas.

constexpr double kSeparableTolerance = 1e-9;

// world phi = flip ? yaw - phi_s : yaw + phi_s; world cos theta = flip ? -cos_s : cos_s.
struct SeparableRotation {
  double yaw_turns = 0;  // yaw / (2 pi), in [0, 1)
  bool flip = false;
};

std::optional<SeparableRotation> separable_rotation(const Mat3& r) {
  const double tol = kSeparableTolerance;
  if (std::abs(r(0, 2)) > tol || std::abs(r(1, 2)) > tol || std::abs(r(2, 0)) > tol || std::abs(r(2, 1)) > tol)
    return std::nullopt;
  SeparableRotation out;
  if (std::abs(r(2, 2) - 1) <= tol)
    out.flip = false;
  else if (std::abs(r(2, 2) + 1) <= tol)
    out.flip = true;
  else
    return std::nullopt;
  // Rz(a) = [c -s 0; s c 0; 0 0 1];  Rz(a) Rx(180) = [c s 0; s -c 0; 0 0 -1].
  const double c = r(0, 0), s = r(1, 0);
  if (std::abs(std::hypot(c, s) - 1) > tol) return std::nullopt;
  if (std::abs(r(0, 1) - (out.flip ? s : -s)) > tol || std::abs(r(1, 1) - (out.flip ? -c : c)) > tol)
    return std::nullopt;
  double turns = std::atan2(s, c) / (2 * M_PI);
  turns -= std::floor(turns);
  if (turns >= 1) turns -= 1;
  out.yaw_turns = turns;
  return out;
}

struct Overlap {
  uint32_t index;  // source row or column
  double length;   // overlap in cos theta, or in phi (radians)
};

// cos theta at the boundary above row v (v = 0 .. height) of a row grid.
double row_boundary_cos(Layout layout, int height, int64_t v) {
  return std::cos(theta_span(layout) * double(v) / height);
}

// Per destination column, the source columns overlapping it and the phi overlap.
std::vector<std::vector<Overlap>> column_overlaps(int src_width, int dst_width, const SeparableRotation& rot) {
  std::vector<std::vector<Overlap>> cols{size_t(dst_width)};
  const double ws = src_width, wd = dst_width, width = 1.0 / ws;
  auto add_piece = [&](uint32_t us, double lo, double hi) {
    const int64_t d0 = std::max<int64_t>(0, int64_t(std::floor(lo * wd)));
    const int64_t d1 = std::min<int64_t>(dst_width, int64_t(std::ceil(hi * wd)));
    for (int64_t d = d0; d < d1; ++d) {
      const double ov = std::min(hi, double(d + 1) / wd) - std::max(lo, double(d) / wd);
      if (ov > 0) cols[size_t(d)].push_back({us, 2 * M_PI * ov});
    }
  };
  for (int u = 0; u < src_width; ++u) {
    double lo = rot.flip ? rot.yaw_turns - double(u + 1) / ws : rot.yaw_turns + double(u) / ws;
    lo -= std::floor(lo);
    if (lo >= 1) lo -= 1;
    const double hi = lo + width;
    if (hi <= 1) {
      add_piece(uint32_t(u), lo, hi);
    } else {
      add_piece(uint32_t(u), lo, 1.0);
      add_piece(uint32_t(u), 0.0, hi - 1);
    }
  }
  return cols;
}

// Per destination row, the source rows overlapping it and the cos theta overlap.
std::vector<std::vector<Overlap>> row_overlaps(const EnvMap& src, const EnvMap& dst, const SeparableRotation& rot) {
  std::vector<std::vector<Overlap>> rows{size_t(dst.height)};
  const double span_s = theta_span(src.layout), span_d = theta_span(dst.layout);
  for (int vd = 0; vd < dst.height; ++vd) {
    const double cd0 = row_boundary_cos(dst.layout, dst.height, vd);
    const double cd1 = row_boundary_cos(dst.layout, dst.height, vd + 1);
    // Theta range of the destination row, in the source frame.
    double t0 = span_d * vd / dst.height, t1 = span_d * (vd + 1) / dst.height;
    if (rot.flip) std::tie(t0, t1) = std::pair(M_PI - t1, M_PI - t0);
    const int64_t first = std::max<int64_t>(0, int64_t(std::floor(t0 / span_s * src.height)) - 1);
    const int64_t last = std::min<int64_t>(src.height - 1, int64_t(std::ceil(t1 / span_s * src.height)) + 1);
    for (int64_t vs = first; vs <= last; ++vs) {
      double hi = row_boundary_cos(src.layout, src.height, vs);  // world cos interval [lo, hi]
      double lo = row_boundary_cos(src.layout, src.height, vs + 1);
      if (rot.flip) std::tie(lo, hi) = std::pair(-hi, -lo);
      const double ov = std::min(hi, cd0) - std::max(lo, cd1);
      if (ov > 0) rows[size_t(vd)].push_back({uint32_t(vs), ov});
    }
  }
  return rows;
}

EnvMap resample_exact(const EnvMap& src, EnvMap dst, const SeparableRotation& rot, double min_valid_fraction) {
  const auto rows = row_overlaps(src, dst, rot);
  const auto cols = column_overlaps(src.width, dst.width, rot);
  const size_t ws = size_t(src.width), wd = size_t(dst.width);
  const bool masked = !src.valid.empty();
  dst.valid.assign(dst.pixel_count(), 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, size_t(dst.height)), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t vd = r.begin(); vd != r.end(); ++vd) {
      const std::vector<Overlap>& row = rows[vd];
      if (row.empty()) continue;  // outside the source's domain
      const double area = pixel_solid_angle(dst, vd * wd);  // the same for the whole row
      const double needed = (min_valid_fraction - 1e-9) * area;
      for (size_t ud = 0; ud < wd; ++ud) {
        const std::vector<Overlap>& col = cols[ud];
        double acc[3] = {0, 0, 0}, valid_area = 0;
        for (const Overlap& ro : row) {
          const size_t base = size_t(ro.index) * ws;
          for (const Overlap& co : col) {
            const size_t s = base + co.index;
            if (masked && !src.valid[s]) continue;
            const double a = ro.length * co.length;
            const float* l = src.pixel(s);
            valid_area += a;
            acc[0] += double(l[0]) * a;
            acc[1] += double(l[1]) * a;
            acc[2] += double(l[2]) * a;
          }
        }
        const size_t p = vd * wd + ud;
        if (!(valid_area > 0) || valid_area < needed) continue;
        float* out = dst.pixel(p);
        for (int c = 0; c < 3; ++c) out[c] = float(acc[c] / area);
        dst.valid[p] = 1;
      }
    }
  });
  if (std::all_of(dst.valid.begin(), dst.valid.end(), [](uint8_t v) { return v != 0; })) dst.valid.clear();
  return dst;
}

}  // namespace

namespace {

void check_resample(const EnvMap& src, Layout layout, const ResampleOptions& options) {
  const size_t nsrc = src.pixel_count();
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
}

// The sparse matrix from source to destination pixels: per destination pixel p (a row,
// entries [row_start[p], row_start[p + 1])) the source pixels its samples landed in.
struct Entry {
  uint32_t src;
  float count;  // samples of the destination pixel in this source pixel
};
struct Footprints {
  std::vector<Entry> entries;
  std::vector<size_t> row_start;
  std::vector<uint8_t> dst_valid;  // enough valid samples
};

// Pass 1 (parallel, race-free): the samples of every destination pixel, located in the
// source. A sample outside the source domain or on an invalid source pixel is invalid.
Footprints locate_samples(const EnvMap& src, const EnvMap& dst, const Mat3& source_from_world, bool identity,
                          const SubSampler& sampler, double needed) {
  const size_t ndst = dst.pixel_count();
  const int spp = sampler.samples_per_pixel();
  const Blocks blocks = make_blocks(dst);
  if (src.pixel_count() > UINT32_MAX) throw InputError("source map too large to resample");
  Footprints f;
  std::vector<std::vector<Entry>> block_entries(blocks.count);
  std::vector<uint32_t> row_length(ndst, 0);
  f.dst_valid.assign(ndst, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks.count), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<Vec3> dirs(spp);
    std::vector<uint32_t> hits(spp);
    for (size_t b = r.begin(); b != r.end(); ++b) {
      std::vector<Entry>& out = block_entries[b];
      for (size_t p = blocks.first(b); p < blocks.first(b + 1); ++p) {
        sampler.directions(p, dirs.data());
        int valid = 0;
        for (int i = 0; i < spp; ++i) {
          const std::optional<size_t> s = pixel_at(src, identity ? dirs[i] : source_from_world * dirs[i]);
          if (s && src.is_valid(*s)) hits[valid++] = uint32_t(*s);
        }
        if (valid < needed) continue;
        f.dst_valid[p] = 1;
        std::sort(hits.begin(), hits.begin() + valid);
        const size_t before = out.size();
        for (int i = 0; i < valid; ++i) {
          if (i > 0 && hits[i] == hits[i - 1])
            ++out.back().count;
          else
            out.push_back({hits[i], 1});
        }
        row_length[p] = uint32_t(out.size() - before);
      }
    }
  });
  f.row_start.assign(ndst + 1, 0);
  for (size_t p = 0; p < ndst; ++p) f.row_start[p + 1] = f.row_start[p] + row_length[p];
  f.entries.reserve(f.row_start[ndst]);
  for (auto& e : block_entries) {
    f.entries.insert(f.entries.end(), e.begin(), e.end());
    std::vector<Entry>().swap(e);
  }
  return f;
}

// Missed source pixels (no sample of a valid destination pixel landed in them) go whole
// to the destination pixel holding their centre: they join that pixel's row as one more
// entry weighing their own solid angle (the row's target, the area its samples cover,
// already includes them), so balancing makes room for them.
void add_missed_sources(const EnvMap& src, const EnvMap& dst, const Mat3& world_from_source, bool identity,
                        const std::vector<double>& owed, const std::vector<double>& row_weight, Footprints* f) {
  const size_t nsrc = src.pixel_count(), ndst = dst.pixel_count();
  std::vector<uint8_t> hit(nsrc, 0);
  for (const Entry& e : f->entries) hit[e.src] = 1;
  std::vector<std::pair<size_t, uint32_t>> extra;  // (destination, source), in source order
  for (size_t s = 0; s < nsrc; ++s) {
    if (hit[s] || owed[s] <= 0) continue;
    const Vec3 d = identity ? pixel_direction(src, s) : world_from_source * pixel_direction(src, s);
    const std::optional<size_t> p = pixel_at(dst, d);
    if (p && f->dst_valid[*p]) extra.push_back({*p, uint32_t(s)});
  }
  if (extra.empty()) return;
  std::stable_sort(extra.begin(), extra.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  std::vector<Entry> merged;
  merged.reserve(f->entries.size() + extra.size());
  std::vector<size_t> merged_start(ndst + 1, 0);
  size_t next = 0;
  for (size_t p = 0; p < ndst; ++p) {
    merged_start[p] = merged.size();
    merged.insert(merged.end(), f->entries.begin() + f->row_start[p], f->entries.begin() + f->row_start[p + 1]);
    for (; next < extra.size() && extra[next].first == p; ++next)
      merged.push_back({extra[next].second, float(owed[extra[next].second] / row_weight[p])});
  }
  merged_start[ndst] = merged.size();
  f->entries.swap(merged);
  f->row_start.swap(merged_start);
}

// A few rounds of balancing (iterative proportional fitting) of the row weights towards
// `row_target`; returns the final column scale T_s / W_s, which keeps every source
// pixel's power exact.
std::vector<double> balance(const Footprints& f, const std::vector<double>& owed, const std::vector<double>& row_target,
                            std::vector<double>* row_weight) {
  const size_t nsrc = owed.size(), ndst = row_target.size();
  const auto& entries = f.entries;
  const auto& row_start = f.row_start;
  std::vector<double>& weight = *row_weight;
  std::vector<double> scale(nsrc);  // T_s / W_s
  auto column_step = [&] {
    std::fill(scale.begin(), scale.end(), 0.0);  // W_s, serial scatter in a fixed order
    for (size_t p = 0; p < ndst; ++p)
      for (size_t e = row_start[p]; e < row_start[p + 1]; ++e) scale[entries[e].src] += weight[p] * entries[e].count;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nsrc, 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t s = r.begin(); s != r.end(); ++s) scale[s] = scale[s] > 0 ? owed[s] / scale[s] : 0.0;
    });
  };
  for (int round = 0; round < kBalanceRounds; ++round) {
    column_step();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, ndst, 1024), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t p = r.begin(); p != r.end(); ++p) {
        double got = 0;
        for (size_t e = row_start[p]; e < row_start[p + 1]; ++e) got += weight[p] * entries[e].count * scale[entries[e].src];
        if (got > 0) weight[p] *= row_target[p] / got;
      }
    });
  }
  column_step();
  return scale;
}

// Pass 2: destination power and radiance, race-free per destination pixel.
void gather_power(const EnvMap& src, const Footprints& f, const std::vector<double>& row_weight,
                  const std::vector<double>& scale, EnvMap* dst) {
  const size_t ndst = dst->pixel_count();
  std::vector<double> power(3 * ndst, 0.0);
  dst->valid.assign(ndst, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, ndst, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t p = r.begin(); p != r.end(); ++p) {
      if (!f.dst_valid[p]) continue;
      double* acc = &power[3 * p];
      for (size_t e = f.row_start[p]; e < f.row_start[p + 1]; ++e) {
        const size_t s = f.entries[e].src;
        const double share = row_weight[p] * f.entries[e].count * scale[s];
        const float* l = src.pixel(s);
        for (int c = 0; c < 3; ++c) acc[c] += double(l[c]) * share;
      }
      const double area = pixel_solid_angle(*dst, p);
      float* out = dst->pixel(p);
      for (int c = 0; c < 3; ++c) out[c] = float(acc[c] / area);
      dst->valid[p] = 1;
    }
  });
  if (std::all_of(dst->valid.begin(), dst->valid.end(), [](uint8_t v) { return v != 0; })) dst->valid.clear();
}

}  // namespace

EnvMap resample(const EnvMap& src, Layout layout, int width, int height, const ResampleOptions& options) {
  EnvMap dst = make_envmap(layout, width, height);
  dst.units = src.units;
  // The probe turned with its map: the rotation recorded composes with this one.
  if (src.world_from_probe) dst.world_from_probe = options.world_from_source * *src.world_from_probe;
  dst.vignetting_corrected = src.vignetting_corrected;
  check_resample(src, layout, options);
  if (src.layout != Layout::Healpix && layout != Layout::Healpix) {
    if (const auto rot = separable_rotation(options.world_from_source))
      return resample_exact(src, std::move(dst), *rot, options.min_valid_fraction);
  }

  const size_t nsrc = src.pixel_count(), ndst = dst.pixel_count();
  const Mat3& world_from_source = options.world_from_source;
  const bool identity = is_identity(world_from_source);
  const int k = options.samples_per_edge > 0 ? options.samples_per_edge : choose_samples_per_edge(src, dst);
  const SubSampler sampler(dst, k);
  const int spp = sampler.samples_per_pixel();
  Footprints f = locate_samples(src, dst, transpose(world_from_source), identity, sampler,
                                options.min_valid_fraction * spp - 1e-9);

  // Power each source pixel owes the destination: all of it, or the part inside the
  // destination's domain when that is the upper hemisphere.
  std::vector<double> fraction;
  if (layout == Layout::Hemisphere) fraction = upper_fraction(src, world_from_source);
  std::vector<double> owed(nsrc);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nsrc, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t s = r.begin(); s != r.end(); ++s)
      owed[s] = src.is_valid(s) ? pixel_solid_angle(src, s) * (fraction.empty() ? 1.0 : fraction[s]) : 0.0;
  });

  // Sample solid angle per destination pixel, times a row balance factor. The factors
  // start at 1 (plain W_s normalisation); balancing makes each destination pixel
  // receive, for a constant map, the solid angle its valid samples cover.
  std::vector<double> row_weight(ndst, 0.0), row_target(ndst, 0.0);
  for (size_t p = 0; p < ndst; ++p) {
    if (!f.dst_valid[p]) continue;
    row_weight[p] = pixel_solid_angle(dst, p) / spp;
    for (size_t e = f.row_start[p]; e < f.row_start[p + 1]; ++e) row_target[p] += row_weight[p] * f.entries[e].count;
  }
  add_missed_sources(src, dst, world_from_source, identity, owed, row_weight, &f);
  const std::vector<double> scale = balance(f, owed, row_target, &row_weight);
  gather_power(src, f, row_weight, scale, &dst);
  return dst;
}

EnvMap rotate(const EnvMap& src, const Mat3& world_from_map) {
  ResampleOptions options;
  options.world_from_source = world_from_map;
  const int width = src.layout == Layout::Healpix ? src.nside : src.width;
  return resample(src, src.layout, width, src.height, options);
}

}  // namespace lp
