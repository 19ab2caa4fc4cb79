// Log sensors live (issue 20 item 3): the stream decodes a log sensor's frames with its
// photometric curve, in the same unit as a linear calibrated camera of the same scene, and
// refuses what it cannot decode.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <vector>

#include <unistd.h>

#include "core/error.h"
#include "tests/core/test_files.h"
#include "core/image_io.h"
#include "hdr/response.h"
#include "live/pipeline.h"

namespace fs = std::filesystem;

namespace lp {
namespace {

using test_files::input_error;

constexpr double kScale = 2.78;               // linear camera: cd/m2 per relative unit
constexpr double kCurveA = 0.25, kCurveB = 0.05;  // log camera: code = a + b ln L

// Three frames of a uniform scene, per-channel luminance-like values in cd/m2.
const std::vector<std::array<double, 3>> kScene = {{3, 3, 3}, {250, 180, 90}, {9000, 9000, 9000}};

PhotometricCalibration linear_calibration() {
  PhotometricCalibration c;
  c.scale_luminance = kScale;
  for (double& s : c.scale_rgb) s = kScale / kLuminousEfficacy;
  return c;
}

PhotometricCalibration log_calibration() {
  PhotometricCalibration c;
  c.log_sensor = LogSensorCurve{kCurveA, kCurveB};
  return c;  // scale_luminance 1, scale_rgb 1/683: as fit_photometric leaves a log fit
}

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("lightprobe_live_log_" + std::to_string(::getpid())) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// 16-bit PNG frames of kScene as each camera records them: the linear one at an exposure
// that puts the brightest channel at code 0.5 (exposures.csv), the log one by its curve.
fs::path write_replay(bool log) {
  const fs::path dir = scratch(log ? "log" : "linear");
  std::ofstream exposures(dir / "exposures.csv");
  for (size_t f = 0; f < kScene.size(); ++f) {
    const double t = 0.5 * kScale / std::max({kScene[f][0], kScene[f][1], kScene[f][2]});
    RgbImage frame;
    frame.width = frame.height = 64;
    for (int p = 0; p < 64 * 64; ++p)
      for (double l : kScene[f]) frame.rgb.push_back(float(log ? kCurveA + kCurveB * std::log(l) : l * t / kScale));
    write_code_image((dir / ("frame" + std::to_string(f) + ".png")).string(), frame, 16);
    if (!log) exposures << t << "\n";
  }
  return dir;
}

LivePipelineOptions pipeline_options(const PhotometricCalibration& calibration) {
  LivePipelineOptions o;
  o.photometric = calibration;
  o.photometric_file = "cal.json";
  // The default layout: a hemisphere, here 90 x 23.
  o.width = 90;
  o.height = 23;
  o.sampling.method = Method::Pharr;
  o.sampling.count = 16;
  o.sampling.sampler.upper_only = true;
  o.queue_brackets = 8;  // keep every frame: the test compares them in order
  return o;
}

// 683 Y of every valid pixel of every published map, per map.
std::vector<std::vector<double>> stream_candelas(const fs::path& replay, const PhotometricCalibration& calibration,
                                                 LiveStats* stats) {
  std::mutex m;
  std::vector<std::vector<double>> maps;
  LivePipeline p([&] { return open_source("replay:" + replay.string()); }, pipeline_options(calibration),
                 [&](const LightList&, std::shared_ptr<const EnvMap> map) {
                   std::vector<double> cd;
                   EXPECT_EQ(map->units, Units::Radiance);
                   for (size_t i = 0; i < map->pixel_count(); ++i)
                     if (map->valid.empty() || map->valid[i])
                       cd.push_back(683.0 * luminance(map->rgb[3 * i], map->rgb[3 * i + 1], map->rgb[3 * i + 2]));
                   std::lock_guard<std::mutex> lock(m);
                   maps.push_back(std::move(cd));
                 });
  p.start();
  p.wait();
  *stats = p.stats();
  return maps;
}

TEST(LiveLogSensor, ALogCameraAndALinearCameraOfOneSceneStreamTheSameCandelas) {
  LiveStats log_stats, linear_stats;
  const auto log = stream_candelas(write_replay(true), log_calibration(), &log_stats);
  const auto linear = stream_candelas(write_replay(false), linear_calibration(), &linear_stats);
  EXPECT_EQ(log_stats.decode, "log-sensor");
  EXPECT_EQ(linear_stats.decode, "linear");
  ASSERT_EQ(log.size(), kScene.size()) << log_stats.last_error;
  ASSERT_EQ(linear.size(), kScene.size()) << linear_stats.last_error;
  for (size_t f = 0; f < kScene.size(); ++f) {
    const double truth = luminance(kScene[f].data());
    ASSERT_GT(log[f].size(), 1000u);
    ASSERT_GT(linear[f].size(), 1000u);
    // 16-bit codes: the log curve resolves ln L to 1/65535/2/b = 1.5e-4; the linear
    // codes (0.5 at the brightest channel) to 3e-5.
    for (double cd : log[f]) ASSERT_NEAR(cd / truth, 1.0, 1e-3) << "log frame " << f;
    for (double cd : linear[f]) ASSERT_NEAR(cd / truth, 1.0, 1e-3) << "linear frame " << f;
  }
}

TEST(LiveLogSensor, WhatTheStreamCannotDecodeIsRefusedAtStartNamingTheCalibration) {
  const auto open = [] { return std::unique_ptr<CameraSource>(); };
  const auto publish = [](const LightList&, std::shared_ptr<const EnvMap>) {};
  auto bracket = pipeline_options(log_calibration());
  bracket.exposure_cycle = {0.001, 0.01};
  auto response = pipeline_options(log_calibration());
  response.response = linear_response(256);
  auto maps = pipeline_options(log_calibration());
  maps.frames_are_maps = true;
  for (const auto& o : {bracket, response, maps}) {
    const std::string e = input_error([&] { LivePipeline p(open, o, publish); });
    EXPECT_EQ(e.rfind("cal.json: a log-sensor calibration", 0), 0u) << e;
    EXPECT_EQ(e.find('\n'), std::string::npos);
  }
  // The same options with a linear calibration are fine (a bracket, a response, maps).
  auto linear_bracket = pipeline_options(linear_calibration());
  linear_bracket.exposure_cycle = {0.001, 0.01};
  EXPECT_EQ(input_error([&] { LivePipeline p(open, linear_bracket, publish); }), "");
}

TEST(LiveLogSensor, ARadianceFrameUnderALogCurveStopsTheStreamAsBadInput) {
  const fs::path dir = scratch("exr");
  RgbImage radiance;
  radiance.width = radiance.height = 16;
  radiance.rgb.assign(16 * 16 * 3, 0.5f);
  write_rgb_image((dir / "frame0.exr").string(), radiance);
  LiveStats stats;
  const auto maps = stream_candelas(dir, log_calibration(), &stats);
  EXPECT_TRUE(maps.empty());
  EXPECT_NE(stats.input_error.find("is float radiance, not the raw codes a log-sensor calibration decodes"),
            std::string::npos)
      << stats.input_error;
}

}  // namespace
}  // namespace lp
