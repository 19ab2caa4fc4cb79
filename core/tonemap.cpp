#include "core/tonemap.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/envmap.h"

namespace lp {

namespace {

constexpr float kCheckerLight = 0.55f, kCheckerDark = 0.45f;
constexpr float kHatchLine = 0.35f, kHatchGround = 0.07f;

float unseen_value(int u, int v, const ToneMapOptions& options) {
  const int size = std::max(1, options.checker_px);
  if (options.unseen == UnseenStyle::Hatch) {
    const int spacing = std::max(3, size * 3 / 2);
    return (u + v) % spacing < std::max(1, spacing / 4) ? kHatchLine : kHatchGround;
  }
  return ((u / size + v / size) % 2) ? kCheckerDark : kCheckerLight;
}

bool seen(ImageView image, int u, int v) {
  if (!image.is_valid(u, v)) return false;
  const float* p = image.pixel(u, v);
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

// Exposure k with Reinhard k Y / (1 + k Y) = display at the chosen percentile of the
// valid luminances; falls back to the maximum when that percentile is black.
double exposure_for(ImageView image, const ToneMapOptions& options) {
  std::vector<float> lum;
  lum.reserve(image.pixel_count());
  for (int v = 0; v < image.height; ++v)
    for (int u = 0; u < image.width; ++u)
      if (seen(image, u, v)) {
        const float* p = image.pixel(u, v);
        lum.push_back(luminance(p[0], p[1], p[2]));
      }
  if (lum.empty()) return 1;
  const double p = std::clamp(options.percentile, 0.0, 1.0);
  const size_t rank = std::min(lum.size() - 1, size_t(std::max(0.0, std::ceil(p * double(lum.size())) - 1)));
  std::nth_element(lum.begin(), lum.begin() + long(rank), lum.end());
  double y = lum[rank];
  if (!(y > 0)) y = *std::max_element(lum.begin(), lum.end());
  if (!(y > 0) || !std::isfinite(y)) return 1;
  const double d = std::clamp(options.display, 1e-6, 1 - 1e-6);
  return d / (1 - d) / y;
}

}  // namespace

uint8_t srgb_code(float v) {
  if (!(v > 0.0f)) return 0;  // also NaN
  if (v >= 1.0f) return 255;
  const double s = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(double(v), 1.0 / 2.4) - 0.055;
  return uint8_t(std::clamp(std::lround(s * 255.0), 0L, 255L));
}

double srgb_to_linear(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }

std::vector<float> tone_map(ImageView image, const ToneMapOptions& options) {
  if (image.channels != 3) throw std::invalid_argument("tone_map: the image is not RGB");
  const int width = image.width, height = image.height;
  const double k = options.exposure > 0 && std::isfinite(options.exposure) ? options.exposure : exposure_for(image, options);
  std::vector<float> out(3 * image.pixel_count());
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      float* o = &out[3 * (size_t(v) * size_t(width) + size_t(u))];
      if (!seen(image, u, v)) {
        o[0] = o[1] = o[2] = unseen_value(u, v, options);
        continue;
      }
      const float* p = image.pixel(u, v);
      double s = k / (1 + k * luminance(p[0], p[1], p[2]));
      s /= std::max(1.0, s * std::max({double(p[0]), double(p[1]), double(p[2])}));
      for (int c = 0; c < 3; ++c) o[c] = float(std::clamp(s * p[c], 0.0, 1.0));
    }
  return out;
}

}  // namespace lp
