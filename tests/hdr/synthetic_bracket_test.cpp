#include "hdr/synthetic_bracket.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"
#include "hdr/hdr_accuracy.h"

namespace lp {
namespace {

const std::string kData = LIGHTPROBE_SHARED_DATA;

RgbImage grace() { return read_rgb_image(kData + "/probes-probulator-latlong256/grace.hdr"); }

RgbImage flat(int w, int h, float value) {
  RgbImage image;
  image.width = w;
  image.height = h;
  image.rgb.assign(size_t(w) * h * 3, value);
  return image;
}

TEST(SyntheticBracket, NoiseFreeLinearBracketMergedByTheLongestUnsaturatedFrameReproducesTheTruth) {
  const RgbImage truth = grace();
  SyntheticBracketOptions options;
  options.add_noise = false;
  const auto bracket = make_synthetic_bracket(truth, options);
  ASSERT_EQ(bracket.frames.size(), 3u);
  const double half_level = 0.5 / 255.0;

  RgbImage estimate = flat(truth.width, truth.height, 0.0f);
  size_t checked = 0, saturated_everywhere = 0, black = 0;
  for (size_t p = 0; p < size_t(truth.width) * truth.height; ++p) {
    int best = -1;
    for (size_t f = 0; f < bracket.frames.size(); ++f) {
      const float* z = &bracket.frames[f].rgb[3 * p];
      if (std::max({z[0], z[1], z[2]}) < 1.0f &&
          (best < 0 || bracket.exposure_seconds[f] > bracket.exposure_seconds[size_t(best)]))
        best = int(f);
    }
    if (best < 0) {
      ++saturated_everywhere;
      estimate.rgb[3 * p] = estimate.rgb[3 * p + 1] = estimate.rgb[3 * p + 2] = NAN;
      continue;
    }
    const double gain = bracket.exposure_scale * bracket.exposure_seconds[size_t(best)];
    for (int c = 0; c < 3; ++c) {
      const double L = bracket.frames[size_t(best)].rgb[3 * p + c] / gain;
      estimate.rgb[3 * p + c] = float(L);
      // Quantisation error: half a code level at this frame's exposure (float rounding aside).
      ASSERT_NEAR(L, truth.rgb[3 * p + c], half_level / gain * 1.0001 + 1e-6 * truth.rgb[3 * p + c]) << "pixel " << p;
    }
    black += luminance(estimate.rgb[3 * p], estimate.rgb[3 * p + 1], estimate.rgb[3 * p + 2]) == 0.0f &&
             luminance(truth.rgb[3 * p], truth.rgb[3 * p + 1], truth.rgb[3 * p + 2]) > 0.0f;
    ++checked;
  }
  EXPECT_GT(checked, 0.99 * truth.width * truth.height);
  // The same in the measure of CONVENTIONS.md: pixels saturated in every frame (NaN here)
  // and pixels too dark for the longest frame (code 0) are reported, not hidden.
  const HdrError error = hdr_log_error(estimate, truth);
  EXPECT_EQ(error.pixels_invalid, saturated_everywhere + black);
  EXPECT_LT(error.median_log10, 0.005);
  EXPECT_NEAR(error.global_scale, 1.0, 0.01);
}

TEST(SyntheticBracket, NoisyDefaultBracketOfARealMapMergesToAFewPercentInLog10Luminance) {
  // Default options: 1/64, 1/8, 1 s, linear, 8 bits, 10000 e- full well, 2 e- read noise.
  const RgbImage truth = grace();
  const auto bracket = make_synthetic_bracket(truth, {});
  RgbImage estimate = truth;
  for (size_t p = 0; p < size_t(truth.width) * truth.height; ++p) {
    int best = -1;
    for (size_t f = 0; f < bracket.frames.size(); ++f) {
      const float* z = &bracket.frames[f].rgb[3 * p];
      if (std::max({z[0], z[1], z[2]}) < 0.95f &&
          (best < 0 || bracket.exposure_seconds[f] > bracket.exposure_seconds[size_t(best)]))
        best = int(f);
    }
    const double gain = best < 0 ? 0.0 : bracket.exposure_scale * bracket.exposure_seconds[size_t(best)];
    for (int c = 0; c < 3; ++c)
      estimate.rgb[3 * p + c] = best < 0 ? NAN : float(bracket.frames[size_t(best)].rgb[3 * p + c] / gain);
  }
  const HdrError e = hdr_log_error(estimate, truth);
  ::testing::Test::RecordProperty("median_log10", std::to_string(e.median_log10));
  ::testing::Test::RecordProperty("p95_log10", std::to_string(e.p95_log10));
  EXPECT_LT(e.median_log10, 0.01);
  EXPECT_LT(e.p95_log10, 0.05);
  EXPECT_GT(e.median_log10, 0.0);  // noise is there
  EXPECT_NEAR(e.global_scale, 1.0, 0.01);
  EXPECT_LT(e.pixels_invalid, size_t(truth.width) * truth.height / 20);
}

TEST(SyntheticBracket, AutomaticExposurePutsTheMedianAtEighteenPercentInTheMiddleFrame) {
  const RgbImage truth = grace();
  SyntheticBracketOptions options;
  options.add_noise = false;
  options.bit_depth = 16;
  const auto bracket = make_synthetic_bracket(truth, options);
  std::vector<float> lum;
  const RgbImage& mid = bracket.frames[1];
  for (size_t p = 0; p < size_t(mid.width) * mid.height; ++p)
    lum.push_back(luminance(mid.rgb[3 * p], mid.rgb[3 * p + 1], mid.rgb[3 * p + 2]));
  std::nth_element(lum.begin(), lum.begin() + lum.size() / 2, lum.end());
  EXPECT_NEAR(lum[lum.size() / 2], 0.18, 0.001);
  EXPECT_EQ(bracket.reference_frame, 1);
}

TEST(SyntheticBracket, TrueLogExposureInvertsTheResponse) {
  SyntheticBracketOptions options;
  options.add_noise = false;
  options.exposure_scale = 2.0;
  for (ResponseCurve curve : {ResponseCurve::Linear, ResponseCurve::Gamma22, ResponseCurve::SCurve, ResponseCurve::Custom}) {
    options.response = curve;
    options.custom_response = {0.0, 0.5, 0.8, 1.0};
    // A flat grey scene of 0.1 at t = 1: X = 0.2.
    const auto bracket = make_synthetic_bracket(flat(4, 4, 0.1f), options);
    ASSERT_EQ(bracket.true_log_exposure[0].size(), 256u);
    for (size_t f = 0; f < 3; ++f) {
      const int z = int(std::lround(bracket.frames[f].rgb[0] * 255));
      if (z <= 0 || z >= 255) continue;
      // Perfect merge: exp(g(z)) / t returns the radiance, within the level's width.
      const double L = std::exp(bracket.true_log_exposure[1][size_t(z)]) / bracket.exposure_seconds[f];
      const double L_up = std::exp(bracket.true_log_exposure[1][size_t(z) + 1]) / bracket.exposure_seconds[f];
      const double L_down = std::exp(bracket.true_log_exposure[1][size_t(z) - 1]) / bracket.exposure_seconds[f];
      EXPECT_GE(0.1, 0.5 * (L + L_down) * 0.9999) << int(curve) << " frame " << f;
      EXPECT_LE(0.1, 0.5 * (L + L_up) * 1.0001) << int(curve) << " frame " << f;
    }
    for (size_t k = 1; k < 256; ++k) ASSERT_GT(bracket.true_log_exposure[2][k], bracket.true_log_exposure[2][k - 1]);
  }
  EXPECT_NEAR(apply_response(options, invert_response(options, 0.37)), 0.37, 1e-12);
  options.response = ResponseCurve::SCurve;
  EXPECT_NEAR(apply_response(options, 1.0), 1.0, 1e-12);
  EXPECT_NEAR(invert_response(options, apply_response(options, 0.05)), 0.05, 1e-12);
}

TEST(SyntheticBracket, ShakeShiftsFramesByExactlyTheRecordedPixels) {
  const RgbImage truth = grace();
  SyntheticBracketOptions options;
  options.exposure_seconds = {1 / 8., 1 / 8., 1 / 8., 1 / 8., 1 / 8.};
  options.add_noise = false;
  options.shake_px = 6;
  options.seed = 77;
  const auto bracket = make_synthetic_bracket(truth, options);
  ASSERT_EQ(bracket.true_shift_px.size(), 5u);
  EXPECT_EQ(bracket.reference_frame, 2);
  EXPECT_EQ(bracket.true_shift_px[2][0], 0.0);
  EXPECT_EQ(bracket.true_shift_px[2][1], 0.0);
  int moved = 0;
  const RgbImage& ref = bracket.frames[2];
  const int W = ref.width, H = ref.height;
  for (size_t f = 0; f < 5; ++f) {
    const int dx = int(bracket.true_shift_px[f][0]), dy = int(bracket.true_shift_px[f][1]);
    EXPECT_LE(std::abs(dx), 6);
    EXPECT_LE(std::abs(dy), 6);
    moved += dx != 0 || dy != 0;
    // Recover the shift by brute force: the translation with the smallest difference.
    double best = 1e300;
    int best_dx = 99, best_dy = 99;
    for (int ty = -6; ty <= 6; ++ty)
      for (int tx = -6; tx <= 6; ++tx) {
        double sum = 0;
        for (int y = 6; y < H - 6; ++y)
          for (int x = 6; x < W - 6; ++x)
            for (int c = 0; c < 3; ++c) {
              const double d = bracket.frames[f].rgb[3 * (size_t(y + ty) * W + x + tx) + c] - ref.rgb[3 * (size_t(y) * W + x) + c];
              sum += d * d;
            }
        if (sum < best) {
          best = sum;
          best_dx = tx;
          best_dy = ty;
        }
      }
    EXPECT_EQ(best_dx, dx) << "frame " << f;
    EXPECT_EQ(best_dy, dy) << "frame " << f;
    EXPECT_EQ(best, 0.0) << "frame " << f;  // same exposure, no noise: identical content
  }
  EXPECT_GE(moved, 3);
  // Deterministic: the same seed gives the same bits, another seed other shifts.
  const auto again = make_synthetic_bracket(truth, options);
  EXPECT_EQ(again.frames[4].rgb, bracket.frames[4].rgb);
  options.seed = 78;
  EXPECT_NE(make_synthetic_bracket(truth, options).true_shift_px, bracket.true_shift_px);
}

TEST(SyntheticBracket, NoiseHasTheShotAndReadVarianceOfTheSensor) {
  SyntheticBracketOptions options;
  options.exposure_seconds = {1.0};
  options.exposure_scale = 1.0;
  options.bit_depth = 16;
  options.full_well_electrons = 10000;
  options.read_noise_electrons = 2;
  const auto bracket = make_synthetic_bracket(flat(200, 100, 0.25f), options);  // 2500 e-
  double sum = 0, sum2 = 0;
  const auto& z = bracket.frames[0].rgb;
  for (float v : z) {
    sum += v;
    sum2 += double(v) * v;
  }
  const double n = double(z.size());
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.25, 0.0003);
  EXPECT_NEAR(sd, std::sqrt(2500.0 + 4.0) / 10000.0, 0.0002);  // 0.0050
}

TEST(SyntheticBracket, AMovingObjectCrossesTheFramesAndSitsInTheTruthAtTheReference) {
  SyntheticBracketOptions options;
  options.add_noise = false;
  options.moving_object = true;
  options.object_radiance = 0.5;
  options.exposure_scale = 1.0;
  const auto bracket = make_synthetic_bracket(flat(64, 32, 0.01f), options);
  ASSERT_EQ(bracket.object_rect.size(), 3u);
  EXPECT_EQ(bracket.object_rect[0][2], 4);  // height / 8
  EXPECT_LT(bracket.object_rect[0][0], bracket.object_rect[1][0]);
  EXPECT_LT(bracket.object_rect[1][0], bracket.object_rect[2][0]);
  for (size_t f = 0; f < 3; ++f) {
    const auto& r = bracket.object_rect[f];
    const size_t inside = 3 * (size_t(r[1] + 1) * 64 + r[0] + 1);
    const double expected = std::min(1.0, 0.5 * bracket.exposure_seconds[f]);
    EXPECT_NEAR(bracket.frames[f].rgb[inside], expected, 0.5 / 255 + 1e-6) << "frame " << f;
  }
  const auto& r = bracket.object_rect[1];
  EXPECT_FLOAT_EQ(bracket.true_radiance.rgb[3 * (size_t(r[1]) * 64 + r[0])], 0.5f);
  EXPECT_FLOAT_EQ(bracket.true_radiance.rgb[3 * (size_t(r[1]) * 64 + bracket.object_rect[0][0])], 0.01f);
}

TEST(SyntheticBracket, BadOptionsAndImagesAreRejected) {
  const RgbImage image = flat(8, 8, 0.2f);
  auto rejects = [&](SyntheticBracketOptions o, const RgbImage& img) {
    try {
      make_synthetic_bracket(img, o);
    } catch (const InputError&) {
      return true;
    }
    return false;
  };
  SyntheticBracketOptions o;
  o.bit_depth = 10;
  EXPECT_TRUE(rejects(o, image));
  o = {};
  o.exposure_seconds = {};
  EXPECT_TRUE(rejects(o, image));
  o = {};
  o.exposure_seconds = {0.1, -1};
  EXPECT_TRUE(rejects(o, image));
  o = {};
  o.response = ResponseCurve::Custom;
  o.custom_response = {0.0, 0.6, 0.5, 1.0};
  EXPECT_TRUE(rejects(o, image));
  RgbImage bad = image;
  bad.rgb[5] = NAN;
  EXPECT_TRUE(rejects({}, bad));
  EXPECT_TRUE(rejects({}, flat(8, 8, 0.0f)));  // median 0, automatic scale
  EXPECT_FALSE(rejects({}, image));
}

}  // namespace
}  // namespace lp
