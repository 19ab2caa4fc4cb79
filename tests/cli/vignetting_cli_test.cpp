// `calib vignetting` from flat fields, and its file divided out by `hdr fuse`, `probe unwrap`
// (and `stream`, tests/live/pipeline_test.cpp): a fisheye-like falloff measured on 8-bit sRGB
// flats makes a linear bracket of a uniform scene uniform.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <random>

#include "core/image_io.h"
#include "tests/cli/cli_run.h"
#include "tests/hdr/test_dng.h"

namespace lp::cli_test {
namespace {

constexpr int kWidth = 320, kHeight = 240;
constexpr double kCx = 165, kCy = 118, kCircle = 115, kHalfDiagonal = 200;

// The lens: V = 1 - 0.8 r^2 + 0.2 r^4 about (165, 118), r over the half-diagonal; black
// outside its image circle.
double lens(int x, int y) {
  const double d = std::hypot(x - kCx, y - kCy);
  if (d > kCircle) return 0;
  const double r2 = d * d / (kHalfDiagonal * kHalfDiagonal);
  return 1 - 0.8 * r2 + 0.2 * r2 * r2;
}

double srgb_encode(double l) { return l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1 / 2.4) - 0.055; }

// A uniform scene of `level` through the lens, as codes: sRGB 8-bit (a flat) or linear 16-bit.
void write_frame(const fs::path& path, double level, bool srgb, unsigned seed) {
  RgbImage img;
  img.width = kWidth;
  img.height = kHeight;
  img.rgb.resize(size_t(kWidth) * kHeight * 3);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.003);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const double l = std::clamp(level * lens(x, y) * (1 + noise(rng)), 0.0, 1.0);
      for (int c = 0; c < 3; ++c) img.rgb[(size_t(y) * kWidth + size_t(x)) * 3 + size_t(c)] = float(srgb ? srgb_encode(l) : l);
    }
  write_code_image(path.string(), img, srgb ? 8 : 16);
}

double green_at(const RgbImage& img, int x, int y) { return img.rgb[(size_t(y) * size_t(img.width) + size_t(x)) * 3 + 1]; }

TEST(CalibVignettingCli, FlatsGiveTheFalloffThatHdrFuseDividesOut) {
  const fs::path d = fresh_dir("vignetting");
  write_frame(d / "flat0.png", 0.6, true, 1);
  write_frame(d / "flat1.png", 0.9, true, 2);
  const CliRun fit = lightprobe("calib vignetting --json " + (d / "flat0.png").string() + " " + (d / "flat1.png").string() +
                                " -o " + (d / "v.json").string());
  ASSERT_EQ(fit.code, 0) << fit.err;
  const auto j = nlohmann::json::parse(fit.out);
  EXPECT_NEAR(j["k"][0].get<double>(), -0.8, 0.03);
  EXPECT_NEAR(j["centre"][0].get<double>(), kCx, 0.5);
  EXPECT_NEAR(j["centre"][1].get<double>(), kCy, 0.5);
  EXPECT_NEAR(j["max_radius"].get<double>(), kCircle / kHalfDiagonal, 0.03);
  EXPECT_LT(j["rms_relative"].get<double>(), 0.005);
  EXPECT_NE(slurp(d / "v.svg").find("<svg"), std::string::npos);

  // A linear 16-bit bracket of a uniform scene through the same lens.
  std::string bracket;
  for (int k = 0; k < 3; ++k) {
    const fs::path f = d / ("b" + std::to_string(k) + ".png");
    write_frame(f, 0.2 * std::pow(4.0, k), false, unsigned(10 + k));
    bracket += f.string() + " ";
  }
  bracket += "--linear --exposure-times 1,4,16 ";
  const CliRun plain = lightprobe("hdr fuse " + bracket + "-o " + (d / "plain.exr").string());
  ASSERT_EQ(plain.code, 0) << plain.err;
  const CliRun fused = lightprobe("hdr fuse " + bracket + "--vignetting " + (d / "v.json").string() + " -o " +
                                  (d / "fused.exr").string());
  ASSERT_EQ(fused.code, 0) << fused.err;
  const RgbImage before = read_rgb_image((d / "plain.exr").string()), after = read_rgb_image((d / "fused.exr").string());
  EXPECT_FALSE(before.vignetting_corrected);
  EXPECT_TRUE(after.vignetting_corrected);
  const double centre = green_at(after, int(kCx), int(kCy));
  double worst = 0;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x)
      if (std::hypot(x - kCx, y - kCy) < kCircle - 5) worst = std::max(worst, std::abs(green_at(after, x, y) / centre - 1));
  EXPECT_LT(worst, 0.015);
  // Uncorrected, the rim of the circle is a third darker.
  EXPECT_LT(green_at(before, int(kCx + 105), int(kCy)) / green_at(before, int(kCx), int(kCy)), 0.8);

  // Corrected once: unwrapping the fused probe with the file again is refused.
  const CliRun twice = lightprobe("probe unwrap " + (d / "fused.exr").string() + " --type fisheye --fov 180 --vignetting " +
                                  (d / "v.json").string() + " -o " + (d / "map.exr").string());
  expect_one_line_error(twice, "fused.exr: its vignetting is corrected already");
  EXPECT_FALSE(fs::exists(d / "map.exr"));
  // ... and a file that cannot record it is not written.
  const CliRun pfm = lightprobe("hdr fuse " + bracket + "--vignetting " + (d / "v.json").string() + " -o " +
                                (d / "fused.pfm").string());
  expect_one_line_error(pfm, "fused.pfm: cannot write: .pfm cannot record that the vignetting was corrected");
  EXPECT_FALSE(fs::exists(d / "fused.pfm"));
  // The uncorrected probe unwrapped with the file: the map is corrected and says so.
  const CliRun unwrap = lightprobe("probe unwrap " + (d / "plain.exr").string() + " --type fisheye --fov 180 --vignetting " +
                                   (d / "v.json").string() + " -o " + (d / "map.exr").string());
  ASSERT_EQ(unwrap.code, 0) << unwrap.err;
  const CliRun info = lightprobe("info --json " + (d / "map.exr").string());
  ASSERT_EQ(info.code, 0) << info.err;
  EXPECT_TRUE(nlohmann::json::parse(info.out)["vignetting_corrected"].get<bool>());
}

// `jpeg` with the APP1 Exif segment of `donor` spliced in after its SOI marker.
std::string with_exif_of(const std::string& jpeg, const std::string& donor) {
  size_t at = 2;
  while (at + 4 < donor.size() && uint8_t(donor[at]) == 0xFF) {
    const size_t length = size_t(uint8_t(donor[at + 2])) << 8 | uint8_t(donor[at + 3]);
    if (uint8_t(donor[at + 1]) == 0xE1 && donor.compare(at + 4, 4, "Exif") == 0)
      return jpeg.substr(0, 2) + donor.substr(at, 2 + length) + jpeg.substr(2);
    at += 2 + length;
  }
  ADD_FAILURE() << "no Exif segment";
  return jpeg;
}

// Vignetting changes with the aperture: the flats' f-number (EXIF) is kept, and a photo taken
// at another is corrected with a warning that says so.
TEST(CalibVignettingCli, TheFlatsApertureIsKeptAndAnotherApertureIsWarnedAbout) {
  const fs::path d = fresh_dir("vignetting_aperture");
  std::vector<float> rgb(size_t(kWidth) * kHeight * 3);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x)
      for (int c = 0; c < 3; ++c) rgb[(size_t(y) * kWidth + size_t(x)) * 3 + size_t(c)] = float(0.7 * lens(x, y));
  write_display_image((d / "plain.jpg").string(), kWidth, kHeight, rgb);  // sRGB-encoded
  // A real phone photo's EXIF: f/1.8.
  std::ofstream(d / "flat.jpg", std::ios::binary)
      << with_exif_of(slurp(d / "plain.jpg"), slurp(shared("hdr-mirrorball-kartik/ball_1-10s.jpg")));
  const CliRun fit = lightprobe("calib vignetting --json " + (d / "flat.jpg").string() + " -o " + (d / "v.json").string());
  ASSERT_EQ(fit.code, 0) << fit.err;
  EXPECT_NEAR(nlohmann::json::parse(fit.out)["f_number"].get<double>(), 1.8, 1e-6);
  const std::string unwrap = "probe unwrap " + (d / "flat.jpg").string() + " --type fisheye --fov 180 -o " +
                             (d / "map.exr").string() + " --vignetting ";
  const CliRun same = lightprobe(unwrap + (d / "v.json").string());
  ASSERT_EQ(same.code, 0) << same.err;
  EXPECT_EQ(same.err.find("aperture"), std::string::npos) << same.err;
  // The same file as if measured at f/8.
  auto v8 = nlohmann::json::parse(slurp(d / "v.json"));
  v8["f_number"] = 8.0;
  std::ofstream(d / "v8.json") << v8.dump(2);
  const CliRun other = lightprobe(unwrap + (d / "v8.json").string());
  ASSERT_EQ(other.code, 0) << other.err;
  EXPECT_NE(other.err.find("v8.json was measured at f/8 and " + (d / "flat.jpg").string() + " is at f/1.8"),
            std::string::npos)
      << other.err;
}

// A RAW flat, the best kind (linear, before any in-camera correction): read as the sensor
// stored it, its f-number from the file, and its clipped highlights left out.
TEST(CalibVignettingCli, ARawFlatIsReadLinearAsStored) {
  const fs::path d = fresh_dir("vignetting_raw");
  std::vector<uint16_t> codes;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      // A speck of clipped light, which must not count as the lens's.
      const double l = std::hypot(x - 120, y - 100) < 6 ? 1.0 : 0.5 * lens(x, y);
      for (int c = 0; c < 3; ++c) codes.push_back(uint16_t(std::lround(l * 65535)));
    }
  // Tagged upside down: LibRaw would show it turned, moving the centre to (154, 121).
  write_test_dng(d, "flat.dng", kWidth, kHeight, codes, 100, 56, 100, 3);
  const CliRun fit = lightprobe("calib vignetting --json " + (d / "flat.dng").string() + " -o " + (d / "v.json").string());
  ASSERT_EQ(fit.code, 0) << fit.err;
  const auto j = nlohmann::json::parse(fit.out);
  EXPECT_NEAR(j["f_number"].get<double>(), 5.6, 1e-6);
  EXPECT_NEAR(j["k"][0].get<double>(), -0.8, 0.01);
  EXPECT_NEAR(j["centre"][0].get<double>(), kCx, 0.3);
  EXPECT_NEAR(j["centre"][1].get<double>(), kCy, 0.3);
}

// A Mono12 camera's flat saved as 16-bit: its codes stop at 4095, where a bright speck clips.
// Read at that white level, as probe unwrap reads such frames: the speck is clipped, not a
// level, and the falloff is the lens's.
TEST(CalibVignettingCli, ASixteenBitFlatOfATwelveBitSensorIsReadAtItsWhiteLevel) {
  const fs::path d = fresh_dir("vignetting_mono12");
  RgbImage img;
  img.width = kWidth;
  img.height = kHeight;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const double level = std::hypot(x - 120, y - 100) < 6 ? 1.0 : 0.6 * lens(x, y);  // 12-bit codes
      const float code = float(std::round(level * 4095) / 65535);
      img.rgb.insert(img.rgb.end(), {code, code, code});
    }
  write_code_image((d / "mono12.png").string(), img, 16);
  const CliRun r = lightprobe("calib vignetting --json --codes linear " + (d / "mono12.png").string() + " -o " +
                              (d / "v.json").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("read as a 12-bit sensor's codes"), std::string::npos) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j["k"][0].get<double>(), -0.8, 0.01);
  EXPECT_NEAR(j["centre"][0].get<double>(), kCx, 0.3);
}

// Uneven light across a single flat looks like a falloff about another centre: said.
TEST(CalibVignettingCli, AFlatLitFromOneSideIsWarnedAbout) {
  const fs::path d = fresh_dir("vignetting_uneven");
  RgbImage img;
  img.width = kWidth;
  img.height = kHeight;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const double r2 = (std::pow(x - 159.5, 2) + std::pow(y - 119.5, 2)) / (kHalfDiagonal * kHalfDiagonal);
      const double l = 0.5 * (1 - 0.5 * r2) * (1 + 0.2 * (double(x) / kWidth - 0.5));  // 20 % across
      img.rgb.insert(img.rgb.end(), {float(l), float(l), float(l)});
    }
  write_code_image((d / "side.png").string(), img, 16);
  const CliRun r = lightprobe("calib vignetting --codes linear " + (d / "side.png").string() + " -o " + (d / "v.json").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("from the image's: light that is not even across the flats looks like this"), std::string::npos)
      << r.err;
  // The same lens evenly lit says nothing.
  for (size_t i = 0; i < img.rgb.size(); i += 3) {
    const double x = double((i / 3) % size_t(kWidth));
    const float even = float(img.rgb[i] / (1 + 0.2 * (x / kWidth - 0.5)));
    img.rgb[i] = img.rgb[i + 1] = img.rgb[i + 2] = even;
  }
  write_code_image((d / "even.png").string(), img, 16);
  const CliRun e = lightprobe("calib vignetting --codes linear " + (d / "even.png").string() + " -o " + (d / "e.json").string());
  ASSERT_EQ(e.code, 0) << e.err;
  EXPECT_EQ(e.err.find("warning"), std::string::npos) << e.err;
}

TEST(CalibVignettingCli, RefusesWhatItCannotMeasureOrApply) {
  const fs::path d = fresh_dir("vignetting_refused");
  write_frame(d / "white.png", 50.0, true, 3);  // every code at the top
  expect_one_line_error(lightprobe("calib vignetting " + (d / "white.png").string() + " -o " + (d / "v.json").string()),
                        "white.png: no block of the image can be measured");
  write_frame(d / "sixteen.png", 0.5, false, 4);
  expect_one_line_error(lightprobe("calib vignetting " + (d / "sixteen.png").string() + " -o " + (d / "v.json").string()),
                        "sixteen.png: 16-bit camera codes may be linear");
  EXPECT_FALSE(fs::exists(d / "v.json"));
  expect_one_line_error(lightprobe("calib vignetting " + (d / "sixteen.png").string() + " --codes linear -o " +
                                   (d / "v.svg").string()),
                        "its picture is written beside it as .svg");

  // Measured on this camera, applied to another's bracket: refused before the merge.
  const CliRun fit = lightprobe("calib vignetting --codes linear " + (d / "sixteen.png").string() + " -o " +
                                (d / "v.json").string());
  ASSERT_EQ(fit.code, 0) << fit.err;
  const std::string memorial = shared("hdr-memorial-debevec/memorial00");
  expect_one_line_error(lightprobe("hdr fuse " + memorial + "61.png " + memorial + "62.png " + memorial +
                                   "63.png --exposure-times 32,16,8 --vignetting " + (d / "v.json").string() + " -o " +
                                   (d / "m.exr").string()),
                        "vignetting measured on 320x240 images, this one is 512x768");
  EXPECT_FALSE(fs::exists(d / "m.exr"));
}

}  // namespace
}  // namespace lp::cli_test
