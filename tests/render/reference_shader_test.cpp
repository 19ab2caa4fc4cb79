// Reference shader: variant a equals a double-precision sum over the lights, culling (b)
// changes nothing but rounding, the glossy two-strata variant (c) leaves a Lambertian
// surface exactly as (a) and stays within its stated bound for Phong, the cap k keeps the
// cone's energy, clustering (d) keeps power and at most Q lights, and the errors use the
// CONVENTIONS.md measures (the same numbers as core/accuracy's light_error).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "core/accuracy.h"
#include "core/error.h"
#include "eval/synthetic_scene.h"
#include "render/reference_shader.h"
#include "sampling/sampler.h"

namespace lp {
namespace {

const EnvMap& scene_map() {
  static const EnvMap map = render_scene(describe_scene(), Layout::LatLong, 128, 64);
  return map;
}

std::vector<Light> scene_lights(int n) { return sample(scene_map(), n, Method::Pharr).lights; }

std::shared_ptr<const AngularRegions> regions(int n, int face = 32) {
  return std::make_shared<const AngularRegions>(AngularRegionOptions{n, face});
}

ShadingScene make_scene(int high, int low_per_high, double cone_deg, int k, int q = 0) {
  ShadingOptions o;
  o.glossy.low_per_high = low_per_high;
  o.glossy.cone_half_angle_deg = cone_deg;
  o.glossy.max_cone_lights = k;
  o.cluster_max_lights = q;
  return prepare_shading(scene_lights(high * low_per_high), high, regions(128), regions(256), o);
}

double sum_diffuse(const std::vector<Light>& lights, Vec3 n) { return lights_irradiance(lights, n); }
double sum_glossy(const std::vector<Light>& lights, Vec3 r, double s) {
  double e = 0;
  for (const Light& l : lights) e += l.luminance() * phong_lobe(dot(r, l.direction), s);
  return e;
}

struct Points {
  std::vector<Vec3> n, r;
};
Points points(int count) {
  Points p;
  make_shading_points(count, 42, p.n, p.r);
  return p;
}

TEST(ReferenceShader, AllLightsMatchesADoublePrecisionSum) {
  const ShadingScene s = make_scene(256, 4, 8, 256);
  const Points p = points(300);
  for (size_t i = 0; i < p.n.size(); ++i) {
    const ShadingSample a = shade(s, ShadingVariant::All, p.n[i], p.r[i], 100);
    const double e = sum_diffuse(s.lights, p.n[i]), g = sum_glossy(s.lights, p.r[i], 100);
    EXPECT_NEAR(a.diffuse.luminance(), e, 1e-5 * e + 1e-9);
    EXPECT_NEAR(a.glossy.luminance(), g, 1e-4 * g + 1e-6);
  }
}

TEST(ReferenceShader, CullingChangesOnlyRounding) {
  const ShadingScene s = make_scene(512, 2, 8, 256);
  const Points p = points(2000);
  for (float exponent : {1.0f, 10.0f, 100.0f, 37.5f}) {
    for (size_t i = 0; i < p.n.size(); ++i) {
      const ShadingSample a = shade(s, ShadingVariant::All, p.n[i], p.r[i], exponent);
      const ShadingSample b = shade(s, ShadingVariant::Culled, p.n[i], p.r[i], exponent);
      EXPECT_NEAR(b.diffuse.r, a.diffuse.r, 1e-5 * a.diffuse.r + 1e-9);
      EXPECT_NEAR(b.diffuse.b, a.diffuse.b, 1e-5 * a.diffuse.b + 1e-9);
      EXPECT_NEAR(b.glossy.g, a.glossy.g, 1e-5 * a.glossy.g + 1e-9);
    }
  }
}

TEST(ReferenceShader, RegionCopiesAndIndexListsShadeAlike) {
  ShadingOptions o;
  o.glossy.low_per_high = 4;
  const auto low = scene_lights(1024);
  const ShadingScene indexed = prepare_shading(low, 256, regions(128), regions(256), o);
  o.region_copies = true;
  const ShadingScene copies = prepare_shading(low, 256, regions(128), regions(256), o);
  const Points p = points(500);
  for (ShadingVariant v : {ShadingVariant::Culled, ShadingVariant::Glossy, ShadingVariant::Clustered})
    for (size_t i = 0; i < p.n.size(); ++i) {
      const ShadingSample a = shade(indexed, v, p.n[i], p.r[i], 100), b = shade(copies, v, p.n[i], p.r[i], 100);
      EXPECT_FLOAT_EQ(a.diffuse.g, b.diffuse.g);  // the same lights in the same order
      EXPECT_FLOAT_EQ(a.glossy.r, b.glossy.r);
    }
}

TEST(ReferenceShader, TwoStrataEqualAllLightsForALambertianSurface) {
  const ShadingScene s = make_scene(128, 8, 8, 64);
  const Points p = points(1000);
  const Material lambert{{0.8f, 0.5f, 0.3f}, {0, 0, 0}, 100};
  for (size_t i = 0; i < p.n.size(); ++i) {
    const Rgb a = combine(lambert, shade(s, ShadingVariant::All, p.n[i], p.r[i], 100));
    const Rgb c = combine(lambert, shade(s, ShadingVariant::Glossy, p.n[i], p.r[i], 100));
    EXPECT_NEAR(c.r, a.r, 1e-5 * a.r + 1e-9);
    EXPECT_NEAR(c.g, a.g, 1e-5 * a.g + 1e-9);
  }
}

// Stated bound: without the cap, the two-strata estimate and the all-L estimate agree
// inside the cone and differ only by how H and L sample the outside, where the lobe is at
// most f(cos(gamma/2)); both outside sums are in [0, f(cos(gamma/2)) P], so
// |G_c - G_L| <= f(cos(gamma/2)) P with P the total luminance power.
TEST(ReferenceShader, TwoStrataStayWithinTheStatedBoundOfAllLowLightsForPhong) {
  for (double cone_deg : {8.0, 20.0}) {
    const ShadingScene s = make_scene(64, 16, cone_deg, 1 << 20);
    double power = 0;
    for (const Light& l : s.glossy.low) power += l.luminance();
    const Points p = points(1500);
    for (double exponent : {10.0, 100.0}) {
      const double bound = phong_lobe(std::cos(cone_deg * M_PI / 180), exponent) * power;
      double worst = 0;
      for (size_t i = 0; i < p.r.size(); ++i) {
        const double c = shade(s, ShadingVariant::Glossy, p.n[i], p.r[i], float(exponent)).glossy.luminance();
        const double l = sum_glossy(s.glossy.low, p.r[i], exponent);
        worst = std::max(worst, std::fabs(c - l) - 1e-4 * l);
      }
      EXPECT_LE(worst, bound) << "cone " << cone_deg << " s " << exponent;
    }
  }
}

TEST(ReferenceShader, ConeCapKeepsTheConeEnergy) {
  // With s = 0 the lobe is constant inside the cone, so capping at k lights and rescaling
  // must give the same luminance as using every L light of the cone.
  const ShadingScene all = make_scene(64, 16, 15, 1 << 20);
  const ShadingScene capped = make_scene(64, 16, 15, 3);
  const Points p = points(500);
  int capped_cones = 0;
  for (size_t i = 0; i < p.r.size(); ++i) {
    const double a = shade(all, ShadingVariant::Glossy, p.n[i], p.r[i], 0).glossy.luminance();
    const double c = shade(capped, ShadingVariant::Glossy, p.n[i], p.r[i], 0).glossy.luminance();
    EXPECT_NEAR(c, a, 1e-4 * a + 1e-9);
    // Count cones that hold more than k = 3 lights, so the cap was exercised.
    int in = 0;
    for (const Light& l : all.glossy.low) in += angle_between(p.r[i], l.direction) < 15 * M_PI / 180;
    capped_cones += in > 3;
  }
  EXPECT_GT(capped_cones, 50);
}

TEST(ReferenceShader, ClusteringKeepsPowerAndAtMostQLights) {
  const ShadingScene s = make_scene(512, 1, 8, 16, 40);
  EXPECT_LE(s.clustered.size(), 40u);
  EXPECT_GE(s.clustered.size(), 1u);
  const auto a = total_power(s.lights), d = total_power(s.clustered);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(d[size_t(c)], a[size_t(c)], 1e-9 * a[size_t(c)]);
  // Clustered shading is the culled sum over the clustered lights.
  const Points p = points(200);
  for (size_t i = 0; i < p.n.size(); ++i) {
    const double e = sum_diffuse(s.clustered, p.n[i]);
    EXPECT_NEAR(shade(s, ShadingVariant::Clustered, p.n[i], p.r[i], 10).diffuse.luminance(), e, 1e-5 * e + 1e-9);
  }
}

TEST(ReferenceShader, BadInputIsAClearError) {
  ShadingOptions o;
  o.cluster_max_lights = -1;  // Q < 1
  EXPECT_THROW(prepare_shading(scene_lights(64), 16, regions(32), regions(32), o), InputError);
  EXPECT_THROW(prepare_shading(scene_lights(64), 16, nullptr, regions(32)), InputError);
  EXPECT_THROW(prepare_shading(scene_lights(64), 0, regions(32), regions(32)), InputError);
}

TEST(ReferenceShader, ErrorsAreTheConventionsMeasures) {
  AccuracyOptions ao;
  ao.shadowed = false;
  const AccuracyReference ref = make_accuracy_reference(scene_map(), ao);
  const ShadingScene s = make_scene(64, 8, 8, 256);
  const LightError le = light_error(ref, s.lights);
  const ShadingError a = shading_error(ref, s, ShadingVariant::All);
  const ShadingError b = shading_error(ref, s, ShadingVariant::Culled);
  const ShadingError c = shading_error(ref, s, ShadingVariant::Glossy);
  EXPECT_NEAR(a.diffuse, le.diffuse, 1e-4 * le.diffuse);
  EXPECT_NEAR(a.glossy[0], le.glossy[0], 1e-4 * le.glossy[0]);
  EXPECT_NEAR(a.glossy[1], le.glossy[1], 1e-4 * le.glossy[1]);
  EXPECT_NEAR(b.diffuse, a.diffuse, 1e-5 * a.diffuse);  // culling costs no accuracy
  EXPECT_NEAR(c.diffuse, a.diffuse, 1e-5 * a.diffuse);
  // Eight times the lights inside the cone: the sharp lobe gets markedly better.
  EXPECT_LT(c.glossy[1], 0.7 * a.glossy[1]) << a.glossy[1] << " -> " << c.glossy[1];
}

}  // namespace
}  // namespace lp
