#include "sampling/overlay.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/image_io.h"
#include "core/resample.h"

namespace lp {

namespace {

constexpr float kCheckerLight = 0.55f, kCheckerDark = 0.45f;
constexpr double kOutline = 0.03;  // display value of the disc outline
constexpr int kShift = 4;          // cv::circle fixed-point bits: sub-pixel centres
constexpr double kFixed = 1 << kShift;

// Exposure k with Reinhard k Y / (1 + k Y) = display at the chosen percentile of the
// valid luminances; falls back to the maximum when that percentile is black.
double exposure_for(const EnvMap& view, const OverlayOptions& options) {
  std::vector<float> lum;
  lum.reserve(view.pixel_count());
  for (size_t i = 0; i < view.pixel_count(); ++i)
    if (view.is_valid(i)) {
      const float* p = view.pixel(i);
      lum.push_back(luminance(p[0], p[1], p[2]));
    }
  if (lum.empty()) return 1;
  const double p = std::clamp(options.percentile, 0.0, 1.0);
  const size_t rank = std::min(lum.size() - 1, size_t(std::max(0.0, std::ceil(p * double(lum.size())) - 1)));
  std::nth_element(lum.begin(), lum.begin() + rank, lum.end());
  double y = lum[rank];
  if (!(y > 0)) y = *std::max_element(lum.begin(), lum.end());
  if (!(y > 0) || !std::isfinite(y)) return 1;
  const double d = std::clamp(options.percentile_display, 1e-6, 1 - 1e-6);
  return d / (1 - d) / y;
}

}  // namespace

std::vector<float> render_overlay(const EnvMap& map, const std::vector<Light>& lights, int width,
                                  const OverlayOptions& options) {
  if (width <= 0 || width % 2 != 0)
    throw InputError(fmt::format("overlay width {} is not a positive even number", width));
  const int height = width / 2;

  // The map as a latlong view of the output size.
  EnvMap resampled;
  const EnvMap* view = &map;
  if (map.layout != Layout::LatLong || map.width != width || map.height != height) {
    resampled = resample(map, Layout::LatLong, width, height);
    view = &resampled;
  }

  // Tone map; invalid pixels as a checkerboard.
  const double k = exposure_for(*view, options);
  const int checker = std::max(1, options.checker_px);
  std::vector<float> out(size_t(width) * size_t(height) * 3);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const size_t i = size_t(v) * size_t(width) + size_t(u);
      float* o = &out[3 * i];
      if (!view->is_valid(i)) {
        const float g = ((u / checker + v / checker) % 2) ? kCheckerDark : kCheckerLight;
        o[0] = o[1] = o[2] = g;
        continue;
      }
      const float* p = view->pixel(i);
      // Saturated colours can exceed 1 in one channel: scale the pixel back (keeping its
      // hue) rather than clipping that channel alone.
      double s = k / (1 + k * luminance(p[0], p[1], p[2]));
      s /= std::max(1.0, s * std::max({p[0], p[1], p[2]}));
      for (int c = 0; c < 3; ++c) o[c] = float(std::clamp(s * p[c], 0.0, 1.0));
    }

  // Lights, dimmest first so the brightest stay on top.
  std::vector<size_t> order(lights.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return lights[a].luminance() < lights[b].luminance(); });
  double brightest = 0;
  for (const Light& l : lights) brightest = std::max(brightest, l.luminance());
  const double r_max = options.max_radius_px > 0 ? options.max_radius_px : std::max(4.0, width / 128.0);
  const double r_min = std::clamp(options.min_radius_px, 0.5, r_max);
  const double per_decade = (r_max - r_min) / std::max(1e-9, options.radius_decades);

  cv::Mat image(height, width, CV_32FC3, out.data());  // RGB in memory; no BGR swap needed
  for (size_t index : order) {
    const Light& l = lights[index];
    const double len = length(l.direction);
    if (!std::isfinite(len) || !(len > 0))
      throw InputError(fmt::format("light {} (id {}): direction is not a usable vector", index, l.id));
    const Vec3 d = (1 / len) * l.direction;
    const double x = azimuth_of(d) / (2 * M_PI) * width - 0.5;
    const double y = zenith_of(d) / M_PI * height - 0.5;
    const double power = l.luminance();
    const double r = (power > 0 && brightest > 0)
                         ? std::clamp(r_max + per_decade * std::log10(power / brightest), r_min, r_max)
                         : r_min;
    const double m = std::max({l.rgb[0], l.rgb[1], l.rgb[2]});
    const cv::Scalar colour = m > 0 ? cv::Scalar(l.rgb[0] / m, l.rgb[1] / m, l.rgb[2] / m) : cv::Scalar(0, 0, 0);
    const cv::Scalar outline(kOutline, kOutline, kOutline);
    for (int wrap = -1; wrap <= 1; ++wrap) {
      const double cx = x + wrap * width;
      if (cx + r + 1 < -1 || cx - r - 1 > width) continue;
      const cv::Point centre(int(std::lround(cx * kFixed)), int(std::lround(y * kFixed)));
      cv::circle(image, centre, int(std::lround((r + 1) * kFixed)), outline, cv::FILLED, cv::LINE_8, kShift);
      cv::circle(image, centre, int(std::lround(r * kFixed)), colour, cv::FILLED, cv::LINE_8, kShift);
    }
  }
  return out;
}

void write_overlay_png(const std::string& path, const EnvMap& map, const std::vector<Light>& lights, int width,
                       const OverlayOptions& options) {
  if (width == 0) width = map.layout == Layout::LatLong ? map.width : 1024;
  write_display_image(path, width, width / 2, render_overlay(map, lights, width, options));
}

}  // namespace lp
