#include "hdr/log_sensor.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/error.h"

namespace lp {
namespace {

TEST(LogSensor, LeastSquaresFitRecoversAAndBExactlyFromNoiseFreePatches) {
  const LogSensorModel truth{0.42, 0.061};
  std::vector<double> values, lum;
  for (double l : {0.01, 0.3, 2.0, 15.0, 120.0, 4000.0}) {
    lum.push_back(l);
    values.push_back(truth.a + truth.b * std::log(l));
  }
  const LogSensorModel fit = fit_log_sensor_least_squares(values, lum);
  EXPECT_NEAR(fit.a, truth.a, 1e-12);
  EXPECT_NEAR(fit.b, truth.b, 1e-12);
}

TEST(LogSensor, LeastSquaresFitMatchesTheNormalEquationsOnNoisyPatches) {
  // Independent reference: the 2x2 normal equations solved by Cramer's rule.
  const std::vector<double> lum = {0.5, 1.0, 4.0, 10.0, 50.0};
  const std::vector<double> v = {0.30, 0.35, 0.46, 0.49, 0.60};
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < lum.size(); ++i) {
    const double x = std::log(lum[i]);
    sx += x, sy += v[i], sxx += x * x, sxy += x * v[i];
  }
  const double n = double(lum.size()), det = n * sxx - sx * sx;
  const LogSensorModel fit = fit_log_sensor_least_squares(v, lum);
  EXPECT_NEAR(fit.b, (n * sxy - sx * sy) / det, 1e-12);
  EXPECT_NEAR(fit.a, (sxx * sy - sx * sxy) / det, 1e-12);
}

TEST(LogSensor, DecodingInvertsTheModelAndKeepsTheMask) {
  const LogSensorModel m{0.5, 0.05};
  RgbImage codes;
  codes.width = 2;
  codes.height = 1;
  codes.valid = {1, 0};
  const double lum[6] = {0.01, 1.0, 7.0, 100.0, 0.2, 3.0};
  for (double l : lum) codes.rgb.push_back(float(m.a + m.b * std::log(l)));
  const RgbImage out = decode_log_sensor(codes, m);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(out.rgb[size_t(i)] / lum[i], 1.0, 2e-5);
  EXPECT_EQ(out.valid, codes.valid);
}

TEST(LogSensor, RefusesDegenerateModelsAndPatches) {
  EXPECT_THROW(decode_log_sensor(RgbImage{}, LogSensorModel{0.1, 0.0}), InputError);
  EXPECT_THROW(fit_log_sensor_least_squares({0.1}, {1.0}), InputError);
  EXPECT_THROW(fit_log_sensor_least_squares({0.1, 0.2}, {1.0}), InputError);
  EXPECT_THROW(fit_log_sensor_least_squares({0.1, 0.2}, {1.0, 0.0}), InputError);
  EXPECT_THROW(fit_log_sensor_least_squares({0.1, 0.2}, {2.0, 2.0}), InputError);
}

}  // namespace
}  // namespace lp
