#include "live/frame_decode.h"

#include "probe/camera_codes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"

namespace lp {
namespace {

TEST(FrameDecode, ThePixelFormatsNameGivesTheCodesBitDepth) {
  EXPECT_EQ(pixel_format_bits("RGB8"), 8);
  EXPECT_EQ(pixel_format_bits("Mono12"), 12);
  EXPECT_EQ(pixel_format_bits("BayerRG16"), 16);
  EXPECT_EQ(pixel_format_bits("RGBFloat"), 0);
  EXPECT_EQ(pixel_format_bits("Mono123"), 0);
  EXPECT_EQ(pixel_format_bits(""), 0);
}

// A single-exposure stream given --response maps each code through the camera's curve
// before dividing by the exposure, as the bracket fusion does (it used to ignore the
// response and take the codes as linear); a response of other levels than the frame's codes
// is refused; float frames and streams without a response are unchanged.
TEST(FrameDecode, ASingleFrameGoesThroughTheGivenResponse) {
  CameraResponse response;
  response.levels = 256;
  for (int c = 0; c < 3; ++c)
    for (int z = 0; z < 256; ++z) response.log_exposure[size_t(c)].push_back(float(std::log((c + 1) * (z + 1.0))));
  CameraFrame frame;
  frame.pixel_format = "RGB8";
  frame.exposure_s = 0.5;
  frame.image.width = frame.image.height = 1;
  frame.image.rgb = {10.0f / 255, 20.0f / 255, 255.0f / 255};
  CameraFrame plain = frame;
  decode_single_frame(frame, FrameDecode::Relative, nullptr, &response);
  EXPECT_NEAR(frame.image.rgb[0], 1 * 11.0 / 0.5, 1e-4);
  EXPECT_NEAR(frame.image.rgb[1], 2 * 21.0 / 0.5, 1e-4);
  EXPECT_NEAR(frame.image.rgb[2], 3 * 256.0 / 0.5, 1e-3);
  decode_single_frame(plain, FrameDecode::Relative, nullptr);  // no response: codes / exposure
  EXPECT_FLOAT_EQ(plain.image.rgb[0], float(10.0f / 255 / 0.5));
  CameraFrame deep = frame;
  deep.pixel_format = "Mono12";
  try {
    decode_single_frame(deep, FrameDecode::Relative, nullptr, &response);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("its 256 levels do not fit frame 0's 12-bit codes (Mono12, 4096 levels)"),
              std::string::npos)
        << e.what();
  }
  CameraFrame radiance = plain;
  radiance.pixel_format = "RGBFloat";
  radiance.exposure_s = 0;
  const auto before = radiance.image.rgb;
  decode_single_frame(radiance, FrameDecode::Relative, nullptr, &response);
  EXPECT_EQ(radiance.image.rgb, before);
}

// libcamera's auto-exposure raises the analogue gain in a dim room frame by frame; the
// stream divided by the time alone, so the same scene's map jumped by the gain (x2 at
// 6 dB), with or without a response curve.
TEST(FrameDecode, TheAnalogueGainDividesOutAsTheTimeDoes) {
  CameraResponse response = linear_response(256);
  for (const CameraResponse* curve : std::vector<const CameraResponse*>{nullptr, &response}) {
    CameraFrame at_0db;
    at_0db.pixel_format = "RGB8";
    at_0db.exposure_s = 0.02;
    at_0db.image.width = at_0db.image.height = 1;
    at_0db.image.rgb = {20.0f / 255, 40.0f / 255, 80.0f / 255};
    CameraFrame at_6db = at_0db;  // twice the gain, half the time: the same codes
    at_6db.exposure_s = 0.01;
    at_6db.gain_db = 20 * std::log10(2.0);
    EXPECT_NEAR(frame_exposure(at_6db), 0.02, 1e-12);
    decode_single_frame(at_0db, FrameDecode::Relative, nullptr, curve);
    decode_single_frame(at_6db, FrameDecode::Relative, nullptr, curve);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(at_6db.image.rgb[c] / at_0db.image.rgb[c], 1.0, 1e-5) << c;  // was 2
  }
  CameraFrame unknown;  // no time, no gain: codes as they are
  EXPECT_EQ(frame_exposure(unknown), 1.0);
}

// The stream keeps the response's per-level table between frames (live/pipeline.cpp): every
// frame decodes to the same floats as with a table built for it alone, and as the plain
// per-sample formula (exp g(z) / exposure, in double, then float); a frame of another bit
// depth rebuilds it rather than reading a table of the wrong size.
TEST(FrameDecode, AKeptResponseTableGivesTheFloatsOfOneBuiltPerFrame) {
  CameraResponse response8;
  response8.levels = 256;
  for (int c = 0; c < 3; ++c)
    for (int z = 0; z < 256; ++z) response8.log_exposure[size_t(c)].push_back(float(0.02 * z - 0.3 * c));
  CodeTable kept;
  for (const double exposure : {0.01, 1.0 / 3, 0.0}) {
    CameraFrame frame;
    frame.pixel_format = "BayerRG8";
    frame.exposure_s = exposure;
    frame.image.width = 256, frame.image.height = 1;
    for (int z = 0; z < 256; ++z)
      for (int c = 0; c < 3; ++c) frame.image.rgb.push_back(float((z + 37 * c) % 256) / 255.0f);
    const std::vector<float> codes = frame.image.rgb;
    CameraFrame alone = frame;
    decode_single_frame(frame, FrameDecode::Relative, nullptr, &response8, &kept);
    decode_single_frame(alone, FrameDecode::Relative, nullptr, &response8);
    EXPECT_EQ(kept.bits, 8);
    ASSERT_EQ(frame.image.rgb, alone.image.rgb);
    for (size_t i = 0; i < codes.size(); ++i) {
      const int z = int(std::lround(codes[i] * 255.0));
      float want = float(std::exp(double(response8.log_exposure[i % 3][size_t(z)])));
      if (exposure > 0) want = float(want / exposure);
      ASSERT_EQ(frame.image.rgb[i], want) << "sample " << i << ", exposure " << exposure;
    }
  }
  CameraResponse response12;
  response12.levels = 4096;
  for (int c = 0; c < 3; ++c)
    for (int z = 0; z < 4096; ++z) response12.log_exposure[size_t(c)].push_back(float(0.001 * z));
  CameraFrame deep;
  deep.pixel_format = "Mono12";
  deep.image.width = deep.image.height = 1;
  deep.image.rgb = {4095.0f / 4095, 2048.0f / 4095, 1.0f / 4095};
  decode_single_frame(deep, FrameDecode::Relative, nullptr, &response12, &kept);
  EXPECT_EQ(kept.bits, 12);
  EXPECT_EQ(deep.image.rgb[0], float(std::exp(double(response12.log_exposure[0][4095]))));
  EXPECT_EQ(deep.image.rgb[1], float(std::exp(double(response12.log_exposure[1][2048]))));
}

}  // namespace
}  // namespace lp
