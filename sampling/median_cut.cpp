// Debevec's median cut (SIGGRAPH 2005 poster "A median cut algorithm for light probe
// sampling") on a latlong or hemisphere row grid, with an exact light count: a max-heap of
// rectangular regions keyed by power (luminance * solid angle); the most powerful region
// is cut across its longest angular side (dphi * sin(theta_mid) against dtheta) where the
// power halves, until there are n regions. One light per region: direction = power-weighted
// centroid of its pixel directions, rgb = integral of radiance over it, solid_angle = its
// area, id = split-path code (root 1, children 2k and 2k + 1).
//
// Cost: prepare is one pass (a summed-area table of luminance * solid angle in double and a
// copy of the colours, so that place() does not depend on the caller's map staying alive),
// in blocks of eight rows: the vector row kernels of sampling/row_sweep.h, then the rows'
// serial sums in lockstep.
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

class MedianCutSampler final : public Sampler {
 public:
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
    const size_t stride = size_t(w) + 1;
    sat_.resize(stride * (size_t(h) + 1));
    std::fill(sat_.begin(), sat_.begin() + ptrdiff_t(stride), 0.0);
    colour_.resize(3 * count);
    lum_.resize(count);
    std::array<double, 3> power{0, 0, 0};
    // Rows in blocks of eight (see sweep_rows); the sums across rows stay in row order.
    int r = 0;
    for (; r + 8 <= h; r += 8) sweep_rows<8>(*map, r, power);
    for (; r < h; ++r) sweep_rows<1>(*map, r, power);
    const double lum_power = luminance(power.data());
    const double table_power = sat_.back();
    if (!std::isfinite(lum_power) || !std::isfinite(table_power) || !(lum_power > 0) || !(table_power > 0)) {
      require_samplable(*map, "mediancut");  // throws the shared message
      throw InputError("mediancut: the map has no positive luminance to sample");
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
    heap_.push_back({0, height_, 0, width_, sat_.back(), 1});
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
    match_total_power(lights, power_);
    return lights;
  }

 private:
  // Rows r .. r + K - 1: copies the colours (invalid pixels zeroed) and the clamped
  // luminances, writes the rows of the summed-area table and adds the rows' power to `power`
  // in row order. The element-wise work and the channel sums are the vector kernels' of
  // sampling/row_sweep.h; each row's running sum is the same chain of additions as a row
  // alone, the K rows in lockstep so that the CPU overlaps their chains.
  template <int K>
  void sweep_rows(const EnvMap& map, int r, std::array<double, 3>& power) {
    const size_t w = size_t(map.width), stride = w + 1;
    const bool masked = !map.valid.empty();
    const float* colour[K];
    const float* lum[K];
    double* out[K];
    double dw[K];
    for (int k = 0; k < K; ++k) {
      const size_t base = size_t(r + k) * w;
      colour[k] = colour_.data() + 3 * base;
      lum[k] = lum_.data() + base;
      out[k] = sat_.data() + (size_t(r + k) + 1) * stride;
      out[k][0] = 0;
      dw[k] = row_solid_angle_[size_t(r + k)];
      detail::colour_and_luminance_row(map.rgb.data() + 3 * base, masked ? map.valid.data() + base : nullptr, w,
                                       false, colour_.data() + 3 * base, lum_.data() + base);
    }
    double s[K][6] = {};  // per row: r, g, b sums (the last three unused)
    detail::add_channel_sums(colour, K, w, false, &s[0][0]);
    const double* above = sat_.data() + size_t(r) * stride;
    double run[K] = {};
    for (size_t c = 0; c < w; ++c) {
      run[0] += dw[0] * double(lum[0][c]);
      out[0][c + 1] = above[c + 1] + run[0];
      for (int k = 1; k < K; ++k) {
        run[k] += dw[k] * double(lum[k][c]);
        out[k][c + 1] = out[k - 1][c + 1] + run[k];
      }
    }
    for (int k = 0; k < K; ++k)
      for (int j = 0; j < 3; ++j) power[j] += dw[k] * s[k][j];
  }

  double rect(int r0, int r1, int c0, int c1) const {
    const size_t stride = size_t(width_) + 1;
    const double* s = sat_.data();
    const double v = s[size_t(r1) * stride + size_t(c1)] - s[size_t(r0) * stride + size_t(c1)] -
                     s[size_t(r1) * stride + size_t(c0)] + s[size_t(r0) * stride + size_t(c0)];
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
      const float* p = colour_.data() + 3 * (size_t(r) * size_t(width_) + size_t(g.c0));
      const float* py = lum_.data() + size_t(r) * size_t(width_);
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
  std::vector<double> sat_;     // (H+1) x (W+1) summed-area table of luminance * solid angle
  std::vector<float> colour_;   // the map's rgb, invalid pixels zeroed
  std::vector<float> lum_;      // clamped luminance per pixel (0 where invalid)
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
