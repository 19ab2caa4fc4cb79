// CCT from white-balance gains, against black bodies computed two ways: the Kim et al.
// spline the library uses, and an independent integration of Planck's law against the
// CIE 1931 colour-matching functions (the analytic multi-lobe fit of Wyman, Sloan and
// Shirley 2013, good to ~1 % of the tabulated functions).
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "estimate/white_balance_cct.h"

namespace lp {
namespace {

double lobe(double lambda, double mu, double s1, double s2) {
  const double t = (lambda - mu) / (lambda < mu ? s1 : s2);
  return std::exp(-0.5 * t * t);
}

// Black-body chromaticity by numerical integration, 360..830 nm in 1 nm steps.
Chromaticity planck_integrated_xy(double t) {
  constexpr double c2 = 1.4387769e-2;  // m K
  double X = 0, Y = 0, Z = 0;
  for (double l = 360; l <= 830; l += 1) {
    const double lm = l * 1e-9;
    const double b = 1 / (std::pow(lm, 5) * (std::exp(c2 / (lm * t)) - 1));
    X += b * (1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7) - 0.065 * lobe(l, 501.1, 20.4, 26.2));
    Y += b * (0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1));
    Z += b * (1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8));
  }
  return {X / (X + Y + Z), Y / (X + Y + Z)};
}

// What an ideal auto white balance reports under a light of this chromaticity.
std::array<double, 3> gains_under(Chromaticity xy) { return wb_gains_for_illuminant(rgb_of_chromaticity(xy)); }

double cct_from_gains(const std::array<double, 3>& gains) {
  return cct_robertson(chromaticity_of_rgb(illuminant_from_wb_gains(gains, "test"))).kelvin;
}

TEST(WhiteBalanceCct, PlanckianSplineMatchesIntegratedBlackBody) {
  for (double t = 2500; t <= 10000; t += 500) {
    const Chromaticity a = planckian_xy(t), b = planck_integrated_xy(t);
    EXPECT_NEAR(a.x, b.x, 0.003) << t;
    EXPECT_NEAR(a.y, b.y, 0.003) << t;
  }
  // A tabulated point of the locus: CIE illuminant A (2856 K) x = 0.44757, y = 0.40745; the
  // spline is good to ~1e-3 there (it gives 0.44707, 0.40745).
  EXPECT_NEAR(planckian_xy(2856).x, 0.44757, 0.001);
  EXPECT_NEAR(planckian_xy(2856).y, 0.40745, 0.001);
}

// Stated tolerance: 0.5 % of T over 2500-10000 K for gains of the library's locus
// (Robertson's table against Kim's spline), 2 % for the independently integrated black body.
TEST(WhiteBalanceCct, RecoversBlackBodyTemperatureFromGains) {
  double worst = 0, worst_independent = 0;
  for (double t = 2500; t <= 10000; t += 250) {
    const auto gains = gains_under(planckian_xy(t));
    EXPECT_NEAR(gains[1], 1.0, 1e-12);
    const double got = cct_from_gains(gains);
    worst = std::max(worst, std::fabs(got / t - 1));
    EXPECT_NEAR(got, t, 0.005 * t) << t;
    const double got_indep = cct_from_gains(gains_under(planck_integrated_xy(t)));
    worst_independent = std::max(worst_independent, std::fabs(got_indep / t - 1));
    EXPECT_NEAR(got_indep, t, 0.02 * t) << t;
    // Black bodies lie on the locus: Duv ~ 0.
    EXPECT_LT(std::fabs(cct_robertson(planckian_xy(t)).duv), 0.001) << t;
  }
  RecordProperty("worst_relative_error_spline", std::to_string(worst));
  RecordProperty("worst_relative_error_integrated", std::to_string(worst_independent));
}

TEST(WhiteBalanceCct, McCamyAgreesInItsRange) {
  for (double t = 2856; t <= 6504; t += 200) EXPECT_NEAR(cct_mccamy(planckian_xy(t)), t, 0.01 * t) << t;
  // D65 (x 0.3127, y 0.3290) is 6504 K by McCamy, ~6500 K by Robertson.
  EXPECT_NEAR(cct_robertson({0.3127, 0.3290}).kelvin, 6504, 30);
}

TEST(WhiteBalanceCct, GreenLightIsFarFromTheLocus) {
  const CctEstimate c = cct_robertson(chromaticity_of_rgb({0.2, 1.0, 0.2}));
  EXPECT_GT(c.duv, 0.02);
  const CctEstimate m = cct_robertson(chromaticity_of_rgb({1.0, 0.2, 1.0}));
  EXPECT_LT(m.duv, -0.02);
}

TEST(WhiteBalanceCct, BadGainsAreInputErrors) {
  EXPECT_THROW(illuminant_from_wb_gains({0.0, 1.0, 1.5}, "f.jsonl:3"), InputError);
  EXPECT_THROW(illuminant_from_wb_gains({NAN, 1.0, 1.5}, "f.jsonl:3"), InputError);
  try {
    illuminant_from_wb_gains({-1.0, 1.0, 1.5}, "f.jsonl:3");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("f.jsonl:3"), std::string::npos);
  }
}

TEST(WhiteBalanceCct, ChromaticityRoundTrip) {
  const Chromaticity xy{0.40, 0.39};
  const Chromaticity back = chromaticity_of_rgb(rgb_of_chromaticity(xy));
  EXPECT_NEAR(back.x, xy.x, 1e-6);  // the two published matrices are inverse to ~7 digits
  EXPECT_NEAR(back.y, xy.y, 1e-6);
  const auto d65 = rgb_of_chromaticity({0.3127, 0.3290});
  EXPECT_NEAR(d65[0], 1.0, 2e-3);
  EXPECT_NEAR(d65[2], 1.0, 2e-3);
}

}  // namespace
}  // namespace lp
