// The environment map as a distribution: the pdf integrates to 1, sample and pdf agree,
// and sample histograms match the pdf (chi-square, fixed seed) per pixel and inside pixels.
#include <gtest/gtest.h>

#include <cmath>

#include "core/envmap.h"
#include "core/error.h"
#include "render/env_distribution.h"
#include "render/rng.h"

namespace lp {
namespace {

// Deterministic, strongly varying radiance: a few pixels 100x brighter, some black.
void fill_varied(EnvMap& m) {
  Rng rng(99);
  for (size_t i = 0; i < m.pixel_count(); ++i) {
    const double u = rng.uniform();
    const float v = u < 0.1 ? 0.0f : u < 0.15 ? 100.0f * float(u) : float(u);
    m.pixel(i)[0] = v;
    m.pixel(i)[1] = 0.5f * v;
    m.pixel(i)[2] = 2.0f * v;
  }
}

std::vector<EnvMap> varied_maps() {
  std::vector<EnvMap> maps{make_latlong(32, 16), make_hemisphere(36, 9), make_healpix(4)};
  for (EnvMap& m : maps) fill_varied(m);
  return maps;
}

double chi_square_threshold(int dof) {
  // Wilson-Hilferty: the 0.999 quantile of chi-square with dof degrees of freedom.
  const double z = 3.09, k = dof;
  return k * std::pow(1 - 2 / (9 * k) + z * std::sqrt(2 / (9 * k)), 3);
}

TEST(EnvDistribution, PdfIntegratesToOneOverTheLayout) {
  for (const EnvMap& m : varied_maps()) {
    const EnvDistribution d(m);
    double sum = 0, psum = 0;
    for (size_t i = 0; i < m.pixel_count(); ++i) {
      sum += d.pdf(pixel_direction(m, i)) * pixel_solid_angle(m, i);
      psum += d.pixel_probability(i);
    }
    EXPECT_NEAR(sum, 1.0, 1e-9) << describe_size(m);
    EXPECT_NEAR(psum, 1.0, 1e-12);
    // Independently: Monte Carlo over uniform directions on the sphere, E[pdf] * 4 pi = 1.
    Rng rng(5);
    double mc = 0;
    const int n = 200000;
    for (int k = 0; k < n; ++k) {
      const double z = 1 - 2 * rng.uniform(), phi = 2 * M_PI * rng.uniform(), s = std::sqrt(1 - z * z);
      mc += d.pdf({s * std::cos(phi), s * std::sin(phi), z});
    }
    EXPECT_NEAR(mc / n * 4 * M_PI, 1.0, 0.03) << describe_size(m);
  }
}

TEST(EnvDistribution, SampledPdfEqualsPdfAndTheSampleLiesInItsPixel) {
  for (const EnvMap& m : varied_maps()) {
    const EnvDistribution d(m);
    Rng rng(11);
    int mismatched = 0;
    for (int k = 0; k < 20000; ++k) {
      const EnvSample s = d.sample(rng.uniform3());
      ASSERT_NEAR(length(s.direction), 1.0, 1e-12);
      ASSERT_GT(s.pdf, 0);
      const auto pix = pixel_at(m, s.direction);
      ASSERT_TRUE(pix.has_value());
      if (*pix != s.pixel) {
        ++mismatched;  // only on a pixel boundary (rounding)
        continue;
      }
      EXPECT_NEAR(d.pdf(s.direction), s.pdf, 1e-12 * s.pdf);
      EXPECT_EQ(s.radiance[0], double(m.pixel(s.pixel)[0]));
    }
    EXPECT_LE(mismatched, 2) << describe_size(m);
  }
}

TEST(EnvDistribution, PixelHistogramPassesChiSquare) {
  for (const EnvMap& m : varied_maps()) {
    const EnvDistribution d(m);
    std::vector<double> count(m.pixel_count(), 0.0);
    Rng rng(2024);
    const int n = 200000;
    for (int k = 0; k < n; ++k) count[*pixel_at(m, d.sample(rng.uniform3()).direction)] += 1;
    double chi2 = 0;
    int dof = -1;
    for (size_t i = 0; i < m.pixel_count(); ++i) {
      const double expected = n * d.pixel_probability(i);
      if (expected == 0) {
        EXPECT_EQ(count[i], 0) << "black pixel " << i << " drawn";
        continue;
      }
      chi2 += (count[i] - expected) * (count[i] - expected) / expected;
      ++dof;
    }
    EXPECT_LT(chi2, chi_square_threshold(dof)) << describe_size(m) << " dof " << dof;
  }
}

// Inside a pixel the direction is uniform in solid angle: sample a coarse map and count
// on a finer one whose pixels split the coarse ones (2 x 2 for latlong, the 4 NESTED
// children for healpix); expected counts are P(coarse) x fine / coarse solid angle.
TEST(EnvDistribution, WithinPixelDirectionsAreUniformInSolidAngle) {
  std::vector<std::pair<EnvMap, EnvMap>> pairs{{make_latlong(16, 8), make_latlong(32, 16)},
                                               {make_healpix(2), make_healpix(4)},
                                               {make_hemisphere(12, 4), make_hemisphere(24, 8)}};
  for (auto& [coarse, fine] : pairs) {
    fill_varied(coarse);
    const EnvDistribution d(coarse);
    std::vector<double> count(fine.pixel_count(), 0.0);
    Rng rng(7);
    const int n = 300000;
    for (int k = 0; k < n; ++k) count[*pixel_at(fine, d.sample(rng.uniform3()).direction)] += 1;
    double chi2 = 0;
    int dof = -1;
    for (size_t j = 0; j < fine.pixel_count(); ++j) {
      const Vec3 c = pixel_direction(fine, j);
      const size_t parent = *pixel_at(coarse, c);
      const double expected = n * d.pixel_probability(parent) * pixel_solid_angle(fine, j) / pixel_solid_angle(coarse, parent);
      if (expected == 0) continue;
      chi2 += (count[j] - expected) * (count[j] - expected) / expected;
      ++dof;
    }
    EXPECT_LT(chi2, chi_square_threshold(dof)) << describe_size(fine) << " dof " << dof;
  }
}

TEST(EnvDistribution, ConstantMapIsUniformAcrossPhiZeroAndThePoles) {
  for (EnvMap m : {make_latlong(64, 32), make_healpix(8)}) {
    std::fill(m.rgb.begin(), m.rgb.end(), 2.0f);
    const EnvDistribution d(m);
    for (Vec3 w : {Vec3{1, 0, 0}, Vec3{1, -1e-9, 0}, Vec3{0, 0, 1}, Vec3{0, 0, -1}, normalize(Vec3{1, 1e-7, 0.9})})
      EXPECT_NEAR(d.pdf(w), 1 / (4 * M_PI), 1e-9) << describe_size(m);
  }
}

TEST(EnvDistribution, UniformShareGivesDarkPixelsTheirShare) {
  EnvMap m = make_latlong(32, 16);
  m.pixel(100)[0] = m.pixel(100)[1] = m.pixel(100)[2] = 5.0f;
  const EnvDistribution exact(m), mixed(m, {0.1});
  const Vec3 dark = pixel_direction(m, 300), bright = pixel_direction(m, 100);
  EXPECT_EQ(exact.pdf(dark), 0.0);
  EXPECT_NEAR(mixed.pdf(dark), 0.1 / (4 * M_PI), 1e-12);
  EXPECT_NEAR(mixed.pdf(bright), 0.9 / pixel_solid_angle(m, 100) + 0.1 / (4 * M_PI), 1e-9);
  // Pixel 100 is the only light: every draw of the exact distribution lands there.
  Rng rng(3);
  for (int k = 0; k < 100; ++k) EXPECT_EQ(exact.sample(rng.uniform3()).pixel, 100u);
}

TEST(EnvDistribution, InvalidPixelsAreNeverDrawn) {
  EnvMap m = make_latlong(32, 16);
  std::fill(m.rgb.begin(), m.rgb.end(), 1.0f);
  m.valid.assign(m.pixel_count(), 1);
  for (size_t i = 0; i < m.pixel_count() / 2; ++i) m.valid[i] = 0;  // the upper half is unknown
  const EnvDistribution d(m, {0.2});
  Rng rng(1);
  for (int k = 0; k < 2000; ++k) EXPECT_LT(d.sample(rng.uniform3()).direction.z, 1e-12);
  EXPECT_EQ(d.pdf({0, 0, 1}), 0.0);
  EXPECT_NEAR(d.pdf({0, 0, -1}), 1 / (2 * M_PI), 1e-9);
}

TEST(EnvDistribution, RejectsBlackAndBrokenMaps) {
  EnvMap black = make_latlong(16, 8);
  try {
    EnvDistribution d(black);
    FAIL() << "a black map was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("black"), std::string::npos) << e.what();
  }
  EXPECT_THROW(EnvDistribution(black, {0.5}), InputError);
  EnvMap nan = make_latlong(16, 8);
  std::fill(nan.rgb.begin(), nan.rgb.end(), 1.0f);
  nan.pixel(3)[1] = NAN;
  EXPECT_THROW(EnvDistribution{nan}, InputError);
  EnvMap ok = make_latlong(16, 8);
  std::fill(ok.rgb.begin(), ok.rgb.end(), 1.0f);
  EXPECT_THROW(EnvDistribution(ok, {1.5}), InputError);
}

}  // namespace
}  // namespace lp
