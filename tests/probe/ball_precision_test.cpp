// find_ball's precision on balls rendered from every shared map (eval/ball_eval.h).
#include <gtest/gtest.h>

#include "core/error.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "core/heap_tuning.h"
#include "core/image_io.h"
#include "eval/ball_eval.h"
#include "eval/synthetic_scene.h"
#include "probe/mirror_ball.h"
#include "probe/synthetic_probe.h"
#include "probe/unwrap_sequence.h"

namespace lp {
namespace {

const std::string kData = LIGHTPROBE_SHARED_DATA;

// The probe tests (this binary: every file) find balls as the commands that find many do (`probe unwrap` on a sequence,
// `probe register`, `eval unwrap`), with the heap kept between calls (core/heap_tuning.h):
// otherwise each call faults its ~100 MB of images in again.
[[maybe_unused]] const bool ball_heap = (keep_heap_for_reuse(), true);

std::vector<std::string> every_shared_map() {
  std::vector<std::string> maps;
  for (const char* m : {"city", "courtyard", "forest", "interior", "night", "studio", "sunrise", "sunset"})
    maps.push_back(kData + "/probes-blender-studiolights/" + m + ".exr");
  for (const char* m : {"ennis", "grace", "pisa", "uffizi", "wells"})
    maps.push_back(kData + "/probes-probulator-latlong256/" + m + ".hdr");
  maps.push_back(kData + "/probes-threejs-spot-and-cube/spot1Lux.hdr");
  maps.push_back(kData + "/probes-threejs-spot-and-cube/pisa_cube");
  maps.push_back(kData + "/hdr-mirrorball-kartik/reference/course_sample_latlon.hdr");
  maps.push_back(kData + "/hdr-mirrorball-kartik/reference/student_flattened_latlon.hdr");
  return maps;
}

const std::string kPhoto = kData + "/hdr-memorial-debevec/reference/memorial_radiance_hdrshop.hdr";

// A map of radiance 1 everywhere: a ball with no rim structure.
EnvMap uniform_map() {
  EnvMap flat = make_envmap(Layout::LatLong, 64, 32);
  std::fill(flat.rgb.begin(), flat.rgb.end(), 1.0f);
  return flat;
}

std::vector<std::string> split_list(const std::string& list) {
  std::vector<std::string> out;
  for (size_t start = 0; start <= list.size();) {
    const size_t comma = std::min(list.find(',', start), list.size());
    if (comma > start) out.push_back(list.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

// The whole grid (17 maps x 3 radii x 5 backgrounds); minutes of CPU, so only on demand:
// LIGHTPROBE_BALL_EVAL=DIR writes DIR/ball.csv and prints the table. A subset while
// iterating: LIGHTPROBE_BALL_EVAL_MAPS=wells,city, LIGHTPROBE_BALL_EVAL_RADII=60,150,
// LIGHTPROBE_BALL_EVAL_BACKGROUNDS=dark,night (comma-separated).
TEST(BallPrecision, EveryMapSizeAndBackgroundOnDemand) {
  const char* dir = std::getenv("LIGHTPROBE_BALL_EVAL");
  if (!dir) GTEST_SKIP() << "set LIGHTPROBE_BALL_EVAL=DIR to run the whole grid";
  EvalBallOptions o;
  o.maps = every_shared_map();
  // Subsets keep the seeds they have in the whole grid (EvalBallOptions::include).
  std::vector<std::string> maps, radii, backgrounds;
  if (const char* v = std::getenv("LIGHTPROBE_BALL_EVAL_MAPS")) maps = split_list(v);  // e.g. "grace,city"
  if (const char* v = std::getenv("LIGHTPROBE_BALL_EVAL_RADII")) radii = split_list(v);  // e.g. "60,150"
  if (const char* v = std::getenv("LIGHTPROBE_BALL_EVAL_BACKGROUNDS")) backgrounds = split_list(v);  // "dark,night"
  auto listed = [](const std::vector<std::string>& list, const std::string& name) {
    return list.empty() || std::find(list.begin(), list.end(), name) != list.end();
  };
  if (!maps.empty() || !radii.empty() || !backgrounds.empty())
    o.include = [=](const std::string& map, double radius, BallBackground bg) {
      return listed(maps, map) && listed(radii, std::to_string(int(std::lround(radius)))) &&
             listed(backgrounds, background_name(bg));
    };
  o.photo = kPhoto;
  o.output_dir = dir;
  // LIGHTPROBE_BALL_EVAL_FRAME=2.3: uncropped photos, the ball a sixth of the frame's width.
  if (const char* v = std::getenv("LIGHTPROBE_BALL_EVAL_FRAME")) o.frame = std::atof(v);
  // LIGHTPROBE_BALL_EVAL_PICTURES=0.2: a picture of every case beyond 0.2 px (EvalBallOptions).
  if (const char* v = std::getenv("LIGHTPROBE_BALL_EVAL_PICTURES")) o.picture_beyond_px = std::atof(v);
  const EvalBallReport rep = evaluate_ball_detection(o, [](size_t d, size_t t) { std::fprintf(stderr, "%zu/%zu\n", d, t); });
  std::printf("%s", rep.summary().c_str());
}


// An uncropped photo: the ball a sixth of the frame's width (render_ball_case's frame 2.3)
// in front of a textured photo. Every coarse seed went to circles two to three times the
// ball's size through the texture (the region score grows with the radius), and find_ball
// refused the ball as "cut by the image border" on 17 of 17 maps; with seeds by the share of
// the rim with contrast and by OpenCV's Hough transform it is found on 15 of them, each within
// 0.2 px (LIGHTPROBE_BALL_EVAL_FRAME=2.3, R 150, photo); 16 since the Hough transform also
// runs on the equalised codes (studio: its dark rim against Memorial's dim walls).
TEST(BallPrecision, ABallInAnUncroppedPhotoIsFound) {
  const RgbImage photo = read_rgb_image(kPhoto);
  for (const char* name : {"probes-probulator-latlong256/pisa.hdr", "hdr-mirrorball-kartik/reference/course_sample_latlon.hdr",
                           "probes-probulator-latlong256/grace.hdr", "probes-blender-studiolights/city.exr",
                           "probes-blender-studiolights/studio.exr"}) {
    SCOPED_TRACE(name);
    const BallCase c = render_ball_case(read_envmap(kData + "/" + name), BallBackground::Photo, 150, photo, 5, 2.3);
    FindBallReport rep;
    const BallInImage found = find_ball(c.image, {}, &rep);
    EXPECT_LT(std::hypot(found.cx - c.truth.cx, found.cy - c.truth.cy), 0.2);
    EXPECT_LT(std::abs(found.radius_px - c.truth.radius_px), 0.2);
    EXPECT_TRUE(rep.subpixel);
  }
}

// The harness's truth: a uniform ball (no rim structure to confuse an edge) on black is
// found to a few hundredths of a pixel, so the coverage compositing and the sub-pixel
// convention agree with find_ball's.
TEST(BallPrecision, AUniformBallOnBlackIsFoundToHundredthsOfAPixel) {
  const EnvMap flat = uniform_map();
  for (const double r : {60.0, 150.0}) {
    const BallCase c = render_ball_case(flat, BallBackground::Black, r, {}, 11);
    FindBallReport rep;
    const BallInImage b = find_ball(c.image, {}, &rep);
    std::printf("uniform R %.1f: centre off %.4f px, radius off %+.4f px, sigma %.4f / %.4f px\n", c.truth.radius_px,
                std::hypot(b.cx - c.truth.cx, b.cy - c.truth.cy), b.radius_px - c.truth.radius_px, rep.sigma_centre_px,
                rep.sigma_radius_px);
    EXPECT_TRUE(rep.subpixel);
    EXPECT_LT(std::hypot(b.cx - c.truth.cx, b.cy - c.truth.cy), 0.05);
    EXPECT_LT(std::abs(b.radius_px - c.truth.radius_px), 0.05);
  }
}

// Below FindBallOptions::min_radius_px a circle is no ball to unwrap: a 6 px ball, found, is
// refused with one line; at 12 px it is found as usual.
TEST(BallPrecision, ABallTooSmallToUnwrapIsRefused) {
  RgbImage tiny;  // a 6 px disc on black (the harness renders from 8 px up)
  tiny.width = tiny.height = 48;
  tiny.rgb.assign(size_t(48 * 48 * 3), 0.0f);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 48; ++x)
      if (std::hypot(x - 23.6, y - 24.3) <= 6)
        for (int c = 0; c < 3; ++c) tiny.rgb[size_t(y * 48 + x) * 3 + size_t(c)] = 0.8f;
  try {
    find_ball(tiny);
    ADD_FAILURE() << "a 6 px ball was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("px in radius, below 8 px: too small to unwrap"), std::string::npos)
        << e.what();
  }
  FindBallOptions any_size;  // the refusal is the size rule: without it the disc is found
  any_size.min_radius_px = 0;
  EXPECT_NEAR(find_ball(tiny, any_size).radius_px, 6, 1.0);
  const BallCase small = render_ball_case(uniform_map(), BallBackground::Black, 12, {}, 11);
  const BallInImage b = find_ball(small.image);
  EXPECT_LT(std::hypot(b.cx - small.truth.cx, b.cy - small.truth.cy), 0.5);
  EXPECT_NEAR(b.radius_px, small.truth.radius_px, 0.5);
}

// A studio map at two sizes on four backgrounds: the photo behind the ball has round
// features of its own (a dome), the sun is a blinding arc at the rim, the night is 1000 x
// darker with noise. Measured (docs/probes.md): centre <= 0.26 px, |radius| <= 0.10 px;
// before this fit only the two black cases were found at all. The fifth background, half
// the rim dark on dark, is NOT solved (2.3 px at R 60, not found at R 150): printed, not
// asserted.
TEST(BallPrecision, AStudioBallIsFoundToAFewTenthsOfAPixelOnFourBackgrounds) {
  EvalBallOptions o;
  o.maps = {kData + "/probes-blender-studiolights/studio.exr"};
  o.photo = kPhoto;
  o.radii = {60, 150};
  const EvalBallReport rep = evaluate_ball_detection(o);
  std::printf("%s", rep.summary().c_str());
  ASSERT_EQ(rep.rows.size(), 10u);
  for (const BallRow& r : rep.rows) {
    if (r.background == std::string("dark")) continue;
    ASSERT_TRUE(r.found) << r.background << " R " << r.radius_px << ": " << r.error;
    EXPECT_TRUE(r.report.subpixel) << r.background << " R " << r.radius_px;
    EXPECT_LE(r.centre_error_px, 0.3) << r.background << " R " << r.radius_px;
    EXPECT_LE(std::abs(r.radius_error_px), 0.2) << r.background << " R " << r.radius_px;
  }
}

// A rim dark against a dark background (issue 21 item 4): the harness's dark cases, where
// the lower half of the rim reflects black (its outer 3.4 % of R) in front of a photo
// darkened 100 x. The step from nothing to dim is the silhouette there; the stronger
// border of the dark reflection further in used to win. Before this change, on these
// renders: centre / radius 0.39 / -4.81 px (uffizi), 1.20 / -4.53 (sunrise), 2.86 / -2.59
// (pisa); measured after: 0.29 / +0.21, 0.15 / -0.12, 0.27 / -0.16.
TEST(BallPrecision, ARimDarkAgainstADarkBackgroundIsFound) {
  EvalBallOptions o;
  o.maps = every_shared_map();
  o.photo = kPhoto;
  o.include = [](const std::string& map, double radius, BallBackground bg) {
    return (map == "uffizi" || map == "sunrise" || map == "pisa") && radius == 150 && bg == BallBackground::Dark;
  };
  const EvalBallReport rep = evaluate_ball_detection(o);
  std::printf("%s", rep.summary().c_str());
  ASSERT_EQ(rep.rows.size(), 3u);
  for (const BallRow& r : rep.rows) {
    ASSERT_TRUE(r.found) << r.map << ": " << r.error;
    EXPECT_LT(r.centre_error_px, 0.5) << r.map;
    EXPECT_LT(std::abs(r.radius_error_px), 0.5) << r.map;
  }
}

// Runs the harness on the renders of every shared map that `include` picks: `cases` of
// them, each found with sub-pixel refinement, centre and radius within `limit_px` of the truth.
void expect_found_within(const std::function<bool(const std::string&, double, BallBackground)>& include,
                         size_t cases, double limit_px) {
  EvalBallOptions o;
  o.maps = every_shared_map();
  o.photo = kPhoto;
  o.include = include;
  const EvalBallReport rep = evaluate_ball_detection(o);
  std::printf("%s", rep.summary().c_str());
  ASSERT_EQ(rep.rows.size(), cases);
  for (const BallRow& r : rep.rows) {
    ASSERT_TRUE(r.found) << r.map << " " << r.background << ": " << r.error;
    EXPECT_TRUE(r.report.subpixel) << r.map << " " << r.background;
    EXPECT_LT(r.centre_error_px, limit_px) << r.map << " " << r.background << " R " << r.radius_px;
    EXPECT_LT(std::abs(r.radius_error_px), limit_px) << r.map << " " << r.background << " R " << r.radius_px;
  }
}

// The edge by pixel coverage (probe/ball_rim_coverage.h) instead of by area: the area rule
// took the ball's value 1.5 px inside for its last 1.5 px, which reflect the cap of
// directions behind the ball. On these renders (harness seeds) the area rule's circle was
// off by centre / radius 0.25 / -0.13 px (pisa, black, R 150), 0.31 / -0.14 (pisa, photo,
// R 150), 0.16 / -0.08 (pisa, black, R 400), 0.27 / +0.18 (uffizi, black, R 400); measured
// with the coverage model: 0.01 / -0.00, 0.01 / +0.00, 0.00 / -0.00, 0.01 / -0.06.
TEST(BallPrecision, TheSilhouetteByPixelCoverageHasNoBiasFromTheRimsReflection) {
  expect_found_within(
      [](const std::string& map, double radius, BallBackground bg) {
        return (map == "pisa" && radius == 150 && (bg == BallBackground::Black || bg == BallBackground::Photo)) ||
               ((map == "pisa" || map == "uffizi") && radius == 400 && bg == BallBackground::Black);
      },
      4, 0.1);
}

// A band of the rim's reflection outside the edge the coverage model picks (probe/
// ball_rim_coverage.h): on the dark background the lower rim of a ball 60 px across reflects
// black over its outer 2 px, in front of a photo darkened 100 x, so the strong step is the
// band's inner border and the silhouette a step from nothing to dim 2 px further out; the
// wells map's rim reflects a dark band of its own. On these renders (harness seeds) the
// circle was off by centre / radius 1.32 / -0.96 px (uffizi), 1.22 / -1.05 (sunrise),
// 1.22 / -1.08 (pisa), all dark at R 60, and 1.27 / -1.34 (wells, black, R 400); measured
// with the band's outer edge: 0.04 / +0.13, 0.10 / -0.06, 0.10 / -0.04, 0.11 / -0.06.
TEST(BallPrecision, TheSilhouetteIsTheOuterEdgeOfABandAtTheRim) {
  expect_found_within(
      [](const std::string& map, double radius, BallBackground bg) {
        return ((map == "uffizi" || map == "sunrise" || map == "pisa") && radius == 60 && bg == BallBackground::Dark) ||
               (map == "wells" && radius == 400 && bg == BallBackground::Black);
      },
      4, 0.2);
}

// A rim fit off by more than the coverage search's reach (studio, dark, R 60: the rim fit's
// outermost edges are a texture edge of the photo 1-1.5 px outside the silhouette at the
// top and the inner border of the dark band 2 px inside it at the bottom, so its circle
// sits 2.2 px high): within +-0.75 px of that circle the arcs at the top find the photo's
// texture and hold the circle there. Before the wide first pass (+-2 px): centre / radius
// 2.41 / -1.34 px; measured after: 0.15 / +0.01.
TEST(BallPrecision, TheFirstCoveragePassReachesASilhouetteTheRimFitMissedByPixels) {
  expect_found_within(
      [](const std::string& map, double radius, BallBackground bg) {
        return map == "studio" && radius == 60 && bg == BallBackground::Dark;
      },
      1, 0.2);
}

// Large circles half outside the image collect edges of texture along their visible half
// and outscored the ball wholly in view (agreement x radius), then find_ball threw: "ball
// cut by the image border" on renders whose ball is wholly in view (night at night, sunrise
// on the photo, R 60). A rim fit that would be rejected as cut loses to one that would not:
// found now, centre / radius 0.04 / -0.17 px (night) and 0.04 / -0.15 (sunrise).
TEST(BallPrecision, ABallWhollyInViewBeatsACircleCutByTheBorder) {
  expect_found_within(
      [](const std::string& map, double radius, BallBackground bg) {
        return radius == 60 && ((map == "night" && bg == BallBackground::Night) ||
                                (map == "sunrise" && bg == BallBackground::Photo));
      },
      2, 0.25);
}

// Where part of the rim has no contrast at the silhouette, its arcs hold a border further in
// (a band of the reflection that matches the background, the ball's own texture), coherently
// along a stretch; the Tukey scale from the residuals' MAD spanned both groups and the
// circle averaged them. Arcs lying more than 0.5 px inside the circle are now dropped and the
// circle refitted (the silhouette is the outer boundary). On these renders (harness seeds)
// max(centre, |radius|) error was 0.21 px (forest, photo, R 150), 0.20 (ennis, night,
// R 150), 0.26 (pisa, night, R 60), 0.25 (course_sample_latlon, dark, R 60); measured
// after: 0.10, 0.09, 0.14, 0.12.
TEST(BallPrecision, ArcsWellInsideTheCircleDoNotPullTheSilhouetteIn) {
  expect_found_within(
      [](const std::string& map, double radius, BallBackground bg) {
        return (map == "forest" && radius == 150 && bg == BallBackground::Photo) ||
               (map == "ennis" && radius == 150 && bg == BallBackground::Night) ||
               (map == "pisa" && radius == 60 && bg == BallBackground::Night) ||
               (map == "course_sample_latlon" && radius == 60 && bg == BallBackground::Dark);
      },
      4, 0.2);
}

// Where the dark arc has no step at all (a uniform ball whose lower rim reflects black, in
// front of black) the circle rests on the bright arc: still right, and flagged, the rim
// agreeing along only half its length. In front of the dim photo the dark arc has its step,
// counts, and the fit is not flagged (before: agreement 0.53, flagged).
TEST(BallPrecision, ARimWithoutContrastIsFittedOnTheRestAndFlagged) {
  EnvMap world = uniform_map();
  for (size_t i = 0; i < world.pixel_count(); ++i) {
    const Vec3 d = pixel_direction(world, i);
    if (d.z < 0 && -d.x < std::cos(150 * M_PI / 180))
      for (int c = 0; c < 3; ++c) world.rgb[3 * i + c] = 0;
  }
  const RgbImage photo = read_rgb_image(kPhoto);
  for (const BallBackground bg : {BallBackground::Dark, BallBackground::Black})
    for (const double r : {150.0, 400.0}) {
      const BallCase c = render_ball_case(world, bg, r, photo, 21);
      FindBallReport rep;
      const BallInImage b = find_ball(c.image, {}, &rep);
      const double dc = std::hypot(b.cx - c.truth.cx, b.cy - c.truth.cy), dr = b.radius_px - c.truth.radius_px;
      std::printf("%s R %.1f: centre off %.3f px, radius off %+.3f px, rim agreement %.2f, warning '%s'\n",
                  background_name(bg), c.truth.radius_px, dc, dr, rep.rim_agreement, ball_fit_warning(rep).c_str());
      EXPECT_TRUE(rep.subpixel);
      EXPECT_LT(dc, 0.2) << background_name(bg) << " R " << r;
      EXPECT_LT(std::abs(dr), 0.2) << background_name(bg) << " R " << r;
      if (bg == BallBackground::Black) {
        EXPECT_LT(rep.rim_agreement, kPartialRimAgreement);
        EXPECT_NE(ball_fit_warning(rep).find("only"), std::string::npos);
      } else {
        EXPECT_GE(rep.rim_agreement, kPartialRimAgreement);
        EXPECT_EQ(ball_fit_warning(rep), "");
      }
    }
}

// The fit's own uncertainty means something: on noisy uniform balls (only noise moves the
// edges) the spread of the centre errors over 8 renders is within a factor 3 of the mean
// reported sigma, and the sigma grows with the noise.
TEST(BallPrecision, TheReportedSigmaMatchesTheScatterFromNoise) {
  const EnvMap flat = uniform_map();
  double ss = 0, sigma = 0, sigma_clean = 0;
  const int n = 8;
  for (int i = 0; i < n; ++i) {
    BallCase c = render_ball_case(flat, BallBackground::Black, 60, {}, 100 + i);
    FindBallReport clean;
    find_ball(c.image, {}, &clean);
    sigma_clean += clean.sigma_centre_px / n;
    std::mt19937_64 rng(7 + i);
    std::normal_distribution<double> noise(0.0, 0.15);
    for (float& v : c.image.rgb) v = float(std::max(0.0, v + noise(rng)));
    FindBallReport rep;
    const BallInImage b = find_ball(c.image, {}, &rep);
    const double dx = b.cx - c.truth.cx, dy = b.cy - c.truth.cy;
    ss += 0.5 * (dx * dx + dy * dy) / n;  // per axis
    sigma += rep.sigma_centre_px / n;
  }
  std::printf("noisy uniform R 60: centre scatter %.4f px per axis, mean sigma %.4f px (clean %.4f)\n", std::sqrt(ss),
              sigma, sigma_clean);
  EXPECT_GT(sigma, 2 * sigma_clean);
  EXPECT_LT(std::sqrt(ss), 3 * sigma);
  EXPECT_GT(std::sqrt(ss), sigma / 3);
}


// The sigmas cover the choice of model, not just the noise: on the dark renders at R 60 of
// every shared map (half the rim a dark band on a dark background, where the one-step and
// the banded circle compete) the centre and the radius are within 2 sigma of the truth in
// at least 90 % of the cases (measured: all 17). The fit's covariance alone (noise_sigma_*,
// the sigmas before this change) covers the centre in 4 of them, the radius in 7.
TEST(BallPrecision, TheReportedSigmaCoversTheChoiceOfModel) {
  EvalBallOptions o;
  o.maps = every_shared_map();
  o.photo = kPhoto;
  o.include = [](const std::string&, double radius, BallBackground bg) {
    return radius == 60 && bg == BallBackground::Dark;
  };
  const EvalBallReport rep = evaluate_ball_detection(o);
  std::printf("%s", rep.summary().c_str());
  int n = 0, centre = 0, radius = 0, centre_noise = 0, radius_noise = 0;
  for (const BallRow& r : rep.rows) {
    if (!r.found || !r.report.subpixel) continue;
    ++n;
    centre += r.centre_error_px <= 2 * r.report.sigma_centre_px;
    radius += std::abs(r.radius_error_px) <= 2 * r.report.sigma_radius_px;
    centre_noise += r.centre_error_px <= 2 * r.report.noise_sigma_centre_px;
    radius_noise += std::abs(r.radius_error_px) <= 2 * r.report.noise_sigma_radius_px;
  }
  std::printf("within 2 sigma of %d: centre %d (noise only %d), radius %d (noise only %d)\n", n, centre, centre_noise,
              radius, radius_noise);
  ASSERT_GE(n, 16);
  EXPECT_GE(centre, 0.9 * n);
  EXPECT_GE(radius, 0.9 * n);
}

// The sigmas cover a circle that rests on part of the rim: where a stretch of the rim has
// no contrast at the silhouette, the circle depends on which half of the rim it trusts,
// which the spread of the fits to each half of the rim (beyond what noise gives them) shows
// and one 45 deg sector's removal did not. On these renders (harness seeds, 0.5-1.1 px off)
// the error was 1.9 / 2.3 sigma (centre / radius; sunset, photo, R 150), 4.9 / 5.4 (sunset,
// night, R 150), 4.3 / 6.7 (night, night, R 400); measured after: 0.9 / 1.2, 1.2 / 1.1,
// 1.4 / 1.5.
TEST(BallPrecision, TheReportedSigmaCoversACircleThatRestsOnPartOfTheRim) {
  EvalBallOptions o;
  o.maps = every_shared_map();
  o.photo = kPhoto;
  o.include = [](const std::string& map, double radius, BallBackground bg) {
    return (map == "sunset" && radius == 150 && (bg == BallBackground::Photo || bg == BallBackground::Night)) ||
           (map == "night" && radius == 400 && bg == BallBackground::Night);
  };
  const EvalBallReport rep = evaluate_ball_detection(o);
  std::printf("%s", rep.summary().c_str());
  ASSERT_EQ(rep.rows.size(), 3u);
  for (const BallRow& r : rep.rows) {
    ASSERT_TRUE(r.found) << r.map << " " << r.background << ": " << r.error;
    ASSERT_TRUE(r.report.subpixel) << r.map << " " << r.background;
    EXPECT_LE(r.centre_error_px, 2 * r.report.sigma_centre_px) << r.map << " " << r.background;
    EXPECT_LE(std::abs(r.radius_error_px), 2 * r.report.sigma_radius_px) << r.map << " " << r.background;
  }
}

// The unwrap report carries how each ball was found, with the fit's standard errors.
TEST(BallPrecision, TheUnwrapReportCarriesTheFitsUncertainty) {
  const EnvMap flat = uniform_map();
  const BallCase c = render_ball_case(flat, BallBackground::Black, 60, {}, 5);
  const std::string path = (std::filesystem::temp_directory_path() / "lp_ball_fit_report.exr").string();
  write_rgb_image(path, c.image);
  UnwrapSequenceOptions o;
  o.width = 64, o.height = 32;
  const auto found = unwrap_probe_sequence({path}, o, [](size_t, EnvMap&) {});
  ASSERT_EQ(found.frames.size(), 1u);
  ASSERT_TRUE(found.frames[0].ball_fit.has_value());
  EXPECT_TRUE(found.frames[0].ball_fit->subpixel);
  EXPECT_GT(found.frames[0].ball_fit->sigma_centre_px, 0.0);
  EXPECT_LT(found.frames[0].ball_fit->sigma_centre_px, 0.05);
  EXPECT_GT(found.frames[0].ball_fit->sigma_radius_px, 0.0);
  o.ball = c.truth;
  const auto given = unwrap_probe_sequence({path}, o, [](size_t, EnvMap&) {});
  EXPECT_FALSE(given.frames[0].ball_fit.has_value());
  std::filesystem::remove(path);
}

// A sequence's frames after the first are searched from the last frame's ball
// (UnwrapSequenceOptions::seed_from_previous). On a jittered sequence of one map at two
// sizes the seeded answers must be the full search's (each frame also searched from
// scratch here), and a ball that jumps beyond the seeded search's reach must still be found.
// And frames the memory budget does not keep between the passes give the same maps.
TEST(BallSequence, SeededFramesAgreeWithTheFullSearch) {
  const EnvMap world = read_envmap(kData + "/probes-blender-studiolights/city.exr");
  for (const double radius : {150.0, 400.0}) {
    const int w = int(2.9 * radius), h = int(2.5 * radius);
    // At R 400 two frames (the search from the first frame's ball used to move 15 px off
    // it); at R 150 three, and a jump.
    auto track = jittered_track({0.5 * w, 0.5 * h, radius}, radius > 200 ? 2 : 3, 1.5, 3);
    if (radius < 200) track.push_back({0.5 * w + 0.3 * radius, 0.5 * h - 0.2 * radius, radius});
    const std::string dir = (std::filesystem::temp_directory_path() / "lp_ball_seeded").string();
    std::filesystem::create_directories(dir);
    std::vector<std::string> files;
    for (size_t f = 0; f < track.size(); ++f) {
      RenderBallOptions ro;
      ro.noise_relative = 0.01;
      ro.seed = 10 + f;
      files.push_back(dir + "/frame_" + std::to_string(f) + ".exr");
      write_rgb_image(files.back(), render_mirror_ball(world, track[f], MirrorBallCamera{}, w, h, ro));
    }
    UnwrapSequenceOptions o;
    o.width = 64, o.height = 32;
    std::vector<std::vector<float>> maps, maps_read_again;
    const auto seeded = unwrap_probe_sequence(files, o, [&](size_t, EnvMap& m) { maps.push_back(m.rgb); });
    if (radius < 200) {  // frames beyond the memory budget are read again in pass 2, to the same maps
      o.kept_frames_bytes = 2.5 * 12.0 * w * h;
      unwrap_probe_sequence(files, o, [&](size_t, EnvMap& m) { maps_read_again.push_back(m.rgb); });
      EXPECT_EQ(maps_read_again, maps);
      o.kept_frames_bytes = UnwrapSequenceOptions{}.kept_frames_bytes;
    }
    o.seed_from_previous = false;
    const auto full = unwrap_probe_sequence(files, o, [](size_t, EnvMap&) {});
    for (size_t f = 0; f < track.size(); ++f) {
      const BallInImage a = *seeded.frames[f].ball_detected, b = *full.frames[f].ball_detected;
      std::printf("R %.0f frame %zu: seeded - full (%+.4f, %+.4f, %+.4f) px, truth off %.3f px, agreement %.3f / %.3f%s\n",
                  radius, f, a.cx - b.cx, a.cy - b.cy, a.radius_px - b.radius_px,
                  std::hypot(a.cx - track[f].cx, a.cy - track[f].cy), seeded.frames[f].ball_fit->rim_agreement,
                  full.frames[f].ball_fit->rim_agreement, seeded.frames[f].ball_seeded ? ", seeded" : "");
      EXPECT_LT(std::hypot(a.cx - b.cx, a.cy - b.cy), 0.05) << "R " << radius << " frame " << f;
      EXPECT_LT(std::abs(a.radius_px - b.radius_px), 0.05) << "R " << radius << " frame " << f;
      EXPECT_EQ(seeded.frames[f].ball_seeded, f > 0 && (radius > 200 || f + 1 < track.size())) << "R " << radius << " frame " << f;
    }
    std::filesystem::remove_all(dir);
  }
}

// A fisheye sequence's frames beyond the memory budget are read again in pass 2 too (its
// image circle tracked per frame, the camera model sized from the first frame).
TEST(BallSequence, FisheyeFramesReadAgainGiveTheSameMaps) {
  const EnvMap world = render_scene(describe_scene(), Layout::LatLong, 128, 64);
  SyntheticProbeOptions so;
  so.type = "fisheye";
  so.width = so.height = 160;
  const std::string dir = (std::filesystem::temp_directory_path() / "lp_fisheye_read_again").string();
  std::filesystem::create_directories(dir);
  std::vector<std::string> files;
  for (int f = 0; f < 3; ++f) {  // each frame brighter than the last, so that no frame passes for another
    EnvMap lit = world;
    for (float& v : lit.rgb) v *= float(f + 1);
    files.push_back(dir + "/frame_" + std::to_string(f) + ".exr");
    write_synthetic_probe(lit, "scene", so, files.back());
  }
  UnwrapSequenceOptions o;
  o.type = ProbeType::Fisheye;
  o.width = 64, o.height = 32;
  std::vector<std::vector<float>> kept, read_again;
  unwrap_probe_sequence(files, o, [&](size_t, EnvMap& m) { kept.push_back(m.rgb); });
  o.kept_frames_bytes = 1.5 * 12.0 * so.width * so.height;  // the first frame only
  unwrap_probe_sequence(files, o, [&](size_t, EnvMap& m) { read_again.push_back(m.rgb); });
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_NE(kept[1], kept[2]);
  EXPECT_EQ(read_again, kept);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace lp
