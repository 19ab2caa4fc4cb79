#include "core/temporal_tonemap.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "core/envmap.h"

namespace lp {

namespace {

constexpr double kDefaultKey = 0.18;
constexpr double kBlackFloor = 1e-4;  // delta, relative to the frame's largest luminance

double percentile(std::vector<float>& values, double p) {
  const size_t rank = std::min(values.size() - 1, size_t(p * double(values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + long(rank), values.end());
  return values[rank];
}

}  // namespace

ToneMapParameters frame_tone_parameters(ImageView image, double fixed_key) {
  if (image.channels != 3) throw std::invalid_argument("frame_tone_parameters: the image is not RGB");
  std::vector<float> lum;
  lum.reserve(image.pixel_count());
  for (int v = 0; v < image.height; ++v)
    for (int u = 0; u < image.width; ++u) {
      if (!image.is_valid(u, v)) continue;
      const float* p = image.pixel(u, v);
      const float y = luminance(p[0], p[1], p[2]);
      if (std::isfinite(y)) lum.push_back(std::max(0.0f, y));
    }
  ToneMapParameters out;
  out.key = fixed_key > 0 ? fixed_key : kDefaultKey;
  if (lum.empty()) return out;
  const double y_max = *std::max_element(lum.begin(), lum.end());
  if (!(y_max > 0)) return out;
  const double delta = kBlackFloor * y_max;
  double log_sum = 0;
  for (float y : lum) log_sum += std::log(delta + y);
  out.world_luminance = std::exp(log_sum / double(lum.size()));
  if (fixed_key > 0) return out;
  const double lo = std::log2(delta + percentile(lum, 0.01)), hi = std::log2(delta + percentile(lum, 0.99));
  if (hi - lo > 1e-6) out.key = kDefaultKey * std::pow(4.0, (2 * std::log2(out.world_luminance) - lo - hi) / (hi - lo));
  return out;
}

TemporalToneMapper::TemporalToneMapper(TemporalToneMapOptions options) : options_(options) {
  if (!(options_.time_constant_s >= 0) || !std::isfinite(options_.time_constant_s))
    throw std::invalid_argument("TemporalToneMapper: the time constant must be finite and >= 0");
}

const ToneMapParameters& TemporalToneMapper::update(ImageView image, double dt_s) {
  return update(frame_tone_parameters(image, options_.key), dt_s);
}

const ToneMapParameters& TemporalToneMapper::update(const ToneMapParameters& frame, double dt_s) {
  if (!(frame.world_luminance > 0) || !(frame.key > 0)) return state_;  // nothing to adapt to
  if (!(state_.world_luminance > 0)) return state_ = frame;             // the first frame
  const double dt = std::isfinite(dt_s) && dt_s > 0 ? dt_s : options_.fallback_frame_s;
  const double alpha = options_.time_constant_s > 0 ? 1 - std::exp(-dt / options_.time_constant_s) : 1.0;
  const auto blend = [alpha](double now, double target) {
    return std::exp(std::log(now) + alpha * (std::log(target) - std::log(now)));
  };
  state_.world_luminance = blend(state_.world_luminance, frame.world_luminance);
  state_.key = blend(state_.key, frame.key);
  return state_;
}

}  // namespace lp
