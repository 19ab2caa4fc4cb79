// Synthetic brackets for the hdr tests: a known radiance image photographed through a
// known response curve at known exposure times, quantised to 8 bits, no noise.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/image_io.h"
#include "hdr/bracket.h"
#include "hdr/response.h"

namespace lp::test {

// A response curve: code value in [0, 1] from exposure X = E t (clipped to [0, 1]), and
// its exact inverse.
struct TrueCurve {
  std::string name;
  std::function<double(double)> f;      // X -> code
  std::function<double(double)> f_inv;  // code -> X
};

inline TrueCurve gamma_curve() {
  return {"gamma2.2", [](double x) { return std::pow(std::max(x, 0.0), 1.0 / 2.2); },
          [](double z) { return std::pow(z, 2.2); }};
}
// A film-like S-curve: z = X^0.6 / (X^0.6 + 0.05).
inline TrueCurve film_curve() {
  const double g = 0.6, c = 0.05;
  return {"film", [=](double x) { x = std::max(x, 0.0); const double p = std::pow(x, g); return p / (p + c); },
          [=](double z) { return std::pow(c * z / (1.0 - z), 1.0 / g); }};
}

// g(z) = ln f^-1(z / 255) for z in [1, 254] (0 and 255 have no finite inverse for all
// curves: they are filled from their neighbours), offset so that g(128) = 0.
inline CameraResponse true_response(const TrueCurve& curve) {
  CameraResponse r;
  r.levels = 256;
  for (auto& g : r.log_exposure) {
    g.resize(256);
    for (int z = 1; z < 255; ++z) g[size_t(z)] = float(std::log(curve.f_inv(z / 255.0)));
    g[0] = g[1] - (g[2] - g[1]);
    g[255] = g[254] + (g[254] - g[253]);
    const float mid = g[128];
    for (float& v : g) v -= mid;
  }
  return r;
}

// Deterministic hash in [0, 1).
inline double hash01(uint64_t i) {
  i ^= i >> 33; i *= 0xff51afd7ed558ccdULL; i ^= i >> 33; i *= 0xc4ceb9fe1a85ec53ULL; i ^= i >> 33;
  return double(i >> 11) / double(1ULL << 53);
}

// Radiance log-uniform in [lo, hi] per pixel, channels scaled by (1, 0.7, 0.45).
inline RgbImage random_radiance(int w, int h, double lo, double hi) {
  RgbImage e;
  e.width = w;
  e.height = h;
  e.rgb.resize(3 * size_t(w) * size_t(h));
  const double scale[3] = {1.0, 0.7, 0.45};
  for (size_t p = 0; p < size_t(w) * size_t(h); ++p) {
    const double l = std::exp(std::log(lo) + (std::log(hi) - std::log(lo)) * hash01(p));
    for (int c = 0; c < 3; ++c) e.rgb[3 * p + size_t(c)] = float(l * scale[c] * (0.8 + 0.4 * hash01(p * 7 + size_t(c) + 1)));
  }
  return e;
}

inline Bracket photograph(const RgbImage& radiance, const std::vector<double>& times, const TrueCurve& curve) {
  Bracket b;
  b.bit_depth = 8;
  b.exposure_seconds = times;
  for (double t : times) {
    RgbImage f;
    f.width = radiance.width;
    f.height = radiance.height;
    f.rgb.resize(radiance.rgb.size());
    for (size_t i = 0; i < f.rgb.size(); ++i) {
      const double z = std::clamp(curve.f(double(radiance.rgb[i]) * t), 0.0, 1.0);
      f.rgb[i] = float(std::lround(z * 255.0) / 255.0);
    }
    b.frames.push_back(std::move(f));
  }
  return b;
}

// Median and 95th percentile of |log10 Y - log10 Y_ref - s| with s the median offset (one
// global scale), over pixels where both luminances are positive and `valid` (if non-empty).
struct LogError {
  double median = 0.0, p95 = 0.0;
  size_t count = 0;
};
inline LogError log10_luminance_error(const RgbImage& a, const RgbImage& ref, const std::vector<uint8_t>& valid = {}) {
  std::vector<double> d;
  for (size_t p = 0; p < size_t(a.width) * size_t(a.height); ++p) {
    if (!valid.empty() && !valid[p]) continue;
    auto lum = [&](const RgbImage& im) {
      return 0.2126 * im.rgb[3 * p] + 0.7152 * im.rgb[3 * p + 1] + 0.0722 * im.rgb[3 * p + 2];
    };
    const double ya = lum(a), yr = lum(ref);
    if (!(ya > 0.0) || !(yr > 0.0)) continue;
    d.push_back(std::log10(ya) - std::log10(yr));
  }
  LogError e;
  e.count = d.size();
  if (d.empty()) return e;
  auto pct = [](std::vector<double> v, double q) {
    const size_t k = std::min(v.size() - 1, size_t(q * double(v.size() - 1) + 0.5));
    std::nth_element(v.begin(), v.begin() + long(k), v.end());
    return v[k];
  };
  const double s = pct(d, 0.5);
  for (double& v : d) v = std::abs(v - s);
  e.median = pct(d, 0.5);
  e.p95 = pct(d, 0.95);
  return e;
}

}  // namespace lp::test
