#include "probe/remap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace lp {
namespace {

RgbImage random_image(int w, int h, unsigned seed) {
  RgbImage im;
  im.width = w;
  im.height = h;
  im.rgb.resize(size_t(w) * h * 3);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 10.0f);
  for (float& v : im.rgb) v = u(rng);
  return im;
}

TEST(Remap, IdentityTableReproducesTheImageExactly) {
  RgbImage im = random_image(17, 11, 1);
  RemapTable t;
  t.out_width = 17;
  t.out_height = 11;
  for (int y = 0; y < 11; ++y)
    for (int x = 0; x < 17; ++x) {
      t.src_x.push_back(x + 0.5f);
      t.src_y.push_back(y + 0.5f);
    }
  RgbImage out = apply_remap(im, t);
  ASSERT_EQ(out.rgb.size(), im.rgb.size());
  EXPECT_TRUE(out.valid.empty());
  for (size_t i = 0; i < im.rgb.size(); ++i) EXPECT_FLOAT_EQ(out.rgb[i], im.rgb[i]);
}

TEST(Remap, AgreesWithOpenCvRemapReplicateBorderOnRandomCoordinates) {
  const int w = 40, h = 30;
  RgbImage im = random_image(w, h, 2);
  RemapTable t;
  t.out_width = 64;
  t.out_height = 48;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> ux(0.0f, float(w)), uy(0.0f, float(h));
  cv::Mat mx(48, 64, CV_32FC1), my(48, 64, CV_32FC1);
  for (int i = 0; i < 64 * 48; ++i) {
    const float x = ux(rng), y = uy(rng);
    t.src_x.push_back(x);
    t.src_y.push_back(y);
    mx.at<float>(i / 64, i % 64) = x - 0.5f;  // OpenCV: pixel centres at integers
    my.at<float>(i / 64, i % 64) = y - 0.5f;
  }
  RgbImage out = apply_remap(im, t, RemapOptions{2});
  cv::Mat src(h, w, CV_32FC3, im.rgb.data()), ref;
  cv::remap(src, ref, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  double max_diff = 0;
  for (int i = 0; i < 64 * 48; ++i)
    for (int c = 0; c < 3; ++c)
      max_diff = std::max(max_diff, double(std::abs(out.rgb[3 * i + c] - ref.at<cv::Vec3f>(i / 64, i % 64)[c])));
  // OpenCV quantises the fractions to 1/32 pixel (INTER_TAB_SIZE), so up to
  // 1/64 of the largest neighbour difference (10 here): ~0.16.
  EXPECT_LT(max_diff, 0.2);
  EXPECT_TRUE(out.valid.empty());
}

TEST(Remap, NanAndOffImageCoordinatesAreInvalidAndBlack) {
  RgbImage im = random_image(8, 8, 4);
  RemapTable t;
  t.out_width = 3;
  t.out_height = 1;
  t.src_x = {std::numeric_limits<float>::quiet_NaN(), -0.1f, 4.0f};
  t.src_y = {2.0f, 2.0f, 4.0f};
  RgbImage out = apply_remap(im, t);
  ASSERT_EQ(out.valid.size(), 3u);
  EXPECT_EQ(out.valid[0], 0);
  EXPECT_EQ(out.valid[1], 0);
  EXPECT_EQ(out.valid[2], 1);
  EXPECT_EQ(out.rgb[0], 0.0f);
  EXPECT_EQ(out.rgb[3], 0.0f);
}

TEST(Remap, InvalidSourcePixelsInvalidateOnlyOutputsThatTouchThem) {
  RgbImage im = random_image(8, 8, 5);
  im.valid.assign(64, 1);
  im.valid[3 * 8 + 3] = 0;  // pixel (3, 3)
  RemapTable t;
  t.out_width = 3;
  t.out_height = 1;
  t.src_x = {3.5f, 3.0f, 5.5f};  // exactly on (3,3); between (2,3) and (3,3); far away
  t.src_y = {2.5f, 3.5f, 3.5f};  // (3,2)-(3,3) blend: weight 0 on (3,3) at y=2.5
  RgbImage out = apply_remap(im, t);
  ASSERT_EQ(out.valid.size(), 3u);
  EXPECT_EQ(out.valid[0], 1);  // centre of (3,2): zero weight on (3,3)
  EXPECT_EQ(out.valid[1], 0);
  EXPECT_EQ(out.valid[2], 1);
}

TEST(Remap, CompiledTableForOneSizeRefusesAnother) {
  RemapTable t;
  t.out_width = 1;
  t.out_height = 1;
  t.src_x = {1.0f};
  t.src_y = {1.0f};
  CompiledRemap c = compile_remap(t, 4, 4);
  RgbImage out;
  EXPECT_THROW(apply_remap(random_image(5, 4, 6), c, &out), InputError);
}

TEST(Remap, AViewOfTheSourceGivesTheSameOutputAndAStridedOneIsRefused) {
  RgbImage im = random_image(9, 7, 7);
  im.valid.assign(63, 1);
  im.valid[20] = 0;
  im.units = Units::Radiance;
  RemapTable t;
  t.out_width = 4;
  t.out_height = 3;
  for (int i = 0; i < 12; ++i) {
    t.src_x.push_back(0.3f + 0.71f * float(i));
    t.src_y.push_back(0.6f + 0.53f * float(i));
  }
  const CompiledRemap c = compile_remap(t, 9, 7);
  RgbImage from_image, from_view;
  apply_remap(im, c, &from_image);
  apply_remap(image_view(im), c, &from_view);
  EXPECT_EQ(from_image.units, Units::Radiance);
  EXPECT_EQ(from_view.units, Units::Relative);  // a view carries pixels, not units
  EXPECT_EQ(from_view.rgb, from_image.rgb);
  EXPECT_EQ(from_view.valid, from_image.valid);
  EXPECT_FALSE(from_view.valid.empty());
  ImageView strided = image_view(im);
  strided.stride += 3;
  strided.height -= 1;
  const CompiledRemap c6 = compile_remap(t, 9, 6);
  EXPECT_THROW(apply_remap(strided, c6, &from_view), InputError);
}

TEST(Remap, TablesFromAProjectionShiftNothingAndInvalidateWhatFallsOffTheImage) {
  // A latlong 8 x 4 map through a projection that puts the azimuth on x (0..8) and every
  // upper direction at y = 1.5, into a 6 x 3 image: the table holds the projected
  // coordinates as they are, NaN below the horizon and where x > 6.
  const RemapTable t = remap_table(Layout::LatLong, 8, 4, 6, 3, [](Vec3 d) -> std::optional<std::array<double, 2>> {
    if (d.z <= 0) return std::nullopt;
    const double phi = std::atan2(d.y, d.x);
    const double u = (phi < 0 ? phi + 2 * M_PI : phi) / (2 * M_PI) * 8;  // 0..8
    return std::array<double, 2>{u, 1.5};
  });
  ASSERT_EQ(t.out_width, 8);
  ASSERT_EQ(t.out_height, 4);
  const EnvMap shape = make_latlong(8, 4);
  for (size_t i = 0; i < 32; ++i) {
    const Vec3 d = pixel_direction(shape, i);
    const double phi = std::atan2(d.y, d.x);
    const double u = (phi < 0 ? phi + 2 * M_PI : phi) / (2 * M_PI) * 8;
    if (d.z > 0 && u <= 6) {
      EXPECT_FLOAT_EQ(t.src_x[i], float(u)) << i;
      EXPECT_FLOAT_EQ(t.src_y[i], 1.5f) << i;
    } else {
      EXPECT_TRUE(std::isnan(t.src_x[i]) && std::isnan(t.src_y[i])) << i;
    }
  }
}

}  // namespace
}  // namespace lp
