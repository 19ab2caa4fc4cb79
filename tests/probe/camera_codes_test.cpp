#include "probe/camera_codes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/error.h"

namespace lp {
namespace {

RgbImage codes(int bits, std::initializer_list<int> levels) {
  RgbImage img;
  img.width = int(levels.size()), img.height = 1, img.code_bits = bits;
  const double top = std::ldexp(1.0, bits) - 1;
  for (int z : levels)
    for (int c = 0; c < 3; ++c) img.rgb.push_back(float(z / top));  // as read_camera_image gives codes
  return img;
}

// IEC 61966-2-1's decoding at codes worked out by hand: 10/255 on the linear toe, 128/255
// = ((0.50196 + 0.055) / 1.055)^2.4 = 0.21586, the top code 1.
TEST(CameraCodes, SrgbCodesAreDecodedAsIec61966Says) {
  RgbImage img = codes(8, {0, 10, 128, 255});
  const CodesReport r = linearise_codes(img, CodeCurve{}, "a.jpg");
  EXPECT_TRUE(r.linearised);
  EXPECT_EQ(img.code_bits, 0);
  EXPECT_FLOAT_EQ(img.rgb[0], 0.0f);
  EXPECT_FLOAT_EQ(img.rgb[3], float(10.0 / 255 / 12.92));
  EXPECT_NEAR(img.rgb[6], 0.2158605, 1e-6);
  EXPECT_FLOAT_EQ(img.rgb[9], 1.0f);
  EXPECT_DOUBLE_EQ(r.clipped_fraction, 0.25);  // one pixel of four at the top code
  // Radiance already: left alone, nothing reported.
  RgbImage radiance = img;
  EXPECT_FALSE(linearise_codes(radiance, CodeCurve{}, "a.exr").linearised);
  EXPECT_EQ(radiance.rgb, img.rgb);
}

TEST(CameraCodes, LinearCodesAndAResponseTableAreAppliedPerLevel) {
  RgbImage img = codes(16, {0, 1000, 65535});
  CodeCurve linear;
  linear.kind = CodeCurve::Kind::Linear;
  RgbImage a = img;
  linearise_codes(a, linear, "a.png");
  EXPECT_FLOAT_EQ(a.rgb[3], float(1000.0 / 65535));
  // A recovered response: level z of channel c is worth (c + 1) z, say.
  CodeCurve response;
  response.kind = CodeCurve::Kind::Table;
  response.name = "r.json";
  for (int c = 0; c < 3; ++c)
    for (int z = 0; z < 256; ++z) response.table[size_t(c)].push_back((c + 1) * z);
  RgbImage b = codes(8, {3, 255});
  linearise_codes(b, response, "b.jpg");
  EXPECT_FLOAT_EQ(b.rgb[0], 3.0f);
  EXPECT_FLOAT_EQ(b.rgb[1], 6.0f);
  EXPECT_FLOAT_EQ(b.rgb[2], 9.0f);
  EXPECT_FLOAT_EQ(b.rgb[5], 765.0f);
  // Its 256 levels do not fit 16-bit codes: refused, naming the file and the response.
  try {
    linearise_codes(a = img, response, "c.png");
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "c.png: 16-bit codes (65536 levels), but the response r.json has 256 levels");
  }
}

// A table built once gives the floats of the curve applied frame by frame; values outside
// [0, 1] take the nearest end of the table (a NaN the lowest level) instead of wrapping
// round to the top code; the clipped count is of pixels with any channel at the top code.
TEST(CameraCodes, ATableBuiltOnceGivesTheCurvesFloatsAndClampsStrayValues) {
  const CodeTable table = make_code_table(CodeCurve{}, 8, "a.jpg");
  ASSERT_EQ(table.bits, 8);
  RgbImage a = codes(8, {0, 1, 17, 128, 200, 254, 255});
  RgbImage b = a;
  linearise_codes(a, CodeCurve{}, "a.jpg");
  const CodesReport r = linearise_codes(b, table, "a.jpg");
  EXPECT_EQ(a.rgb, b.rgb);
  EXPECT_NEAR(r.clipped_fraction, 1.0 / 7, 1e-12);
  float stray[9] = {-0.25f, 1.5f, std::nanf(""), 0.5f / 255, 0.49f / 255, 254.6f / 255, 0, 0, 0};
  EXPECT_EQ(apply_code_table(stray, 3, table), 2u);  // 1.5 and 254.6 / 255 round to the top
  EXPECT_EQ(stray[0], 0.0f);                         // below 0: level 0
  EXPECT_EQ(stray[1], 1.0f);                         // above 1: the top level
  EXPECT_EQ(stray[2], 0.0f);                         // NaN: level 0
  EXPECT_EQ(stray[3], table.linear[0][1]);           // half a level rounds up, as std::lround
  EXPECT_EQ(stray[4], 0.0f);
  EXPECT_EQ(stray[5], 1.0f);
  // A table for other bit depths is refused, naming the file.
  RgbImage deep = codes(16, {1000});
  try {
    linearise_codes(deep, table, "deep.png");
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("deep.png: 16-bit codes, but its code table is for 8-bit ones"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace lp
