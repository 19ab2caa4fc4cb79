// Reflectance lobes: densities integrate to what they should, sampling and pdf agree,
// the normalisation holds analytically, and lobes that are not normalised are refused.
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "render/brdf.h"
#include "render/rng.h"

namespace lp {
namespace {

Brdf lambert() { return Brdf{LobeType::Lambertian, {0.5, 0.5, 0.5}, 0}; }
Brdf phong(double e) { return Brdf{LobeType::BlinnPhong, {1, 1, 1}, e}; }

// Midpoint quadrature of g over the sphere, fine in theta near the lobe (theta-phi grid).
template <typename G>
double sphere_integral(G g, int nt = 2000, int np = 800) {
  double sum = 0;
  for (int i = 0; i < nt; ++i) {
    const double z0 = 1 - 2.0 * i / nt, z1 = 1 - 2.0 * (i + 1) / nt, z = 0.5 * (z0 + z1);
    const double s = std::sqrt(1 - z * z);
    for (int j = 0; j < np; ++j) {
      const double phi = 2 * M_PI * (j + 0.5) / np;
      sum += g(Vec3{s * std::cos(phi), s * std::sin(phi), z});
    }
  }
  return sum * 4 * M_PI / (double(nt) * np);
}

TEST(Brdf, LambertianPdfIntegratesToOneAndAlbedoIsExact) {
  const Vec3 n = normalize(Vec3{0.3, -0.2, 0.9}), wo = normalize(Vec3{0.1, 0.4, 0.8});
  EXPECT_NEAR(sphere_integral([&](Vec3 w) { return lobe_pdf(lambert(), n, wo, w); }), 1.0, 1e-3);
  EXPECT_NEAR(sphere_integral([&](Vec3 w) { return eval_lobe(lambert(), n, wo, w)[0]; }), 0.5, 1e-3);
}

TEST(Brdf, BlinnPhongAtNormalViewReflectsAlbedoTimesTheShareAboveTheHorizon) {
  // wo = n: wi = reflect(n, h) is above the horizon iff theta_h < 45 deg, so the integral
  // of f cos is albedo (1 - cos^(e+1)(pi/4)) = albedo (1 - 2^(-(e+1)/2)); the pdf over
  // the whole sphere integrates to 1.
  const Vec3 n{0, 0, 1};
  for (double e : {1.0, 10.0, 100.0}) {
    const Brdf b = phong(e);
    const int nt = e > 50 ? 20000 : 4000;
    EXPECT_NEAR(sphere_integral([&](Vec3 w) { return lobe_pdf(b, n, n, w); }, nt, 64), 1.0, 2e-3) << e;
    EXPECT_NEAR(sphere_integral([&](Vec3 w) { return eval_lobe(b, n, n, w)[0]; }, nt, 64), 1 - std::pow(2.0, -(e + 1) / 2),
                2e-3)
        << e;
  }
}

TEST(Brdf, SampledDirectionsFollowThePdf) {
  const Vec3 n = normalize(Vec3{0.2, 0.1, 1}), wo = normalize(Vec3{-0.5, 0.2, 0.7});
  for (const Brdf& b : {lambert(), phong(10), phong(200)}) {
    Rng rng(42);
    const int count = 200000;
    double mean_g = 0, valid = 0;
    const Vec3 axis = normalize(Vec3{1, 2, 3});
    auto g = [&](Vec3 w) { return dot(w, axis) * dot(w, axis) + w.z; };
    for (int k = 0; k < count; ++k) {
      const double u1 = rng.uniform(), u2 = rng.uniform();
      const LobeSample s = sample_lobe(b, n, wo, u1, u2);
      if (!s.valid) continue;
      valid += 1;
      ASSERT_NEAR(length(s.direction), 1.0, 1e-9);
      EXPECT_NEAR(s.pdf, lobe_pdf(b, n, wo, s.direction), 1e-9 * s.pdf);
      mean_g += g(s.direction);
    }
    // E[g(w)] over valid samples = integral of g pdf; P(valid) = integral of pdf.
    const int nt = b.exponent > 100 ? 8000 : 2000;
    const double p_valid = sphere_integral([&](Vec3 w) { return lobe_pdf(b, n, wo, w); }, nt, 800);
    const double eg = sphere_integral([&](Vec3 w) { return g(w) * lobe_pdf(b, n, wo, w); }, nt, 800);
    EXPECT_NEAR(valid / count, p_valid, 0.005) << describe(b);
    EXPECT_NEAR(mean_g / count, eg, 0.01) << describe(b);
  }
}

TEST(Brdf, RefusesLobesThatAreNotNormalised) {
  Brdf b = lambert();
  b.albedo = {1.2, 0.5, 0.5};
  try {
    validate(b);
    FAIL() << "albedo 1.2 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not normalised"), std::string::npos) << e.what();
  }
  b.albedo = {0.5, -0.1, 0.5};
  EXPECT_THROW(validate(b), InputError);
  EXPECT_THROW(validate(phong(0)), InputError);
  EXPECT_THROW(validate(phong(-3)), InputError);
  EXPECT_NO_THROW(validate(phong(1000)));
  EXPECT_EQ(describe(phong(100)), "blinn-phong-100");
}

}  // namespace
}  // namespace lp
