#include "calib/vignetting.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "core/error.h"
#include "tests/core/test_files.h"

namespace lp {
namespace {

using Falloff = std::function<double(double x, double y)>;

// A flat field of a uniform scene seen through `falloff` (0 outside a lens's image), at
// `scale`, with relative Gaussian noise per pixel.
FlatField make_flat(int width, int height, const Falloff& falloff, double scale, double noise, unsigned seed,
                    const std::string& name = "flat.exr") {
  FlatField f;
  f.width = width;
  f.height = height;
  f.name = name;
  f.luminance.resize(size_t(width) * size_t(height));
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double v = scale * falloff(x, y);
      f.luminance[size_t(y) * size_t(width) + size_t(x)] = float(std::max(0.0, v * (1 + noise * n(rng)) + 1e-4 * n(rng)));
    }
  return f;
}

// The largest relative difference between the model and the truth within r <= reach (of the
// model's half-diagonal) from the true centre.
double worst_relative(const VignettingModel& m, const Falloff& truth, std::array<double, 2> centre, double reach) {
  double worst = 0;
  for (int y = 0; y < m.image_height; y += 3)
    for (int x = 0; x < m.image_width; x += 3) {
      if (std::hypot(x - centre[0], y - centre[1]) > reach * m.radius_px) continue;
      worst = std::max(worst, std::abs(relative_illumination(m, x, y) / truth(x, y) - 1));
    }
  return worst;
}

TEST(Vignetting, FitsAPinholeLensCosineFourthFalloffWithinATenthOfAPercent) {
  // cos^4 of the field angle, the natural vignetting of an ideal wide lens: not a
  // polynomial, so the truth is not the model's own. Focal length 1.2 half-diagonals:
  // the corners get 35 % of the centre's light.
  const int w = 640, h = 480;
  const double cx = 319.5, cy = 239.5, f = 1.2 * 400;
  const Falloff cos4 = [&](double x, double y) {
    const double t2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (f * f);
    return 1 / ((1 + t2) * (1 + t2));
  };
  const std::vector<FlatField> flats{make_flat(w, h, cos4, 0.7, 0.01, 1), make_flat(w, h, cos4, 0.4, 0.01, 2)};
  const VignettingModel m = fit_vignetting(flats);
  EXPECT_EQ(m.flats, 2);
  EXPECT_NEAR(m.centre[0], cx, 1.0);
  EXPECT_NEAR(m.centre[1], cy, 1.0);
  EXPECT_NEAR(relative_illumination(m, 0, 0), cos4(0, 0), 0.01 * cos4(0, 0));
  EXPECT_LT(worst_relative(m, cos4, {cx, cy}, 1.0), 0.001);
  EXPECT_GT(m.max_radius, 0.97);
  EXPECT_LT(m.rms_relative, 0.01);
  // Three terms (lensfun's model) cannot follow it as closely; fitted alone they start from
  // V = 1, not from the five-term fit cut short (which bent V through zero: refused).
  VignettingFitOptions three;
  three.terms = 3;
  const VignettingModel m3 = fit_vignetting(flats, three);
  EXPECT_EQ(m3.terms, 3);
  EXPECT_GT(worst_relative(m3, cos4, {cx, cy}, 1.0), 0.005);
  EXPECT_LT(worst_relative(m3, cos4, {cx, cy}, 1.0), 0.02);
}

TEST(Vignetting, FindsAFisheyeFalloffOffCentreInsideItsImageCircleDespiteDust) {
  // A fisheye's circle of 280 px, off the image centre by (12.5, -9.5) px, black outside; its
  // falloff 1 - 1.5 r^2 + 0.8 r^4 - 0.3 r^6 (0.6 at the circle's edge); three specks of dust.
  const int w = 800, h = 600;
  const double cx = 412, cy = 290, radius = 500;  // half-diagonal
  const Falloff lens = [&](double x, double y) {
    const double d = std::hypot(x - cx, y - cy);
    if (d > 280) return 0.0;
    const double r2 = d * d / (radius * radius);
    double v = 1 + r2 * (-1.5 + r2 * (0.8 - 0.3 * r2));
    for (auto [sx, sy] : {std::pair{300.0, 200.0}, std::pair{500.0, 420.0}, std::pair{420.0, 100.0}})
      if (std::hypot(x - sx, y - sy) < 8) v *= 0.75;
    return v;
  };
  const Falloff clean = [&](double x, double y) {
    const double r2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (radius * radius);
    return 1 + r2 * (-1.5 + r2 * (0.8 - 0.3 * r2));
  };
  const VignettingModel m = fit_vignetting({make_flat(w, h, lens, 0.5, 0.02, 3), make_flat(w, h, lens, 0.9, 0.02, 4)});
  EXPECT_EQ(m.centre_from, "fit");
  EXPECT_NEAR(m.centre[0], cx, 0.5);
  EXPECT_NEAR(m.centre[1], cy, 0.5);
  EXPECT_NEAR(m.max_radius, 280.0 / radius, 0.03);
  EXPECT_GT(m.blocks_dropped, 0u);  // the specks
  EXPECT_LT(worst_relative(m, clean, {cx, cy}, 270.0 / radius), 0.002);
  EXPECT_EQ(m.terms, 3);
  // Far beyond the measured circle V is not extrapolated below half of its edge's value.
  const double edge = relative_illumination(m, m.centre[0] + m.max_radius * radius, m.centre[1]);
  EXPECT_NEAR(relative_illumination(m, m.centre[0] + 480, m.centre[1]), 0.5 * edge, 1e-12);
}

TEST(Vignetting, TakesTheFewestTermsTheFlatsSupport) {
  const int w = 480, h = 360;
  const Falloff quadratic = [&](double x, double y) {
    return 1 - 0.4 * ((x - 239.5) * (x - 239.5) + (y - 179.5) * (y - 179.5)) / (300.0 * 300.0);
  };
  const VignettingModel m = fit_vignetting({make_flat(w, h, quadratic, 0.6, 0.005, 5)});
  EXPECT_EQ(m.terms, 1);
  EXPECT_NEAR(m.k[0], -0.4, 0.005);
  EXPECT_EQ(m.k[1], 0.0);
  VignettingFitOptions three;
  three.terms = 3;
  EXPECT_EQ(fit_vignetting({make_flat(w, h, quadratic, 0.6, 0.005, 5)}, three).terms, 3);
}

TEST(Vignetting, ALensWithoutFalloffIsFlatWhereverTheCentreLands) {
  const Falloff none = [](double, double) { return 1.0; };
  const VignettingModel m = fit_vignetting({make_flat(320, 240, none, 0.5, 0.02, 6)});
  EXPECT_LT(worst_relative(m, none, {159.5, 119.5}, 1.0), 0.002);
}

TEST(Vignetting, RefusesFlatsItCannotMeasure) {
  const Falloff none = [](double, double) { return 1.0; };
  FlatField clipped = make_flat(320, 240, none, 0.5, 0.0, 7, "clipped.png");
  std::fill(clipped.luminance.begin(), clipped.luminance.end(), std::numeric_limits<float>::quiet_NaN());
  EXPECT_NE(test_files::input_error([&] { fit_vignetting({clipped}); }).find("clipped.png: no block"), std::string::npos);
  const std::string sizes = test_files::input_error(
      [&] { fit_vignetting({make_flat(320, 240, none, 1, 0, 8, "a.png"), make_flat(240, 320, none, 1, 0, 9, "b.png")}); });
  EXPECT_NE(sizes.find("b.png: 240x320, but a.png is 320x240"), std::string::npos) << sizes;
  EXPECT_NE(test_files::input_error([] { fit_vignetting({}); }), "");
}

TEST(Vignetting, CorrectionDividesByTheFalloffOfWhereEachPixelWasRead) {
  VignettingModel m;
  m.image_width = 64;
  m.image_height = 48;
  m.centre = {30, 25};
  m.radius_px = 40;
  m.k = {-0.5, 0.1, 0};
  m.terms = 2;
  m.max_radius = 0.9;
  RgbImage image;
  image.width = 64;
  image.height = 48;
  image.rgb.resize(64 * 48 * 3);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x)
      for (int c = 0; c < 3; ++c) image.rgb[(size_t(y) * 64 + size_t(x)) * 3 + size_t(c)] = float((c + 1) * relative_illumination(m, x, y));
  correct_vignetting(image, m, "v.json");
  for (size_t i = 0; i < image.rgb.size(); ++i) ASSERT_NEAR(image.rgb[i], float(i % 3 + 1), 1e-5);
  // The falloff at r: 1 - 0.5 r^2 + 0.1 r^4; beyond 0.9 along its tangent there.
  EXPECT_NEAR(relative_illumination(m, 30 + 20, 25), 1 - 0.5 * 0.25 + 0.1 * 0.0625, 1e-12);
  const double edge = 1 - 0.5 * 0.81 + 0.1 * 0.6561, slope = 2 * 0.9 * (-0.5 + 2 * 0.1 * 0.81);
  EXPECT_NEAR(relative_illumination(m, 30, 25 - 40), edge + 0.1 * slope, 1e-12);

  const std::vector<float> gain = inverse_vignetting_at(m, {50.5f, std::nanf("")}, {25.5f, 3.0f});
  EXPECT_NEAR(gain[0], 1 / (1 - 0.5 * 0.25 + 0.1 * 0.0625), 1e-6);
  EXPECT_EQ(gain[1], 1.0f);

  RgbImage other = image;
  other.width = 48;
  other.height = 64;
  EXPECT_EQ(test_files::input_error([&] { correct_vignetting(other, m, "v.json"); }),
            "v.json: vignetting measured on 64x48 images, this one is 48x64");
  RgbImage codes = image;
  codes.code_bits = 8;
  EXPECT_NE(test_files::input_error([&] { correct_vignetting(codes, m, "v.json"); }), "");
}

// A model is in the sensor's frame; an image shown turned by its EXIF Orientation gets the
// model turned alike: the same V at the same sensor pixel, in all eight orientations.
TEST(Vignetting, TurnsWithAnImageShownAsItsExifOrientationSays) {
  VignettingModel m;
  m.image_width = 64;
  m.image_height = 48;
  m.centre = {20, 30};
  m.radius_px = 40;
  m.k = {-0.6, 0.1};
  m.terms = 2;
  m.max_radius = 1;
  for (int orientation = 1; orientation <= 8; ++orientation) {
    const VignettingModel shown = vignetting_as_shown(m, orientation);
    EXPECT_EQ(shown.image_width, orientation >= 5 ? 48 : 64) << orientation;
    for (const std::array<double, 2> p : {std::array<double, 2>{0, 0}, {63, 5}, {10, 47}, {40, 20}}) {
      const auto q = shown_from_stored(orientation, 64, 48, p);
      EXPECT_NEAR(relative_illumination(shown, q[0], q[1]), relative_illumination(m, p[0], p[1]), 1e-12) << orientation;
    }
  }
  EXPECT_EQ(vignetting_as_shown(m, 3).centre, (std::array<double, 2>{43, 17}));  // half a turn
}

TEST(Vignetting, TheFileRoundTripsAndAFalloffThroughZeroIsRefused) {
  const std::string dir = test_files::temp_dir("Vignetting");
  VignettingModel m;
  m.image_width = 1280;
  m.image_height = 960;
  m.centre = {641.25, 478.5};
  m.radius_px = 800;
  m.k = {-0.8, 0.3, -0.05};
  m.terms = 3;
  m.max_radius = 0.75;
  m.rms_relative = 0.002;
  m.flats = 3;
  save_vignetting(dir + "v.json", m);
  const VignettingModel back = load_vignetting(dir + "v.json");
  EXPECT_EQ(back.image_width, 1280);
  EXPECT_EQ(back.centre, m.centre);
  EXPECT_EQ(back.k, m.k);
  EXPECT_EQ(back.max_radius, m.max_radius);
  EXPECT_EQ(relative_illumination(back, 10, 20), relative_illumination(m, 10, 20));

  m.k = {-2.5, 0, 0};  // V = 1 - 2.5 r^2 is 0 at r = 0.63, inside 0.75
  save_vignetting(dir + "bad.json", m);
  EXPECT_NE(test_files::input_error([&] { load_vignetting(dir + "bad.json"); }).find("bad.json: V = "),
            std::string::npos);
  // Flats at one aperture, photos at another: said; a sixth of a stop (EXIF's rounding) or an
  // unrecorded f-number is not.
  m.f_number = 2.8;
  EXPECT_EQ(aperture_mismatch(m, 2.83, "v.json", "a.jpg"), "");
  EXPECT_EQ(aperture_mismatch(m, 0, "v.json", "a.jpg"), "");
  EXPECT_EQ(aperture_mismatch(m, 8, "v.json", "a.jpg").rfind("v.json was measured at f/2.8 and a.jpg is at f/8", 0), 0u);
  // Numbers no camera has: refused, not cast (1e12 as an int came out negative).
  const std::string good = R"("format": "lightprobe.vignetting/1", "image_height": 600, "radius_px": 500, "k": [-0.1], "max_radius": 0.5)";
  test_files::write_bytes(dir + "huge.json", "{" + good + R"(, "image_width": 1e12, "centre": [1, 2]})");
  EXPECT_EQ(test_files::input_error([&] { load_vignetting(dir + "huge.json"); }),
            dir + "huge.json: image size 1000000000000x600 is not a camera's");
  test_files::write_bytes(dir + "terms.json", "{" + good + R"(, "image_width": 800, "centre": [1, 2], "terms": 9})");
  EXPECT_NE(test_files::input_error([&] { load_vignetting(dir + "terms.json"); }).find("out of range"), std::string::npos);
  test_files::write_bytes(dir + "far.json", "{" + good + R"(, "image_width": 800, "centre": [1e9, 2]})");
  EXPECT_NE(test_files::input_error([&] { load_vignetting(dir + "far.json"); }).find("off the image"), std::string::npos);
  test_files::write_bytes(dir + "fine.json", "{" + good + R"(, "image_width": 800, "centre": [400, 300]})");
  EXPECT_EQ(load_vignetting(dir + "fine.json").terms, 1);
  test_files::write_bytes(dir + "other.json", R"({"format": "lightprobe.photometric/1"})");
  EXPECT_NE(test_files::input_error([&] { load_vignetting(dir + "other.json"); }), "");
}

}  // namespace
}  // namespace lp
