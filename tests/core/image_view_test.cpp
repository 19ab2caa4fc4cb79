#include "core/image_view.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/image_io.h"
#include "core/tonemap.h"

namespace lp {
namespace {

// A 5 x 4 RGB image with a mask, every value different.
RgbImage sample_image() {
  RgbImage im;
  im.width = 5, im.height = 4;
  for (int i = 0; i < 5 * 4 * 3; ++i) im.rgb.push_back(0.01f * float(i * i % 97) + 0.001f);
  im.valid.assign(20, 1);
  im.valid[7] = 0;
  return im;
}

TEST(ImageView, OwnersHandOutPackedViewsOfTheirPixels) {
  const RgbImage im = sample_image();
  const ImageView v = image_view(im);
  EXPECT_TRUE(v.packed());
  EXPECT_EQ(v.stride, 15u);
  EXPECT_EQ(v.pixel(2, 1), &im.rgb[3 * 7]);
  EXPECT_FALSE(v.is_valid(2, 1));
  EXPECT_TRUE(v.is_valid(3, 1));
  EXPECT_EQ(im.units, Units::Relative);
  CameraImage c;
  c.width = 2, c.height = 1, c.rgb = {1, 2, 3, 4, 5, 6};
  EXPECT_EQ(*image_view(c).pixel(1, 0), 4.0f);
  EXPECT_EQ(image_view(c).valid, nullptr);
}

TEST(ImageView, ToneMappingAStridedWindowEqualsToneMappingItsCopy) {
  // The right 3 x 3 window of the image, viewed in place (rows 15 floats apart), against
  // a packed copy of the same pixels and mask.
  const RgbImage im = sample_image();
  ImageView window = image_view(im);
  window.data = image_view(im).pixel(2, 1);
  window.valid = im.valid.data() + 1 * 5 + 2;
  window.width = 3, window.height = 3;
  EXPECT_FALSE(window.packed());
  std::vector<float> copy;
  std::vector<uint8_t> mask;
  for (int y = 1; y < 4; ++y)
    for (int x = 2; x < 5; ++x) {
      for (int c = 0; c < 3; ++c) copy.push_back(im.rgb[3 * (size_t(y) * 5 + x) + c]);
      mask.push_back(im.valid[size_t(y) * 5 + x]);
    }
  ASSERT_EQ(mask[0], 0);  // the invalid pixel (2, 1) is in the window
  const std::vector<float> a = tone_map(window), b = tone_map(packed_view(copy.data(), 3, 3, 3, mask.data()));
  ASSERT_EQ(a.size(), 27u);
  EXPECT_EQ(a, b);
  EXPECT_FLOAT_EQ(a[0], 0.55f);  // the checkerboard's light square, not black
}

TEST(ImageView, TheSrgbTransferMatchesIec61966) {
  // Independent values: 1.055 x^(1/2.4) - 0.055 above 0.0031308, 12.92 x below.
  EXPECT_EQ(srgb_code(0.5f), 188);    // 0.7354 * 255 = 187.5
  EXPECT_EQ(srgb_code(0.18f), 118);   // 0.4614 * 255 = 117.6
  EXPECT_EQ(srgb_code(0.002f), 7);    // 12.92 * 0.002 * 255 = 6.59
  EXPECT_EQ(srgb_code(std::nanf("")), 0);
  EXPECT_EQ(srgb_code(-0.5f), 0);
  EXPECT_EQ(srgb_code(1.5f), 255);
}

}  // namespace
}  // namespace lp
