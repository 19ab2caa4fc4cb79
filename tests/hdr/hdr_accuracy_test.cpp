#include "hdr/hdr_accuracy.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"

namespace lp {
namespace {

const std::string kData = LIGHTPROBE_SHARED_DATA;

RgbImage pisa() { return read_rgb_image(kData + "/probes-probulator-latlong256/pisa.hdr"); }

TEST(HdrAccuracy, IdenticalImagesHaveNoError) {
  const RgbImage truth = pisa();
  const HdrError e = hdr_log_error(truth, truth);
  EXPECT_EQ(e.median_log10, 0.0);
  EXPECT_EQ(e.p95_log10, 0.0);
  EXPECT_EQ(e.global_scale, 1.0);
  EXPECT_EQ(e.pixels_invalid, 0u);
  // Pisa's lat-long has black pixels where the probe saw nothing: no log, counted apart.
  EXPECT_GT(e.pixels_truth_dark, 0u);
  EXPECT_EQ(e.pixels_compared + e.pixels_truth_dark, size_t(truth.width) * truth.height);
}

TEST(HdrAccuracy, AConstantFactorIsRemovedByTheGlobalScale) {
  const RgbImage truth = pisa();
  RgbImage estimate = truth;
  for (float& v : estimate.rgb) v *= 2.0f;
  const HdrError e = hdr_log_error(estimate, truth);
  EXPECT_NEAR(e.median_log10, 0.0, 1e-12);
  EXPECT_NEAR(e.p95_log10, 0.0, 1e-6);
  EXPECT_NEAR(e.global_scale, 0.5, 1e-6);
}

TEST(HdrAccuracy, PixelsOffByAFactorOfTwoShowAsLog10OfTwoInTheTail) {
  const RgbImage truth = pisa();
  RgbImage estimate = truth;
  const size_t n = size_t(truth.width) * truth.height;
  // Every fifth pixel twice too bright (20 %): the median ratio stays 1, the 95th
  // percentile is exactly the error of those pixels.
  for (size_t p = 0; p < n; p += 5)
    for (int c = 0; c < 3; ++c) estimate.rgb[3 * p + c] *= 2.0f;
  const HdrError e = hdr_log_error(estimate, truth);
  EXPECT_EQ(e.global_scale, 1.0);
  EXPECT_EQ(e.median_log10, 0.0);
  EXPECT_NEAR(e.p95_log10, std::log10(2.0), 1e-6);
}

TEST(HdrAccuracy, InvalidEstimatePixelsAreCountedNotHidden) {
  const RgbImage truth = pisa();
  RgbImage estimate = truth;
  estimate.rgb[0] = std::numeric_limits<float>::quiet_NaN();
  estimate.rgb[30] = std::numeric_limits<float>::infinity();
  for (int c = 0; c < 3; ++c) estimate.rgb[300 + c] = 0.0f;  // pixel 100 black
  estimate.valid.assign(size_t(truth.width) * truth.height, 1);
  estimate.valid[200] = 0;
  const HdrError e = hdr_log_error(estimate, truth);
  EXPECT_EQ(e.pixels_invalid, 4u);
  EXPECT_EQ(e.pixels_compared + e.pixels_truth_dark, size_t(truth.width) * truth.height - 4);
  EXPECT_EQ(e.median_log10, 0.0);
}

TEST(HdrAccuracy, AMaskLimitsTheComparison) {
  const RgbImage truth = pisa();
  RgbImage estimate = truth;
  const size_t n = size_t(truth.width) * truth.height;
  std::vector<uint8_t> mask(n, 1);
  // A ruined border (as a registration border would be) masked out entirely.
  for (int y = 0; y < truth.height; ++y)
    for (int x = 0; x < 8; ++x) {
      const size_t p = size_t(y) * truth.width + x;
      mask[p] = 0;
      estimate.rgb[3 * p] = std::numeric_limits<float>::quiet_NaN();
      estimate.rgb[3 * p + 1] *= 100.0f;
    }
  const HdrError e = hdr_log_error(estimate, truth, mask);
  EXPECT_EQ(e.pixels_invalid, 0u);
  EXPECT_EQ(e.pixels_compared + e.pixels_truth_dark, n - size_t(8 * truth.height));
  EXPECT_EQ(e.p95_log10, 0.0);
  // Without the mask the border's NaNs are invalid (its black truth pixels are not compared).
  const HdrError unmasked = hdr_log_error(estimate, truth);
  EXPECT_GT(unmasked.pixels_invalid, 0u);
  EXPECT_EQ(unmasked.pixels_invalid + (unmasked.pixels_truth_dark - e.pixels_truth_dark), size_t(8 * truth.height));
}

TEST(HdrAccuracy, MismatchedSizesAreAnInputError) {
  const RgbImage truth = pisa();
  RgbImage small;
  small.width = 2;
  small.height = 1;
  small.rgb.assign(6, 1.0f);
  EXPECT_THROW(hdr_log_error(small, truth), InputError);
  EXPECT_THROW(hdr_log_error(truth, truth, std::vector<uint8_t>(3, 1)), InputError);
}

}  // namespace
}  // namespace lp
