// The merge's vector kernel (hdr/merge_kernel.cpp) on every Highway target compiled into it
// and supported by this CPU, against the scalar loop (MergeOptions::simd = false): the same
// image bit for bit, the same report and flags.
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "hdr/merge.h"
#include "hdr/merge_kernel.h"
#include "tests/hdr/synthetic_bracket.h"

namespace lp {
namespace {

// Random 8-bit codes, with whole pixels and single channels clipped or black in every frame
// (the kernel hands those back to the scalar fallback), pixels black in the long frame and
// clipped in the short one, and a few codes outside [0, 1] (negative, above 1, infinite, NaN:
// level 0 or the top level, as the scalar loop has them).
Bracket random_bracket(int width, int height, size_t frames, std::mt19937& rng) {
  Bracket b;
  std::uniform_int_distribution<int> code(0, 255), kind(0, 99), channel(0, 2);
  for (size_t k = 0; k < frames; ++k) {
    RgbImage f;
    f.width = width;
    f.height = height;
    f.rgb.resize(3 * size_t(width) * size_t(height));
    b.frames.push_back(std::move(f));
    // Not powers of two: products with the frame factors must round (a fused multiply-add or
    // another order of operations then shows in the last bit).
    b.exposure_seconds.push_back(std::pow(3.7, double(k)) / 60.0);
  }
  const float odd[] = {-0.25f, 1.5f, std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN()};
  for (size_t p = 0; p < size_t(width) * size_t(height); ++p) {
    const int what = kind(rng);
    const int c = channel(rng);
    for (size_t k = 0; k < frames; ++k)
      for (int ch = 0; ch < 3; ++ch) {
        float v = float(code(rng)) / 255.0f;
        if (what < 4) v = 1.0f;                                     // clipped everywhere
        else if (what < 8) v = 0.0f;                                // black everywhere
        else if (what < 12 && ch == c) v = 1.0f;                    // one channel clipped everywhere
        else if (what < 16 && ch == c) v = 0.0f;                    // one channel black everywhere
        else if (what < 20 && ch == c) v = k == 0 ? 0.0f : 1.0f;    // black short, clipped long
        else if (what < 22 && ch == c) v = odd[size_t(code(rng)) % 4];
        b.frames[k].rgb[3 * p + size_t(ch)] = v;
      }
  }
  return b;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// First index where two images differ in their bits, for the failure message.
std::string first_difference(const std::vector<float>& a, const std::vector<float>& b) {
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    if (std::memcmp(&a[i], &b[i], sizeof(float)) != 0)
      return "float " + std::to_string(i) + ": " + std::to_string(a[i]) + " vs " + std::to_string(b[i]);
  return "sizes " + std::to_string(a.size()) + " vs " + std::to_string(b.size());
}

TEST(MergeKernel, EveryTargetEqualsTheScalarLoopBitForBit) {
  std::mt19937 rng(23);
  const std::vector<int64_t> targets = hwy::SupportedAndGeneratedTargets();
  // On x86-64 at least the scalar fallback and SSSE3: a list of one would test nothing.
  ASSERT_GE(targets.size(), 2u);
  for (const int64_t t : targets) std::printf("[ merge kernel ] target %s\n", hwy::TargetName(t));
  // Every target, and AVX3 also without its VBMI path where the CPU takes that path.
  std::vector<std::pair<int64_t, bool>> variants;
  for (const int64_t t : targets) {
    variants.emplace_back(t, true);
    if ((t == HWY_AVX3 || t == HWY_AVX3_DL) && detail::merge_vbmi_supported()) variants.emplace_back(t, false);
  }
  std::printf("[ merge kernel ] VBMI byte permutes on AVX3: %s\n", detail::merge_vbmi_supported() ? "yes, tested too" : "no");
  CameraResponse s_curve = test::true_response(test::film_curve());
  // Three different channels (the tables are per channel; a kernel that read another
  // channel's table would pass with three equal ones).
  CameraResponse per_channel = s_curve;
  for (size_t z = 0; z < 256; ++z) {
    per_channel.log_exposure[1][z] = 1.3f * s_curve.log_exposure[1][z];
    per_channel.log_exposure[2][z] = 0.7f * s_curve.log_exposure[2][z] + 0.01f * float(z % 5);
  }
  const CameraResponse responses[] = {linear_response(256), s_curve, per_channel, linear_response(1024)};
  const MergeOptions::Weighting weightings[] = {MergeOptions::Weighting::Hat, MergeOptions::Weighting::HatTimesExposure,
                                                MergeOptions::Weighting::NoiseAware};
  // Widths around every vector length (4, 8, 16 floats per vector; 1 for the scalar target):
  // full groups, tails, and rows shorter than one group.
  // 64 pixels per block of the VBMI kernel: blocks, blocks with a tail of vectors and of pixels.
  const int widths[] = {1, 3, 5, 16, 17, 31, 64, 67, 160, 211};
  size_t cases = 0, redone = 0;
  for (const int width : widths)
    for (size_t r = 0; r < 4; ++r)
      for (const auto weighting : weightings) {
        const Bracket b = random_bracket(width, 5, 2 + (cases % 3), rng);
        MergeOptions o;
        o.weighting = weighting;
        o.exposure_weighting = (cases % 4) != 3;  // also the legacy switch
        o.flag_image = (cases % 2) == 0;  // with a flag image and without (the kernel counts as vectors)
        o.threads = 1 + int(cases % 2);
        o.simd = false;
        MergeReport scalar_report;
        const RgbImage scalar = merge_bracket(b, responses[r], o, &scalar_report);
        redone += scalar_report.saturated_everywhere + scalar_report.black_everywhere;
        o.simd = true;
        for (const auto& [target, vbmi] : variants) {
          hwy::SetSupportedTargetsForTest(target);
          detail::set_merge_vbmi_for_test(vbmi);
          // The dispatch really took this target.
          ASSERT_STREQ(detail::merge_simd_target(), hwy::TargetName(target));
          MergeReport report;
          const RgbImage vec = merge_bracket(b, responses[r], o, &report);
          detail::set_merge_vbmi_for_test(true);
          const std::string where = std::string(hwy::TargetName(target)) + (vbmi ? "" : " without VBMI") + ", width " + std::to_string(width) +
                                    ", response " + std::to_string(r) + ", weighting " +
                                    std::to_string(int(weighting));
          EXPECT_TRUE(same_bits(vec.rgb, scalar.rgb)) << where << ": " << first_difference(vec.rgb, scalar.rgb);
          EXPECT_EQ(vec.valid, scalar.valid) << where;
          EXPECT_EQ(report.flags, scalar_report.flags) << where;
          EXPECT_EQ(report.saturated_everywhere, scalar_report.saturated_everywhere) << where;
          EXPECT_EQ(report.black_everywhere, scalar_report.black_everywhere) << where;
          EXPECT_EQ(report.well_exposed, scalar_report.well_exposed) << where;
        }
        hwy::SetSupportedTargetsForTest(0);
        ++cases;
      }
  // The fallback pixels the kernel hands back were there to hand back.
  EXPECT_GT(redone, 100u);
}

// A bracket of real shape (the benchmark's sky ramp over four decades, 3 frames; a third of
// its pixels clipped or black in every frame) on every target: the same bits and report.
TEST(MergeKernel, SkyRampOnEveryTargetEqualsTheScalarLoop) {
  Bracket b;
  const int w = 333, h = 40;
  for (double t : {0.0005, 0.004, 0.032}) {
    RgbImage f;
    f.width = w;
    f.height = h;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          const double radiance = std::pow(10.0, 4.0 * x / w) * (1.0 + 0.2 * (y % 7));
          f.rgb.push_back(float(std::round(std::min(1.0, radiance * t * (0.8 + 0.2 * c) / 40.0) * 255) / 255));
        }
    b.frames.push_back(std::move(f));
    b.exposure_seconds.push_back(t);
  }
  const CameraResponse response = linear_response(256);
  MergeOptions o;
  o.simd = false;
  MergeReport scalar_report;
  const RgbImage scalar = merge_bracket(b, response, o, &scalar_report);
  o.simd = true;
  // Every target: whole vectors of codes black or clipped in a frame, whose table reads the
  // kernel skips, are common here (the ramp's ends in each frame).
  for (const int64_t target : hwy::SupportedAndGeneratedTargets())
    for (const bool vbmi : {true, false}) {
      hwy::SetSupportedTargetsForTest(target);
      detail::set_merge_vbmi_for_test(vbmi);
      MergeReport report;
      const RgbImage vec = merge_bracket(b, response, o, &report);
      detail::set_merge_vbmi_for_test(true);
      EXPECT_TRUE(same_bits(vec.rgb, scalar.rgb)) << hwy::TargetName(target) << (vbmi ? "" : " without VBMI") << ": " << first_difference(vec.rgb, scalar.rgb);
      EXPECT_EQ(report.well_exposed, scalar_report.well_exposed);
      EXPECT_EQ(report.saturated_everywhere, scalar_report.saturated_everywhere);
      EXPECT_EQ(report.black_everywhere, scalar_report.black_everywhere);
    }
  hwy::SetSupportedTargetsForTest(0);
  EXPECT_EQ(scalar_report.well_exposed, 8818u);  // of 13 320: the fallback's pixels are many
}

// merge_bracket into a reused image (hdr/merge.h) leaves nothing of the image's last use:
// stale values (NaN here), a stale valid mask, another size. The same bits, mask and report
// as a new image, on the vector kernel and the scalar loop.
TEST(MergeKernel, IntoAReusedImageEqualsANewOne) {
  std::mt19937 rng(7);
  const CameraResponse response = linear_response(256);
  for (const bool simd : {true, false}) {
    MergeOptions o;
    o.simd = simd;
    o.flag_image = true;
    RgbImage out;
    out.width = 3;
    out.height = 2;
    out.rgb.assign(3 * 6, std::numeric_limits<float>::quiet_NaN());
    out.valid.assign(6, 0);
    out.units = Units::Radiance;
    for (const int width : {67, 67, 35}) {  // the same size twice, then another
      const Bracket b = random_bracket(width, 9, 3, rng);
      MergeReport fresh_report, report;
      const RgbImage fresh = merge_bracket(b, response, o, &fresh_report);
      merge_bracket(bracket_view(b), response, o, &out, &report);
      EXPECT_EQ(out.width, fresh.width);
      EXPECT_EQ(out.height, fresh.height);
      EXPECT_EQ(out.units, Units::Relative);
      EXPECT_TRUE(same_bits(out.rgb, fresh.rgb)) << "simd " << simd << ", width " << width << ": "
                                                 << first_difference(out.rgb, fresh.rgb);
      EXPECT_TRUE(out.valid.empty());
      EXPECT_EQ(report.flags, fresh_report.flags);
      EXPECT_EQ(report.well_exposed, fresh_report.well_exposed);
      EXPECT_GT(report.saturated_everywhere, 0u);  // the kernel's counts were exercised
      EXPECT_EQ(report.saturated_everywhere, fresh_report.saturated_everywhere);
      EXPECT_EQ(report.black_everywhere, fresh_report.black_everywhere);
      std::fill(out.rgb.begin(), out.rgb.end(), std::numeric_limits<float>::quiet_NaN());
      out.valid.assign(out.rgb.size() / 3, 0);
    }
  }
}

// 8-bit brackets as read_bracket makes them: random codes (0 and 255 common: whole pixels and
// single channels clipped or black in every frame, black in the short frame and clipped in the
// long ones), the frames code * (1 / 255.f) as read_camera_image converts them, and the codes
// kept in Bracket::codes straight from the bytes (not through keep_8bit_codes).
Bracket random_8bit_bracket(int width, int height, size_t frames, std::mt19937& rng) {
  Bracket b;
  std::uniform_int_distribution<int> code(0, 255), kind(0, 99), channel(0, 2);
  const size_t n = 3 * size_t(width) * size_t(height);
  for (size_t k = 0; k < frames; ++k) {
    RgbImage f;
    f.width = width;
    f.height = height;
    f.rgb.resize(n);
    b.frames.push_back(std::move(f));
    b.codes.emplace_back(n);
    b.exposure_seconds.push_back(std::pow(3.7, double(k)) / 60.0);
  }
  for (size_t p = 0; p < size_t(width) * size_t(height); ++p) {
    const int what = kind(rng);
    const int c = channel(rng);
    for (size_t k = 0; k < frames; ++k)
      for (int ch = 0; ch < 3; ++ch) {
        int v = code(rng);
        if (what < 4) v = 255;
        else if (what < 8) v = 0;
        else if (what < 12 && ch == c) v = 255;
        else if (what < 16 && ch == c) v = 0;
        else if (what < 20 && ch == c) v = k == 0 ? 0 : 255;
        else if (what < 24 && ch == c) v = code(rng) % 2 ? 1 : 254;  // next to the ends
        b.codes[k][3 * p + size_t(ch)] = uint8_t(v);
        b.frames[k].rgb[3 * p + size_t(ch)] = float(v) * (1.0f / 255.0f);
      }
  }
  return b;
}

// The float path's level of code k / 255 is k (how read_camera_image divides, and the plain
// division), so the codes can stand in for the floats; odd values get the scalar loop's ends.
TEST(MergeCodes, KeepsEvery8BitCodeAsItsOwnLevel) {
  Bracket b;
  for (int k = 0; k < 2; ++k) {
    RgbImage f;
    f.width = 256 + 4;
    f.height = 1;
    for (int code = 0; code < 256; ++code) {
      f.rgb.push_back(float(code) * (1.0f / 255.0f));
      f.rgb.push_back(float(code) / 255.0f);
      f.rgb.push_back(float(double(code) / 255.0));
    }
    for (float odd : {-0.25f, 1.5f, std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN(),
                      -std::numeric_limits<float>::infinity(), 0.4999f / 255.0f, 254.5001f / 255.0f, -0.0f,
                      0.5001f / 255.0f, 1.0f / 510.0f - 1e-9f, 100.0f, std::numeric_limits<float>::max()})
      f.rgb.push_back(odd);
    b.frames.push_back(std::move(f));
  }
  keep_8bit_codes(b);
  ASSERT_EQ(b.codes.size(), 2u);
  ASSERT_EQ(b.codes[0].size(), 3u * 260u);
  for (int code = 0; code < 256; ++code)
    for (int form = 0; form < 3; ++form) EXPECT_EQ(b.codes[0][size_t(3 * code + form)], code) << "form " << form;
  const std::vector<uint8_t> odd(b.codes[0].begin() + 768, b.codes[0].end());
  EXPECT_EQ(odd, (std::vector<uint8_t>{0, 255, 255, 0, 0, 0, 255, 0, 1, 0, 255, 255}));
}

// The merge reading 8-bit codes (BracketView::codes) gives the float path's image, flags and
// counts bit for bit: the scalar loop, every Highway target, AVX3 with and without VBMI; row
// widths that are no multiple of 64 (the VBMI blocks), 16 or 8 (the vectors).
TEST(MergeCodes, EveryTargetGivesTheFloatPathsImageBitForBit) {
  std::mt19937 rng(2023);
  std::vector<std::pair<int64_t, bool>> variants;
  for (const int64_t t : hwy::SupportedAndGeneratedTargets()) {
    variants.emplace_back(t, true);
    if ((t == HWY_AVX3 || t == HWY_AVX3_DL) && detail::merge_vbmi_supported()) variants.emplace_back(t, false);
  }
  ASSERT_GE(variants.size(), 2u);
  CameraResponse per_channel = test::true_response(test::film_curve());
  for (size_t z = 0; z < 256; ++z) {
    per_channel.log_exposure[1][z] = 1.3f * per_channel.log_exposure[1][z];
    per_channel.log_exposure[2][z] = 0.7f * per_channel.log_exposure[2][z] + 0.01f * float(z % 5);
  }
  const CameraResponse responses[] = {linear_response(256), per_channel};
  const int widths[] = {1, 7, 17, 63, 65, 131, 200, 333};
  size_t cases = 0, flagged = 0;
  for (const int width : widths)
    for (const CameraResponse& response : responses) {
      Bracket with_codes = random_8bit_bracket(width, 6, 2 + cases % 3, rng);
      Bracket floats = with_codes;
      floats.codes.clear();
      // NaN floats (level 0) beside the codes: the same image only if every pixel's codes are read.
      for (RgbImage& f : with_codes.frames) std::fill(f.rgb.begin(), f.rgb.end(), std::numeric_limits<float>::quiet_NaN());
      MergeOptions o;
      o.flag_image = cases % 2 == 0;
      o.threads = 1 + int(cases % 2);
      o.weighting = cases % 3 == 0 ? MergeOptions::Weighting::Hat : MergeOptions::Weighting::NoiseAware;
      o.simd = false;
      MergeReport ref_report;
      const RgbImage ref = merge_bracket(floats, response, o, &ref_report);
      flagged += ref_report.saturated_everywhere + ref_report.black_everywhere;
      auto expect_same = [&](const std::string& where, const MergeOptions& options) {
        MergeReport report;
        const RgbImage img = merge_bracket(with_codes, response, options, &report);
        EXPECT_TRUE(same_bits(img.rgb, ref.rgb)) << where << ", width " << width << ": " << first_difference(img.rgb, ref.rgb);
        EXPECT_EQ(report.flags, ref_report.flags) << where << ", width " << width;
        EXPECT_EQ(report.saturated_everywhere, ref_report.saturated_everywhere) << where;
        EXPECT_EQ(report.black_everywhere, ref_report.black_everywhere) << where;
        EXPECT_EQ(report.well_exposed, ref_report.well_exposed) << where;
      };
      expect_same("scalar loop", o);
      o.simd = true;
      for (const auto& [target, vbmi] : variants) {
        hwy::SetSupportedTargetsForTest(target);
        detail::set_merge_vbmi_for_test(vbmi);
        ASSERT_STREQ(detail::merge_simd_target(), hwy::TargetName(target));
        expect_same(std::string(hwy::TargetName(target)) + (vbmi ? "" : " without VBMI"), o);
        detail::set_merge_vbmi_for_test(true);
      }
      hwy::SetSupportedTargetsForTest(0);
      ++cases;
    }
  EXPECT_GT(flagged, 100u);  // the unweighted channels' bounds and flags were exercised
}

// Rows whose codes in a frame all fall in one half of the 256-entry tables (a dark or a bright
// stretch of a scene), which the VBMI kernel reads with half its permutes (its sums' tables
// and the bounds' tables), and rows in both halves: every target gives the scalar loop's
// image and report bit for bit.
TEST(MergeCodes, RowsInOneHalfOfTheTablesOnEveryTargetEqualTheScalarLoop) {
  std::mt19937 rng(77);
  const CameraResponse response = test::true_response(test::film_curve());
  size_t cases = 0;
  for (const int width : {64, 128, 200}) {
    const int height = 12;
    const size_t frames = 2 + size_t(width) % 3;
    Bracket b = random_8bit_bracket(width, height, frames, rng);
    for (size_t k = 0; k < frames; ++k)
      for (int y = 0; y < height; ++y) {
        const int half = int(rng() % 3);  // 0: levels 0-127, 1: 128-255, 2: as drawn
        for (size_t i = 3 * size_t(y) * size_t(width); i < 3 * size_t(y + 1) * size_t(width); ++i) {
          const int v = b.codes[k][i];
          b.codes[k][i] = uint8_t(half == 0 ? v / 2 : half == 1 ? 128 + v / 2 : v);
        }
      }
    for (const auto weighting : {MergeOptions::Weighting::Hat, MergeOptions::Weighting::NoiseAware}) {
      MergeOptions o;
      o.weighting = weighting;
      o.flag_image = true;
      o.simd = false;
      MergeReport ref_report;
      const RgbImage ref = merge_bracket(b, response, o, &ref_report);
      o.simd = true;
      for (const int64_t target : hwy::SupportedAndGeneratedTargets()) {
        hwy::SetSupportedTargetsForTest(target);
        MergeReport report;
        const RgbImage img = merge_bracket(b, response, o, &report);
        EXPECT_TRUE(same_bits(img.rgb, ref.rgb)) << hwy::TargetName(target) << ", width " << width << ": " << first_difference(img.rgb, ref.rgb);
        EXPECT_EQ(report.flags, ref_report.flags) << hwy::TargetName(target);
        EXPECT_EQ(report.saturated_everywhere, ref_report.saturated_everywhere);
        EXPECT_EQ(report.black_everywhere, ref_report.black_everywhere);
        EXPECT_EQ(report.well_exposed, ref_report.well_exposed);
      }
      hwy::SetSupportedTargetsForTest(0);
      ++cases;
      EXPECT_GT(ref_report.saturated_everywhere + ref_report.black_everywhere, 0u);  // bounds were read
    }
  }
  EXPECT_EQ(cases, 6u);
}

// The scalar loop's other paths read the codes too (ignore_colour, frame masks, valid masks),
// and a response of another size reads the floats: the same image as without codes.
TEST(MergeCodes, MaskedIgnoredAndOtherLevelCountsGiveTheFloatPathsImage) {
  std::mt19937 rng(5);
  Bracket with_codes = random_8bit_bracket(67, 9, 3, rng);
  Bracket floats = with_codes;
  floats.codes.clear();
  // NaN floats beside the codes at 256 levels: the same image only if the codes are read.
  Bracket nan_floats = with_codes;
  for (RgbImage& f : nan_floats.frames) std::fill(f.rgb.begin(), f.rgb.end(), std::numeric_limits<float>::quiet_NaN());
  MergeOptions o;
  o.ignore_colour = std::array<uint8_t, 3>{255, 255, 255};
  o.frame_masks.assign(3, std::vector<uint8_t>(67 * 9, 1));
  for (size_t i = 0; i < o.frame_masks[1].size(); i += 3) o.frame_masks[1][i] = 0;
  o.flag_image = true;
  for (const int levels : {256, 1024}) {
    for (const bool masks : {false, true}) {
      MergeOptions m = o;
      if (!masks) m.frame_masks.clear();
      MergeReport a, b;
      const RgbImage x = merge_bracket(levels == 256 ? nan_floats : with_codes, linear_response(levels), m, &a);
      const RgbImage y = merge_bracket(floats, linear_response(levels), m, &b);
      EXPECT_TRUE(same_bits(x.rgb, y.rgb)) << levels << " levels, masks " << masks << ": " << first_difference(x.rgb, y.rgb);
      EXPECT_EQ(x.valid, y.valid);
      EXPECT_EQ(a.flags, b.flags);
      EXPECT_GT(a.ignored, 0u);  // white in every frame: the clipped pixels
      EXPECT_EQ(a.ignored, b.ignored);
      EXPECT_EQ(a.no_frame, b.no_frame);
      EXPECT_EQ(a.well_exposed, b.well_exposed);
    }
  }
  // A view whose codes do not match its frames in number is refused.
  BracketView v = bracket_view(with_codes);
  ASSERT_EQ(v.codes.size(), 3u);
  v.codes.pop_back();
  EXPECT_THROW(merge_bracket(v, linear_response(256)), InputError);
  Bracket short_codes = with_codes;
  short_codes.codes[2].pop_back();
  EXPECT_THROW(merge_bracket(short_codes, linear_response(256)), InputError);
}

}  // namespace
}  // namespace lp
