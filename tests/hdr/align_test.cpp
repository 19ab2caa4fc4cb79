#include "hdr/align.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/image_io.h"

namespace lp {
namespace {

const std::string kData = LIGHTPROBE_SHARED_DATA;
constexpr int kCropX = 96, kCropY = 224, kCrop = 320;  // a textured part of the memorial

// The memorial photo as rough radiance (code^2.2), full size, 3 floats per pixel.
CameraImage memorial_radiance() {
  CameraImage im = read_camera_image(kData + "/hdr-memorial-debevec/memorial0068.png");
  for (float& v : im.rgb) v = std::pow(v, 2.2f);
  return im;
}

// Bilinear sample of channel c at (x, y), edges clamped.
double sample(const CameraImage& im, double x, double y, int c) {
  x = std::clamp(x, 0.0, im.width - 1.0);
  y = std::clamp(y, 0.0, im.height - 1.0);
  const int x0 = std::min(int(x), im.width - 2), y0 = std::min(int(y), im.height - 2);
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int xx, int yy) { return double(im.rgb[(size_t(yy) * im.width + xx) * 3 + c]); };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) + fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

// One frame: radiance moved so that frame(M p) = radiance(p) (M = [R(angle) | d] about the
// full image's origin), cropped, exposed by `gain`, re-encoded (^1/2.2), quantised to 8 bits.
RgbImage make_frame(const CameraImage& radiance, double gain, double dx, double dy, double angle = 0.0) {
  const double c = std::cos(angle), s = std::sin(angle);
  RgbImage f;
  f.width = f.height = kCrop;
  f.rgb.resize(size_t(kCrop) * kCrop * 3);
  for (int y = 0; y < kCrop; ++y)
    for (int x = 0; x < kCrop; ++x) {
      // q = M p  =>  p = R^T (q - d)
      const double qx = x + kCropX - dx, qy = y + kCropY - dy;
      const double px = c * qx + s * qy, py = -s * qx + c * qy;
      for (int ch = 0; ch < 3; ++ch) {
        const double v = std::max(0.0, sample(radiance, px, py, ch)) * gain;
        const double code = std::min(1.0, std::pow(v, 1.0 / 2.2));
        f.rgb[(size_t(y) * kCrop + x) * 3 + ch] = float(std::round(code * 255.0) / 255.0);
      }
    }
  return f;
}

// Motion in the crop's coordinates of a frame made with make_frame(angle, d):
// crop(R p + d') = reference crop(p) with d' = R o + d - o, o the crop origin.
std::array<double, 2> crop_motion(double dx, double dy, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return {c * kCropX - s * kCropY + dx - kCropX, s * kCropX + c * kCropY + dy - kCropY};
}

struct Bracket3 {
  std::vector<RgbImage> frames;
  std::vector<double> times;
};

// Three exposures 1/3, 1, 3 (the middle one is the unmoved reference); the dark frame
// moves by (d0, a0), the bright one by (d2, a2).
Bracket3 bracket(double d0x, double d0y, double d2x, double d2y, double a0 = 0, double a2 = 0) {
  static const CameraImage radiance = memorial_radiance();
  Bracket3 b;
  b.frames = {make_frame(radiance, 1.0 / 3.0, d0x, d0y, a0), make_frame(radiance, 1.0, 0, 0),
              make_frame(radiance, 3.0, d2x, d2y, a2)};
  b.times = {1.0 / 3.0, 1.0, 3.0};
  return b;
}

size_t count_valid(const RgbImage& f) {
  if (f.valid.empty()) return size_t(f.width) * f.height;
  size_t n = 0;
  for (uint8_t v : f.valid) n += v ? 1 : 0;
  return n;
}

TEST(Align, TheReferenceIsTheMiddleExposure) {
  EXPECT_EQ(middle_exposure_index({0.01, 1.0, 0.1}), 2u);
  EXPECT_EQ(middle_exposure_index({4, 2, 1, 0.5}), 2u);  // the shorter of the two middle ones (1 s)
  EXPECT_EQ(middle_exposure_index({0.5}), 0u);
}

TEST(Align, MtbRecoversIntegerShiftsWithinOnePixel) {
  const Bracket3 b = bracket(7, -4, -12, 5);
  AlignReport report;
  const std::vector<RgbImage> out = align_frames(b.frames, b.times, {}, &report);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(report.reference, 1u);
  EXPECT_NEAR(report.shift_per_frame[0][0], 7, 1.0);
  EXPECT_NEAR(report.shift_per_frame[0][1], -4, 1.0);
  EXPECT_NEAR(report.shift_per_frame[2][0], -12, 1.0);
  EXPECT_NEAR(report.shift_per_frame[2][1], 5, 1.0);
  EXPECT_EQ(report.shift_per_frame[1], (std::array<double, 3>{0, 0, 0}));
  EXPECT_GE(report.seconds, 0.0);
}

TEST(Align, MtbShiftedFramesLoseExactlyTheBorderTheyShiftedOut) {
  const Bracket3 b = bracket(7, -4, -12, 5);
  AlignReport report;
  const std::vector<RgbImage> out = align_frames(b.frames, b.times, {}, &report);
  for (size_t i : {0u, 2u}) {
    const double dx = report.shift_per_frame[i][0], dy = report.shift_per_frame[i][1];
    EXPECT_EQ(count_valid(out[i]), size_t(kCrop - std::abs(dx)) * size_t(kCrop - std::abs(dy))) << i;
  }
  // Frame 0 moved right by 7: aligned(p) = frame(p + 7), so its last 7 columns are invalid.
  EXPECT_EQ(out[0].valid[size_t(100) * kCrop + kCrop - 1], 0);
  EXPECT_EQ(out[0].valid[size_t(100) * kCrop + 0], 1);
  EXPECT_EQ(count_valid(out[1]), size_t(kCrop) * kCrop);
}

TEST(Align, MtbAlignedFramesMatchTheReferenceWhereBothAreWellExposed) {
  const Bracket3 b = bracket(7, -4, -12, 5);
  const std::vector<RgbImage> out = align_frames(b.frames, b.times);
  // Bring the bright frame to the reference's exposure (code^2.2 / 3) and compare.
  double err = 0;
  size_t n = 0;
  for (size_t p = 0; p < size_t(kCrop) * kCrop; ++p) {
    if (!out[2].valid[p]) continue;
    for (int c = 0; c < 3; ++c) {
      const float bright = out[2].rgb[3 * p + c], ref = out[1].rgb[3 * p + c];
      if (bright > 0.9f || ref < 0.2f) continue;
      err += std::abs(std::pow(bright, 2.2) / 3.0 - std::pow(ref, 2.2));
      ++n;
    }
  }
  ASSERT_GT(n, 10000u);
  EXPECT_LT(err / n, 0.01);
}

TEST(Align, EccRecoversSubPixelShiftsWithinAFifthOfAPixel) {
  const Bracket3 b = bracket(2.3, -1.6, -5.7, 3.4);
  AlignOptions options;
  options.method = AlignOptions::Method::Ecc;
  AlignReport report;
  align_frames(b.frames, b.times, options, &report);
  EXPECT_TRUE(report.ecc_converged[0]);
  EXPECT_TRUE(report.ecc_converged[2]);
  EXPECT_NEAR(report.shift_per_frame[0][0], 2.3, 0.2);
  EXPECT_NEAR(report.shift_per_frame[0][1], -1.6, 0.2);
  EXPECT_NEAR(report.shift_per_frame[2][0], -5.7, 0.2);
  EXPECT_NEAR(report.shift_per_frame[2][1], 3.4, 0.2);
  EXPECT_EQ(report.shift_per_frame[0][2], 0.0);
}

TEST(Align, EccEuclideanRecoversASmallRotation) {
  const double a0 = 0.015, a2 = -0.01;
  const Bracket3 b = bracket(1.5, 2.0, -3.0, 0.5, a0, a2);
  AlignOptions options;
  options.method = AlignOptions::Method::Ecc;
  options.rotation = true;
  AlignReport report;
  align_frames(b.frames, b.times, options, &report);
  const auto m0 = crop_motion(1.5, 2.0, a0), m2 = crop_motion(-3.0, 0.5, a2);
  EXPECT_TRUE(report.ecc_converged[0]);
  EXPECT_TRUE(report.ecc_converged[2]);
  EXPECT_NEAR(report.shift_per_frame[0][2], a0, 0.001);
  EXPECT_NEAR(report.shift_per_frame[2][2], a2, 0.001);
  EXPECT_NEAR(report.shift_per_frame[0][0], m0[0], 0.2);
  EXPECT_NEAR(report.shift_per_frame[0][1], m0[1], 0.2);
  EXPECT_NEAR(report.shift_per_frame[2][0], m2[0], 0.2);
  EXPECT_NEAR(report.shift_per_frame[2][1], m2[1], 0.2);
}

TEST(Align, ZeroShiftStaysZeroForBothMethods) {
  const Bracket3 b = bracket(0, 0, 0, 0);
  AlignReport report;
  const std::vector<RgbImage> out = align_frames(b.frames, b.times, {}, &report);
  for (const auto& s : report.shift_per_frame) EXPECT_EQ(s, (std::array<double, 3>{0, 0, 0}));
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(out[i].rgb, b.frames[i].rgb) << i;
    EXPECT_EQ(count_valid(out[i]), size_t(kCrop) * kCrop) << i;
  }
  AlignOptions ecc;
  ecc.method = AlignOptions::Method::Ecc;
  align_frames(b.frames, b.times, ecc, &report);
  for (const auto& s : report.shift_per_frame) {
    EXPECT_NEAR(s[0], 0, 0.02);
    EXPECT_NEAR(s[1], 0, 0.02);
  }
}

// Debevec's Memorial frames are registered already (with pure-blue borders where they were
// moved): Mtb's coarse levels locked onto shifts of (39, 9) to (63, 63) px on the triples with
// a frame mostly black, and `hdr fuse --align mtb` refused them. Every triple 2 stops apart
// now stays put, with the borders left out of the match or not.
TEST(Align, MtbLeavesTheRegisteredMemorialFramesWhereTheyAre) {
  const double seconds[] = {32, 16, 8, 4, 2, 1, 0.5, 0.25, 0.125, 0.0625, 0.03125, 0.015625, 0.0078125, 0.00390625,
                            0.001953125, 0.0009765625};
  for (const int first : {62, 64, 66, 68, 70, 72}) {
    std::vector<RgbImage> frames;
    std::vector<double> times;
    for (int k = first; k <= first + 4; k += 2) {
      const CameraImage im = read_camera_image(kData + "/hdr-memorial-debevec/memorial00" + std::to_string(k) + ".png");
      RgbImage f;
      f.width = im.width, f.height = im.height, f.rgb = im.rgb;
      frames.push_back(std::move(f));
      times.push_back(seconds[k - 61]);
    }
    for (const bool ignore_blue : {true, false}) {
      AlignOptions o;
      if (ignore_blue) o.ignore_colour = std::array<uint8_t, 3>{0, 0, 255};
      AlignReport report;
      ASSERT_NO_THROW(align_frames(frames, times, o, &report)) << "memorial00" << first;
      for (const auto& s : report.shift_per_frame)
        EXPECT_EQ(s, (std::array<double, 3>{0, 0, 0})) << "memorial00" << first << (ignore_blue ? " ignoring blue" : "");
    }
  }
}

TEST(Align, AShiftBeyondMaxShiftIsRefused) {
  const Bracket3 b = bracket(7, -4, -12, 5);
  AlignOptions options;
  options.max_shift_px = 8;
  EXPECT_THROW(align_frames(b.frames, b.times, options), InputError);
}

// A frame of the memorial enlarged `k` times (its whole width, 2600 px of its height when
// k = 4), moved by (dx, dy) px of the enlarged frame, exposed by `gain`, 8-bit codes.
RgbImage enlarged_frame(const CameraImage& radiance, int k, double gain, double dx, double dy) {
  RgbImage f;
  f.width = radiance.width * k;
  f.height = std::min(radiance.height * k, 2600);
  f.rgb.resize(size_t(f.width) * f.height * 3);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x)
      for (int ch = 0; ch < 3; ++ch) {
        const double v = std::max(0.0, sample(radiance, (x - dx + 0.5) / k - 0.5, (y - dy + 0.5) / k - 0.5, ch)) * gain;
        f.rgb[(size_t(y) * f.width + x) * 3 + ch] = float(std::round(std::min(1.0, std::pow(v, 1.0 / 2.2)) * 255.0) / 255.0);
      }
  return f;
}

// A hand's shake is an angle: in a frame of 2048x2600 px a bracket moved 55 px, which is 27 px
// at 1280. The search reaches 2.5 % of the long side (65 px here), not a fixed 32 px, which
// refused it; 32 px asked for still refuses it.
TEST(Align, TheSearchGrowsWithTheFrame) {
  EXPECT_EQ(default_max_shift_px(320, 320), 32);
  EXPECT_EQ(default_max_shift_px(1280, 960), 32);
  EXPECT_EQ(default_max_shift_px(6000, 4000), 150);
  static const CameraImage radiance = memorial_radiance();
  const std::vector<RgbImage> frames = {enlarged_frame(radiance, 4, 1.0 / 3.0, 55, -21),
                                        enlarged_frame(radiance, 4, 1.0, 0, 0),
                                        enlarged_frame(radiance, 4, 3.0, -40, 36)};
  const std::vector<double> times = {1.0 / 3.0, 1.0, 3.0};
  AlignReport report;
  align_frames(frames, times, {}, &report);
  EXPECT_NEAR(report.shift_per_frame[0][0], 55, 1.0);
  EXPECT_NEAR(report.shift_per_frame[0][1], -21, 1.0);
  EXPECT_NEAR(report.shift_per_frame[2][0], -40, 1.0);
  EXPECT_NEAR(report.shift_per_frame[2][1], 36, 1.0);
  AlignOptions fixed;
  fixed.max_shift_px = 32;
  EXPECT_THROW(align_frames(frames, times, fixed), InputError);
}

TEST(Align, FramesOfDifferentSizesOrMissingTimesAreRefused) {
  Bracket3 b = bracket(0, 0, 0, 0);
  EXPECT_THROW(align_frames(b.frames, {1.0, 2.0}), InputError);
  EXPECT_THROW(align_frames(b.frames, {1.0, 0.0, 2.0}), InputError);
  EXPECT_THROW(align_frames({}, {}), InputError);
  b.frames[2].width = 10;
  EXPECT_THROW(align_frames(b.frames, b.times), InputError);
}

}  // namespace
}  // namespace lp
