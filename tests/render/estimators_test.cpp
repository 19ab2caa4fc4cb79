// MIS and BIS at a shading point: unbiased on a constant map and on a one-pixel sun
// (mean over many seeds against the analytic answer, tolerance 4 standard errors plus
// 0.2 %), the reference integral against core/accuracy, and bad input refused.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "core/accuracy.h"
#include "core/envmap.h"
#include "core/error.h"
#include "eval/synthetic_scene.h"
#include "render/estimators.h"

namespace lp {
namespace {

EnvMap constant_map(float value) {
  EnvMap m = make_latlong(64, 32);
  std::fill(m.rgb.begin(), m.rgb.end(), value);
  return m;
}

// One pixel of radiance `value` at row v, column u of a 64 x 32 latlong map.
EnvMap sun_map(int u, int v, float value) {
  EnvMap m = make_latlong(64, 32);
  float* p = m.pixel(size_t(v) * 64 + size_t(u));
  p[0] = p[1] = p[2] = value;
  return m;
}

// Analytic integral of max(0, n.w) over latlong pixel (u, v) of a W x H map when the
// pixel is wholly above the surface: n.w is linear in w, and over the pixel
// int sin^2(t) dt [sin phi] , int sin(t)cos(t) dt [phi] have closed forms.
double cosine_over_pixel(Vec3 n, int u, int v, int w, int h) {
  const double t0 = M_PI * v / h, t1 = M_PI * (v + 1) / h, p0 = 2 * M_PI * u / w, p1 = 2 * M_PI * (u + 1) / w;
  const double s2 = (t1 - t0) / 2 - (std::sin(2 * t1) - std::sin(2 * t0)) / 4;  // int sin^2
  const double sc = (std::sin(t1) * std::sin(t1) - std::sin(t0) * std::sin(t0)) / 2;  // int sin cos
  return n.x * s2 * (std::sin(p1) - std::sin(p0)) + n.y * s2 * (std::cos(p0) - std::cos(p1)) + n.z * sc * (p1 - p0);
}

struct MeanSe {
  double mean, se;
};
MeanSe mean_over_seeds(int seeds, const std::function<double(Rng&)>& estimate) {
  double s = 0, s2 = 0;
  for (int k = 0; k < seeds; ++k) {
    Rng rng(1000 + uint64_t(k));
    const double v = estimate(rng);
    s += v;
    s2 += v * v;
  }
  const double m = s / seeds;
  return {m, std::sqrt(std::max(0.0, s2 / seeds - m * m) / seeds)};
}

double lum(const Rgb& c) { return luminance(c.data()); }

// Lobe-only BIS finds a one-pixel sun rarely (that is its weakness), so its check is
// looser and runs over more seeds; the other estimators must be within a few percent.
void expect_unbiased(const EnvDistribution& d, const ShadingPoint& p, double truth, const std::string& what,
                     int seeds = 3000) {
  const MisOptions mis{4, 4};
  const BisOptions bis{4, 8, 0.0};
  const BisOptions bis_mixed{4, 8, 0.5};
  const auto m = mean_over_seeds(seeds, [&](Rng& r) { return lum(estimate_mis(d, p, mis, r)); });
  const auto b = mean_over_seeds(seeds, [&](Rng& r) { return lum(estimate_bis(d, p, bis, r)); });
  const auto bm = mean_over_seeds(seeds, [&](Rng& r) { return lum(estimate_bis(d, p, bis_mixed, r)); });
  const auto map_only = mean_over_seeds(seeds, [&](Rng& r) { return lum(estimate_mis(d, p, {0, 8}, r)); });
  EXPECT_NEAR(m.mean, truth, 4 * m.se + 2e-3 * truth) << what << " MIS";
  EXPECT_NEAR(b.mean, truth, 4 * b.se + 2e-3 * truth) << what << " BIS";
  EXPECT_NEAR(bm.mean, truth, 4 * bm.se + 2e-3 * truth) << what << " BIS (mixed proposals)";
  EXPECT_NEAR(map_only.mean, truth, 4 * map_only.se + 2e-3 * truth) << what << " map sampling alone";
  // The tolerance must be tight enough to mean something: a few percent at most.
  // (Map sampling alone is only checked for bias: on a narrow lobe it rarely hits it.)
  EXPECT_LT(4 * std::max(m.se, bm.se), 0.08 * truth) << what;
  EXPECT_LT(4 * b.se, 0.2 * truth) << what;
}

TEST(Estimators, UnbiasedOnAConstantMap) {
  const float c = 3.0f;
  const EnvDistribution d(constant_map(c));
  const Vec3 n = normalize(Vec3{0.3, 0.2, 0.9});
  ShadingPoint lam{n, n, Brdf{LobeType::Lambertian, {0.6, 0.6, 0.6}, 0}, {}};
  expect_unbiased(d, lam, c * 0.6, "lambertian");
  for (double e : {10.0, 100.0, 1000.0}) {
    ShadingPoint gl{n, n, Brdf{LobeType::BlinnPhong, {0.9, 0.9, 0.9}, e}, {}};
    expect_unbiased(d, gl, c * 0.9 * (1 - std::pow(2.0, -(e + 1) / 2)), "blinn-phong " + std::to_string(e));
  }
}

TEST(Estimators, UnbiasedOnAOnePixelSun) {
  const int u = 10, v = 9;
  const float l = 1000.0f;
  const EnvMap m = sun_map(u, v, l);
  const EnvDistribution d(m);
  const Vec3 sun = pixel_direction(m, size_t(v) * 64 + u);
  // Lambertian facing partly towards the sun: analytic pixel integral.
  const Vec3 n = normalize(sun + Vec3{0, 0, 1});
  ShadingPoint lam{n, n, Brdf{LobeType::Lambertian, {0.5, 0.5, 0.5}, 0}, {}};
  const double truth = l * 0.5 / M_PI * cosine_over_pixel(n, u, v, 64, 32);
  EXPECT_NEAR(lum(reference_reflected(m, lam, {16})), truth, 1e-4 * truth);
  expect_unbiased(d, lam, truth, "lambertian sun", 30000);
  // Glossy, the sun inside the lobe: the reference with 32 x 32 sub-pixels is the truth.
  const Vec3 wo = normalize(2 * dot(n, sun) * n - sun + Vec3{0.05, 0, 0});
  for (double e : {10.0, 100.0}) {
    ShadingPoint gl{n, normalize(wo), Brdf{LobeType::BlinnPhong, {1, 1, 1}, e}, {}};
    const double t = lum(reference_reflected(m, gl, {32}));
    ASSERT_GT(t, 0);
    expect_unbiased(d, gl, t, "blinn-phong sun " + std::to_string(e), 30000);
  }
}

TEST(Estimators, UnbiasedOnHealpixAndHemisphereLayouts) {
  // A constant healpix sphere, and a constant hemisphere map (sky only) seen by an upward
  // normal: both reflect albedo x L.
  EnvMap healpix = make_healpix(8), hemi = make_hemisphere(72, 18);
  std::fill(healpix.rgb.begin(), healpix.rgb.end(), 1.5f);
  std::fill(hemi.rgb.begin(), hemi.rgb.end(), 1.5f);
  ShadingPoint lam{{0, 0, 1}, {0, 0, 1}, Brdf{LobeType::Lambertian, {0.6, 0.6, 0.6}, 0}, {}};
  ShadingPoint gl{{0, 0, 1}, {0, 0, 1}, Brdf{LobeType::BlinnPhong, {0.9, 0.9, 0.9}, 50}, {}};
  for (const EnvMap* m : {&healpix, &hemi}) {
    const EnvDistribution d(*m);
    expect_unbiased(d, lam, 1.5 * 0.6, describe_size(*m) + " lambertian");
    EXPECT_NEAR(lum(reference_reflected(*m, lam, {4})), 0.9, 2e-3) << describe_size(*m);
    const double truth = 1.5 * 0.9 * (1 - std::pow(2.0, -51.0 / 2));
    expect_unbiased(d, gl, truth, describe_size(*m) + " blinn-phong 50");
  }
}

TEST(Estimators, VisibilityHalvesAConstantHemisphere) {
  const EnvDistribution d(constant_map(2.0f));
  ShadingPoint p{{0, 0, 1}, {0, 0, 1}, Brdf{LobeType::Lambertian, {1, 1, 1}, 0}, [](Vec3 w) { return w.x > 0; }};
  expect_unbiased(d, p, 1.0, "half occluded");
  EXPECT_NEAR(lum(reference_reflected(d.map(), p)), 1.0, 2e-3);
}

TEST(Estimators, LambertianReferenceMatchesCoreAccuracyIrradiance) {
  const EnvMap scene = render_scene(describe_scene(), Layout::LatLong, 128, 64);
  for (Vec3 n : {Vec3{0, 0, 1}, normalize(Vec3{1, 1, 0.2}), normalize(Vec3{-0.3, 0.5, -0.8})}) {
    ShadingPoint p{n, n, Brdf{LobeType::Lambertian, {0.7, 0.7, 0.7}, 0}, {}};
    const double ours = lum(reference_reflected(scene, p));
    const double core = 0.7 / M_PI * map_irradiance(scene, n);
    EXPECT_NEAR(ours, core, 1e-4 * core);
  }
}

TEST(Estimators, GlossyReferenceConvergesWithSubdivision) {
  // The automatic subdivision is within 0.2 % of a 16 x 16 supersampled sum.
  const EnvMap scene = render_scene(describe_scene(), Layout::LatLong, 128, 64);
  const Vec3 n = normalize(Vec3{0.4, 0.2, 1});
  for (double e : {10.0, 100.0, 1000.0}) {
    ShadingPoint p{n, normalize(Vec3{-0.2, 0.3, 1}), Brdf{LobeType::BlinnPhong, {1, 1, 1}, e}, {}};
    const double fine = lum(reference_reflected(scene, p, {16})), automatic = lum(reference_reflected(scene, p));
    EXPECT_NEAR(automatic, fine, 2e-3 * fine) << e;
  }
}

TEST(Estimators, RefuseBadInput) {
  const EnvDistribution d(constant_map(1.0f));
  ShadingPoint p{{0, 0, 1}, {0, 0, 1}, Brdf{}, {}};
  Rng rng(1);
  try {
    estimate_mis(d, p, {0, 0}, rng);
    FAIL() << "zero samples accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mis"), std::string::npos) << e.what();
  }
  EXPECT_THROW(estimate_bis(d, p, {0, 8, 0}, rng), InputError);
  EXPECT_THROW(estimate_bis(d, p, {4, 0, 0}, rng), InputError);
  ShadingPoint bright = p;
  bright.brdf.albedo = {1.5, 1, 1};
  EXPECT_THROW(estimate_mis(d, bright, {4, 4}, rng), InputError);
  EXPECT_THROW(reference_reflected(d.map(), bright), InputError);
  ShadingPoint below = p;
  below.view = {0, 0, -1};
  EXPECT_THROW(estimate_bis(d, below, {4, 8, 0}, rng), InputError);
  EXPECT_THROW(EnvDistribution(make_latlong(16, 8)), InputError);  // a map of zeros
}

}  // namespace
}  // namespace lp
