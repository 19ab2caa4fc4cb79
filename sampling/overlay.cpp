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
#include "core/tonemap.h"

namespace lp {

namespace {

constexpr double kOutline = 0.03;  // display value of the disc outline
constexpr int kShift = 4;          // cv::circle fixed-point bits: sub-pixel centres
constexpr double kFixed = 1 << kShift;

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
  ToneMapOptions tm;
  tm.percentile = options.percentile;
  tm.display = options.percentile_display;
  tm.checker_px = options.checker_px;
  tm.exposure = options.exposure;
  tm.unseen = options.unseen;
  std::vector<float> out = tone_map(image_view(*view), tm);

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
