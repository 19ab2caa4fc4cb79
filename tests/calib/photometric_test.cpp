#include "calib/photometric.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "tests/core/test_files.h"

namespace fs = std::filesystem;

namespace lp {
namespace {

using test_files::input_error;

using Unit = PhotometricReading::Unit;

std::string temp_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = fs::path(::testing::TempDir()) / "lightprobe_photometric" / info->name();
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string() + "/";
}

std::string write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

PhotometricReading reading(double camera, double measured, Unit unit, std::string label) {
  PhotometricReading r;
  r.camera_value = camera;
  r.measured = measured;
  r.unit = unit;
  r.label = std::move(label);
  return r;
}

// Six grey patches over three decades of luminance, as in Havran et al. 2005, 5.1.
const std::vector<double> kPatchLuminance{3.1, 12.0, 48.5, 160.0, 720.0, 2950.0};

TEST(Photometric, NoiselessLuminanceReadingsGiveTheScaleToOnePercent) {
  const double k = 1234.5;
  std::vector<PhotometricReading> readings;
  for (size_t i = 0; i < kPatchLuminance.size(); ++i)
    readings.push_back(reading(kPatchLuminance[i] / k, kPatchLuminance[i], Unit::CandelaPerSquareMetre,
                               "patch" + std::to_string(i)));
  const auto cal = fit_photometric(readings);
  EXPECT_NEAR(cal.scale_luminance / k, 1.0, 1e-9);
  for (double s : cal.scale_rgb) EXPECT_NEAR(s, k / 683.0, 1e-9 * k);
  EXPECT_LT(cal.rms_relative, 1e-9);
  EXPECT_LT(cal.held_out_rms_relative, 1e-9);
  EXPECT_LT(cal.scale_relative_error, 1e-9);
  EXPECT_EQ(cal.readings, 6);
  EXPECT_FALSE(cal.log_sensor.has_value());
}

TEST(Photometric, NoisyReadingsGiveTheScaleWithinTheReportedUncertainty) {
  const double k = 870.0;
  std::mt19937_64 rng(4242);
  std::normal_distribution<double> noise(0.0, 0.03);  // a 3 % meter
  // 50 seeded trials of 24 readings: the error of k against its reported standard error
  // (estimated from the residuals, so itself uncertain: a t distribution with 23 dof).
  int within_one = 0, within_three = 0;
  const int trials = 50;
  for (int t = 0; t < trials; ++t) {
    std::vector<PhotometricReading> readings;
    for (int i = 0; i < 24; ++i) {
      const double L = 5.0 * std::pow(1.35, i);
      readings.push_back(reading(L / k, L * std::exp(noise(rng)), Unit::CandelaPerSquareMetre,
                                 "p" + std::to_string(i)));
    }
    const auto cal = fit_photometric(readings);
    EXPECT_NEAR(cal.scale_relative_error, cal.rms_relative / std::sqrt(23.0), 1e-3) << "trial " << t;
    EXPECT_GT(cal.scale_relative_error, 0.002);
    EXPECT_LT(cal.scale_relative_error, 0.015);  // about 0.03 / sqrt(24) = 0.006
    const double err = std::abs(cal.scale_luminance / k - 1);
    within_one += err < cal.scale_relative_error;
    within_three += err < 3 * cal.scale_relative_error;
    // The held-out error is about the meter's noise, a little more than the fit's.
    EXPECT_GT(cal.held_out_rms_relative, 0.015);
    EXPECT_LT(cal.held_out_rms_relative, 0.05);
    EXPECT_GE(cal.held_out_rms_relative, cal.rms_relative);
  }
  // One standard error holds about 68 % of the time, three nearly always.
  EXPECT_GE(within_one, 25);
  EXPECT_LE(within_one, 45);
  EXPECT_GE(within_three, 49);
}

// The held-out check refits without each reading; it is solved in O(n log n) for the linear
// model with no loss or Huber's. Reference: the root of the fit's estimating equation
// sum psi(theta + c_j) over j != i, by bisection (psi clipped at the Huber scale), where
// c = ln camera - ln measured; and, looser, Ceres refits (converged to ~1e-9 only).
TEST(Photometric, HeldOutErrorsEqualExactRefitsWithoutEachReading) {
  const double k = 640.0;
  std::mt19937_64 rng(77);
  std::normal_distribution<double> noise(0.0, 0.04);
  std::vector<PhotometricReading> readings;
  for (int i = 0; i < 30; ++i) {
    const double L = 3.0 * std::pow(1.3, i);
    const double outlier = i % 9 == 4 ? 1.6 : 1.0;  // three readings 60 % off: clipped by Huber
    readings.push_back(reading(L / k, L * outlier * std::exp(noise(rng)), Unit::CandelaPerSquareMetre, "p" + std::to_string(i)));
  }
  for (RobustLoss loss : {RobustLoss::Huber, RobustLoss::None}) {
    PhotometricOptions options;
    options.loss = loss;
    const double clip = loss == RobustLoss::Huber ? options.loss_scale : 1e300;
    const auto cal = fit_photometric(readings, options);
    double max_exact = 0, max_ceres = 0;
    for (size_t i = 0; i < readings.size(); ++i) {
      auto psi_sum = [&](double theta) {
        double s = 0;
        for (size_t j = 0; j < readings.size(); ++j)
          if (j != i)
            s += std::clamp(theta + std::log(readings[j].camera_value) - std::log(readings[j].measured), -clip, clip);
        return s;
      };
      double lo = -20, hi = 20;
      for (int it = 0; it < 200; ++it) (psi_sum(0.5 * (lo + hi)) > 0 ? hi : lo) = 0.5 * (lo + hi);
      const double exact = std::exp(0.5 * (lo + hi)) * readings[i].camera_value / readings[i].measured - 1;
      max_exact = std::max(max_exact, std::abs(cal.residuals[i].held_out_relative - exact));
      std::vector<PhotometricReading> rest = readings;
      rest.erase(rest.begin() + long(i));
      const double ceres = fit_photometric(rest, options).scale_luminance * readings[i].camera_value / readings[i].measured - 1;
      max_ceres = std::max(max_ceres, std::abs(cal.residuals[i].held_out_relative - ceres));
    }
    EXPECT_LT(max_exact, 1e-13) << cal.loss;
    EXPECT_LT(max_ceres, 1e-8) << cal.loss;
    EXPECT_GT(cal.held_out_rms_relative, cal.rms_relative) << cal.loss;
  }
}

TEST(Photometric, ALuxReadingAndALuminanceReadingOfTheSameSceneGiveTheSameScale) {
  // A uniform sky of relative radiance 0.25 (RGB equal, so Y = 0.25): E_rel = pi * 0.25.
  EnvMap sky = make_hemisphere(360, 90);
  for (float& v : sky.rgb) v = 0.25f;
  const double e_rel = relative_illuminance(sky);
  EXPECT_NEAR(e_rel / (M_PI * 0.25), 1.0, 1e-4);  // cos at pixel centres: 4e-5 off
  const double k = 4000.0;  // true cd/m2 per relative unit
  const double sky_luminance = k * 0.25;    // what a luminance meter reads on the sky
  const double lux = M_PI * sky_luminance;  // what a lux meter reads under it
  const auto by_luminance = fit_photometric(
      {reading(mean_luminance_in_region(RgbImage{4, 1, std::vector<float>(12, 0.25f)}, 0, 0, 4, 1),
               sky_luminance, Unit::CandelaPerSquareMetre, "sky patch"),
       reading(0.5, 2 * sky_luminance, Unit::CandelaPerSquareMetre, "grey card")});
  const auto by_lux = fit_photometric({reading(e_rel, lux, Unit::Lux, "lux meter"),
                                       reading(2 * e_rel, 2 * lux, Unit::Lux, "lux meter, lamp on")});
  EXPECT_NEAR(by_luminance.scale_luminance / k, 1.0, 1e-5);
  EXPECT_NEAR(by_lux.scale_luminance / by_luminance.scale_luminance, 1.0, 1e-4);
  // Both kinds of readings fit together with no residual.
  const auto mixed = fit_photometric({reading(e_rel, lux, Unit::Lux, "lux"),
                                      reading(0.25, sky_luminance, Unit::CandelaPerSquareMetre, "nits")});
  EXPECT_NEAR(mixed.scale_luminance / k, 1.0, 1e-4);
  EXPECT_LT(mixed.max_abs_relative, 1e-4);
}

std::vector<PhotometricReading> log_patches(double a, double b) {
  std::vector<PhotometricReading> readings;
  for (size_t i = 0; i < kPatchLuminance.size(); ++i)
    readings.push_back(reading(a + b * std::log(kPatchLuminance[i]), kPatchLuminance[i],
                               Unit::CandelaPerSquareMetre, "patch" + std::to_string(i)));
  return readings;
}

TEST(Photometric, LogSensorFitRecoversAAndBFromNoiselessPatches) {
  PhotometricOptions options;
  options.model = PhotometricOptions::Model::LogSensor;
  const auto cal = fit_photometric(log_patches(212.0, 41.5), options);
  ASSERT_TRUE(cal.log_sensor.has_value());
  EXPECT_NEAR(cal.log_sensor->a, 212.0, 1e-6);
  EXPECT_NEAR(cal.log_sensor->b, 41.5, 1e-6);
  EXPECT_EQ(cal.scale_luminance, 1.0);
  EXPECT_LT(cal.held_out_rms_relative, 1e-9);
}

TEST(Photometric, LogSensorFitShrugsOffOneOutlierThanksToTheRobustLoss) {
  const double a = 212.0, b = 41.5;
  auto readings = log_patches(a, b);
  // Small meter noise on every patch, and one patch misread (the meter on the wrong range:
  // 10x too bright).
  const double noise[] = {0.01, -0.008, 0.004, -0.012, 0.006, -0.003};
  for (size_t i = 0; i < readings.size(); ++i) readings[i].measured *= std::exp(noise[i]);
  auto bad = reading(a + b * std::log(300.0), 3000.0, Unit::CandelaPerSquareMetre, "outlier");
  readings.push_back(bad);

  PhotometricOptions plain;
  plain.model = PhotometricOptions::Model::LogSensor;
  plain.loss = RobustLoss::None;
  const auto least_squares = fit_photometric(readings, plain);
  for (RobustLoss loss : {RobustLoss::Huber, RobustLoss::Cauchy}) {
    PhotometricOptions robust = plain;
    robust.loss = loss;
    const auto cal = fit_photometric(readings, robust);
    ASSERT_TRUE(cal.log_sensor.has_value());
    EXPECT_NEAR(cal.log_sensor->b, b, 0.01 * b) << cal.loss;
    EXPECT_NEAR(cal.log_sensor->a, a, 0.05 * b) << cal.loss;  // ln L off by < 5 %
    // Decoded luminance of the good patches within 2 %; the outlier stands out.
    for (size_t i = 0; i + 1 < cal.residuals.size(); ++i) EXPECT_LT(std::abs(cal.residuals[i].relative), 0.025);
    EXPECT_NEAR(cal.residuals.back().relative, 300.0 / 3000.0 - 1, 0.01);
    // Plain least squares is pulled further away than the robust fit.
    EXPECT_GT(std::abs(least_squares.log_sensor->a - a), 2 * std::abs(cal.log_sensor->a - a)) << cal.loss;
  }
}

TEST(Photometric, ReadingsCsvRoundTripsLabelsRegionsAndUnits) {
  const std::string dir = temp_dir();
  // A 8x4 image whose left half is 0.1 and right half 0.3 (grey).
  RgbImage image;
  image.width = 8;
  image.height = 4;
  image.rgb.resize(8 * 4 * 3);
  for (int v = 0; v < 4; ++v)
    for (int u = 0; u < 8; ++u)
      for (int c = 0; c < 3; ++c) image.rgb[3 * (v * 8 + u) + c] = u < 4 ? 0.1f : 0.3f;
  write_rgb_image(dir + "patches.exr", image);
  const std::string csv = write_text(dir + "readings.csv",
                                     "# grey patches, meter at 1 m\n"
                                     "Region , Camera_Value, measured, unit\r\n"
                                     "\"patches.exr:0,0,4,4\",,50,cd/m2\n"
                                     "\"patches.exr:4,0,4,4\",,150,nits\n"
                                     "\n"
                                     "sky,0.5,250,lx\n");
  auto readings = read_readings_csv(csv);
  ASSERT_EQ(readings.size(), 3u);
  EXPECT_EQ(readings[0].label, "patches.exr:0,0,4,4");
  ASSERT_TRUE(readings[1].region.has_value());
  EXPECT_EQ(readings[1].region->image, "patches.exr");
  EXPECT_EQ(readings[1].region->x, 4);
  EXPECT_EQ(readings[1].region->width, 4);
  EXPECT_TRUE(std::isnan(readings[0].camera_value));
  EXPECT_EQ(readings[2].unit, Unit::Lux);
  EXPECT_EQ(readings[2].source, csv + ":6");
  // Unresolved regions are an input error, naming the line.
  EXPECT_NE(input_error([&] { fit_photometric(readings); }).find(csv + ":3:"), std::string::npos);
  resolve_regions(readings);
  EXPECT_NEAR(readings[0].camera_value, 0.1, 1e-6);
  EXPECT_NEAR(readings[1].camera_value, 0.3, 1e-6);
  const auto cal = fit_photometric(readings);
  EXPECT_NEAR(cal.scale_luminance, 500.0, 0.5);
  EXPECT_EQ(cal.residuals.size(), 3u);

  save_photometric(dir + "photometric.json", cal);
  const auto back = load_photometric(dir + "photometric.json");
  EXPECT_DOUBLE_EQ(back.scale_luminance, cal.scale_luminance);
  EXPECT_DOUBLE_EQ(back.scale_rgb[1], cal.scale_rgb[1]);
  EXPECT_DOUBLE_EQ(back.held_out_rms_relative, cal.held_out_rms_relative);
  EXPECT_EQ(back.residuals.size(), 3u);
  EXPECT_EQ(back.residuals[2].label, "sky");

  // Applying it: relative 0.1 grey becomes 0.1 * 500 / 683 W sr^-1 m^-2, i.e. 50 cd/m2.
  apply_photometric(image, back);
  EXPECT_EQ(image.units, Units::Radiance);
  EXPECT_NEAR(683.0 * luminance(image.rgb[0], image.rgb[1], image.rgb[2]), 50.0, 0.1);
  EXPECT_NE(input_error([&] { apply_photometric(image, back); }), "");
}

TEST(Photometric, BadReadingsFilesAreRejectedNamingFileAndLine) {
  const std::string dir = temp_dir();
  const std::string header = "region,camera_value,measured,unit\n";
  struct Case {
    std::string body;
    std::string expected;  // substring after "file:"
  };
  const std::vector<Case> cases{
      {header + "a,0.1,50,cd/m2\nb,0.2,-3,cd/m2\n", ":3: measured value -3 is not positive"},
      {header + "a,0.1,50,cd/m2\nb,0,30,cd/m2\n", ":3: camera_value 0 is not positive"},
      {header + "a,0.1,50,cd/m2\nb,nan,30,cd/m2\n", ":3: camera_value 'nan' is not finite"},
      {header + "a,0.1,50,cd/m2\nb,0.2,inf,cd/m2\n", ":3: measured value 'inf' is not finite"},
      {header + "a,0.1,50,cd/m2\nb,0.2,1e999,cd/m2\n", ":3: measured value '1e999' is not a number"},
      {header + "a,0.1,50,cd/m2\nb,0.2,30,foot-lambert\n", ":3: unknown unit 'foot-lambert'"},
      {header + "a,0.1,50,cd/m2\nb,0.2,30,cd/m2\na,0.3,80,cd/m2\n", ":4: duplicate label 'a' (first on line 2)"},
      {header + "a,0.1,50,cd/m2\n", ": 1 reading(s); at least 2"},
      {"label,value,measured,unit\na,0.1,50,cd/m2\n", ":1: header must be"},
      {header + "a,0.1,50,cd/m2\nimg.exr:1,2,3,4,,30,cd/m2\n", ":3: expected 4 fields"},
      {header + "a,0.1,50,cd/m2\n\"img.exr:1,2,3\",,30,cd/m2\n", ":3: region 'img.exr:1,2,3' is not image:x,y,w,h"},
      {header + "a,0.1,50,cd/m2\nb,,30,cd/m2\n", ":3: camera_value is empty"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string path = write_text(dir + "case" + std::to_string(i) + ".csv", cases[i].body);
    const std::string message = input_error([&] { read_readings_csv(path); });
    EXPECT_NE(message.find(path + cases[i].expected), std::string::npos)
        << "case " << i << ": got '" << message << "'";
    EXPECT_EQ(message.find('\n'), std::string::npos);
  }
  EXPECT_NE(input_error([&] { read_readings_csv(dir + "missing.csv"); }).find("missing.csv"), std::string::npos);
}

TEST(Photometric, FitsRefuseTooFewReadingsAndLuxForLogSensors) {
  EXPECT_NE(input_error([] { fit_photometric({reading(0.1, 50, Unit::CandelaPerSquareMetre, "a")}); })
                .find("at least 2"),
            std::string::npos);
  PhotometricOptions log;
  log.model = PhotometricOptions::Model::LogSensor;
  EXPECT_NE(input_error([&] {
              fit_photometric({reading(100, 50, Unit::CandelaPerSquareMetre, "a"),
                               reading(140, 500, Unit::CandelaPerSquareMetre, "b")},
                              log);
            }).find("at least 3"),
            std::string::npos);
  EXPECT_NE(input_error([&] {
              fit_photometric({reading(100, 50, Unit::CandelaPerSquareMetre, "a"),
                               reading(140, 500, Unit::Lux, "b"), reading(160, 5000, Unit::CandelaPerSquareMetre, "c")},
                              log);
            }).find("'b' is in lux"),
            std::string::npos);
  EXPECT_NE(input_error([] {
              fit_photometric({reading(0.1, 50, Unit::CandelaPerSquareMetre, "a"),
                               reading(0.2, 90, Unit::CandelaPerSquareMetre, "a")});
            }).find("duplicate label 'a'"),
            std::string::npos);
}

// Regions of a camera image are codes: a log sensor's fit reads them, a linear scale must
// not (they are neither linear nor divided by the exposure time), and a clipped code's value
// is unknown, so a region holding one is refused.
TEST(Photometric, RegionsOfCameraCodesAreReadOnlyUnclippedAndOnlyByALogFit) {
  const std::string dir = temp_dir();
  RgbImage frame;
  frame.width = 12;
  frame.height = 2;
  // Three 4x2 patches: codes 0.2, 0.5 and one whose right half is at the top code.
  for (int v = 0; v < 2; ++v)
    for (int u = 0; u < 12; ++u)
      for (int c = 0; c < 3; ++c) frame.rgb.push_back(u < 4 ? 0.2f : u < 8 ? 0.5f : u < 10 ? 0.9f : 1.0f);
  write_code_image(dir + "frame.png", frame, 8);
  const std::string header = "region,camera_value,measured,unit\n";
  const std::string two = "\"frame.png:0,0,4,2\",,10,cd/m2\n\"frame.png:4,0,4,2\",,100,cd/m2\n";
  auto readings = read_readings_csv(write_text(dir + "log.csv", header + two + "c,0.8,1000,cd/m2\n"));
  resolve_regions(readings);
  EXPECT_NEAR(readings[0].camera_value, 51.0 / 255, 1e-6);
  EXPECT_NEAR(readings[1].camera_value, 128.0 / 255, 1e-6);
  EXPECT_EQ(readings[0].code_bits, 8);
  EXPECT_EQ(readings[2].code_bits, 0);
  PhotometricOptions log;
  log.model = PhotometricOptions::Model::LogSensor;
  EXPECT_TRUE(fit_photometric(readings, log).log_sensor.has_value());
  EXPECT_NE(input_error([&] { fit_photometric(readings); }).find(dir + "log.csv:2: 'frame.png:0,0,4,2' is a region of 8-bit camera codes"),
            std::string::npos);

  auto clipped = read_readings_csv(write_text(dir + "clipped.csv", header + two + "\"frame.png:8,0,4,2\",,1000,cd/m2\n"));
  EXPECT_NE(input_error([&] { resolve_regions(clipped); }).find(dir + "clipped.csv:4: " + dir + "frame.png: 4 of 8 pixels of region 8,0,4,2 are clipped"),
            std::string::npos);
  EXPECT_EQ(clipped_codes_in_region(frame, 8, 0, 4, 2), 0u) << "radiance (code_bits 0) never clips";
  frame.code_bits = 8;
  EXPECT_EQ(clipped_codes_in_region(frame, 8, 0, 4, 2), 4u);
  EXPECT_EQ(clipped_codes_in_region(frame, 0, 0, 8, 2), 0u);
  frame.rgb.assign(frame.rgb.size(), 0.0f);
  EXPECT_EQ(clipped_codes_in_region(frame, 0, 0, 3, 1), 3u) << "black in every channel is clipped too";
}

// A region of a map that is calibrated already gave k near 683 (its radiance units), which
// then scaled relative maps by that.
TEST(Photometric, RegionsOfAMapInRadianceUnitsAreRefused) {
  const std::string dir = temp_dir();
  RgbImage map{4, 2, std::vector<float>(24, 0.1f)};
  map.units = Units::Radiance;
  write_rgb_image(dir + "calibrated.exr", map);
  map.units = Units::Relative;
  write_rgb_image(dir + "relative.exr", map);
  const std::string header = "region,camera_value,measured,unit\n";
  const std::string second = "\"relative.exr:2,0,2,2\",,68.3,cd/m2\n";
  auto relative = read_readings_csv(write_text(dir + "relative.csv", header + "\"relative.exr:0,0,2,2\",,68.3,cd/m2\n" + second));
  resolve_regions(relative);
  EXPECT_NEAR(relative[0].camera_value, 0.1, 1e-6);
  auto calibrated = read_readings_csv(write_text(dir + "calibrated.csv", header + "\"calibrated.exr:0,0,2,2\",,68.3,cd/m2\n" + second));
  EXPECT_NE(input_error([&] { resolve_regions(calibrated); })
                .find(dir + "calibrated.csv:2: " + dir + "calibrated.exr is in radiance units already"),
            std::string::npos);
}

TEST(Photometric, RegionsOutsideTheImageAreRejected) {
  RgbImage image{4, 4, std::vector<float>(48, 1.0f)};
  EXPECT_DOUBLE_EQ(mean_luminance_in_region(image, 1, 1, 2, 2), 1.0);
  EXPECT_NE(input_error([&] { mean_luminance_in_region(image, 2, 2, 3, 1); }).find("not inside the 4x4 image"),
            std::string::npos);
  image.valid.assign(16, 0);
  EXPECT_NE(input_error([&] { mean_luminance_in_region(image, 0, 0, 2, 2); }).find("no valid pixel"),
            std::string::npos);
}

}  // namespace
}  // namespace lp
