#include "hdr/log_sensor.h"

#include <array>
#include <cmath>

#include <gtest/gtest.h>

#include "calib/photometric.h"
#include "core/envmap.h"
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

// One unit everywhere (issue 20 item 3). A synthetic scene of known luminance, coloured
// patches from 0.05 to 20000 cd/m2, seen by a linear camera (code = L_c t / k) and a log
// camera (code = a + b ln L_c), each calibrated from six grey patches by fit_photometric:
// both decode to Radiance units with 683 Y = the scene's cd/m2 (the log decode alone gave
// 683 times that, the "683x").
TEST(LogSensor, ALogDecodedFrameAndALinearCalibratedFrameOfOneSceneGiveTheSameCandelas) {
  const double k = 2.78, t = 1e-5, a = 0.25, b = 0.05;
  std::vector<PhotometricReading> linear_readings, log_readings;
  for (double l : {3.1, 12.0, 48.5, 160.0, 720.0, 2950.0}) {
    PhotometricReading r;
    r.measured = l;
    r.label = std::to_string(l);
    r.camera_value = l / k;  // the linear camera's relative luminance Y_rel
    linear_readings.push_back(r);
    r.camera_value = a + b * std::log(l);  // the log camera's raw code
    log_readings.push_back(r);
  }
  const PhotometricCalibration linear = fit_photometric(linear_readings);
  PhotometricOptions log_options;
  log_options.model = PhotometricOptions::Model::LogSensor;
  const PhotometricCalibration log = fit_photometric(log_readings, log_options);
  ASSERT_TRUE(log.log_sensor.has_value());

  // The scene: per-channel luminance-like values L_c, cd/m2.
  const std::vector<std::array<double, 3>> scene = {
      {0.05, 0.05, 0.05}, {1.0, 2.0, 3.0}, {250, 180, 90}, {4000, 5000, 6000}, {20000, 20000, 20000}};
  RgbImage linear_codes, log_codes;
  for (RgbImage* im : {&linear_codes, &log_codes}) im->width = int(scene.size()), im->height = 1;
  for (const auto& px : scene)
    for (double l : px) {
      linear_codes.rgb.push_back(float(l * t / k));
      log_codes.rgb.push_back(float(a + b * std::log(l)));
    }
  // The linear route: codes / exposure, then the calibration's scale (as hdr fuse and the
  // stream do); the log route: the curve.
  RgbImage from_linear = linear_codes;
  for (float& v : from_linear.rgb) v = float(v / t);
  apply_photometric(from_linear, linear);
  const RgbImage from_log = decode_log_sensor(log_codes, log);
  EXPECT_EQ(from_log.units, Units::Radiance);
  EXPECT_EQ(from_linear.units, Units::Radiance);
  for (size_t p = 0; p < scene.size(); ++p) {
    const double truth = luminance(scene[p].data());
    const double y_linear = 683.0 * luminance(from_linear.rgb[3 * p], from_linear.rgb[3 * p + 1], from_linear.rgb[3 * p + 2]);
    const double y_log = 683.0 * luminance(from_log.rgb[3 * p], from_log.rgb[3 * p + 1], from_log.rgb[3 * p + 2]);
    EXPECT_NEAR(y_linear / truth, 1.0, 1e-5) << p;
    EXPECT_NEAR(y_log / truth, 1.0, 1e-4) << p;  // float codes: ln L to ~1e-7 / b
    EXPECT_NEAR(y_log / y_linear, 1.0, 1e-4) << p;
  }
}

TEST(LogSensor, ACalibratedDecodeRefusesLinearCalibrationsAndRadianceAndAScaleRefusesLogCurves) {
  PhotometricCalibration linear, log;
  log.log_sensor = LogSensorCurve{0.25, 0.05};
  RgbImage codes;
  codes.width = codes.height = 1;
  codes.rgb = {0.5f, 0.5f, 0.5f};
  EXPECT_THROW(decode_log_sensor(codes, linear), InputError);
  EXPECT_THROW(apply_photometric(codes, log), InputError);  // never scaled as if linear
  EXPECT_EQ(codes.rgb[0], 0.5f);
  codes.units = Units::Radiance;
  EXPECT_THROW(decode_log_sensor(codes, log), InputError);
}

}  // namespace
}  // namespace lp
