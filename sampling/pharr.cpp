// Pharr & Humphreys inverse-CDF sampling on a row grid (Nikodym et al. 2013, section 3.1):
// per-pixel weight = luminance * exact pixel solid angle; a marginal CDF over rows and a
// conditional CDF per row; light i is the image of Halton point i (bases 2, 3) through
// them, placed continuously inside its pixel (phi linear, cos theta linear: area-uniform).
// Every light carries 1/n of the luminance power with the colour of its pixel; the total is
// then matched per channel to the map's power.
//
// Cost: prepare is one pass over the pixels in blocks of eight rows (CDFs, per-channel
// power; place() reads the colours and the mask from the caller's map, sampler.h): the
// vector row kernels of sampling/row_sweep.h, then the serial luminance sums of the eight
// rows in lockstep; ~1.3x one plain read of the map (was 2.9x, docs/sampling.md).
// place is two binary searches and one sincos per light. Buffers and the per-row geometry
// are reused across frames; Halton points are cached across calls.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "sampling/halton.h"
#include "sampling/methods.h"
#include "sampling/power.h"
#include "sampling/row_sweep.h"

namespace lp {
namespace {

class PharrSampler final : public Sampler {
 public:
  Method method() const override { return Method::Pharr; }

  void prepare(const EnvMap& input) override {
    prepared_ = false;
    const EnvMap* map = &input;
    if (input.layout == Layout::Healpix) {
      require_samplable(input, "pharr");
      grid_ = as_row_grid(input);
      map = &grid_;
    }
    update_geometry(*map);
    const int w = map->width, h = map->height;
    const size_t count = map->pixel_count();
    if (map->rgb.size() < 3 * count) throw InputError("pharr: the map has fewer pixels than its size says");
    cdf_.resize(count);
    colour_ = map->rgb.data();
    valid_ = map->valid.empty() ? nullptr : map->valid.data();
    if (valid_) scratch_.resize(3 * 8 * size_t(w));
    row_cdf_.resize(size_t(h));
    std::array<double, 3> power{0, 0, 0};
    double marginal = 0;
    // Rows in blocks of eight (see sweep_rows); the sums across rows stay in row order.
    int r = 0;
    for (; r + 8 <= h; r += 8) sweep_rows<8>(*map, r, power, marginal);
    for (; r < h; ++r) sweep_rows<1>(*map, r, power, marginal);
    const double lum_power = luminance(power.data());
    if (!std::isfinite(lum_power) || !std::isfinite(marginal) || !(lum_power > 0) || !(marginal > 0)) {
      refuse_unsummable(*map, "pharr");
    }
    power_ = input.layout == Layout::Healpix ? total_power(input) : power;
    luminance_power_ = luminance(power_.data());
    width_ = w;
    height_ = h;
    prepared_ = true;
  }

  std::vector<Light> place(int n) override {
    if (n <= 0) throw InputError(fmt::format("pharr: the number of lights must be positive, got {}", n));
    if (!prepared_) throw InputError("pharr: place() called before a successful prepare()");
    ensure_halton(n);
    std::vector<Light> lights(static_cast<size_t>(n));
    const double total = row_cdf_.back();
    const double share = luminance_power_ / n;
    const double dphi = 2 * M_PI / width_;
    const double* rows = row_cdf_.data();
    for (int i = 0; i < n; ++i) {
      const double u = halton_u_[size_t(i)], v = halton_v_[size_t(i)];
      // Row: first with cumulative weight > u * total (skips rows of zero weight).
      const double x = u * total;
      int r = int(std::upper_bound(rows, rows + height_, x) - rows);
      if (r >= height_) r = last_positive_row();
      const double before = r > 0 ? rows[r - 1] : 0.0;
      const double rw = rows[r] - before;
      const double fr = std::clamp((x - before) / rw, 0.0, 1.0);
      // Column inside the row.
      const float* cdf = cdf_.data() + size_t(r) * size_t(width_);
      const double y = v * double(cdf[width_ - 1]);
      int c = int(std::upper_bound(cdf, cdf + width_, y, [](double a, float b) { return a < double(b); }) - cdf);
      if (c >= width_) c = last_positive_column(cdf);
      const double left = c > 0 ? double(cdf[c - 1]) : 0.0;
      const double cw = double(cdf[c]) - left;
      const double fc = cw > 0 ? std::clamp((y - left) / cw, 0.0, 1.0) : 0.5;

      const double phi = dphi * (c + fc);
      const double z = cos0_[size_t(r)] + fr * (cos1_[size_t(r)] - cos0_[size_t(r)]);
      const double s = std::sqrt(std::max(0.0, 1 - z * z));
      Light& l = lights[size_t(i)];
      l.id = uint64_t(i) + 1;
      l.direction = {s * std::cos(phi), s * std::sin(phi), z};
      static constexpr float kBlack[3] = {0, 0, 0};  // an invalid pixel
      const size_t at = size_t(r) * size_t(width_) + size_t(c);
      const float* p = valid_ && !valid_[at] ? kBlack : colour_ + 3 * at;
      const double lum = std::max(0.0, double(luminance(p[0], p[1], p[2])));
      if (lum > 0) {
        const double k = share / lum;
        l.rgb = {k * p[0], k * p[1], k * p[2]};
        l.solid_angle = k;  // the solid angle that carries 1/n of the power at this radiance
      } else {
        l.rgb = {share, share, share};
        l.solid_angle = row_solid_angle_[size_t(r)];
      }
    }
    match_total_power(lights, power_);
    return lights;
  }

 private:
  // Rows r .. r + K - 1: writes each row's luminance CDF (for a masked map also the block's
  // colours, invalid pixels zeroed, to scratch_ for their sums), then adds the rows' power
  // to `power` and `marginal` in row order. The element-wise work is the vector kernel's (sampling/row_sweep.h); each row's sums are
  // the same chains of additions in the same order as before (two partial sums per
  // channel, one running luminance sum), swept K rows at a time so that the CPU overlaps
  // K independent chains instead of waiting on each addition (one row alone runs at the
  // adder's latency: the speed of the whole plain read).
  template <int K>
  void sweep_rows(const EnvMap& map, int r, std::array<double, 3>& power, double& marginal) {
    const size_t w = size_t(map.width);
    const bool masked = !map.valid.empty();
    const float* colour[K];
    float* cdf[K];
    for (int k = 0; k < K; ++k) {
      const size_t base = size_t(r + k) * w;
      float* zeroed = masked ? scratch_.data() + 3 * size_t(k) * w : nullptr;
      colour[k] = zeroed ? zeroed : colour_ + 3 * base;
      cdf[k] = cdf_.data() + base;
      detail::colour_and_luminance_row(map.rgb.data() + 3 * base, masked ? map.valid.data() + base : nullptr, w,
                                       false, zeroed, cdf[k]);
    }
    // Per-channel sums: even pixels into s[k][0..2], odd into s[k][3..5].
    double s[K][6] = {};
    detail::add_channel_sums(colour, K, w, true, &s[0][0]);
    // The luminance CDF, in place over the luminances. Its K chains run at the adder's
    // latency and leave the memory idle, so they carry the prefetch of the next block's
    // radiance (K rows, contiguous: 12 K bytes for each column of this block, 96 at K = 8),
    // two lines an iteration, spread over the loop.
    const char* next = r + 2 * K <= map.height ? reinterpret_cast<const char*>(map.rgb.data() + 3 * size_t(r + K) * w) : nullptr;
    const size_t stride = 12 * K;  // bytes of the next block per column of this one
    float run[K] = {};
    for (size_t c = 0; c < w; ++c) {
      if (next) {
        __builtin_prefetch(next + c * stride, 0, 2);
        __builtin_prefetch(next + c * stride + 64, 0, 2);
      }
      for (int k = 0; k < K; ++k) cdf[k][c] = run[k] += cdf[k][c];
    }
    for (int k = 0; k < K; ++k) {
      const double dw = row_solid_angle_[size_t(r + k)];
      for (int j = 0; j < 3; ++j) power[j] += dw * (s[k][j] + s[k][3 + j]);
      marginal += dw * double(run[k]);
      row_cdf_[size_t(r + k)] = marginal;
    }
  }

  // Per-row geometry, a function of the layout and size only.
  void update_geometry(const EnvMap& map) {
    if (map.layout == geo_layout_ && map.width == geo_width_ && map.height == geo_height_) return;
    const int h = map.height;
    const double span = map.layout == Layout::Hemisphere ? M_PI / 2 : M_PI;
    cos0_.resize(size_t(h));
    cos1_.resize(size_t(h));
    row_solid_angle_.resize(size_t(h));
    for (int r = 0; r < h; ++r) {
      cos0_[size_t(r)] = std::cos(span * r / h);
      cos1_[size_t(r)] = std::cos(span * (r + 1) / h);
      row_solid_angle_[size_t(r)] = pixel_solid_angle(map, size_t(r) * size_t(map.width));
    }
    geo_layout_ = map.layout;
    geo_width_ = map.width;
    geo_height_ = map.height;
  }

  void ensure_halton(int n) {
    for (size_t i = halton_u_.size(); i < size_t(n); ++i) {
      double u, v;
      halton2(i + 1, &u, &v);
      halton_u_.push_back(u);
      halton_v_.push_back(v);
    }
  }

  int last_positive_row() const {
    for (int r = height_ - 1; r > 0; --r)
      if (row_cdf_[size_t(r)] > row_cdf_[size_t(r - 1)]) return r;
    return 0;
  }
  int last_positive_column(const float* cdf) const {
    for (int c = width_ - 1; c > 0; --c)
      if (cdf[c] > cdf[c - 1]) return c;
    return 0;
  }

  EnvMap grid_;                         // healpix input resampled to latlong
  std::vector<float> cdf_;              // per row: inclusive prefix sums of luminance
  const float* colour_ = nullptr;       // the map's rgb
  const uint8_t* valid_ = nullptr;      // its mask (null: all valid)
  std::vector<float> scratch_;          // a masked block's colours, invalid pixels zeroed
  std::vector<double> row_cdf_;         // inclusive prefix of row luminance * solid angle
  std::array<double, 3> power_{0, 0, 0};
  double luminance_power_ = 0;
  int width_ = 0, height_ = 0;
  bool prepared_ = false;

  Layout geo_layout_ = Layout::Healpix;
  int geo_width_ = -1, geo_height_ = -1;
  std::vector<double> cos0_, cos1_, row_solid_angle_;

  std::vector<double> halton_u_, halton_v_;  // points 1, 2, ... (index 0 is the corner)
};

}  // namespace

std::unique_ptr<Sampler> make_pharr_sampler(const SamplerOptions&) { return std::make_unique<PharrSampler>(); }

}  // namespace lp
