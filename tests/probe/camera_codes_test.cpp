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

}  // namespace
}  // namespace lp
