// Merging several cameras (sampling/merge_cameras.h): index-wise merge of pharr/hemigon
// lists, position weights, the Q2-tree merge of Algorithm 2 (what is and is not equal to
// the Q2-tree of the averaged map), and the robust merge over inputs that stall.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <vector>

#include "core/accuracy.h"
#include "core/envmap.h"
#include "core/error.h"
#include "eval/synthetic_scene.h"
#include "sampling/merge_cameras.h"
#include "sampling/sampler.h"

namespace lp {
namespace {

double lum_total(const LightList& list) {
  const auto p = total_power(list.lights);
  return luminance(p.data());
}

std::set<uint64_t> ids_of(const LightList& list) {
  std::set<uint64_t> ids;
  for (const Light& l : list.lights) ids.insert(l.id);
  return ids;
}

// Scene on a healpix map, pixels rounded to multiples of 1/16: sums of two such maps
// (below 2^22 / 16) are exact in float, so the average map is the exact average.
EnvMap quantised_scene(const SceneOptions& options, int nside, double scale = 1.0) {
  EnvMap map = render_scene(describe_scene(options), Layout::Healpix, nside, 1);
  for (float& x : map.rgb) x = float(std::round(double(x) * scale * 16.0) / 16.0);
  return map;
}

EnvMap average_map(const EnvMap& a, const EnvMap& b) {
  EnvMap m = a;
  for (size_t i = 0; i < m.rgb.size(); ++i) m.rgb[i] = (a.rgb[i] + b.rgb[i]) * 0.5f;
  return m;
}

SceneOptions sun_at(double theta_deg, double phi_deg, double sky = 1.0) {
  SceneOptions o;
  o.sun_direction = direction_from_angles(theta_deg * M_PI / 180.0, phi_deg * M_PI / 180.0);
  o.sky_scale = sky;
  return o;
}

TEST(MergeCameras, WeightsAreNormalisedAndChecked) {
  const EnvMap a = render_scene(describe_scene(sun_at(40, 30)), Layout::LatLong, 128, 64);
  const EnvMap b = render_scene(describe_scene(sun_at(60, 200, 2.0)), Layout::LatLong, 128, 64);
  const LightList la = sample(a, 32, Method::Pharr), lb = sample(b, 32, Method::Pharr);
  const LightList m1 = merge_by_index({la, lb}, {2, 6});
  const LightList m2 = merge_by_index({la, lb}, {0.25, 0.75});
  ASSERT_EQ(m1.lights.size(), 32u);
  for (size_t k = 0; k < m1.lights.size(); ++k) {
    const Light &x = m1.lights[k], &y = m2.lights[k], &p = la.lights[k], &q = lb.lights[k];
    ASSERT_EQ(x.id, p.id);
    EXPECT_EQ(x.id, y.id);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(x.rgb[c], 0.25 * p.rgb[c] + 0.75 * q.rgb[c], 1e-12 * (p.rgb[c] + q.rgb[c]));
      EXPECT_NEAR(x.rgb[c], y.rgb[c], 1e-12 * (p.rgb[c] + q.rgb[c]));
    }
    EXPECT_NEAR(x.solid_angle, 0.25 * p.solid_angle + 0.75 * q.solid_angle, 1e-12);
    const Vec3 d = normalize(0.25 * p.direction + 0.75 * q.direction);
    EXPECT_LT(angle_between(x.direction, d), 1e-12);
    EXPECT_NEAR(length(x.direction), 1.0, 1e-12);
  }
  EXPECT_NEAR(lum_total(m1), 0.25 * lum_total(la) + 0.75 * lum_total(lb), 1e-12 * lum_total(m1));
  // Empty weights: equal.
  const LightList eq = merge_by_index({la, lb}, {});
  EXPECT_NEAR(lum_total(eq), 0.5 * (lum_total(la) + lum_total(lb)), 1e-12 * lum_total(eq));
  EXPECT_THROW(merge_by_index({la, lb}, {0, 0}), InputError);
  EXPECT_THROW(merge_by_index({la, lb}, {1, -1}), InputError);
  EXPECT_THROW(merge_by_index({la, lb}, {1}), InputError);
  EXPECT_THROW(merge_by_index({la, lb}, {1, NAN}), InputError);
  EXPECT_THROW(merge_by_index({}, {}), InputError);

  // Inverse-distance weights.
  const auto w = position_weights({{0, 0, 0}, {2, 0, 0}}, {0.5, 0, 0});
  ASSERT_EQ(w.size(), 2u);
  EXPECT_NEAR(w[0] + w[1], 1.0, 1e-15);
  EXPECT_NEAR(w[0] / w[1], (1.5 * 1.5) / (0.5 * 0.5), 1e-12);
  const auto at = position_weights({{0, 0, 0}, {1, 2, 3}, {4, 0, 0}}, {1, 2, 3});
  EXPECT_EQ(at, (std::vector<double>{0, 1, 0}));
  const auto flat = position_weights({{0, 0, 0}, {3, 0, 0}}, {1, 0, 0}, 0.0);
  EXPECT_NEAR(flat[0], 0.5, 1e-15);
  EXPECT_THROW(position_weights({}, {0, 0, 0}), InputError);
  EXPECT_THROW(position_weights({{0, 0, 0}}, {0, 0, 0}, -1), InputError);
}

TEST(MergeCameras, ByIndexMergesMissingIdsFromTheInputsThatHaveThem) {
  const EnvMap a = render_scene(describe_scene(sun_at(40, 30)), Layout::LatLong, 128, 64);
  const EnvMap b = render_scene(describe_scene(sun_at(60, 200)), Layout::LatLong, 128, 64);
  for (Method method : {Method::Pharr, Method::Hemigon}) {
    const LightList la = sample(a, 64, method), lb = sample(b, 32, method);
    const LightList m = merge_by_index({la, lb}, {1, 3});
    EXPECT_EQ(m.method, la.method);
    ASSERT_EQ(m.lights.size(), 64u);
    std::map<uint64_t, Light> byb;
    for (const Light& l : lb.lights) byb[l.id] = l;
    for (size_t k = 0; k < 64; ++k) {
      const Light &x = m.lights[k], &p = la.lights[k];
      ASSERT_EQ(x.id, p.id);
      if (byb.count(x.id)) {
        EXPECT_NEAR(x.rgb[1], 0.25 * p.rgb[1] + 0.75 * byb[x.id].rgb[1], 1e-12 * (p.rgb[1] + byb[x.id].rgb[1]));
      } else {  // only in camera a: its values, weight renormalised to 1
        EXPECT_NEAR(x.rgb[1], p.rgb[1], 1e-12 * p.rgb[1]);
        EXPECT_LT(angle_between(x.direction, p.direction), 1e-12);
      }
    }
  }
  EXPECT_THROW(merge_by_index({sample(a, 16, Method::Pharr), sample(b, 16, Method::Hemigon)}, {}), InputError);
}

// (a) A camera merged with itself gives its own lights.
TEST(MergeCameras, Q2TreeMergedWithItselfIsUnchanged) {
  const EnvMap a = render_scene(describe_scene(sun_at(40, 30)), Layout::Healpix, 32, 1);
  for (int n : {12, 60, 240}) {
    const LightList la = sample(a, n, Method::Q2Tree);
    for (const std::vector<double>& w : {std::vector<double>{1, 1}, std::vector<double>{0.3, 0.7}}) {
      const LightList m = merge_q2trees({la, la}, w, n);
      ASSERT_EQ(m.lights.size(), la.lights.size());
      for (size_t k = 0; k < la.lights.size(); ++k) {
        const Light &x = m.lights[k], &y = la.lights[k];
        ASSERT_EQ(x.id, y.id);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(x.rgb[c], y.rgb[c], 1e-12 * lum_total(la));
        EXPECT_DOUBLE_EQ(x.solid_angle, y.solid_angle);
        EXPECT_LT(angle_between(x.direction, y.direction), 1e-9);
      }
    }
  }
}

// (b) Different maps: total power is the average exactly; accuracy against the average
// map close to the Q2-tree of the average map at the same n.
TEST(MergeCameras, Q2TreeMergeOfDifferentMapsKeepsPowerAndAccuracy) {
  const EnvMap a = render_scene(describe_scene(sun_at(40, 30)), Layout::Healpix, 64, 1);
  const EnvMap b = render_scene(describe_scene(sun_at(75, 210, 2.0)), Layout::Healpix, 64, 1);
  const EnvMap avg = average_map(a, b);
  AccuracyOptions acc;
  acc.shadowed = false;
  const AccuracyReference ref = make_accuracy_reference(avg, acc);
  for (int n : {30, 60, 120, 240}) {
    const LightList la = sample(a, n, Method::Q2Tree), lb = sample(b, n, Method::Q2Tree);
    const LightList m = merge_q2trees({la, lb}, {1, 1}, n);
    const LightList q = sample(avg, n, Method::Q2Tree);
    EXPECT_LE(int(m.lights.size()), n);
    EXPECT_GE(int(m.lights.size()), n - 2);
    for (int c = 0; c < 3; ++c) {
      const double expect = 0.5 * (total_power(la.lights)[c] + total_power(lb.lights)[c]);
      EXPECT_NEAR(total_power(m.lights)[c], expect, 1e-12 * expect);
    }
    const auto em = light_error(ref, m.lights), eq = light_error(ref, q.lights);
    const auto ea = light_error(ref, la.lights), eb = light_error(ref, lb.lights);
    size_t common = 0;
    const auto qi = ids_of(q);
    for (uint64_t id : ids_of(m)) common += qi.count(id);
    std::printf("[ merge ] n=%3d diffuse error vs average map: merged %.5f, q2tree(average) %.5f "
                "(camera a alone %.4f, b alone %.4f); glossy10 %.4f vs %.4f; %zu of %zu ids shared\n",
                n, em.diffuse, eq.diffuse, ea.diffuse, eb.diffuse, em.glossy[0], eq.glossy[0], common,
                m.lights.size());
    EXPECT_LT(em.diffuse, eq.diffuse + 0.01);
  }
}

// b = a with the pixels of every leaf of a's tree at n reversed (nested order): each leaf
// keeps its power, so no node of a's tree changes rank against a leaf and b's tree at n
// (and below) is a's, but the centroids inside the leaves move.
EnvMap shuffled_within_leaves(const EnvMap& a, const LightList& tree) {
  EnvMap b = a;
  const int finest = std::bit_width(unsigned(a.nside)) - 1;
  for (const Light& l : tree.lights) {
    const int level = (int(std::bit_width(l.id >> 2)) - 1) / 2;
    const size_t ipix = size_t(l.id - (uint64_t(4) << (2 * level)));
    const size_t begin = ipix << (2 * (finest - level)), end = (ipix + 1) << (2 * (finest - level));
    for (size_t i = begin, j = end - 1; i < j; ++i, --j)
      for (int c = 0; c < 3; ++c) std::swap(b.rgb[3 * i + c], b.rgb[3 * j + c]);
  }
  return b;
}

// (c) When the inputs' trees agree (same leaf set) and a = 1, the merge is the Q2-tree of
// the average map: same ids, powers to rounding; directions exact at the inputs' n when
// the inputs' centroids agree (b = 3 a), approximate once leaves are merged.
TEST(MergeCameras, Q2TreeMergeEqualsAverageMapTreeWhenTheTreesAgree) {
  const int nside = 32;
  const EnvMap a = quantised_scene(sun_at(40, 30), nside);
  EnvMap triple = a;
  for (float& x : triple.rgb) x *= 3.0f;  // exact: multiples of 1/16 below 2^22 / 16
  for (int n : {30, 90, 180}) {
    const LightList la = sample(a, n, Method::Q2Tree);
    for (int variant = 0; variant < 2; ++variant) {
      const EnvMap b = variant == 0 ? triple : shuffled_within_leaves(a, la);
      const char* name = variant == 0 ? "b = 3 a" : "b = a shuffled inside a's leaves";
      const LightList lb = sample(b, n, Method::Q2Tree);
      ASSERT_EQ(ids_of(la), ids_of(lb)) << name << " n=" << n << ": the trees must agree for this case";
      const EnvMap avg = average_map(a, b);
      double angle_at_n = 0, angle_reduced = 0;
      for (int target : {n, n - 9}) {
        if (target < 12) continue;
        const LightList m = merge_q2trees({la, lb}, {1, 1}, target);
        const LightList q = sample(avg, target, Method::Q2Tree);
        ASSERT_EQ(ids_of(m), ids_of(q)) << name << " n=" << n << " target=" << target;
        for (size_t k = 0; k < m.lights.size(); ++k) {
          const Light &x = m.lights[k], &y = q.lights[k];
          for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(x.rgb[ch], y.rgb[ch], 1e-9 * lum_total(q));
          double& worst = target == n ? angle_at_n : angle_reduced;
          worst = std::max(worst, angle_between(x.direction, y.direction));
        }
      }
      std::printf("[ merge ] trees agree (%s), n=%d: ids and powers equal; largest direction difference "
                  "%.3g deg at n, %.3g deg reduced to n-9\n", name, n, angle_at_n * 180 / M_PI,
                  angle_reduced * 180 / M_PI);
      if (variant == 0) {
        EXPECT_LT(angle_at_n, 1e-9);
      }
    }
  }
}

// The paper's claim fails in general: the average map's tree can split a quad no input
// split (second brightest in both cameras, brightest in neither).
TEST(MergeCameras, Q2TreeAverageMapCanSplitANodeNoCameraSplit) {
  const int nside = 8;
  EnvMap a = make_healpix(nside), b = make_healpix(nside);
  const size_t per_quad = size_t(nside) * nside;
  const float value_a[12] = {10, 9, 0, .1f, .1f, .1f, .1f, .1f, .1f, .1f, .1f, .1f};
  const float value_b[12] = {0, 9, 10, .1f, .1f, .1f, .1f, .1f, .1f, .1f, .1f, .1f};
  for (size_t i = 0; i < a.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) a.rgb[3 * i + c] = value_a[i / per_quad], b.rgb[3 * i + c] = value_b[i / per_quad];
  const EnvMap avg = average_map(a, b);
  const LightList la = sample(a, 15, Method::Q2Tree), lb = sample(b, 15, Method::Q2Tree);
  const LightList q = sample(avg, 15, Method::Q2Tree);
  const LightList m = merge_q2trees({la, lb}, {1, 1}, 15);
  // a splits base quad 0 (NUNIQ 4), b quad 2 (6), the average quad 1 (5): children 20..23.
  EXPECT_TRUE(ids_of(la).count(16));
  EXPECT_TRUE(ids_of(lb).count(24));
  EXPECT_TRUE(ids_of(q).count(20));
  EXPECT_FALSE(ids_of(m).count(20));
  EXPECT_TRUE(ids_of(m).count(5));
  EXPECT_NEAR(lum_total(m), lum_total(q), 1e-12 * lum_total(q));
  const AccuracyReference ref = make_accuracy_reference(avg, AccuracyOptions{.shadowed = false});
  std::printf("[ merge ] counterexample n=15: diffuse error merged %.5f, q2tree(average) %.5f\n",
              light_error(ref, m.lights).diffuse, light_error(ref, q.lights).diffuse);
}

TEST(MergeCameras, Q2TreeRejectsListsThatAreNotTrees) {
  const EnvMap a = render_scene(describe_scene(), Layout::Healpix, 16, 1);
  const LightList la = sample(a, 30, Method::Q2Tree);
  LightList gap = la;
  gap.lights.pop_back();
  EXPECT_THROW(merge_q2trees({la, gap}, {}, 30), InputError);
  LightList overlap = la;
  overlap.lights.push_back(overlap.lights.back());
  EXPECT_THROW(merge_q2trees({la, overlap}, {}, 30), InputError);
  LightList bad_id = la;
  bad_id.lights[0].id = 3;
  EXPECT_THROW(merge_q2trees({bad_id}, {}, 30), InputError);
  EXPECT_THROW(merge_q2trees({la}, {}, 11), InputError);
  // Fewer leaves than asked: the merged tree as it is (no splitting beyond the inputs).
  EXPECT_EQ(merge_q2trees({la, la}, {}, 300).lights.size(), la.lights.size());
}

TEST(MergeCameras, TheStrictMergesRefuseMixedMethodsAndUnits) {
  const EnvMap a = render_scene(describe_scene(), Layout::Healpix, 16, 1);
  const LightList q = sample(a, 30, Method::Q2Tree), p = sample(a, 30, Method::Pharr);
  EXPECT_THROW(merge_q2trees({q, p}, {}, 30), InputError);
  EXPECT_THROW(merge_by_index({p, q}, {}), InputError);
  EXPECT_THROW(merge_by_index({q, q}, {}), InputError);
  LightList other_units = p;
  other_units.units = Units::Radiance;
  EXPECT_THROW(merge_by_index({p, other_units}, {}), InputError);
  EXPECT_THROW(merge_light_lists({p, other_units}, {}, 30), InputError);
  EXPECT_EQ(merge_mode({p, p}), MergeMode::Index);
  EXPECT_EQ(merge_mode({q, q}), MergeMode::Q2Tree);
  EXPECT_EQ(merge_mode({q, p}), MergeMode::Direction);
}

// Diffuse error of `lights` against the map (CONVENTIONS.md).
double diffuse_error(const EnvMap& map, const LightList& list) {
  return light_error(make_accuracy_reference(map), list.lights).diffuse;
}

// Issue 22: a q2tree camera beside a pharr one merges (by direction) instead of aborting.
TEST(MergeCameras, DifferentMethodsMergeByDirectionKeepingPowerAndIrradiance) {
  const EnvMap a = render_scene(describe_scene(sun_at(40, 30)), Layout::LatLong, 256, 128);
  const EnvMap b = render_scene(describe_scene(sun_at(60, 200)), Layout::LatLong, 256, 128);
  const EnvMap avg = average_map(a, b);
  const LightList q = sample(a, 128, Method::Q2Tree), p = sample(b, 128, Method::Pharr);
  ASSERT_EQ(merge_mode({q, p}), MergeMode::Direction);
  // The union of both cameras' lights at half power: what merging by direction reduces.
  LightList both;
  for (const LightList* l : {&q, &p})
    for (Light x : l->lights) {
      for (double& c : x.rgb) c *= 0.5;
      both.lights.push_back(x);
    }
  const double union_error = diffuse_error(avg, both);
  for (int n : {32, 64, 128, 256}) {
    const LightList m = merge_light_lists({q, p}, {}, n);
    EXPECT_EQ(m.method, "q2tree");
    EXPECT_LE(m.lights.size(), size_t(n));
    EXPECT_GE(m.lights.size(), size_t(n - 2));
    for (const Light& l : m.lights) {
      ASSERT_NEAR(length(l.direction), 1.0, 1e-12);
      ASSERT_TRUE(std::isfinite(l.rgb[0]) && l.rgb[0] >= 0);
    }
    EXPECT_NEAR(lum_total(m), 0.5 * (lum_total(q) + lum_total(p)), 1e-12 * lum_total(m));
    const double e = diffuse_error(avg, m);
    std::printf("direction merge q2tree 128 + pharr 128 -> %d lights: diffuse error %.4f against the average map "
                "(union of both inputs %.4f, inputs against their own maps %.4f / %.4f)\n",
                n, e, union_error, diffuse_error(a, q), diffuse_error(b, p));
    EXPECT_LT(e, union_error + (n < 64 ? 0.02 : 0.005)) << n;
  }
  // Weights: all on one camera gives that camera's power.
  const LightList only_q = merge_light_lists({q, p}, {1, 0}, 128);
  EXPECT_NEAR(lum_total(only_q), lum_total(q), 1e-12 * lum_total(q));
  // A q2tree list merged by direction with itself keeps its irradiance.
  const LightList self = merge_by_direction({q, q}, {}, 128);
  EXPECT_LT(std::fabs(diffuse_error(a, self) - diffuse_error(a, q)), 0.01);
}

LightList with_rgb(LightList list, size_t k, std::array<double, 3> rgb) {
  list.lights.at(k).rgb = rgb;
  return list;
}

// Issue 22: lists that used to abort `merge` are merged (by direction) or skipped with a
// reason; merge_available never throws for what the inputs hold.
TEST(MergeCameras, UnmergeableListsAreSkippedWithAReasonAndNeverThrow) {
  const EnvMap a = render_scene(describe_scene(sun_at(40, 30)), Layout::LatLong, 128, 64);
  const LightList q = sample(a, 64, Method::Q2Tree), p = sample(a, 64, Method::Pharr);
  LightList empty = q;
  empty.lights.clear();
  LightList same_ids = p;
  for (Light& l : same_ids.lights) l.id = 7;
  LightList cut = q;
  cut.lights.erase(cut.lights.begin() + 5);
  LightList radiance = p;
  radiance.units = Units::Radiance;
  LightList skew = p;
  skew.lights[3].direction = {1, 1, 0};
  const std::vector<std::pair<LightList, std::string>> bad{
      {empty, "empty"},
      {with_rgb(p, 0, {1e308, 1e308, 1e308}), "too_bright"},
      {with_rgb(p, 1, {-1, 0.5, 0.5}), "negative"},
      {with_rgb(p, 2, {NAN, 1, 1}), "not_finite"},
      {skew, "not_unit"},
      {radiance, "units"}};
  for (const auto& [list, code] : bad) {
    MergeState state;
    std::vector<MergeInput> in{{"good", p, 10.0}, {"bad", list, 10.0}};
    LightList out;
    ASSERT_NO_THROW(out = merge_available(in, 10.1, 1.0, state)) << code;
    ASSERT_EQ(state.skipped.size(), 1u) << code;
    EXPECT_EQ(state.skipped[0].name, "bad");
    EXPECT_EQ(state.skipped[0].code, code);
    EXPECT_FALSE(state.skipped[0].detail.empty());
    EXPECT_EQ(state.used, std::vector<std::string>{"good"});
    EXPECT_FALSE(state.stale);
    EXPECT_NEAR(lum_total(out), lum_total(p), 1e-12 * lum_total(p)) << code;  // the good one alone
    // Alone, the bad list gives nothing to merge: stale, no output yet, no throw.
    if (code == "units") continue;  // alone, its units are the merge's
    MergeState alone;
    ASSERT_NO_THROW(out = merge_available({{"bad", list, 10.0}}, 10.1, 1.0, alone)) << code;
    EXPECT_TRUE(alone.stale);
    EXPECT_TRUE(out.lights.empty());
  }
  // Ids that do not correspond: merged by direction, power the average of the inputs'.
  for (const LightList& odd : {same_ids, cut}) {
    MergeState state;
    std::vector<MergeInput> in{{"a", q, 10.0}, {"b", odd, 10.0}};
    LightList out;
    ASSERT_NO_THROW(out = merge_available(in, 10.1, 1.0, state));
    EXPECT_EQ(state.mode, MergeMode::Direction);
    EXPECT_TRUE(state.skipped.empty());
    EXPECT_EQ(state.used.size(), 2u);
    EXPECT_NEAR(lum_total(out), 0.5 * (lum_total(q) + lum_total(odd)), 1e-12 * lum_total(out));
    for (const Light& l : out.lights) ASSERT_NEAR(length(l.direction), 1.0, 1e-12);
  }
  // A merge that fails (n below 12 for a q2tree merge) keeps the last output, flagged.
  MergeState state;
  MergeAvailableOptions tiny;
  tiny.n = 64;
  const LightList first = merge_available({{"a", q, 10.0}, {"b", q, 10.0}}, 10.1, 1.0, state, tiny);
  tiny.n = 5;
  LightList again;
  ASSERT_NO_THROW(again = merge_available({{"a", q, 11.0}, {"b", q, 11.0}}, 11.1, 1.0, state, tiny));
  EXPECT_TRUE(state.stale);
  EXPECT_NE(state.error.find("n >= 12"), std::string::npos) << state.error;
  EXPECT_EQ(again.lights.size(), first.lights.size());
}

TEST(MergeCameras, SilentInputIsDroppedAfterTheTimeoutAndTakenBack) {
  std::vector<LightList> lists;
  for (double phi : {30.0, 150.0, 270.0})
    lists.push_back(sample(render_scene(describe_scene(sun_at(50, phi)), Layout::LatLong, 128, 64), 32, Method::Pharr));
  const auto same = [](const LightList& x, const LightList& y) {
    if (x.lights.size() != y.lights.size()) return false;
    for (size_t k = 0; k < x.lights.size(); ++k)
      if (x.lights[k].id != y.lights[k].id || length(x.lights[k].direction - y.lights[k].direction) > 1e-12 ||
          std::abs(x.lights[k].luminance() - y.lights[k].luminance()) > 1e-12 * y.lights[k].luminance())
        return false;
    return true;
  };
  MergeState state;
  MergeAvailableOptions options;
  options.weights = {1, 2, 3};
  std::vector<MergeInput> in{{"a", lists[0], 10.0}, {"b", lists[1], 10.0}, {"c", std::nullopt, 0.0}};
  // c has never delivered: merged without it.
  LightList out = merge_available(in, 10.2, 1.0, state, options);
  EXPECT_TRUE(same(out, merge_by_index({lists[0], lists[1]}, {1, 2})));
  EXPECT_EQ(state.dropped, std::vector<std::string>{"c"});
  EXPECT_FALSE(state.stale);
  // c arrives; then b stays silent past the timeout and is dropped.
  in[2].latest = lists[2];
  in[2].last_seen_s = 10.5;
  out = merge_available(in, 10.9, 1.0, state, options);
  EXPECT_TRUE(same(out, merge_by_index(lists, {1, 2, 3})));
  in[0].last_seen_s = 11.5, in[2].last_seen_s = 11.5;
  out = merge_available(in, 11.6, 1.0, state, options);
  EXPECT_TRUE(same(out, merge_by_index({lists[0], lists[2]}, {1, 3})));
  EXPECT_EQ(state.used, (std::vector<std::string>{"a", "c"}));
  EXPECT_EQ(state.dropped, std::vector<std::string>{"b"});
  // b returns: taken back.
  in[1].last_seen_s = 11.7;
  out = merge_available(in, 11.8, 1.0, state, options);
  EXPECT_TRUE(same(out, merge_by_index(lists, {1, 2, 3})));
  EXPECT_TRUE(state.dropped.empty());
  // Everyone silent: the last output, flagged.
  const LightList last = out;
  out = merge_available(in, 100.0, 1.0, state, options);
  EXPECT_TRUE(state.stale);
  EXPECT_TRUE(same(out, last));
  EXPECT_EQ(state.dropped.size(), 3u);
  // And back to normal.
  in[1].last_seen_s = 100.0;
  out = merge_available(in, 100.1, 1.0, state, options);
  EXPECT_FALSE(state.stale);
  EXPECT_TRUE(same(out, lists[1]));
  // No output ever and no live input: empty, flagged.
  MergeState fresh;
  EXPECT_TRUE(merge_available(in, 1000.0, 1.0, fresh, options).lights.empty());
  EXPECT_TRUE(fresh.stale);
  EXPECT_THROW(merge_available(in, 100.1, -1.0, state, options), InputError);
}

}  // namespace
}  // namespace lp
