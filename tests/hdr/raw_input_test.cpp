#include "hdr/raw_input.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"

namespace lp {
namespace {

const std::string kData = LIGHTPROBE_SHARED_DATA;
constexpr int kW = 64, kH = 48, kPatchW = 32, kPatchH = 24;

// Four flat patches of distinct colours (fractions of full scale).
std::array<double, 3> truth(int x, int y) {
  static const std::array<std::array<double, 3>, 4> patches = {
      {{0.80, 0.20, 0.10}, {0.15, 0.70, 0.30}, {0.05, 0.25, 0.90}, {0.50, 0.50, 0.50}}};
  return patches[size_t((y / kPatchH) * 2 + x / kPatchW)];
}

// Channel (0 R, 1 G, 2 B) sampled at (x, y) by a sensor with this pattern.
int channel_at(BayerPattern p, int x, int y) {
  static const std::array<std::array<int, 4>, 4> cells = {{
      {0, 1, 1, 2},  // RGGB
      {2, 1, 1, 0},  // BGGR
      {1, 0, 2, 1},  // GRBG
      {1, 2, 0, 1},  // GBRG
  }};
  return cells[size_t(p)][size_t((y % 2) * 2 + x % 2)];
}

std::vector<uint16_t> mosaic(BayerPattern p, int bit_depth) {
  const double max_code = double((1u << bit_depth) - 1);
  std::vector<uint16_t> data(size_t(kW) * kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x)
      data[size_t(y) * kW + x] = uint16_t(std::lround(truth(x, y)[size_t(channel_at(p, x, y))] * max_code));
  return data;
}

struct Case {
  BayerPattern pattern;
  const char* name;
};

TEST(Raw, EveryBayerPatternAndDepthDemosaicsFlatPatchesToTheirColour) {
  const Case cases[] = {{BayerPattern::RGGB, "RGGB"},
                        {BayerPattern::BGGR, "BGGR"},
                        {BayerPattern::GRBG, "GRBG"},
                        {BayerPattern::GBRG, "GBRG"}};
  for (int depth : {8, 12, 16}) {
    for (const Case& c : cases) {
      const RgbImage im = demosaic_bayer(mosaic(c.pattern, depth), kW, kH, depth, c.pattern);
      ASSERT_EQ(im.width, kW);
      ASSERT_EQ(im.height, kH);
      double worst = 0;
      // Patch interiors, 3 px from every patch edge (the demosaic kernels reach 2 px).
      for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) {
          const int px = x % kPatchW, py = y % kPatchH;
          if (px < 3 || px >= kPatchW - 3 || py < 3 || py >= kPatchH - 3) continue;
          for (int ch = 0; ch < 3; ++ch)
            worst = std::max(worst, std::abs(im.rgb[(size_t(y) * kW + x) * 3 + ch] - truth(x, y)[size_t(ch)]));
        }
      EXPECT_LT(worst, 0.01) << c.name << " " << depth << "-bit";
    }
  }
}

TEST(Raw, AWrongPatternGivesWrongColours) {
  // Guards the test above: reading an RGGB mosaic as BGGR swaps red and blue.
  const RgbImage im = demosaic_bayer(mosaic(BayerPattern::RGGB, 12), kW, kH, 12, BayerPattern::BGGR);
  const size_t p = (size_t(12) * kW + 16) * 3;  // inside the (0.8, 0.2, 0.1) patch
  EXPECT_NEAR(im.rgb[p + 0], 0.1, 0.01);
  EXPECT_NEAR(im.rgb[p + 2], 0.8, 0.01);
}

TEST(Raw, MonoFramesBecomeGreyScaledByTheirDepth) {
  const RgbImage im = mono_to_rgb({0, 4095, 2048, 100}, 2, 2, 12);
  ASSERT_EQ(im.rgb.size(), 12u);
  EXPECT_EQ(im.rgb[3], 1.0f);
  EXPECT_EQ(im.rgb[4], 1.0f);
  EXPECT_NEAR(im.rgb[6], 2048.0 / 4095.0, 1e-6);
  EXPECT_EQ(im.rgb[6], im.rgb[8]);
  EXPECT_EQ(mono_to_rgb({255, 0}, 2, 1, 8).rgb[0], 1.0f);
  EXPECT_EQ(mono_to_rgb({65535, 0}, 1, 2, 16).rgb[0], 1.0f);
}

TEST(Raw, BuffersOfTheWrongSizeDepthOrRangeAreRefused) {
  EXPECT_THROW(mono_to_rgb({1, 2, 3}, 2, 2, 8), InputError);
  EXPECT_THROW(mono_to_rgb({1, 2, 3, 4}, 2, 2, 7), InputError);
  EXPECT_THROW(mono_to_rgb({1, 2, 3, 4096}, 2, 2, 12), InputError);
  EXPECT_THROW(demosaic_bayer(std::vector<uint16_t>(9, 0), 3, 3, 8, BayerPattern::RGGB), InputError);
  try {
    demosaic_bayer({0, 0, 0, 300}, 2, 2, 8, BayerPattern::RGGB);
    ADD_FAILURE() << "no throw";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("300"), std::string::npos) << msg;
    EXPECT_NE(msg.find("(1, 1)"), std::string::npos) << msg;
  }
}

TEST(Raw, AFileLibRawCannotReadIsAnInputErrorNamingIt) {
  for (const std::string& path : {kData + "/hdr-memorial-debevec/memorial0068.png", kData + "/no-such-file.cr2"}) {
    RawExposure t{-1, -1, -1};
    try {
      read_camera_raw(path, &t);
      ADD_FAILURE() << "no throw for " << path;
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(path), std::string::npos) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    }
    EXPECT_EQ(t.seconds, -1);  // untouched on failure
  }
}

}  // namespace
}  // namespace lp
