// Model selection ranked on the cross-validation repeated over balanced splits
// (calib/geometric.h, CalibrateOptions::cv_splits), against the single odd/even split, on
// corners projected through known cameras.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <sys/stat.h>

#include "calib/geometric.h"
#include "calib/synthetic_boards.h"
#include "tests/calib/test_cameras.h"

namespace lp {
namespace {

using calib_test::kb190;

using Corners = std::vector<std::vector<std::array<double, 2>>>;

const BoardSpec kBoard{10, 7, 40};

CameraModel narrow(double k1) {  // pinhole (k1 = 0) or plumb_bob, 71 deg across
  CameraModel m{k1 == 0 ? "LENSMODEL_PINHOLE" : "LENSMODEL_OPENCV5", {900, 902, 639.2, 481.7}, 1280, 960};
  if (k1 != 0) m.intrinsics.insert(m.intrinsics.end(), {k1, 0.02, 0, 0, 0});
  return m;
}

// The area the boards covered (union of each view's convex hull of corners), the area a
// cross-validation compares models over.
std::vector<uint8_t> covered(const Corners& views, int w, int h) {
  std::vector<uint8_t> mask(size_t(w) * h, 0);
  for (const auto& v : views) {
    std::vector<std::array<double, 2>> p = v;  // Andrew's monotone chain
    std::sort(p.begin(), p.end());
    std::vector<std::array<double, 2>> hull(2 * p.size());
    auto turn = [](const auto& o, const auto& a, const auto& b) {
      return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    };
    size_t k = 0;
    for (size_t i = 0; i < p.size(); ++i) {
      while (k >= 2 && turn(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
      hull[k++] = p[i];
    }
    for (size_t i = p.size() - 1, t = k + 1; i-- > 0;) {
      while (k >= t && turn(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
      hull[k++] = p[i];
    }
    hull.resize(k - 1);  // counter-clockwise (y down: clockwise on screen)
    double x0 = w, x1 = 0, y0 = h, y1 = 0;
    for (const auto& q : hull) {
      x0 = std::min(x0, q[0]), x1 = std::max(x1, q[0]), y0 = std::min(y0, q[1]), y1 = std::max(y1, q[1]);
    }
    for (int y = std::max(0, int(y0)); y <= std::min(h - 1, int(y1) + 1); ++y)
      for (int x = std::max(0, int(x0)); x <= std::min(w - 1, int(x1) + 1); ++x) {
        bool in = true;
        for (size_t i = 0; i < hull.size() && in; ++i)
          in = turn(hull[i], hull[(i + 1) % hull.size()], std::array<double, 2>{double(x), double(y)}) >= 0;
        if (in) mask[size_t(y) * w + x] = 1;
      }
  }
  return mask;
}

// RMS pixel error of a fitted model against the truth over the covered area (rotation fitted
// out, as cross-validation does); inf when the model cannot image a tenth of it.
double error_vs_truth(const CameraModel& m, const CameraModel& truth, const std::vector<uint8_t>& mask) {
  const int full = projection_difference(truth, truth, mask, 8).samples;
  const ProjectionDiff d = projection_difference(m, truth, mask, 8);
  return d.samples >= 0.9 * full ? d.rms_px : std::numeric_limits<double>::infinity();
}

// The measurement in docs/calibration.md ("Model selection uses the measured noise"): over 8
// noise draws of three lenses, how close to the truth the selected model is when the
// selection ranks on one odd/even split, and on the mean of 4 splits (with the jackknife
// tolerance, and with the per-split spread's). 12 views: ~3 minutes, 20 views: ~15 on a shared
// 2-core machine:
//   calib_tests --gtest_also_run_disabled_tests --gtest_filter='ModelSelection.DISABLED_*'
TEST(ModelSelection, DISABLED_RepeatedSplitsAgainstOneSplit) {
  struct Lens {
    const char* name;
    CameraModel truth;
    double max_theta, distance;
  };
  const Lens lenses[] = {{"plumb_bob k1 -0.12", narrow(-0.12), 25, 900},
                         {"Kannala-Brandt 190 deg", kb190(), 80, 600},
                         {"pinhole", narrow(0), 25, 900}};
  struct Rule {
    const char* name;
    int splits;
    bool split_noise;
  };
  const Rule rules[] = {{"odd/even", 1, false}, {"4 splits, jackknife SE", 4, false}, {"4 splits, split SE", 4, true}};
  // LP_SELECTION_VIEWS / LP_SELECTION_NOISE override the setup (docs: 12 and 20 views).
  const char* ev = std::getenv("LP_SELECTION_VIEWS");
  const char* en = std::getenv("LP_SELECTION_NOISE");
  const int kSeeds = 8, kViews = ev ? std::atoi(ev) : 12;
  const double kNoise = en ? std::atof(en) : 0.25;
  std::printf("%d views, %.2f px corner noise, %d draws; error = RMS vs the truth over the covered area, px\n", kViews,
              kNoise, kSeeds);
  std::printf("| lens | rule | picks within 1.25x of the best candidate | mean error of the pick | mean pick / best | picks | s per calibration |\n");
  for (const Lens& lens : lenses) {
    std::vector<double> err[3], ratio[3];
    double seconds[3] = {0, 0, 0};
    std::map<std::string, int> picks[3];
    for (int seed = 1; seed <= kSeeds; ++seed) {
      const Corners views = project_board_views(lens.truth, kBoard, kViews, lens.max_theta, lens.distance, kNoise, seed);
      const auto mask = covered(views, lens.truth.width, lens.truth.height);
      for (int r = 0; r < 3; ++r) {
        CalibrateOptions o;
        o.leverage = false;
        o.uncertainty = false;
        o.cv_splits = rules[r].splits;
        o.selection_noise_from_splits = rules[r].split_noise;
        const auto t0 = std::chrono::steady_clock::now();
        const CalibrationResult res = calibrate(views, kBoard, lens.truth.width, lens.truth.height, o);
        seconds[r] += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        double best = std::numeric_limits<double>::infinity(), mine = best;
        for (const auto& c : res.table) {
          if (!c.ok) continue;
          const double e = error_vs_truth(c.model, lens.truth, mask);
          best = std::min(best, e);
          if (c.name == res.selected) mine = e;
          if (r == 1)
            std::printf("    seed %d %-32s err %.3f  cv odd/even %.3f  4 splits %.3f%s\n", seed, c.name.c_str(), e,
                        c.cross_validation_px, c.cross_validation_repeated_px, c.within_noise ? " (within)" : "");
        }
        std::printf("  seed %d %-24s picks %-32s err %.3f best %.3f (noise jk %.3f split %.3f)\n", seed, rules[r].name,
                    res.selected.c_str(), mine, best, res.cv_noise_px, res.cv_split_noise_px);
        err[r].push_back(mine);
        ratio[r].push_back(mine / best);
        picks[r][res.selected]++;
      }
    }
    for (int r = 0; r < 3; ++r) {
      int hits = 0;
      double se = 0, sr = 0;
      for (size_t i = 0; i < err[r].size(); ++i) {
        hits += ratio[r][i] <= 1.25;
        se += err[r][i];
        sr += ratio[r][i];
      }
      std::string p;
      for (const auto& [n, k] : picks[r]) p += (p.empty() ? "" : ", ") + n + " " + std::to_string(k);
      std::printf("| %s | %s | %d / %d | %.3f | %.2f | %s | %.2f |\n", lens.name, rules[r].name, hits, kSeeds,
                  se / kSeeds, sr / kSeeds, p.c_str(), seconds[r] / kSeeds);
    }
  }
}

}  // namespace
}  // namespace lp


namespace lp {
namespace {

// The selection ranks on the repeated cross-validation: every candidate that can matter has
// one value per split (the first the odd/even one), the ranking value is their RMS, a
// hopeless candidate is screened out, and a split's value is what two independent (cold)
// calibrations of that split's halves give. cv_splits = 1 is the odd/even rule.
TEST(ModelSelection, RanksOnTheCrossValidationRepeatedOverSplits) {
  const CameraModel truth = narrow(-0.12);
  const Corners views = project_board_views(truth, kBoard, 16, 25, 900, 0.1, 3);
  ASSERT_EQ(views.size(), 16u);
  CalibrateOptions o;
  o.leverage = false;
  o.uncertainty = false;
  o.diff_step_px = 8;
  o.candidates = {"LENSMODEL_PINHOLE", "plumb_bob"};
  const CalibrationResult r = calibrate(views, kBoard, truth.width, truth.height, o);
  EXPECT_EQ(r.selected_on, "repeated");
  EXPECT_EQ(r.cv_splits, 4);
  EXPECT_EQ(r.selected, "plumb_bob");
  const ModelCandidate& pin = r.table[0];
  const ModelCandidate& pb = r.table[1];
  std::printf("  pinhole odd/even %.3f px (screened: %d); plumb_bob splits", pin.cross_validation_px,
              int(pin.cross_validation_splits_px.empty()));
  for (double x : pb.cross_validation_splits_px) std::printf(" %.3f", x);
  std::printf(" -> %.3f px\n", pb.cross_validation_repeated_px);
  // Pinhole on a k1 = -0.12 lens is pixels off: > 10x the best odd/even, no further splits.
  EXPECT_GT(pin.cross_validation_px, 10 * pb.cross_validation_px);
  EXPECT_TRUE(pin.cross_validation_splits_px.empty());
  EXPECT_TRUE(std::isnan(pin.cross_validation_repeated_px));
  ASSERT_EQ(pb.cross_validation_splits_px.size(), 4u);
  EXPECT_EQ(pb.cross_validation_splits_px[0], pb.cross_validation_px);
  double ss = 0;
  for (double x : pb.cross_validation_splits_px) ss += x * x;
  EXPECT_NEAR(pb.cross_validation_repeated_px, std::sqrt(ss / 4), 1e-12);
  EXPECT_EQ(r.cross_validation_repeated_px, pb.cross_validation_repeated_px);
  // The splits differ: the pseudo-random ones are not odd/even (nor its complement).
  const auto splits = balanced_view_splits(16, 4);
  ASSERT_EQ(splits.size(), 4u);
  for (size_t k = 1; k < 4; ++k) {
    EXPECT_NE(splits[k], splits[0]);
    for (int v = 0; v < 16; ++v) EXPECT_TRUE(splits[k][size_t(v)] == 0 || splits[k][size_t(v)] == 1);
    EXPECT_EQ(std::count(splits[k].begin(), splits[k].end(), 1), 8);
  }
  // Split 2 by hand: each half calibrated on its own (cold, plumb_bob only), the two models
  // compared over the area every board covered. The selection refits the halves warm from
  // the full fit: the same minimum, so the same value to a few percent (the mask is
  // rasterised slightly differently).
  Corners half[2];
  for (int v = 0; v < 16; ++v) half[splits[2][size_t(v)]].push_back(views[size_t(v)]);
  CalibrateOptions one = o;
  one.model = "plumb_bob";
  const CalibrationResult a = calibrate(half[0], kBoard, truth.width, truth.height, one);
  const CalibrationResult b = calibrate(half[1], kBoard, truth.width, truth.height, one);
  const double by_hand = projection_difference(a.model, b.model, covered(views, truth.width, truth.height), 8).rms_px;
  std::printf("  split 2: %.4f px in the selection, %.4f px by hand\n", pb.cross_validation_splits_px[2], by_hand);
  EXPECT_NEAR(pb.cross_validation_splits_px[2], by_hand, 0.05 * by_hand);
  EXPECT_NE(pb.cross_validation_splits_px[2], pb.cross_validation_splits_px[0]);

  // The rule reads the 4-split values: with OpenCV8 among the candidates, "within the noise"
  // is exactly |4-split value - the lowest one| <= k * noise (+ floor) and the held-out
  // condition, and the pick has the fewest parameters among those.
  CalibrateOptions three = o;
  three.candidates = {"LENSMODEL_PINHOLE", "plumb_bob", "LENSMODEL_OPENCV8"};
  const CalibrationResult t = calibrate(views, kBoard, truth.width, truth.height, three);
  const ModelCandidate* lowest = nullptr;
  for (const auto& c : t.table)
    if (std::isfinite(c.cross_validation_repeated_px) &&
        (!lowest || c.cross_validation_repeated_px < lowest->cross_validation_repeated_px))
      lowest = &c;
  ASSERT_NE(lowest, nullptr);
  EXPECT_EQ(t.selection_noise_px, t.cv_noise_px);  // the jackknife, by default
  int components = 0;
  for (const auto& v : views) components += 2 * int(v.size());
  const double ho_limit = lowest->heldout_rms_px * (1 + 2 / std::sqrt(double(components - 2 * t.corners_rejected)));
  int fewest = 1 << 30;
  for (const auto& c : t.table) {
    std::printf("  %-20s odd/even %.3f  4 splits %.3f  held-out %.4f%s\n", c.name.c_str(), c.cross_validation_px,
                c.cross_validation_repeated_px, c.heldout_rms_px, c.within_noise ? "  (within)" : "");
    const bool expect = std::isfinite(c.cross_validation_repeated_px) &&
                        c.cross_validation_repeated_px - lowest->cross_validation_repeated_px <=
                            2 * t.selection_noise_px + 0.005 &&
                        c.heldout_rms_px <= ho_limit;
    EXPECT_EQ(c.within_noise, expect) << c.name;
    if (c.within_noise) fewest = std::min(fewest, c.params);
  }
  for (const auto& c : t.table)
    if (c.name == t.selected) {
      EXPECT_EQ(c.params, fewest);
    }

  CalibrateOptions single = o;
  single.cv_splits = 1;
  const CalibrationResult s = calibrate(views, kBoard, truth.width, truth.height, single);
  EXPECT_EQ(s.selected_on, "odd/even");
  EXPECT_TRUE(s.table[1].cross_validation_splits_px.empty());
  EXPECT_EQ(s.table[1].cross_validation_px, pb.cross_validation_px);
}

}  // namespace
}  // namespace lp

namespace lp {
namespace {

std::string fmt_px(double x) {
  char b[32];
  std::snprintf(b, sizeof b, " %.3f", x);
  return b;
}

// The chosen pairs against the fixed families over several draws (or splits of one set), two
// ways beside the plain ratio of means. The best family on average is picked in hindsight
// among seven noisy means, so it is biased low: (a) the paired t of chosen - that family over
// the draws (is the gap beyond the draws' noise?), and (b) the family picked without
// hindsight: for each draw, the family best on average over the other draws, scored on this
// one (leave one draw out); the chosen pairs' mean against that one's.
std::string against_fixed(const std::vector<double>& chosen, const std::vector<std::map<std::string, double>>& fixed) {
  const size_t n = chosen.size();
  std::map<std::string, double> sum;
  for (const auto& f : fixed)
    for (const auto& [name, d] : f) sum[name] += d;
  std::string best;
  double best_sum = std::numeric_limits<double>::infinity();
  for (const auto& [name, v] : sum)
    if (v < best_sum) best_sum = v, best = name;
  double chosen_sum = 0, mean_d = 0, var_d = 0, loo_sum = 0;
  for (double c : chosen) chosen_sum += c;
  std::vector<double> d(n);
  for (size_t k = 0; k < n; ++k) d[k] = chosen[k] - fixed[k].at(best), mean_d += d[k] / double(n);
  for (size_t k = 0; k < n; ++k) var_d += (d[k] - mean_d) * (d[k] - mean_d) / double(n > 1 ? n - 1 : 1);
  std::map<std::string, int> loo_names;
  for (size_t k = 0; k < n; ++k) {
    std::string pick;
    double pick_sum = std::numeric_limits<double>::infinity();
    for (const auto& [name, v] : sum)
      if (const double others = v - fixed[k].at(name); others < pick_sum) pick_sum = others, pick = name;
    loo_sum += fixed[k].at(pick);
    ++loo_names[pick];
  }
  std::string names;
  for (const auto& [name, c] : loo_names) names += (names.empty() ? "" : " ") + name + " " + std::to_string(c);
  const double se = std::sqrt(var_d / double(n));
  char b[400];
  std::snprintf(b, sizeof b,
                "mean chosen %.3f px, best fixed on average %s %.3f px: %.2f (chosen - it %+.3f +- %.3f px, t %.2f); "
                "fixed without hindsight (%s) %.3f px: %.2f",
                chosen_sum / double(n), best.c_str(), best_sum / double(n), chosen_sum / best_sum, mean_d, se,
                se > 0 ? mean_d / se : 0.0, names.c_str(), loo_sum / double(n), chosen_sum / loo_sum);
  return b;
}

// Lenses for the halves' agreement (docs/calibration.md, "A choice that holds"): a wide
// plumb_bob-like lens (94 deg across), the 190 deg Kannala-Brandt fisheye and a Mei
// (unified model) fisheye, with where their boards go.
struct HalvesLens {
  const char* name;
  CameraModel truth;
  double max_theta, distance;
};
std::vector<HalvesLens> halves_lenses() {
  return {{"wide plumb_bob", {"LENSMODEL_OPENCV5", {600, 601, 639.2, 481.7, -0.28, 0.09, 4e-4, -3e-4, -0.012}, 1280, 960}, 38, 800},
          {"Kannala-Brandt 190 deg", kb190(), 80, 600},
          {"Mei xi 1.1", {"LENSMODEL_OMNIDIR_MEI", {540, 541, 640.5, 479.5, 1.1, -0.05, 0.01, 0, 0}, 1280, 960}, 75, 600}};
}

// Two disjoint halves (odd / even views) calibrated apart: how far the chosen models of the
// two halves are apart (median projection difference over the area the boards of both
// halves covered, rotation fitted out), against the same for every fixed family (each half's table
// row of that family) and the best of those.
struct HalvesOutcome {
  std::string pick[2], before[2];  // chosen by the rule, and by the simplest-within-noise rule
  double chosen_px = 0, before_px = 0, best_fixed_px = 0;
  std::string best_fixed;
  std::map<std::string, double> fixed_px;
};
// split_seed 0: odd / even views; otherwise a balanced random split from that seed (the
// halves' sizes as odd / even's), so that one set gives several disjoint pairs of halves.
HalvesOutcome calibrate_halves(const Corners& views, const BoardSpec& board, int width, int height,
                               const CalibrateOptions& o, bool verbose, unsigned split_seed = 0) {
  std::vector<size_t> order(views.size());
  std::iota(order.begin(), order.end(), size_t(0));
  if (split_seed != 0) std::shuffle(order.begin(), order.end(), std::mt19937(split_seed));
  Corners half[2];
  for (size_t i = 0; i < views.size(); ++i) half[i % 2].push_back(views[order[i]]);
  CalibrationResult r[2];
  for (int h = 0; h < 2; ++h) r[h] = calibrate(half[h], board, width, height, o);
  const auto mask = covered(views, width, height);
  auto row = [&](int h, const std::string& name) -> const ModelCandidate& {
    for (const auto& c : r[h].table)
      if (c.name == name) return c;
    throw std::runtime_error("no row " + name);
  };
  auto apart = [&](const ModelCandidate& a, const ModelCandidate& b) {
    if (!a.ok || !b.ok) return std::numeric_limits<double>::infinity();
    const ProjectionDiff d = projection_difference(a.model, b.model, mask, 4);
    return d.samples > 0 ? d.median_px : std::numeric_limits<double>::infinity();
  };
  HalvesOutcome out;
  out.best_fixed_px = std::numeric_limits<double>::infinity();
  for (const auto& c : r[0].table) {
    const double d = apart(c, row(1, c.name));
    out.fixed_px[c.name] = d;
    if (d < out.best_fixed_px) out.best_fixed_px = d, out.best_fixed = c.name;
  }
  for (int h = 0; h < 2; ++h) out.pick[h] = r[h].selected, out.before[h] = r[h].simplest_within_noise;
  out.chosen_px = apart(row(0, out.pick[0]), row(1, out.pick[1]));
  out.before_px = apart(row(0, out.before[0]), row(1, out.before[1]));
  if (verbose)
    for (int h = 0; h < 2; ++h) {
      std::printf("    half %d (%zu views, field %.1f deg): %s; before %s\n", h, half[h].size(),
                  r[h].selection_field_deg, r[h].selected.c_str(), r[h].simplest_within_noise.c_str());
      for (const auto& c : r[h].table) {
        if (!c.ok || c.heldout_splits_px.empty()) {
          std::printf("      %-32s p%-3d rms %.3f cv %.3f%s\n", c.name.c_str(), c.params, c.rms_px,
                      c.cross_validation_px, c.ok ? " (not cross-validated)" : (" failed: " + c.error).c_str());
          continue;
        }
        std::string cv, ho;
        for (double x : c.cross_validation_splits_px) cv += fmt_px(x);
        for (double x : c.heldout_splits_px) ho += fmt_px(x);
        std::printf("      %-32s p%-3d cv[%s] ho[%s] wins %d gain %.4f se %.4f cv gain %.4f se %.4f%s\n",
                    c.name.c_str(), c.params, cv.c_str(), ho.c_str(), c.split_wins, c.challenge_gain_px,
                    c.challenge_se_px, c.challenge_cv_gain_px, c.challenge_cv_se_px, c.outfitted ? " (outfitted)" : (c.within_noise ? " (within)" : ""));
      }
    }
  return out;
}

// The measurement of docs/calibration.md ("A choice that holds"): lenses x set sizes x noise
// draws, each set calibrated in two disjoint halves; the chosen pair's agreement against the
// best fixed family's, with the incumbent rule and the simplest-within-noise rule of before.
//   LP_HALVES_VIEWS=8,16,32 LP_HALVES_SEEDS=4 LP_HALVES_NOISE=0.2 LP_HALVES_VERBOSE=1 (LP_HALVES_OUTFIT=0: no
//   outfitting; LP_HALVES_SMALL_SET=0: 4 splits for small sets too; LP_HALVES_WARP=on|off|auto)
//   calib_tests --gtest_also_run_disabled_tests --gtest_filter='ModelSelection.DISABLED_HalvesAgree'
TEST(ModelSelection, DISABLED_HalvesAgree) {
  std::vector<int> sizes;
  {
    const char* e = std::getenv("LP_HALVES_VIEWS");
    std::string s = e ? e : "8,16,32";
    for (size_t p = 0; p < s.size();) {
      sizes.push_back(std::atoi(s.c_str() + p));
      p = s.find(',', p);
      if (p == std::string::npos) break;
      ++p;
    }
  }
  const int seeds = std::getenv("LP_HALVES_SEEDS") ? std::atoi(std::getenv("LP_HALVES_SEEDS")) : 3;
  const double noise = std::getenv("LP_HALVES_NOISE") ? std::atof(std::getenv("LP_HALVES_NOISE")) : 0.2;
  const bool verbose = std::getenv("LP_HALVES_VERBOSE") != nullptr;
  const char* only = std::getenv("LP_HALVES_LENS");
  CalibrateOptions o;
  o.leverage = false;
  o.uncertainty = false;
  if (const char* f = std::getenv("LP_HALVES_OUTFIT")) o.selection_outfit_factor = std::atof(f);  // 0: off
  if (const char* k = std::getenv("LP_HALVES_CV_SPLITS")) o.cv_splits = std::atoi(k);
  if (const char* k = std::getenv("LP_HALVES_SMALL_SET")) o.selection_small_set_views = std::atoi(k);  // 0: off
  if (const char* w = std::getenv("LP_HALVES_WARP")) {  // on (default), off, auto
    o.board_warp = std::string(w) != "off";
    o.board_warp_auto = std::string(w) == "auto";
  }
  std::printf("| lens | views | draws | halves differ: before / now | chosen / best fixed, median: before / now | worst: before / now |\n");
  for (const HalvesLens& lens : halves_lenses()) {
    if (only && std::string(lens.name).find(only) == std::string::npos) continue;
    for (int n : sizes) {
      int flips[2] = {0, 0};
      std::vector<double> ratio[2];
      // Over the draws: the chosen pairs' mean agreement against each fixed family's mean (the
      // best single family fixed in advance, rather than the best of each draw in hindsight).
      std::vector<double> chosen;
      std::vector<std::map<std::string, double>> fixed;
      for (int seed = 1; seed <= seeds; ++seed) {
        const Corners views = project_board_views(lens.truth, kBoard, n, lens.max_theta, lens.distance, noise, seed);
        const auto t0 = std::chrono::steady_clock::now();
        const HalvesOutcome h = calibrate_halves(views, kBoard, lens.truth.width, lens.truth.height, o, verbose);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        flips[0] += h.before[0] != h.before[1];
        flips[1] += h.pick[0] != h.pick[1];
        ratio[0].push_back(h.before_px / h.best_fixed_px);
        ratio[1].push_back(h.chosen_px / h.best_fixed_px);
        chosen.push_back(h.chosen_px);
        fixed.push_back(h.fixed_px);
        std::printf("  %s, %d views (%zu placed), seed %d: before %s | %s %.3f px; now %s | %s %.3f px; best fixed %s %.3f px (%.1f s)\n",
                    lens.name, n, views.size(), seed, h.before[0].c_str(), h.before[1].c_str(), h.before_px,
                    h.pick[0].c_str(), h.pick[1].c_str(), h.chosen_px, h.best_fixed.c_str(), h.best_fixed_px, s);
      }
      auto med = [](std::vector<double> v) { return median_of(v); };
      auto worst = [](const std::vector<double>& v) { return *std::max_element(v.begin(), v.end()); };
      std::printf("| %s | %d | %d | %d / %d | %.2f / %.2f | %.2f / %.2f | %s |\n", lens.name, n, seeds, flips[0],
                  flips[1], med(ratio[0]), med(ratio[1]), worst(ratio[0]), worst(ratio[1]),
                  against_fixed(chosen, fixed).c_str());
      std::fflush(stdout);
    }
  }
}

// The same on the shared real sets: every view with a board, odd / even in the images'
// natural order (Fisheye1_2 before Fisheye1_10).
//   calib_tests --gtest_also_run_disabled_tests --gtest_filter='ModelSelection.DISABLED_HalvesAgreeOnRealSets'
TEST(ModelSelection, DISABLED_HalvesAgreeOnRealSets) {
  const char* only = std::getenv("LP_HALVES_SET");
  CalibrateOptions o;
  o.leverage = false;
  o.uncertainty = false;
  if (const char* f = std::getenv("LP_HALVES_OUTFIT")) o.selection_outfit_factor = std::atof(f);  // 0: off
  if (const char* k = std::getenv("LP_HALVES_CV_SPLITS")) o.cv_splits = std::atoi(k);
  if (const char* k = std::getenv("LP_HALVES_SMALL_SET")) o.selection_small_set_views = std::atoi(k);  // 0: off
  if (const char* w = std::getenv("LP_HALVES_WARP")) {  // on (default), off, auto
    o.board_warp = std::string(w) != "off";
    o.board_warp_auto = std::string(w) == "auto";
  }
  for (const calib_test::RealSet& set : calib_test::real_sets()) {
    if (only && std::string(set.name).find(only) == std::string::npos) continue;
    const calib_test::RealSetViews rs = calib_test::real_set_views(set);
    if (rs.views.empty()) GTEST_SKIP() << "no images in " << set.dir;
    const Corners& views = rs.views;
    const auto t0 = std::chrono::steady_clock::now();
    const CalibrationResult full = calibrate(views, set.board, rs.width, rs.height, o);
    std::printf("  %s, all %zu views: %s (before: %s), field %.1f deg, wins:", set.name, views.size(),
                full.selected.c_str(), full.simplest_within_noise.c_str(), full.selection_field_deg);
    for (const auto& c : full.table)
      if (c.split_wins > 0) std::printf(" %s %d/%d", c.name.c_str(), c.split_wins, full.cv_splits);
    std::printf("\n");
    // LP_HALVES_SPLITS = K: odd / even and K - 1 balanced random splits (seeds 1 ..), and over
    // them the chosen pairs' mean agreement against each fixed family's mean.
    const int splits = std::max(1, std::getenv("LP_HALVES_SPLITS") ? std::atoi(std::getenv("LP_HALVES_SPLITS")) : 1);
    std::vector<double> chosen;
    std::vector<std::map<std::string, double>> fixed_all;
    int same = 0;
    const int first = std::getenv("LP_HALVES_FIRST_SPLIT") ? std::atoi(std::getenv("LP_HALVES_FIRST_SPLIT")) : 0;
    const bool verbose = splits == 1 || std::getenv("LP_HALVES_VERBOSE") != nullptr;
    for (int k = first; k < first + splits; ++k) {
      const HalvesOutcome h = calibrate_halves(views, set.board, rs.width, rs.height, o, verbose, unsigned(k));
      std::string fixed;
      for (const auto& [n, d] : h.fixed_px) fixed += n + " " + fmt_px(d) + ";";
      chosen.push_back(h.chosen_px);
      fixed_all.push_back(h.fixed_px);
      same += h.pick[0] == h.pick[1];
      std::printf("| %s | %zu | split %d | %s / %s | %.3f | %s / %s | %.3f | %s %.3f | (%.1f s) fixed: %s\n", set.name,
                  views.size(), k, h.before[0].c_str(), h.before[1].c_str(), h.before_px, h.pick[0].c_str(),
                  h.pick[1].c_str(), h.chosen_px, h.best_fixed.c_str(), h.best_fixed_px,
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), fixed.c_str());
      std::fflush(stdout);
    }
    if (splits > 1) {
      std::printf("| %s | %d splits | halves chose one model %d / %d | %s |\n", set.name, splits, same, splits,
                  against_fixed(chosen, fixed_all).c_str());
      std::fflush(stdout);
    }
  }
}

// A fitted candidate with measured per-split held-out RMS and cross-validation (the tables
// of the incumbent rule's tests).
ModelCandidate measured_candidate(const char* name, int params, std::vector<double> heldout, std::vector<double> cv) {
  ModelCandidate c;
  c.name = name;
  c.params = params;
  c.ok = true;
  c.heldout_splits_px = std::move(heldout);
  c.cross_validation_splits_px = std::move(cv);
  return c;
}

// The incumbent rule picks the first candidate (family, then parameters) that no later one
// beats, whatever the order of the challenges. The table is the one measured on the first
// half (4 views, 3 splits) of the shared Fisheye190deg set: Mei beats the stereographic model
// (held-out gain 1.40 +- 0.15 px), Kannala-Brandt does not (one split's held-out RMS diverged,
// and its cross-validation gain is within t(2) = 4.3 standard errors), and Mei does not beat
// Kannala-Brandt. A chain of challenges picked Mei (the other half picked Kannala-Brandt:
// 2.0 px apart, against 0.15 px for Kannala-Brandt on both).
TEST(ModelSelection, ThePickIsTheSimplestCandidateNoLaterOneBeats) {
  std::vector<ModelCandidate> table = {
      measured_candidate("LENSMODEL_STEREOGRAPHIC", 4, {2.075, 1.539, 1.872}, {3.695, 9.455, 6.326}),
      measured_candidate("LENSMODEL_KANNALA_BRANDT", 8, {237356.332, 1.045, 1.181}, {2.686, 1.845, 1.631}),
      measured_candidate("LENSMODEL_OPENCV8", 12, {0.610, 2.681, 0.599}, {0.857, 5.803, 0.655}),
      measured_candidate("LENSMODEL_OMNIDIR_MEI", 9, {0.476, 0.436, 0.374}, {0.611, 7.305, 3.568})};
  const std::vector<char> eligible(table.size(), 1);
  const size_t pick = incumbent_pick(table, eligible, false);
  ASSERT_LT(pick, table.size());
  EXPECT_EQ(table[pick].name, "LENSMODEL_KANNALA_BRANDT");
  // Reported against the pick: Mei's held-out gain is the diverged split's (~79 000 px) with
  // as large a standard error, not a win.
  EXPECT_NEAR(table[3].challenge_gain_px, (237356.332 - 0.476 + 1.045 - 0.436 + 1.181 - 0.374) / 3, 1e-6);
  EXPECT_TRUE(std::isnan(table[pick].challenge_gain_px));
  // The order of the table does not matter.
  std::vector<ModelCandidate> reversed(table.rbegin(), table.rend());
  EXPECT_EQ(reversed[incumbent_pick(reversed, eligible, false)].name, "LENSMODEL_KANNALA_BRANDT");
  // A Mei clearly better than Kannala-Brandt on every split (and no diverged split) is the pick.
  table[3].heldout_splits_px = {0.30, 0.28, 0.29};
  table[3].cross_validation_splits_px = {0.40, 0.42, 0.41};
  table[1].heldout_splits_px = {1.10, 1.045, 1.181};
  EXPECT_EQ(table[incumbent_pick(table, eligible, false)].name, "LENSMODEL_OMNIDIR_MEI");
}

// A candidate that another fits 1.2x worse on every split, and that repeats no better on
// most, takes no part (SelectionOptions::outfit_factor). Two measured tables: the half of the
// shared 190-degree set (random split 5, 4 views, 3 splits) where the stereographic model
// stood as the pick (Kannala-Brandt, next in the family order, could not beat it: one split
// of it diverged), 17 px from the other half's Kannala-Brandt; and a half of the stereo set
// (odd/even, 6 views, 4 splits), where comparing plumb_bob with the best of each split (the
// least of six noisy values, from Kannala-Brandt on two splits and Mei on two) instead of
// with one candidate outfitted it, and Kannala-Brandt, 0.38 px from the other half's
// plumb_bob, became the pick.
TEST(ModelSelection, ACandidateOutfittedOnEverySplitIsNotThePick) {
  std::vector<ModelCandidate> fisheye = {
      measured_candidate("LENSMODEL_STEREOGRAPHIC", 4, {1.326, 1.308, 1.788}, {2.936, 0.654, 5.035}),
      measured_candidate("plumb_bob", 9, {7.564, 7.525, 19.839}, {1.441, 4.535, 90.729}),
      measured_candidate("LENSMODEL_KANNALA_BRANDT", 8, {1.178, 0.922, 302571.142}, {1.728, 1.025, 3.680}),
      measured_candidate("LENSMODEL_OPENCV8", 12, {1.089, 1.068, 0.800}, {2.805, 2.683, 1.114}),
      measured_candidate("LENSMODEL_SPLINED_STEREOGRAPHIC", 100, {0.843, 1.099, 1.110}, {2.165, 1.561, 9.757})};
  const std::vector<char> all5(fisheye.size(), 1);
  EXPECT_EQ(fisheye[incumbent_pick(fisheye, all5, false)].name, "LENSMODEL_KANNALA_BRANDT");
  EXPECT_TRUE(fisheye[0].outfitted);   // OpenCV8 fits it 1.22-2.2x better, repeats better on 2 of 3
  EXPECT_TRUE(fisheye[1].outfitted);
  EXPECT_FALSE(fisheye[2].outfitted);  // the diverged split is one of three
  EXPECT_FALSE(fisheye[3].outfitted);
  EXPECT_FALSE(fisheye[4].outfitted);
  SelectionOptions off;
  off.outfit_factor = 0;
  EXPECT_EQ(fisheye[incumbent_pick(fisheye, all5, false, off)].name, "LENSMODEL_STEREOGRAPHIC");
  EXPECT_FALSE(fisheye[0].outfitted);
  // Just below the factor on one split, the stereographic model stays.
  SelectionOptions strict;
  strict.outfit_factor = 1.25;
  EXPECT_EQ(fisheye[incumbent_pick(fisheye, all5, false, strict)].name, "LENSMODEL_STEREOGRAPHIC");

  std::vector<ModelCandidate> stereo = {
      measured_candidate("LENSMODEL_STEREOGRAPHIC", 4, {0.437, 0.437, 0.652, 0.553}, {1.351, 0.486, 5.617, 3.210}),
      measured_candidate("plumb_bob", 9, {0.285, 0.290, 0.330, 0.441}, {0.641, 1.621, 1.575, 1.328}),
      measured_candidate("LENSMODEL_KANNALA_BRANDT", 8, {0.216, 0.237, 0.464, 0.369}, {0.178, 0.536, 1.842, 0.498}),
      measured_candidate("LENSMODEL_OPENCV8", 12, {0.277, 0.510, 0.461, 0.414}, {0.781, 1.580, 1.650, 1.603}),
      measured_candidate("LENSMODEL_SPLINED_STEREOGRAPHIC", 100, {0.281, 0.319, 0.558, 0.379}, {1.146, 0.427, 2.084, 2.573}),
      measured_candidate("LENSMODEL_OMNIDIR_MEI", 9, {0.252, 0.260, 0.250, 0.253}, {0.630, 1.765, 1.169, 1.346})};
  const std::vector<char> all6(stereo.size(), 1);
  EXPECT_EQ(stereo[incumbent_pick(stereo, all6, true)].name, "plumb_bob");
  EXPECT_FALSE(stereo[1].outfitted);  // Mei fits it 1.13-1.74x better: not 1.2x on every split
  EXPECT_TRUE(stereo[0].outfitted);
}

// The race (SelectionOptions::race_dear_candidates) stops a candidate's splits only when the
// rest cannot change the pick. The rows are the stereo left set's (4 splits; plumb_bob the
// pick), the spline's first two splits worse than plumb_bob's in both statistics.
TEST(ModelSelection, ARacedCandidateStopsOnlyWhenItCannotChangeThePick) {
  std::vector<ModelCandidate> table = {
      measured_candidate("plumb_bob", 9, {0.183, 0.188, 0.198, 0.192}, {0.119, 0.146, 0.558, 0.876}),
      measured_candidate("LENSMODEL_KANNALA_BRANDT", 8, {0.197, 0.341, 0.237, 0.342}, {0.756, 0.335, 1.072, 0.328}),
      measured_candidate("LENSMODEL_OMNIDIR_MEI", 9, {0.182, 0.188, 0.211, 0.195}, {0.134, 0.146, 0.590, 0.858}),
      measured_candidate("LENSMODEL_SPLINED_STEREOGRAPHIC", 100, {0.191, 0.213}, {0.539, 0.401})};
  const std::vector<char> eligible = {1, 1, 1, 0};  // the spline's row is short: not in the rule yet
  std::vector<ModelCandidate> trial = table;
  const size_t pick = incumbent_pick(trial, eligible, true);
  ASSERT_EQ(pick, 0u);
  const ModelCandidate spline = table[3];
  // Worse on 2 of 4 in both: at best 2 of 4 better, not most.
  EXPECT_TRUE(cannot_change_pick(spline, table, pick, 4, true));
  // With one split only it could still be better on 3 of 4.
  ModelCandidate one = spline;
  one.heldout_splits_px.resize(1);
  one.cross_validation_splits_px.resize(1);
  EXPECT_FALSE(cannot_change_pick(one, table, pick, 4, true));
  // Better on one of its two splits in either statistic: 3 of 4 still possible.
  ModelCandidate close = spline;
  close.heldout_splits_px[1] = 0.187;
  EXPECT_FALSE(cannot_change_pick(close, table, pick, 4, true));
  close = spline;
  close.cross_validation_splits_px[0] = 0.100;
  EXPECT_FALSE(cannot_change_pick(close, table, pick, 4, true));
  // With 8 splits, two lost ones leave 6 to win.
  EXPECT_FALSE(cannot_change_pick(spline, table, pick, 8, true));
  // Before the pick in the rule's order (the wide-angle family first): never stopped early.
  EXPECT_FALSE(cannot_change_pick(table[1], table, 2, 4, false));
  // Outfitting. Wide-angle family first: Kannala-Brandt is the pick, having beaten the
  // stereographic model, and so has Mei. A spline lower than Mei's held-out RMS by the outfit
  // factor on its splits could take Mei out of the rule, which may change what beats the
  // stereographic model: not stopped.
  std::vector<ModelCandidate> wide = {
      measured_candidate("LENSMODEL_STEREOGRAPHIC", 4, {1.00, 1.00, 1.00, 1.00}, {2.00, 2.00, 2.00, 2.00}),
      measured_candidate("LENSMODEL_KANNALA_BRANDT", 8, {0.20, 0.21, 0.20, 0.21}, {0.30, 0.31, 0.30, 0.31}),
      measured_candidate("LENSMODEL_OMNIDIR_MEI", 9, {0.40, 0.41, 0.42, 0.40}, {0.50, 0.52, 0.51, 0.50}),
      measured_candidate("LENSMODEL_SPLINED_STEREOGRAPHIC", 100, {0.25, 0.26}, {0.60, 0.60})};
  trial = wide;
  const size_t kb = incumbent_pick(trial, {1, 1, 1, 0}, false);
  ASSERT_EQ(kb, 1u);
  EXPECT_FALSE(cannot_change_pick(wide[3], wide, kb, 4, false));
  SelectionOptions no_outfit;
  no_outfit.outfit_factor = 0;
  EXPECT_TRUE(cannot_change_pick(wide[3], wide, kb, 4, false, no_outfit));
  // A Mei that beats nothing up to the pick may be outfitted: nothing changes.
  wide[2].heldout_splits_px = {1.10, 1.10, 1.10, 1.10};
  wide[2].cross_validation_splits_px = {2.50, 2.50, 2.50, 2.50};
  EXPECT_TRUE(cannot_change_pick(wide[3], wide, kb, 4, false));
}

// A calibration prints nothing of its own on stderr. Five of Ladybug's views make some Ceres
// solve meet a singular system, which Ceres reported as glog warnings (6-11 lines) until the
// plugin raised glog's threshold to errors. ~1 s.
TEST(ModelSelection, SolvesOnAFewViewsLeaveStderrQuiet) {
  const calib_test::RealSet set = calib_test::real_sets()[3];
  ASSERT_EQ(std::string(set.name), "Ladybug");
  const calib_test::RealSetViews rs = calib_test::real_set_views(set);
  if (rs.views.empty()) GTEST_SKIP() << "no images in " << set.dir;
  ASSERT_EQ(rs.views.size(), 9u);
  std::vector<std::vector<std::array<double, 2>>> five;
  for (size_t i : {0, 1, 5, 6, 8}) five.push_back(rs.views[i]);
  testing::internal::CaptureStderr();
  const CalibrationResult r = calibrate(five, set.board, rs.width, rs.height, {});
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_FALSE(r.selected.empty());
  EXPECT_EQ(err, "");
}

// A forced Mei on a narrow lens (the stereo camera, corners to 30 deg): from the unit-xi seed
// a half's refinement walked xi across -1 and on to -4e7 (focal length -2e10 px), and the
// command failed with "no covered pixel both half-models can image" while the automatic
// choice fitted Mei fine; on the right camera a half walked off yet still imaged a few
// pixels, and its cross-validation was that half's. Such a fit is now solved again from the
// Kannala-Brandt fit, as the selection seeds Mei there. ~3 s.
TEST(ModelSelection, AForcedMeiOnANarrowLensIsFittedAsTheSelectionFitsIt) {
  for (const size_t k : {0, 1}) {
    const calib_test::RealSet set = calib_test::real_sets()[k];
    const calib_test::RealSetViews rs = calib_test::real_set_views(set);
    if (rs.views.empty()) GTEST_SKIP() << "no images in " << set.dir;
    CalibrateOptions o;
    o.leverage = false;
    o.uncertainty = false;
    const CalibrationResult automatic = calibrate(rs.views, set.board, rs.width, rs.height, o);
    o.model = "LENSMODEL_OMNIDIR_MEI";
    const CalibrationResult forced = calibrate(rs.views, set.board, rs.width, rs.height, o);
    ASSERT_EQ(forced.table.size(), 1u) << set.name;
    const ModelCandidate& m = forced.table[0];
    ASSERT_TRUE(m.ok) << set.name << ": " << m.error;
    const double xi = m.model.intrinsics[4];
    EXPECT_GT(xi, -1) << set.name;
    EXPECT_LT(xi, 1e3) << set.name;  // xi is barely observable here: 15.7 on the right camera, as the selection's
    EXPECT_GT(m.model.intrinsics[0], 0) << set.name;
    for (const ModelCandidate& c : automatic.table)
      if (c.name == "LENSMODEL_OMNIDIR_MEI") {
        EXPECT_NEAR(m.rms_px, c.rms_px, 1e-4) << set.name;
        EXPECT_NEAR(m.cross_validation_px, c.cross_validation_px, 0.02) << set.name;
      }
  }
}

// The race on a real set: the same pick and the same numbers as every split of every
// candidate, at fewer refits; the raced rows hold the first splits of the full rows. ~3 s.
TEST(ModelSelection, RacingGivesThePickOfEverySplitOnTheStereoSet) {
  CalibrateOptions o;
  o.leverage = false;
  o.uncertainty = false;
  const calib_test::RealSet set = calib_test::real_sets()[0];
  ASSERT_EQ(std::string(set.name), "stereo left");
  const calib_test::RealSetViews rs = calib_test::real_set_views(set);
  if (rs.views.empty()) GTEST_SKIP() << "no images in " << set.dir;
  const CalibrationResult raced = calibrate(rs.views, set.board, rs.width, rs.height, o);
  o.selection_race_dear_candidates = false;
  const CalibrationResult full = calibrate(rs.views, set.board, rs.width, rs.height, o);
  EXPECT_EQ(raced.selected, full.selected);
  EXPECT_EQ(raced.model.intrinsics, full.model.intrinsics);
  ASSERT_EQ(raced.table.size(), full.table.size());
  std::string raced_out;
  for (size_t i = 0; i < raced.table.size(); ++i) {
    const ModelCandidate &a = raced.table[i], &b = full.table[i];
    EXPECT_FALSE(b.raced_out) << b.name;
    if (a.raced_out) raced_out += " " + a.name + " " + std::to_string(a.heldout_splits_px.size());
    if (!a.raced_out) {
      EXPECT_EQ(a.heldout_splits_px.size(), b.heldout_splits_px.size()) << a.name;
    } else {
      EXPECT_LT(a.heldout_splits_px.size(), b.heldout_splits_px.size()) << a.name;
      EXPECT_TRUE(std::isnan(a.cross_validation_repeated_px)) << a.name;
    }
    ASSERT_LE(a.heldout_splits_px.size(), b.heldout_splits_px.size()) << a.name;
    // (OpenCV8's seed is not bit-reproducible between calls, docs/calibration.md "Determinism".)
    const double tol = a.name == "LENSMODEL_OPENCV8" ? 1e-6 : 0;
    for (size_t k = 0; k < a.heldout_splits_px.size(); ++k) {
      EXPECT_NEAR(a.heldout_splits_px[k], b.heldout_splits_px[k], tol * b.heldout_splits_px[k]) << a.name << " " << k;
      EXPECT_NEAR(a.cross_validation_splits_px[k], b.cross_validation_splits_px[k],
                  tol * b.cross_validation_splits_px[k])
          << a.name << " " << k;
    }
  }
  std::printf("  raced out:%s\n", raced_out.c_str());
  // The spline loses to plumb_bob on the first two splits in both statistics.
  EXPECT_EQ(raced_out, " LENSMODEL_SPLINED_STEREOGRAPHIC 2");
}

// The halves of the shared 190-degree set (4 + 4 views) choose one family and agree as well
// as the best fixed one (they chose Mei and Kannala-Brandt under the chain of challenges,
// 2.0 px apart against 0.15). ~3 s.
TEST(ModelSelection, TheHalvesOfTheShared190DegreeSetChooseOneFamily) {
  CalibrateOptions o;
  o.leverage = false;
  o.uncertainty = false;
  for (const calib_test::RealSet& set : calib_test::real_sets()) {
    if (std::string(set.name) != "Fisheye190deg") continue;
    const calib_test::RealSetViews rs = calib_test::real_set_views(set);
    if (rs.views.empty()) GTEST_SKIP() << "no images in " << set.dir;
    const HalvesOutcome h = calibrate_halves(rs.views, set.board, rs.width, rs.height, o, true);
    EXPECT_EQ(h.pick[0], h.pick[1]);
    EXPECT_LE(h.chosen_px, 1.05 * h.best_fixed_px) << h.pick[0] << " / " << h.pick[1] << ": " << h.chosen_px
                                                    << " px against " << h.best_fixed << " " << h.best_fixed_px;
    return;
  }
  FAIL() << "the Fisheye190deg set is not among the real sets";
}

// Six disjoint pairs of halves of the shared 190-degree set (odd / even and five random
// balanced splits, 4 + 4 views): the chosen pairs agree on average as well as the best single
// family fixed in advance (Kannala-Brandt). Measured: 0.543 px against 0.556; without the
// outfitting (SelectionOptions::outfit_factor) 3.28 px, one half keeping a stereographic
// model 17 px from the other's Kannala-Brandt. ~6 s.
TEST(ModelSelection, SixPairsOfHalvesOfTheShared190DegreeSetAgreeAsTheBestFixedFamily) {
  CalibrateOptions o;
  o.leverage = false;
  o.uncertainty = false;
  for (const calib_test::RealSet& set : calib_test::real_sets()) {
    if (std::string(set.name) != "Fisheye190deg") continue;
    const calib_test::RealSetViews rs = calib_test::real_set_views(set);
    if (rs.views.empty()) GTEST_SKIP() << "no images in " << set.dir;
    double chosen = 0;
    std::map<std::string, double> fixed;
    for (unsigned k = 0; k < 6; ++k) {
      const HalvesOutcome h = calibrate_halves(rs.views, set.board, rs.width, rs.height, o, false, k);
      std::printf("  split %u: %s / %s %.3f px; best fixed %s %.3f px\n", k, h.pick[0].c_str(), h.pick[1].c_str(),
                  h.chosen_px, h.best_fixed.c_str(), h.best_fixed_px);
      chosen += h.chosen_px;
      for (const auto& [name, d] : h.fixed_px) fixed[name] += d;
    }
    double best = std::numeric_limits<double>::infinity();
    for (const auto& [name, sum] : fixed) best = std::min(best, sum);
    EXPECT_LE(chosen, 1.1 * best) << "mean " << chosen / 6 << " px against the best fixed family's " << best / 6;
    return;
  }
  FAIL() << "the Fisheye190deg set is not among the real sets";
}

// A set of at most 12 views is split 8 times, a larger one 4 times (SelectionOptions::
// small_set_views). On the shared VMRImage set's random split 1 (5 + 5 views) one half kept
// Kannala-Brandt, the first of the wide-angle family, though Mei fitted the held-out corners
// better on all 4 splits (t = 2.7 against t(3) = 3.18): 2.87 px from the other half's Mei.
// With 8 splits it picks Mei: 1.28 px, Mei's own agreement. ~10 s.
TEST(ModelSelection, SmallSetsAreSplitMoreOften) {
  CalibrateOptions o;
  o.leverage = false;
  o.uncertainty = false;
  const CameraModel truth = kb190();
  EXPECT_EQ(calibrate(project_board_views(truth, kBoard, 10, 80, 600, 0.2, 1), kBoard, truth.width, truth.height, o).cv_splits, 8);
  EXPECT_EQ(calibrate(project_board_views(truth, kBoard, 14, 80, 600, 0.2, 1), kBoard, truth.width, truth.height, o).cv_splits, 4);
  for (const calib_test::RealSet& set : calib_test::real_sets()) {
    if (std::string(set.name) != "VMRImage") continue;
    const calib_test::RealSetViews rs = calib_test::real_set_views(set);
    if (rs.views.empty()) GTEST_SKIP() << "no images in " << set.dir;
    const HalvesOutcome h = calibrate_halves(rs.views, set.board, rs.width, rs.height, o, false, 1);
    EXPECT_EQ(h.pick[0], "LENSMODEL_OMNIDIR_MEI");
    EXPECT_EQ(h.pick[1], "LENSMODEL_OMNIDIR_MEI");
    EXPECT_LE(h.chosen_px, 1.05 * h.fixed_px.at("LENSMODEL_OMNIDIR_MEI")) << h.chosen_px;
    CalibrateOptions four = o;
    four.selection_small_set_views = 0;
    const HalvesOutcome f = calibrate_halves(rs.views, set.board, rs.width, rs.height, four, false, 1);
    EXPECT_NE(f.pick[0], f.pick[1]) << "the measured case no longer needs the extra splits";
    return;
  }
  FAIL() << "the VMRImage set is not among the real sets";
}

// The choice on every shared real set (docs/calibration.md "Real sets" and "Selection at the
// cost of one solve"), as the selection made it before candidates were screened and solved
// in parallel: a screening that drops the right model, or a parallel solve that changes a
// number the rule reads, fails here. ~40 s on the shared 2-core machine.
// The same lens behind five times the pixels each way (a 5160x3890 camera; corners and their
// noise 5x, in its pixels): the choice is the one made at 1032 px. With the fit limits fixed
// at 1.5 px RMS and 5 px of cross-validation whatever the image, Kannala-Brandt (1.87 px
// RMS here) and every other parametric model was screened out, and the least bad model was
// ranked with a "no model fits" warning.
TEST(ModelSelection, FiveTimesThePixelsChooseAsTheLensAtItsOwnSize) {
  const calib_test::RealSet set = calib_test::real_sets()[2];
  ASSERT_EQ(std::string(set.name), "fisheye1");
  const calib_test::RealSetViews rs = calib_test::real_set_views(set);
  if (rs.views.empty()) GTEST_SKIP() << "no images in " << set.dir;
  EXPECT_DOUBLE_EQ(pixel_limit_scale(rs.width, rs.height), 1.0);
  EXPECT_DOUBLE_EQ(pixel_limit_scale(5 * rs.width, 5 * rs.height), 5 * rs.width / 2048.0);
  CalibrateOptions o;
  o.leverage = false;
  o.uncertainty = false;
  const CalibrationResult own = calibrate(rs.views, set.board, rs.width, rs.height, o);
  std::vector<std::vector<std::array<double, 2>>> large = rs.views;
  for (auto& v : large)
    for (auto& p : v) p = {(p[0] + 0.5) * 5 - 0.5, (p[1] + 0.5) * 5 - 0.5};
  const CalibrationResult big = calibrate(large, set.board, 5 * rs.width, 5 * rs.height, o);
  std::printf("  own size: %s %.3f px; 5x: %s %.3f px%s\n", own.selected.c_str(), own.model.rms_reprojection_px,
              big.selected.c_str(), big.model.rms_reprojection_px, big.no_model_fits ? " (no model fits)" : "");
  EXPECT_EQ(own.selected, "LENSMODEL_KANNALA_BRANDT");
  EXPECT_EQ(big.selected, own.selected);
  EXPECT_FALSE(big.no_model_fits);
  EXPECT_NEAR(big.model.rms_reprojection_px, 5 * own.model.rms_reprojection_px, 0.05 * own.model.rms_reprojection_px);
}

TEST(ModelSelection, ChoiceOnTheSharedRealSetsHolds) {
  const std::map<std::string, std::string> expected = {
      {"stereo left", "plumb_bob"},
      {"stereo right", "plumb_bob"},
      {"fisheye1", "LENSMODEL_KANNALA_BRANDT"},
      {"Ladybug", "plumb_bob"},
      {"VMRImage", "LENSMODEL_OMNIDIR_MEI"},
      {"KaidanOmni", "LENSMODEL_OMNIDIR_MEI"},
      {"MiniOmni", "LENSMODEL_OMNIDIR_MEI"},
      {"Fisheye190deg", "LENSMODEL_KANNALA_BRANDT"}};
  // The outliers' reference model. Ties (OutlierOptions::reference_tie, 1 %) go to the
  // earlier reference: on fisheye1 Mei fits 0.16 % better than Kannala-Brandt, whose rounds
  // re-solve warm; on stereo and Ladybug the rational model, within 1 %, yields to Mei.
  const std::map<std::string, std::string> reference = {
      {"stereo left", "LENSMODEL_OMNIDIR_MEI"}, {"stereo right", "LENSMODEL_OMNIDIR_MEI"}, {"fisheye1", "LENSMODEL_KANNALA_BRANDT"}, {"Ladybug", "LENSMODEL_OMNIDIR_MEI"},
      {"VMRImage", "LENSMODEL_OMNIDIR_MEI"},
      {"KaidanOmni", "LENSMODEL_OMNIDIR_MEI"}, {"MiniOmni", "LENSMODEL_OMNIDIR_MEI"},
      {"Fisheye190deg", "LENSMODEL_KANNALA_BRANDT"}};
  // The richest models the race stopped early, with the splits they kept.
  const std::map<std::string, std::string> raced_out = {
      {"stereo left", " LENSMODEL_SPLINED_STEREOGRAPHIC 2"},
      {"stereo right", " LENSMODEL_SPLINED_STEREOGRAPHIC 3"},
      // fisheye1's rational model fits as Kannala-Brandt does since it also starts from
      // Kannala-Brandt's profile (0.372 px; 0.552 before, raced out after 2 splits): all 4.
      {"fisheye1", " LENSMODEL_SPLINED_STEREOGRAPHIC 2"},
      {"Ladybug", " LENSMODEL_OPENCV8 4 LENSMODEL_SPLINED_STEREOGRAPHIC 7"},
      {"VMRImage", " LENSMODEL_SPLINED_STEREOGRAPHIC 4"},
      {"KaidanOmni", " LENSMODEL_SPLINED_STEREOGRAPHIC 2"},
      {"MiniOmni", " LENSMODEL_SPLINED_STEREOGRAPHIC 2"},
      {"Fisheye190deg", " LENSMODEL_SPLINED_STEREOGRAPHIC 4"}};  // the rational model won a split: completed
  CalibrateOptions o;
  o.leverage = false;
  o.uncertainty = false;
  for (const calib_test::RealSet& set : calib_test::real_sets()) {
    const calib_test::RealSetViews rs = calib_test::real_set_views(set);
    if (rs.views.empty()) GTEST_SKIP() << "no images in " << set.dir;
    const CalibrationResult r = calibrate(rs.views, set.board, rs.width, rs.height, o);
    EXPECT_EQ(r.selected, expected.at(set.name)) << set.name;
    EXPECT_EQ(r.selection_rule, "incumbent") << set.name;
    EXPECT_EQ(r.outlier_reference, reference.at(set.name)) << set.name;
    // Mei's seed: from Kannala-Brandt on the narrow sets (their corners within 45 deg:
    // SolveOptions::mei_from_kannala_brandt), the unit-xi search on the wider ones (no
    // cv::omnidir: it poses every view of every set).
    const bool narrow = std::string(set.name).rfind("stereo", 0) == 0 || std::string(set.name) == "Ladybug";
    for (const ModelCandidate& c : r.table) {
      if (c.name == "LENSMODEL_OMNIDIR_MEI" && !c.solver.empty()) {
        EXPECT_EQ(c.solver.rfind(narrow ? "Kannala-Brandt fit" : "unit-xi search", 0), 0u) << set.name << ": " << c.solver;
      }
      // The stereographic seed: Mei's fit, which fits every shared set (stop 43). On VMRImage
      // the seed of before (Kannala-Brandt's 41 px misfit) left the stereographic fit 186 px
      // off; from Mei it fits.
      if (c.name == "LENSMODEL_STEREOGRAPHIC") {
        EXPECT_EQ(c.solver.rfind("LENSMODEL_OMNIDIR_MEI fit", 0), 0u) << set.name << ": " << c.solver;
        if (std::string(set.name) == "VMRImage") {
          EXPECT_LT(c.rms_px, o.fit_max_rms_px) << c.solver;
        }
      }
    }
    // The fits the candidate stage took over from the outlier stage instead of solving them
    // again (outlier_rejection.h: reference_fit, fits_from_sample), per set: the
    // reference's where its fit can stand, the other references' (and plumb_bob's) from the
    // reference sample where they fit it, the rational model's only where no corner was
    // flagged (none here). A path that silently stopped applying (e.g. the sample's views no
    // longer matched) would still choose the same models, only slower: this pins it.
    const std::map<std::string, std::string> carried = {
        {"stereo left", "plumb_bob sample, LENSMODEL_KANNALA_BRANDT sample, LENSMODEL_OMNIDIR_MEI carried"},
        {"stereo right", "plumb_bob sample, LENSMODEL_KANNALA_BRANDT sample, LENSMODEL_OMNIDIR_MEI carried"},
        {"fisheye1", "LENSMODEL_KANNALA_BRANDT carried, LENSMODEL_OMNIDIR_MEI sample"},
        {"Ladybug", "plumb_bob sample, LENSMODEL_KANNALA_BRANDT sample, LENSMODEL_OMNIDIR_MEI carried"},
        // Kannala-Brandt's fit of every view on this mirror fits since one view is posed
        // again (calibration_solve.cpp, repose_stuck_views): 447213 -> 0.344 px RMS.
        {"VMRImage", "LENSMODEL_KANNALA_BRANDT sample, LENSMODEL_OMNIDIR_MEI carried"},
        {"KaidanOmni", "LENSMODEL_OMNIDIR_MEI carried"},  // rounds warm on a mirror since stop 41
        {"MiniOmni", "LENSMODEL_OMNIDIR_MEI carried"},
        {"Fisheye190deg", "plumb_bob sample, LENSMODEL_KANNALA_BRANDT carried, LENSMODEL_OMNIDIR_MEI sample"}};
    std::string took_over;
    for (const ModelCandidate& c : r.table) {
      const char* how = c.solver.find(", carried from the outlier stage") != std::string::npos ? "carried"
                        : c.solver.find(", refined warm from the outlier stage's sample") != std::string::npos ? "sample"
                                                                                                                : nullptr;
      if (how) took_over += (took_over.empty() ? "" : ", ") + c.name + " " + how;
    }
    EXPECT_EQ(took_over, carried.at(set.name)) << set.name;
    // On the mirrors (corners seen to 102-120 deg under Mei) the perspective candidates are
    // not fitted (kPerspectiveFieldLimitDeg); elsewhere every screened one was fitted and missed.
    const bool mirror = std::string(set.name) == "VMRImage" || std::string(set.name) == "KaidanOmni" ||
                        std::string(set.name) == "MiniOmni";
    std::string screened;
    for (const ModelCandidate& c : r.table) {
      const bool perspective = is_perspective(candidate_lens_type(c.name));
      if (mirror && perspective) {
        EXPECT_TRUE(c.screened && std::isnan(c.rms_px)) << set.name << " " << c.name;
        EXPECT_NE(c.error.find("beyond a perspective model's reach"), std::string::npos) << set.name << " " << c.error;
      } else if (c.screened) {
        EXPECT_GT(c.rms_px, o.fit_max_rms_px) << set.name << " " << c.name;
      }
      if (c.screened) {
        screened += " " + c.name;
        EXPECT_NE(c.name, r.selected) << set.name;
      }
    }
    // The rows the race stopped early (SelectionOptions::race_dear_candidates), with the
    // splits they kept: a race that no longer applied would choose the same, only slower.
    std::string raced;
    for (const ModelCandidate& c : r.table)
      if (c.raced_out) raced += " " + c.name + " " + std::to_string(c.heldout_splits_px.size());
    EXPECT_EQ(raced, raced_out.at(set.name)) << set.name;
    std::printf("  %s: %s; screened:%s; raced out:%s\n", set.name, r.selected.c_str(), screened.c_str(), raced.c_str());
  }
}

// The stages' parallel solves (CalibrateOptions::parallel) give the serial loop's numbers:
// every candidate's row, the choice, each view's leverage and the uncertainty. And mrcal's
// solves, which quiet stderr while they run, leave it as it was when they overlap.
TEST(ModelSelection, ParallelSolvesGiveTheSerialNumbers) {
  const CameraModel truth = kb190();
  const Corners views = project_board_views(truth, kBoard, 10, 80, 600, 0.2, 2);
  ASSERT_GE(views.size(), 8u);
  struct stat before {};
  ASSERT_EQ(fstat(2, &before), 0);
  CalibrateOptions o;
  o.parallel = false;
  const CalibrationResult serial = calibrate(views, kBoard, truth.width, truth.height, o);
  o.parallel = true;
  const CalibrationResult parallel = calibrate(views, kBoard, truth.width, truth.height, o);
  struct stat after {};
  ASSERT_EQ(fstat(2, &after), 0);
  EXPECT_EQ(before.st_dev, after.st_dev);
  EXPECT_EQ(before.st_ino, after.st_ino);
  EXPECT_EQ(serial.selected, parallel.selected);
  ASSERT_EQ(serial.table.size(), parallel.table.size());
  for (size_t i = 0; i < serial.table.size(); ++i) {
    const ModelCandidate &a = serial.table[i], &b = parallel.table[i];
    // OpenCV8 is not reproducible between two calls (cv::calibrateCamera's seed,
    // docs/calibration.md "Determinism"), and on a 190 deg lens, which the rational model
    // cannot fit, two calls landed 0.89 and 1.07 px RMS apart: not compared. Mei's
    // cv::omnidir seed differs in its last digits (~1e-14 relative) when it runs on another
    // thread; it is rounded (stop 43), so Mei and the stereographic and splined fits seeded
    // from it are the same bits.
    if (a.name == "LENSMODEL_OPENCV8") continue;
    EXPECT_EQ(a.ok, b.ok) << a.name;
    EXPECT_EQ(a.screened, b.screened) << a.name;
    EXPECT_EQ(a.rms_px, b.rms_px) << a.name;
    EXPECT_EQ(a.cross_validation_px, b.cross_validation_px) << a.name;
    EXPECT_EQ(a.heldout_splits_px, b.heldout_splits_px) << a.name;
    EXPECT_EQ(a.cross_validation_splits_px, b.cross_validation_splits_px) << a.name;
  }
  EXPECT_EQ(serial.cv_noise_px, parallel.cv_noise_px);
  ASSERT_EQ(serial.views.size(), parallel.views.size());
  for (size_t v = 0; v < serial.views.size(); ++v) EXPECT_EQ(serial.views[v].leverage_px, parallel.views[v].leverage_px);
  EXPECT_EQ(serial.uncertainty.jackknife.median_px, parallel.uncertainty.jackknife.median_px);
  EXPECT_EQ(serial.model.intrinsics, parallel.model.intrinsics);
}

// The hard case of issue 21 item 1, synthetic: 8 views through the 190 deg Kannala-Brandt
// lens (0.2 px corner noise), calibrated in two disjoint halves of 4. The rule of before
// (fewest parameters within the jackknife noise of the best) chose Mei on one half and
// Kannala-Brandt on the other, 0.749 px apart against 0.366 px for Kannala-Brandt on both
// (the best fixed family). The incumbent rule chooses one family on both halves, as close
// as the best fixed one; and the same corners give the same choice and the same numbers.
TEST(ModelSelection, HalvesOfAFisheyeSetChooseOneFamily) {
  const CameraModel truth = kb190();
  const Corners views = project_board_views(truth, kBoard, 8, 80, 600, 0.2, 1);
  ASSERT_EQ(views.size(), 8u);
  CalibrateOptions o;
  o.leverage = false;
  o.uncertainty = false;
  // The case as found, on a flat board model: with the board warp fitted (the default since
  // issue 21 item 2) these halves no longer flip under the rule of before (Kannala-Brandt on
  // both, 0.214 px apart), so the case would not test the rule.
  o.board_warp = false;
  const HalvesOutcome h = calibrate_halves(views, kBoard, truth.width, truth.height, o, true);
  std::printf("  before: %s | %s, %.3f px; now: %s | %s, %.3f px; best fixed %s %.3f px\n", h.before[0].c_str(),
              h.before[1].c_str(), h.before_px, h.pick[0].c_str(), h.pick[1].c_str(), h.chosen_px,
              h.best_fixed.c_str(), h.best_fixed_px);
  EXPECT_NE(h.before[0], h.before[1]);  // the flip the rule of before made
  EXPECT_GT(h.before_px, 1.5 * h.best_fixed_px);
  EXPECT_EQ(h.pick[0], h.pick[1]);
  EXPECT_EQ(h.pick[0], "LENSMODEL_KANNALA_BRANDT");
  EXPECT_LE(h.chosen_px, 1.05 * h.best_fixed_px);
  EXPECT_NEAR(h.best_fixed_px, 0.366, 0.05);

  // Deterministic: the same half twice gives the same choice, votes and per-split numbers.
  Corners half;
  for (size_t i = 0; i < views.size(); i += 2) half.push_back(views[i]);
  const CalibrationResult a = calibrate(half, kBoard, truth.width, truth.height, o);
  const CalibrationResult b = calibrate(half, kBoard, truth.width, truth.height, o);
  EXPECT_EQ(a.selection_rule, "incumbent");
  EXPECT_EQ(a.selected, b.selected);
  ASSERT_EQ(a.table.size(), b.table.size());
  int wins = 0;
  for (size_t i = 0; i < a.table.size(); ++i) {
    EXPECT_EQ(a.table[i].split_wins, b.table[i].split_wins) << a.table[i].name;
    // (OpenCV8 alone is not bit-identical: cv::calibrateCamera's seed, docs/calibration.md.)
    for (const auto member : {&ModelCandidate::heldout_splits_px, &ModelCandidate::cross_validation_splits_px}) {
      const std::vector<double>&x = a.table[i].*member, &y = b.table[i].*member;
      ASSERT_EQ(x.size(), y.size()) << a.table[i].name;
      for (size_t k = 0; k < x.size(); ++k)
        if (x[k] != y[k]) {
          EXPECT_NEAR(x[k], y[k], 1e-6 * std::abs(x[k])) << a.table[i].name << " split " << k;
        }
    }
    wins += a.table[i].split_wins;
  }
  EXPECT_EQ(wins, a.cv_splits);  // one winner per split (4 views: 3 distinct balanced splits)
  EXPECT_EQ(a.cv_splits, 3);
}

// A lens that sees beyond 90 deg (a catadioptric Mei lens, xi 1.8, its boards reaching 115 deg
// off the axis): the perspective candidates, which cannot image such rays, are not fitted
// (kPerspectiveFieldLimitDeg), and the outlier stage's rational reference neither. Fitted
// anyway, each misses the corners by several times the chosen model's RMS (the rational
// model, folding the boards forward, by 1.24 px against Mei's 0.28: within the 1.5 px fit
// threshold, yet no contender), and the choice is the same.
TEST(ModelSelection, PerspectiveModelsAreNotFittedBeyondTheirReach) {
  const CameraModel mirror{"LENSMODEL_OMNIDIR_MEI", {450, 450, 512.3, 383.6, 1.8, -0.05, 0.01, 0, 0}, 1024, 768};
  const Corners views = project_board_views(mirror, kBoard, 12, 105, 600, 0.2, 3, 115);
  ASSERT_GE(views.size(), 10u);
  CalibrateOptions o;
  o.leverage = false;
  o.uncertainty = false;
  const CalibrationResult gated = calibrate(views, kBoard, mirror.width, mirror.height, o);
  o.perspective_field_limit_deg = std::numeric_limits<double>::infinity();
  const CalibrationResult fitted = calibrate(views, kBoard, mirror.width, mirror.height, o);
  EXPECT_EQ(gated.selected, "LENSMODEL_OMNIDIR_MEI");
  EXPECT_EQ(gated.selected, fitted.selected);
  EXPECT_GT(gated.selection_field_deg, kPerspectiveFieldLimitDeg);
  int perspective = 0;
  ASSERT_EQ(gated.table.size(), fitted.table.size());
  for (size_t i = 0; i < gated.table.size(); ++i) {
    const ModelCandidate &g = gated.table[i], &f = fitted.table[i];
    if (!is_perspective(candidate_lens_type(g.name))) continue;
    ++perspective;
    EXPECT_TRUE(g.screened && std::isnan(g.rms_px)) << g.name << ": " << g.error;
    EXPECT_NE(g.error.find("beyond a perspective model's reach"), std::string::npos) << g.error;
    EXPECT_GT(f.rms_px, 3 * fitted.table[size_t(std::find_if(fitted.table.begin(), fitted.table.end(),
                                                               [&](const ModelCandidate& c) {
                                                                 return c.name == fitted.selected;
                                                               }) - fitted.table.begin())].rms_px)
        << f.name;
    std::printf("  %s: not fitted (%s); fitted anyway: %s %.3f px\n", g.name.c_str(), g.error.c_str(),
                f.screened ? "screened" : f.ok ? "fitted, not chosen," : "failed", f.rms_px);
  }
  EXPECT_EQ(perspective, 3);
  // The wide candidates' rows are the same numbers either way.
  for (size_t i = 0; i < gated.table.size(); ++i) {
    if (!is_perspective(candidate_lens_type(gated.table[i].name))) {
      EXPECT_EQ(gated.table[i].rms_px, fitted.table[i].rms_px) << gated.table[i].name;
    }
  }
}

}  // namespace
}  // namespace lp

namespace lp {
namespace {

// A lens no parametric candidate can describe: a stereographic spline (mrcal's) with a
// non-radial ripple of `amplitude` in its normalised coordinates (0.1: up to ~50 px at
// f = 500). The selection must still reach for the spline when the data need it, on a set as
// small as a user's first calibration: a rule (or a screen for speed) that left the richest
// model out of small sets would fail here. Measured (stop 52, 0.2 px corner noise): picked on
// 12 and 16 views and on one of two 8-view draws; with a ripple of 0.005 (0.29 px RMS misfit
// of the stereographic model) it is not, and need not be.
CameraModel rippled_spline(double amplitude) {
  const int nx = 8, ny = 6;
  std::vector<double> intrinsics = {500, 501, 641.3, 478.6};
  for (int iy = 0; iy < ny; ++iy)
    for (int ix = 0; ix < nx; ++ix) {
      intrinsics.push_back(amplitude * std::sin(2 * M_PI * ix / (nx - 1)) * std::sin(M_PI * iy / (ny - 1)));
      intrinsics.push_back(amplitude * std::cos(M_PI * ix / (nx - 1)) * std::sin(2 * M_PI * iy / (ny - 1)));
    }
  return {"LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=6_fov_x_deg=200", intrinsics, 1280, 960};
}

TEST(ModelSelection, ALensOnlyASplineDescribesGetsTheSplineFromTwelveViews) {
  const CameraModel truth = rippled_spline(0.1);
  const Corners views = project_board_views(truth, kBoard, 12, 70, 600, 0.2, 1, 85);
  ASSERT_EQ(views.size(), 12u);
  CalibrateOptions o;
  o.leverage = false;
  o.uncertainty = false;
  const CalibrationResult r = calibrate(views, kBoard, truth.width, truth.height, o);
  EXPECT_EQ(r.selected, "LENSMODEL_SPLINED_STEREOGRAPHIC");
  // Against the truth, over the area the boards covered: the spline (its own knots, not the
  // truth's: 1.1 px median) an order of magnitude closer than any parametric candidate
  // (15-23 px).
  const auto mask = covered(views, truth.width, truth.height);
  double spline_px = NAN, best_parametric_px = INFINITY;
  for (const ModelCandidate& c : r.table) {
    if (!c.ok) continue;
    const ProjectionDiff d = projection_difference(c.model, truth, mask, 8);
    ASSERT_GT(d.samples, 0) << c.name;
    if (c.name == "LENSMODEL_SPLINED_STEREOGRAPHIC")
      spline_px = d.median_px;
    else
      best_parametric_px = std::min(best_parametric_px, d.median_px);
    std::printf("  %-34s median %.3f px from the truth\n", c.name.c_str(), d.median_px);
  }
  EXPECT_LT(spline_px, 2.0);
  EXPECT_GT(best_parametric_px, 5 * spline_px);
}

}  // namespace
}  // namespace lp
