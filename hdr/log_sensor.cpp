#include "hdr/log_sensor.h"

#include <cmath>

#include <fmt/format.h>

#include "core/error.h"

namespace lp {

RgbImage decode_log_sensor(const RgbImage& codes, const LogSensorModel& m) {
  if (!std::isfinite(m.a) || !std::isfinite(m.b) || m.b == 0.0)
    throw InputError(fmt::format("log sensor model: a = {}, b = {} (b must be non-zero, both finite)", m.a, m.b));
  RgbImage out = codes;
  const double inv_b = 1.0 / m.b;
  for (float& v : out.rgb) v = float(std::exp((double(v) - m.a) * inv_b));
  return out;
}

RgbImage decode_log_sensor(const RgbImage& codes, const PhotometricCalibration& calibration) {
  if (!calibration.log_sensor)
    throw InputError("the photometric calibration is linear, not a log-sensor curve: nothing to decode");
  if (codes.units == Units::Radiance)
    throw InputError("a log-sensor frame must hold raw codes, not radiance (the curve would apply twice)");
  RgbImage out = decode_log_sensor(codes, LogSensorModel{calibration.log_sensor->a, calibration.log_sensor->b});
  for (size_t i = 0; i + 2 < out.rgb.size(); i += 3)
    for (size_t c = 0; c < 3; ++c) out.rgb[i + c] = float(out.rgb[i + c] * calibration.scale_rgb[c]);
  out.units = Units::Radiance;
  return out;
}

LogSensorModel fit_log_sensor_least_squares(const std::vector<double>& values, const std::vector<double>& lum) {
  if (values.size() != lum.size())
    throw InputError(fmt::format("log sensor fit: {} values for {} luminances", values.size(), lum.size()));
  if (values.size() < 2) throw InputError(fmt::format("log sensor fit: needs at least 2 patches, got {}", values.size()));
  const size_t n = values.size();
  double mx = 0.0, my = 0.0;
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(lum[i]) || !(lum[i] > 0.0))
      throw InputError(fmt::format("log sensor fit: luminance {} of patch {} is not positive and finite", lum[i], i));
    if (!std::isfinite(values[i]))
      throw InputError(fmt::format("log sensor fit: value of patch {} is not finite", i));
    mx += std::log(lum[i]);
    my += values[i];
  }
  mx /= double(n);
  my /= double(n);
  double sxx = 0.0, sxy = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double dx = std::log(lum[i]) - mx;
    sxx += dx * dx;
    sxy += dx * (values[i] - my);
  }
  if (!(sxx > 0.0)) throw InputError("log sensor fit: all luminances are equal; need at least two different ones");
  LogSensorModel m;
  m.b = sxy / sxx;
  m.a = my - m.b * mx;
  if (m.b == 0.0) throw InputError("log sensor fit: values do not change with luminance (b = 0)");
  return m;
}

}  // namespace lp
