#include "hdr/synthetic_bracket.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>

#include "core/error.h"
#include "core/image_io.h"
#include "hdr/bracket.h"
#include "hdr/response.h"

namespace lp {
namespace {

constexpr double kSCurveGamma = 1.6;
constexpr double kSCurveKnee = 0.2;

uint64_t splitmix(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

void check_options(const SyntheticBracketOptions& o) {
  if (o.exposure_seconds.empty()) throw InputError("synthetic bracket: no exposure times");
  for (double t : o.exposure_seconds)
    if (!(t > 0) || !std::isfinite(t))
      throw InputError("synthetic bracket: exposure time " + std::to_string(t) + " is not a positive number");
  if (o.bit_depth != 8 && o.bit_depth != 12 && o.bit_depth != 16)
    throw InputError("synthetic bracket: bit depth " + std::to_string(o.bit_depth) + " is not 8, 12 or 16");
  if (!(o.exposure_scale >= 0) || !std::isfinite(o.exposure_scale))
    throw InputError("synthetic bracket: exposure scale must be >= 0 (0: automatic)");
  if (o.add_noise && (!(o.full_well_electrons > 0) || !(o.read_noise_electrons >= 0)))
    throw InputError("synthetic bracket: full well must be > 0 and read noise >= 0 electrons");
  if (o.shake_px < 0) throw InputError("synthetic bracket: shake must be >= 0 pixels");
  if (o.object_size_px < 0 || !(o.object_radiance >= 0))
    throw InputError("synthetic bracket: object size and radiance must be >= 0");
  if (o.response == ResponseCurve::Custom) {
    const auto& c = o.custom_response;
    if (c.size() < 2 || c.front() != 0.0 || c.back() != 1.0)
      throw InputError("synthetic bracket: custom response needs at least 2 values from 0 to 1");
    for (size_t i = 1; i < c.size(); ++i)
      if (!(c[i] > c[i - 1]))
        throw InputError("synthetic bracket: custom response is not increasing at entry " + std::to_string(i));
  }
}

}  // namespace

double apply_response(const SyntheticBracketOptions& o, double x) {
  x = std::max(0.0, x);
  switch (o.response) {
    case ResponseCurve::Linear: return x;
    case ResponseCurve::Gamma22: return std::pow(x, 1 / 2.2);
    case ResponseCurve::SCurve: {
      const double k = std::pow(kSCurveKnee, kSCurveGamma);
      const double p = std::pow(x, kSCurveGamma);
      return p / (p + k) * (1 + k);
    }
    case ResponseCurve::Custom: {
      const auto& c = o.custom_response;
      const double pos = x * double(c.size() - 1);
      if (pos >= double(c.size() - 1)) return 1.0;
      const size_t i = size_t(pos);
      const double f = pos - double(i);
      return c[i] + f * (c[i + 1] - c[i]);
    }
  }
  return x;
}

double invert_response(const SyntheticBracketOptions& o, double z) {
  z = std::clamp(z, 0.0, 1.0);
  switch (o.response) {
    case ResponseCurve::Linear: return z;
    case ResponseCurve::Gamma22: return std::pow(z, 2.2);
    case ResponseCurve::SCurve: {
      const double k = std::pow(kSCurveKnee, kSCurveGamma);
      const double q = z / (1 + k);  // < 1
      return std::pow(k * q / (1 - q), 1 / kSCurveGamma);
    }
    case ResponseCurve::Custom: {
      const auto& c = o.custom_response;
      const size_t i = std::min<size_t>(std::upper_bound(c.begin(), c.end(), z) - c.begin(), c.size() - 1);
      const size_t lo = i == 0 ? 0 : i - 1;
      const double f = c[i] > c[lo] ? (z - c[lo]) / (c[i] - c[lo]) : 0.0;
      return (double(lo) + f) / double(c.size() - 1);
    }
  }
  return z;
}

RgbImage image_from_envmap(const EnvMap& map) {
  RgbImage image;
  image.width = map.width;
  image.height = map.height;
  image.rgb = map.rgb;
  image.valid = map.valid;
  image.units = map.units;
  return image;
}

SyntheticBracket make_synthetic_bracket(const RgbImage& radiance, const SyntheticBracketOptions& o) {
  check_options(o);
  const int W = radiance.width, H = radiance.height;
  const size_t pixels = size_t(W) * size_t(H);
  if (W <= 0 || H <= 0 || radiance.rgb.size() != 3 * pixels)
    throw InputError("synthetic bracket: the radiance image is empty or its size does not match its pixels");
  for (size_t i = 0; i < 3 * pixels; ++i)
    if (!std::isfinite(radiance.rgb[i]) || radiance.rgb[i] < 0)
      throw InputError("synthetic bracket: input pixel (" + std::to_string((i / 3) % W) + ", " +
                       std::to_string((i / 3) / W) + ") is negative, NaN or Inf");

  // Median luminance over valid pixels.
  std::vector<float> lum;
  lum.reserve(pixels);
  for (size_t i = 0; i < pixels; ++i)
    if (radiance.valid.empty() || radiance.valid[i])
      lum.push_back(luminance(radiance.rgb[3 * i], radiance.rgb[3 * i + 1], radiance.rgb[3 * i + 2]));
  if (lum.empty()) throw InputError("synthetic bracket: the image has no valid pixel");
  std::nth_element(lum.begin(), lum.begin() + lum.size() / 2, lum.end());
  const double median_lum = lum[lum.size() / 2];

  const size_t n = o.exposure_seconds.size();
  std::vector<double> sorted_t = o.exposure_seconds;
  std::sort(sorted_t.begin(), sorted_t.end());
  const double t_mid = sorted_t[n / 2];

  SyntheticBracket out;
  out.exposure_seconds = o.exposure_seconds;
  out.reference_frame = int(n / 2);
  out.exposure_scale = o.exposure_scale;
  if (out.exposure_scale == 0) {
    if (!(median_lum > 0))
      throw InputError("synthetic bracket: the median luminance is 0; give an exposure scale");
    out.exposure_scale = 0.18 / (median_lum * t_mid);
  }

  // g(z) per level.
  const int levels = (1 << o.bit_depth) - 1;
  std::vector<float> g(size_t(levels) + 1);
  for (int k = 0; k <= levels; ++k) {
    const double z = std::clamp(double(k), 0.5, levels - 0.5) / levels;
    g[size_t(k)] = float(std::log(invert_response(o, z)) - std::log(out.exposure_scale));
  }
  out.true_log_exposure = {g, g, g};

  // Random streams: shake, then noise, from one seed.
  uint64_t state = o.seed;
  std::mt19937_64 shake_rng(splitmix(state));
  std::mt19937_64 noise_rng(splitmix(state));
  std::uniform_int_distribution<int> shake(-o.shake_px, o.shake_px);
  out.true_shift_px.assign(n, {0.0, 0.0});
  for (size_t i = 0; i < n; ++i) {
    const int dx = shake(shake_rng), dy = shake(shake_rng);  // drawn for every frame: stable streams
    if (int(i) != out.reference_frame) out.true_shift_px[i] = {double(dx), double(dy)};
  }

  // Moving object rectangles.
  const int s = std::max(1, std::min({o.object_size_px > 0 ? o.object_size_px : H / 8, W, H}));
  const double object_value = o.object_radiance > 0 ? o.object_radiance : 16.0 * median_lum;
  if (o.moving_object) {
    for (size_t i = 0; i < n; ++i) {
      const int x = int(std::lround(double(W - s) * (double(i) + 0.5) / double(n)));
      out.object_rect.push_back({x, (H - s) / 2, s, s});
    }
  }
  auto scene_with_object = [&](size_t frame) {
    std::vector<float> scene = radiance.rgb;
    if (!o.moving_object) return scene;
    const auto& r = out.object_rect[frame];
    for (int y = r[1]; y < r[1] + r[3]; ++y)
      for (int x = r[0]; x < r[0] + r[2]; ++x)
        for (int c = 0; c < 3; ++c) scene[3 * (size_t(y) * W + x) + c] = float(object_value);
    return scene;
  };

  out.true_radiance = radiance;
  out.true_radiance.rgb = scene_with_object(size_t(out.reference_frame));

  std::normal_distribution<double> read_noise(0.0, o.add_noise ? o.read_noise_electrons : 0.0);
  const double full_well = o.full_well_electrons;
  for (size_t i = 0; i < n; ++i) {
    const std::vector<float> scene = scene_with_object(i);
    const int dx = int(out.true_shift_px[i][0]), dy = int(out.true_shift_px[i][1]);
    const double gain = out.exposure_scale * o.exposure_seconds[i];
    RgbImage frame;
    frame.width = W;
    frame.height = H;
    frame.rgb.resize(3 * pixels);
    for (int y = 0; y < H; ++y) {
      const int sy = std::clamp(y - dy, 0, H - 1);
      for (int x = 0; x < W; ++x) {
        const int sx = std::clamp(x - dx, 0, W - 1);
        const float* src = &scene[3 * (size_t(sy) * W + sx)];
        float* dst = &frame.rgb[3 * (size_t(y) * W + x)];
        for (int c = 0; c < 3; ++c) {
          double X = double(src[c]) * gain;
          if (o.clip) X = std::min(X, 2.0);  // beyond the well: saturated whatever the noise
          if (o.add_noise) {
            const double mean = X * full_well;
            double electrons = mean > 0 ? double(std::poisson_distribution<long long>(mean)(noise_rng)) : 0.0;
            if (o.read_noise_electrons > 0) electrons += read_noise(noise_rng);
            X = std::max(0.0, electrons / full_well);
          }
          double z = apply_response(o, X);
          if (o.clip) z = std::clamp(z, 0.0, 1.0);
          z = std::round(z * levels) / levels;
          dst[c] = float(z);
        }
      }
    }
    out.frames.push_back(std::move(frame));
  }
  return out;
}

void write_synthetic_bracket(const std::string& dir, const SyntheticBracket& b, int bit_depth) {
  namespace fs = std::filesystem;
  make_output_directory(dir);
  std::string csv = "file,seconds\n";
  for (size_t f = 0; f < b.frames.size(); ++f) {
    const std::string name = fmt::format("frame_{:02d}.png", f);
    write_code_image((fs::path(dir) / name).string(), b.frames[f], bit_depth);
    csv += fmt::format("{},{:.9g}\n", name, b.exposure_seconds[f]);
  }
  write_file_atomically((fs::path(dir) / "exposures.csv").string(), csv);
  write_rgb_image((fs::path(dir) / "truth.exr").string(), b.true_radiance);
  CameraResponse truth;
  truth.levels = int(b.true_log_exposure[0].size());
  truth.log_exposure = b.true_log_exposure;
  save_response((fs::path(dir) / "true_response.json").string(), truth);
}

}  // namespace lp
