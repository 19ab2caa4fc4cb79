// Debevec's median cut (SIGGRAPH 2005 poster "A median cut algorithm for light probe
// sampling") on a latlong or hemisphere row grid, with an exact light count: a max-heap of
// rectangular regions keyed by power (luminance * solid angle); the most powerful region
// is cut across its longest angular side (dphi * sin(theta_mid) against dtheta) where the
// power halves, until there are n regions. One light per region: direction = power-weighted
// centroid of its pixel directions, rgb = integral of radiance over it, solid_angle = its
// area, id = split-path code (root 1, children 2k and 2k + 1).
//
// Cost: prepare is one pass (a summed-area table of luminance * solid angle in double, the
// clamped luminances and the power), in blocks of eight rows, each step a vector row kernel
// of sampling/row_sweep.h. place() reads the colours from the caller's map (sampler.h: it
// must outlive the frame's place() calls); only a masked map's are copied, invalid pixels
// zeroed.
// place is n heap steps with O(log size) table look-ups each, then one pass over the
// colours to integrate each final region (the regions partition the map).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <queue>

#include "core/error.h"
#include "sampling/methods.h"
#include "sampling/power.h"
#include "sampling/row_sweep.h"

namespace lp {
namespace {

struct Region {
  int r0, r1, c0, c1;  // rows [r0, r1), columns [c0, c1)
  double power;
  uint64_t id;
};

struct ByPower {
  bool operator()(const Region& a, const Region& b) const {
    if (a.power != b.power) return a.power < b.power;
    return a.id > b.id;  // deterministic among equals: the smaller code first
  }
};

// Split-path codes above this would overflow 64 bits; deeper regions (only on maps whose
// power keeps peeling single rows off one side) get the code kDeep | first pixel index,
// which is unique among the leaves because they partition the map.
constexpr uint64_t kDeep = uint64_t(1) << 63;

// Rows prepare sweeps at once: enough running sums in flight to hide the adds' latency,
// few enough that the block's colours and luminances are still in cache for the sums.
constexpr int kBlock = 8;

// `count` elements of `storage` from its first 64-byte boundary on (kept in its slack).
template <class T>
T* line_aligned(std::vector<T>& storage, size_t count) {
  constexpr size_t kLine = 64;
  storage.resize(count + kLine / sizeof(T));
  const size_t offset = reinterpret_cast<uintptr_t>(storage.data()) % kLine;
  return storage.data() + (kLine - offset) % kLine / sizeof(T);
}

class MedianCutSampler final : public Sampler {
 public:
  MedianCutSampler() = default;
  MedianCutSampler(const MedianCutSampler&) = delete;  // sat_, colour_, lum_ point into its own storage
  MedianCutSampler& operator=(const MedianCutSampler&) = delete;

  Method method() const override { return Method::MedianCut; }

  void prepare(const EnvMap& input) override {
    prepared_ = false;
    const EnvMap* map = &input;
    if (input.layout == Layout::Healpix) {
      require_samplable(input, "mediancut");
      grid_ = as_row_grid(input);
      map = &grid_;
    }
    update_geometry(*map);
    const int w = map->width, h = map->height;
    const size_t count = map->pixel_count();
    if (map->rgb.size() < 3 * count) throw InputError("mediancut: the map has fewer pixels than its size says");
    allocate_table(w, h);
    // An unmasked map's colours are read where they are: copying them was ~40 % of prepare.
    copy_ = map->valid.empty() ? nullptr : line_aligned(colour_storage_, 3 * count);
    colour_ = copy_ ? copy_ : map->rgb.data();
    lum_ = line_aligned(lum_storage_, count);
    std::array<double, 3> power{0, 0, 0};
    // Rows in blocks (see sweep_rows); the sums across rows stay in row order.
    for (int r = 0; r < h; r += kBlock) sweep_rows(*map, r, std::min(kBlock, h - r), power);
    const double lum_power = luminance(power.data());
    const double table_power = table(h, w);
    if (!std::isfinite(lum_power) || !std::isfinite(table_power) || !(lum_power > 0) || !(table_power > 0)) {
      refuse_unsummable(*map, "mediancut");
    }
    power_ = input.layout == Layout::Healpix ? total_power(input) : power;
    width_ = w;
    height_ = h;
    prepared_ = true;
  }

  std::vector<Light> place(int n) override {
    if (n <= 0) throw InputError(fmt::format("mediancut: the number of lights must be positive, got {}", n));
    if (!prepared_) throw InputError("mediancut: place() called before a successful prepare()");
    const size_t pixels = size_t(width_) * size_t(height_);
    if (size_t(n) > pixels)
      throw InputError(fmt::format("mediancut: {} lights asked of a map with only {} pixels", n, pixels));

    heap_.clear();
    leaves_.clear();
    heap_.push_back({0, height_, 0, width_, table(height_, width_), 1});
    while (heap_.size() + leaves_.size() < size_t(n)) {
      std::pop_heap(heap_.begin(), heap_.end(), ByPower{});
      const Region top = heap_.back();
      heap_.pop_back();
      if (top.r1 - top.r0 == 1 && top.c1 - top.c0 == 1) {
        leaves_.push_back(top);  // one pixel: cannot split
        continue;
      }
      Region a, b;
      split(top, &a, &b);
      heap_.push_back(a);
      std::push_heap(heap_.begin(), heap_.end(), ByPower{});
      heap_.push_back(b);
      std::push_heap(heap_.begin(), heap_.end(), ByPower{});
    }
    leaves_.insert(leaves_.end(), heap_.begin(), heap_.end());

    std::vector<Light> lights;
    lights.reserve(leaves_.size());
    for (const Region& g : leaves_) lights.push_back(integrate(g));
    // A region's single-precision sums overflow only on values near float's limit (3e38):
    // said here, at the cost of the lights, not of a pass over the map in prepare().
    for (const Light& l : lights)
      if (!std::isfinite(l.rgb[0] + l.rgb[1] + l.rgb[2]))
        throw InputError("mediancut: the map's power overflows single precision (values near 3.4e38): scale the map down");
    match_total_power(lights, power_);
    return lights;
  }

 private:
  // Rows r .. r + count - 1 (count <= kBlock): writes the clamped luminances (for a masked
  // map also copies the colours, invalid pixels zeroed) and the rows of the summed-area
  // table, and adds the rows' power to `power` in row order, each step a vector kernel of
  // sampling/row_sweep.h whose results equal the plain loops' bit for bit.
  void sweep_rows(const EnvMap& map, int r, int count, std::array<double, 3>& power) {
    const size_t w = size_t(map.width), stride = sat_stride_;
    const bool masked = !map.valid.empty();
    const float* colour[kBlock];
    const float* lum[kBlock];
    double* out[kBlock];
    double dw[kBlock];
    for (int k = 0; k < count; ++k) {
      const size_t base = size_t(r + k) * w;
      colour[k] = colour_ + 3 * base;
      lum[k] = lum_ + base;
      out[k] = sat_ + (size_t(r + k) + 1) * stride;
      dw[k] = row_solid_angle_[size_t(r + k)];
      detail::colour_and_luminance_row(map.rgb.data() + 3 * base, masked ? map.valid.data() + base : nullptr, w,
                                       false, copy_ ? copy_ + 3 * base : nullptr, lum_ + base);
    }
    double s[kBlock][6] = {};  // per row: r, g, b sums (the last three unused)
    detail::add_channel_sums(colour, size_t(count), w, false, &s[0][0]);
    detail::summed_area_rows(lum, dw, size_t(count), w, sat_ + size_t(r) * stride, out);
    for (int k = 0; k < count; ++k)
      for (int j = 0; j < 3; ++j) power[j] += dw[k] * s[k][j];
  }

  // The table's rows are padded so that every row's entries from column 1 on (what the
  // kernels write) start on a cache line, as do the colours: a vector store that straddles
  // two lines costs two, and with 64-byte vectors every unaligned one does.
  void allocate_table(int w, int h) {
    sat_stride_ = (size_t(w) + 8 + 7) / 8 * 8;  // >= w + 8: column w fits before the next row's column 1
    sat_ = line_aligned(sat_storage_, (size_t(h) + 1) * sat_stride_ + 7) + 7;
    std::fill(sat_, sat_ + size_t(w) + 1, 0.0);
  }

  // The summed-area table's entry for rows [0, r) and columns [0, c).
  double table(int r, int c) const { return sat_[size_t(r) * sat_stride_ + size_t(c)]; }

  double rect(int r0, int r1, int c0, int c1) const {
    const double v = table(r1, c1) - table(r0, c1) - table(r1, c0) + table(r0, c0);
    return std::max(0.0, v);
  }

  // Best cut position along columns (by_columns) or rows, in (lo, hi); returns the
  // power on the low side through *low.
  int best_cut(const Region& g, bool by_columns, double* low) const {
    const int lo = (by_columns ? g.c0 : g.r0) + 1, hi = (by_columns ? g.c1 : g.r1) - 1;
    auto low_power = [&](int k) { return by_columns ? rect(g.r0, g.r1, g.c0, k) : rect(g.r0, k, g.c0, g.c1); };
    if (!(g.power > 0)) {  // dark region: cut in the middle
      const int k = (lo + hi + 1) / 2;
      *low = low_power(k);
      return k;
    }
    const double half = 0.5 * g.power;
    int a = lo, b = hi;  // smallest k in [lo, hi] with low_power(k) >= half, else hi
    while (a < b) {
      const int m = a + (b - a) / 2;
      if (low_power(m) >= half) b = m;
      else a = m + 1;
    }
    int k = a;
    double pk = low_power(k);
    if (k > lo) {
      const double pm = low_power(k - 1);
      if (std::abs(pm - half) < std::abs(pk - half)) {
        k = k - 1;
        pk = pm;
      }
    }
    *low = pk;
    return k;
  }

  void split(const Region& g, Region* a, Region* b) const {
    const int rows = g.r1 - g.r0, cols = g.c1 - g.c0;
    bool by_columns;
    if (rows == 1) by_columns = true;
    else if (cols == 1) by_columns = false;
    else {
      const double theta_mid = 0.5 * (theta_[size_t(g.r0)] + theta_[size_t(g.r1)]);
      by_columns = cols * dphi_ * std::sin(theta_mid) >= rows * dtheta_;
    }
    double low = 0;
    int k = best_cut(g, by_columns, &low);
    // Debevec cuts the longest side; when that leaves (almost) all the power on one side
    // and the other side can do better, cut the other way (e.g. two lights stacked in a
    // wide region).
    if (g.power > 0 && rows > 1 && cols > 1 && std::min(low, g.power - low) < 0.1 * g.power) {
      double other_low = 0;
      const int other = best_cut(g, !by_columns, &other_low);
      if (std::min(other_low, g.power - other_low) > std::min(low, g.power - low)) {
        by_columns = !by_columns;
        k = other;
        low = other_low;
      }
    }
    *a = g;
    *b = g;
    if (by_columns) {
      a->c1 = k;
      b->c0 = k;
    } else {
      a->r1 = k;
      b->r0 = k;
    }
    a->power = low;
    b->power = std::max(0.0, g.power - low);
    if (g.id < (kDeep >> 1)) {
      a->id = 2 * g.id;
      b->id = 2 * g.id + 1;
    } else {
      a->id = kDeep | (size_t(a->r0) * size_t(width_) + size_t(a->c0));
      b->id = kDeep | (size_t(b->r0) * size_t(width_) + size_t(b->c0));
    }
  }

  Light integrate(const Region& g) const {
    double rgb[3] = {0, 0, 0}, d[3] = {0, 0, 0};
    for (int r = g.r0; r < g.r1; ++r) {
      const float* p = colour_ + 3 * (size_t(r) * size_t(width_) + size_t(g.c0));
      const float* py = lum_ + size_t(r) * size_t(width_);
      // Two pixels per step into separate accumulators: the add chains, not the
      // arithmetic, bound this loop.
      float s[3] = {0, 0, 0}, lc = 0, ls = 0, l = 0;
      float t[3] = {0, 0, 0}, tc = 0, ts = 0, tl = 0;
      const float* cp = cos_phi_.data();
      const float* sp = sin_phi_.data();
      int c = g.c0;
      for (; c + 1 < g.c1; c += 2, p += 6) {
        const float y0 = py[c], y1 = py[c + 1];
        s[0] += p[0];
        s[1] += p[1];
        s[2] += p[2];
        t[0] += p[3];
        t[1] += p[4];
        t[2] += p[5];
        lc += y0 * cp[c];
        tc += y1 * cp[c + 1];
        ls += y0 * sp[c];
        ts += y1 * sp[c + 1];
        l += y0;
        tl += y1;
      }
      if (c < g.c1) {
        const float y = py[c];
        s[0] += p[0];
        s[1] += p[1];
        s[2] += p[2];
        lc += y * cp[c];
        ls += y * sp[c];
        l += y;
      }
      for (int k = 0; k < 3; ++k) s[k] += t[k];
      lc += tc;
      ls += ts;
      l += tl;
      const double dw = row_solid_angle_[size_t(r)];
      for (int k = 0; k < 3; ++k) rgb[k] += dw * s[k];
      const double st = dw * sin_theta_[size_t(r)];
      d[0] += st * lc;
      d[1] += st * ls;
      d[2] += dw * cos_theta_[size_t(r)] * l;
    }
    Light light;
    light.id = g.id;
    light.rgb = {rgb[0], rgb[1], rgb[2]};
    light.solid_angle = (g.c1 - g.c0) * dphi_ * (std::cos(theta_[size_t(g.r0)]) - std::cos(theta_[size_t(g.r1)]));
    const Vec3 sum{d[0], d[1], d[2]};
    const double len = length(sum);
    if (len > 1e-300 && std::isfinite(len)) {
      light.direction = (1.0 / len) * sum;
    } else {  // no light in the region (or a cancelling ring): its angular centre
      light.direction = direction_from_angles(0.5 * (theta_[size_t(g.r0)] + theta_[size_t(g.r1)]),
                                              0.5 * dphi_ * (g.c0 + g.c1));
    }
    return light;
  }

  // Per-row and per-column geometry, a function of the layout and size only.
  void update_geometry(const EnvMap& map) {
    if (map.layout == geo_layout_ && map.width == geo_width_ && map.height == geo_height_) return;
    const int w = map.width, h = map.height;
    const double span = map.layout == Layout::Hemisphere ? M_PI / 2 : M_PI;
    dtheta_ = span / h;
    dphi_ = 2 * M_PI / w;
    theta_.resize(size_t(h) + 1);
    for (int r = 0; r <= h; ++r) theta_[size_t(r)] = span * r / h;
    row_solid_angle_.resize(size_t(h));
    sin_theta_.resize(size_t(h));
    cos_theta_.resize(size_t(h));
    for (int r = 0; r < h; ++r) {
      row_solid_angle_[size_t(r)] = pixel_solid_angle(map, size_t(r) * size_t(w));
      const double t = span * (r + 0.5) / h;
      sin_theta_[size_t(r)] = std::sin(t);
      cos_theta_[size_t(r)] = std::cos(t);
    }
    cos_phi_.resize(size_t(w));
    sin_phi_.resize(size_t(w));
    for (int c = 0; c < w; ++c) {
      const double p = dphi_ * (c + 0.5);
      cos_phi_[size_t(c)] = float(std::cos(p));
      sin_phi_[size_t(c)] = float(std::sin(p));
    }
    geo_layout_ = map.layout;
    geo_width_ = w;
    geo_height_ = h;
  }

  EnvMap grid_;                 // healpix input resampled to latlong
  // (H+1) x (W+1) summed-area table of luminance * solid angle (see table()), in
  // sat_storage_; the colours and luminances in theirs, each from a cache line on.
  std::vector<double> sat_storage_;
  double* sat_ = nullptr;
  size_t sat_stride_ = 0;
  std::vector<float> colour_storage_, lum_storage_;
  float* copy_ = nullptr;          // a masked map's colours, invalid pixels zeroed
  const float* colour_ = nullptr;  // the map's rgb, or copy_
  float* lum_ = nullptr;     // clamped luminance per pixel (0 where invalid)
  std::array<double, 3> power_{0, 0, 0};
  int width_ = 0, height_ = 0;
  bool prepared_ = false;
  std::vector<Region> heap_, leaves_;

  Layout geo_layout_ = Layout::Healpix;
  int geo_width_ = -1, geo_height_ = -1;
  double dtheta_ = 0, dphi_ = 0;
  std::vector<double> theta_, row_solid_angle_, sin_theta_, cos_theta_;
  std::vector<float> cos_phi_, sin_phi_;
};

}  // namespace

std::unique_ptr<Sampler> make_median_cut_sampler(const SamplerOptions&) {
  return std::make_unique<MedianCutSampler>();
}

}  // namespace lp
