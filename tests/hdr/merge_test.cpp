#include "hdr/merge.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"
#include "hdr/opencv_peer.h"
#include "tests/hdr/synthetic_bracket.h"

namespace lp {
namespace {

const std::string kMemorial = std::string(LIGHTPROBE_SHARED_DATA) + "/hdr-memorial-debevec";
constexpr std::array<uint8_t, 3> kBlue{0, 0, 255};

TEST(MergeBracket, WithTheTrueResponseIsWithinQuantisationOfTheRadianceAndBeatsOpenCv) {
  for (const auto& curve : {test::gamma_curve(), test::film_curve()}) {
    const RgbImage e = test::random_radiance(160, 120, 1e-3, 10.0);
    const Bracket b = test::photograph(e, {1.0 / 64, 1.0 / 16, 0.25, 1.0, 4.0}, curve);
    const CameraResponse truth = test::true_response(curve);
    // Noise-free data: quantisation, not photon noise, limits the error, and on the film
    // curve the exposure factor (which favours the long frames' compressed shoulder) doubles
    // it (median 0.0026 vs 0.0012). So the film case merges without it; both are printed.
    const bool film = curve.name == "film";
    MergeOptions options;
    options.exposure_weighting = !film;
    MergeReport report;
    const RgbImage ours = merge_bracket(b, truth, options, &report);
    const auto err = test::log10_luminance_error(ours, e);
    options.exposure_weighting = film;
    const auto err_other = test::log10_luminance_error(merge_bracket(b, truth, options), e);
    std::printf("[ merge %s ] exposure weighting %s: %.4f/%.4f\n", curve.name.c_str(), film ? "on" : "off",
                err_other.median, err_other.p95);
    const auto err_deb = test::log10_luminance_error(opencv_merge(b, OpenCvHdrMethod::Debevec, &truth), e);
    const auto err_rob = test::log10_luminance_error(opencv_merge(b, OpenCvHdrMethod::Robertson, &truth), e);
    std::printf("[ merge %s ] |dlog10 Y| median/p95: ours %.4f/%.4f, cv::MergeDebevec %.4f/%.4f, "
                "cv::MergeRobertson %.4f/%.4f\n",
                curve.name.c_str(), err.median, err.p95, err_deb.median, err_deb.p95, err_rob.median, err_rob.p95);
    EXPECT_EQ(err.count, size_t(160 * 120));
    // Measured: gamma 0.0013/0.0086, film 0.0012/0.0038.
    EXPECT_LT(err.median, 0.002) << curve.name;
    EXPECT_LT(err.p95, 0.01) << curve.name;
    EXPECT_LE(err.median, std::min(err_deb.median, err_rob.median)) << curve.name;
    EXPECT_LE(err.p95, std::min(err_deb.p95, err_rob.p95)) << curve.name;
    EXPECT_EQ(report.saturated_everywhere, 0u);
    EXPECT_EQ(report.black_everywhere, 0u);
  }
}

TEST(MergeBracket, FlagsAndCountsPixelsSaturatedOrBlackInEveryFrameExactly) {
  RgbImage e = test::random_radiance(64, 48, 1e-3, 10.0);
  // 7 pixels far too bright for the shortest exposure, 5 far too dark for the longest, and
  // one pixel with only its red channel saturated everywhere.
  const std::vector<size_t> bright = {0, 1, 2, 100, 200, 1000, 3071};
  const std::vector<size_t> dark = {5, 6, 300, 2000, 3000};
  for (size_t p : bright)
    for (int c = 0; c < 3; ++c) e.rgb[3 * p + size_t(c)] = 1e5f;
  for (size_t p : dark)
    for (int c = 0; c < 3; ++c) e.rgb[3 * p + size_t(c)] = 1e-7f;
  e.rgb[3 * 1500] = 1e5f;
  const std::vector<double> times = {1.0 / 64, 1.0 / 16, 0.25, 1.0, 4.0};
  const auto curve = test::gamma_curve();
  const Bracket b = test::photograph(e, times, curve);
  const CameraResponse truth = test::true_response(curve);
  MergeOptions options;
  options.flag_image = true;
  MergeReport report;
  const RgbImage out = merge_bracket(b, truth, options, &report);
  EXPECT_EQ(report.saturated_everywhere, bright.size() + 1);
  EXPECT_EQ(report.black_everywhere, dark.size());
  ASSERT_EQ(report.flags.size(), size_t(64 * 48));
  size_t flagged = 0;
  for (uint8_t f : report.flags) flagged += f != 0;
  EXPECT_EQ(flagged, bright.size() + dark.size() + 1);
  for (size_t p : bright) EXPECT_EQ(report.flags[p], kSaturatedEverywhere);
  for (size_t p : dark) EXPECT_EQ(report.flags[p], kBlackEverywhere);
  EXPECT_EQ(report.flags[1500], kSaturatedEverywhere);
  // Saturated: the shortest exposure's estimate exp(g(255)) / t, a lower bound on the truth
  // (k turns the response's relative units back into the radiance's).
  const double k = curve.f_inv(128.0 / 255.0);
  const double lower = std::exp(double(truth.log_exposure[0][255])) / times.front();
  EXPECT_NEAR(out.rgb[3 * bright[0]] / lower, 1.0, 1e-5);
  EXPECT_LT(out.rgb[3 * bright[0]] * k, 1e5);
  // Black: the longest exposure's estimate exp(g(0)) / t, an upper bound.
  const double upper = std::exp(double(truth.log_exposure[0][0])) / times.back();
  EXPECT_NEAR(out.rgb[3 * dark[0]] / upper, 1.0, 1e-5);
  EXPECT_GT(out.rgb[3 * dark[0]] * k, 1e-7);
  EXPECT_TRUE(out.valid.empty());
}

TEST(MergeBracket, GivesTheSameImageOnOneThreadAsOnMany) {
  const Bracket b = test::photograph(test::random_radiance(64, 64, 1e-3, 10.0), {0.01, 0.1, 1.0}, test::gamma_curve());
  const CameraResponse r = test::true_response(test::gamma_curve());
  MergeOptions one;
  one.threads = 1;
  EXPECT_EQ(merge_bracket(b, r, one).rgb, merge_bracket(b, r, {}).rgb);
}

// Frames someone else owns, inside wider buffers (a row stride of 80 pixels for 64-pixel rows,
// with garbage in the gap): the same image bit for bit, masks and ignored colour included.
TEST(MergeBracket, ViewsOfStridedFramesMergeToTheSameImageAsTheBracket) {
  Bracket b = test::photograph(test::random_radiance(64, 48, 1e-3, 10.0), {0.01, 0.1, 1.0}, test::gamma_curve());
  b.frames[1].valid.assign(64 * 48, 1);
  for (size_t i = 0; i < b.frames[1].valid.size(); i += 7) b.frames[1].valid[i] = 0;
  const CameraResponse r = test::true_response(test::gamma_curve());
  std::vector<std::vector<float>> buffers;
  std::vector<std::vector<uint8_t>> masks;
  BracketView v = bracket_view(b);
  for (size_t k = 0; k < b.frames.size(); ++k) {
    buffers.emplace_back(size_t(80) * 48 * 3, -7.0f);  // the gap holds values no merge may read
    masks.emplace_back(size_t(80) * 48, 0);
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 64; ++x) {
        for (int c = 0; c < 3; ++c) buffers[k][(size_t(y) * 80 + size_t(x)) * 3 + size_t(c)] = b.frames[k].rgb[(size_t(y) * 64 + size_t(x)) * 3 + size_t(c)];
        masks[k][size_t(y) * 80 + size_t(x)] = b.frames[k].valid.empty() ? 1 : b.frames[k].valid[size_t(y) * 64 + size_t(x)];
      }
    v.frames[k] = {buffers[k].data(), 64, 48, 3, size_t(80) * 3, b.frames[k].valid.empty() ? nullptr : masks[k].data()};
  }
  MergeOptions o;
  o.ignore_colour = std::array<uint8_t, 3>{0, 0, 0};
  const RgbImage want = merge_bracket(b, r, o), got = merge_bracket(v, r, o);
  EXPECT_EQ(got.rgb, want.rgb);
  EXPECT_EQ(got.valid, want.valid);
  Bracket unmasked = b;  // the mask took effect: without it the merge differs
  unmasked.frames[1].valid.clear();
  EXPECT_NE(merge_bracket(unmasked, r, o).rgb, want.rgb);
  v.frames.pop_back();
  EXPECT_THROW(merge_bracket(v, r, o), InputError);
}

TEST(MergeBracket, IgnoresTheBorderColourAndMarksPixelsThatAreBorderInEveryFrameInvalid) {
  const RgbImage e = test::random_radiance(32, 32, 1e-2, 1.0);
  Bracket b = test::photograph(e, {0.25, 1.0, 4.0}, test::gamma_curve());
  auto paint = [&](size_t k, size_t p) {
    float* v = &b.frames[k].rgb[3 * p];
    v[0] = 0.0f, v[1] = 0.0f, v[2] = 1.0f;
  };
  for (size_t k = 0; k < 3; ++k) paint(k, 10);
  paint(0, 20);
  paint(1, 20);
  const CameraResponse r = test::true_response(test::gamma_curve());
  MergeOptions options;
  options.ignore_colour = kBlue;
  MergeReport report;
  const RgbImage out = merge_bracket(b, r, options, &report);
  EXPECT_EQ(report.ignored, 1u);
  ASSERT_EQ(out.valid.size(), size_t(32 * 32));
  EXPECT_EQ(out.valid[10], 0);
  EXPECT_EQ(out.valid[20], 1);
  // Pixel 20 comes from the third frame alone: the same as merging that frame with one that
  // is border everywhere (two frames at one exposure time are refused).
  Bracket last;
  RgbImage border = b.frames[2];
  for (size_t p = 0; p < border.rgb.size() / 3; ++p) border.rgb[3 * p] = border.rgb[3 * p + 1] = 0.0f, border.rgb[3 * p + 2] = 1.0f;
  last.frames = {b.frames[2], border};
  last.exposure_seconds = {4.0, 1.0};
  const RgbImage alone = merge_bracket(last, r, options);
  for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(out.rgb[3 * 20 + size_t(c)], alone.rgb[3 * 20 + size_t(c)]);
}

TEST(MergeBracket, RefusesABracketWithNoPixelWellExposedInAnyFrame) {
  const CameraResponse r = test::true_response(test::gamma_curve());
  for (float level : {0.0f, 1.0f}) {  // all black, all saturated
    Bracket b;
    for (int k = 0; k < 3; ++k) {
      RgbImage f;
      f.width = 6, f.height = 4;
      f.rgb.assign(3 * 6 * 4, level);
      b.frames.push_back(f);
      b.paths.push_back("frame" + std::to_string(k) + ".png");
    }
    b.exposure_seconds = {0.01, 0.1, 1.0};
    try {
      merge_bracket(b, r);
      ADD_FAILURE() << "a bracket at level " << level << " was fused";
    } catch (const InputError& e) {
      EXPECT_STREQ(e.what(), "frame0.png .. frame2.png: no pixel is well exposed in any of the 3 frames (every one "
                             "is black or saturated in all of them)");
    }
    // One mid-grey pixel in one frame is a measurement: fused, and counted.
    b.frames[1].rgb[3 * 5] = b.frames[1].rgb[3 * 5 + 1] = b.frames[1].rgb[3 * 5 + 2] = 0.5f;
    MergeReport report;
    merge_bracket(b, r, {}, &report);
    EXPECT_EQ(report.well_exposed, 1u);
  }
}

TEST(MergeBracket, RefusesAResponseOfTheWrongShapeAndBadThresholds) {
  const Bracket b = test::photograph(test::random_radiance(8, 8, 1e-2, 1.0), {0.5, 1.0}, test::gamma_curve());
  CameraResponse r = test::true_response(test::gamma_curve());
  r.log_exposure[1].pop_back();
  EXPECT_THROW(merge_bracket(b, r), InputError);
  MergeOptions bad;
  bad.black_threshold = 0.9;
  bad.saturation_threshold = 0.1;
  EXPECT_THROW(merge_bracket(b, linear_response(), bad), InputError);
}

class Memorial : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::vector<std::string> paths;
    for (int i = 61; i <= 76; ++i) paths.push_back(kMemorial + "/memorial00" + std::to_string(i) + ".png");
    bracket_ = new Bracket(read_bracket(paths, read_exposure_list(kMemorial + "/exposures.csv")));
  }
  static void TearDownTestSuite() {
    delete bracket_;
    bracket_ = nullptr;
  }
  static Bracket* bracket_;
};
Bracket* Memorial::bracket_ = nullptr;

TEST_F(Memorial, FusesToDebevecsOwnRadianceMapWithinAMeasuredLogError) {
  const Bracket& b = *bracket_;
  ASSERT_EQ(b.frames.size(), 16u);
  EXPECT_DOUBLE_EQ(b.exposure_seconds.front(), 32.0);
  EXPECT_DOUBLE_EQ(b.exposure_seconds.back(), 1.0 / 1024);
  DebevecOptions dopt;
  dopt.ignore_colour = kBlue;
  const CameraResponse resp = recover_debevec(b, dopt);
  MergeOptions mopt;
  mopt.ignore_colour = kBlue;
  MergeReport report;
  const RgbImage ours = merge_bracket(b, resp, mopt, &report);
  const RgbImage ref = read_rgb_image(kMemorial + "/reference/memorial_radiance_hdrshop.hdr");
  ASSERT_EQ(ref.width, ours.width);
  ASSERT_EQ(ref.height, ours.height);
  const auto err = test::log10_luminance_error(ours, ref, ours.valid);
  RobertsonOptions ropt;
  ropt.ignore_colour = kBlue;
  const auto err_rob = test::log10_luminance_error(merge_bracket(b, recover_robertson(b, ropt), mopt), ref, ours.valid);
  const CameraResponse cv_resp = opencv_recover_response(b, OpenCvHdrMethod::Debevec);
  const auto err_cv = test::log10_luminance_error(opencv_merge(b, OpenCvHdrMethod::Debevec, &cv_resp), ref, ours.valid);
  std::printf("[ memorial vs HDRShop ] |dlog10 Y| median/p95: ours (Debevec g) %.4f/%.4f, ours (Robertson g) "
              "%.4f/%.4f, OpenCV Calibrate+MergeDebevec %.4f/%.4f; %zu px compared, %zu border-only, "
              "%zu saturated everywhere, %zu black everywhere\n",
              err.median, err.p95, err_rob.median, err_rob.p95, err_cv.median, err_cv.p95, err.count, report.ignored,
              report.saturated_everywhere, report.black_everywhere);
  EXPECT_GT(err.count, size_t(0.95 * 512 * 768));
  // Measured 0.0104/0.0508 with the default noise-aware weights (0.0117/0.0611 with hat x exposure time) (Robertson's g 0.0108/0.0579; OpenCV 0.0500/0.3412). The bounds
  // leave about 30 % headroom: the reference was assembled by HDRShop from the same scans
  // with its own curve and weights, so a few hundredths of a decade is agreement.
  EXPECT_LT(err.median, 0.016);
  EXPECT_LT(err.p95, 0.08);
  EXPECT_LT(err.median, err_cv.median);
}

TEST_F(Memorial, MergeSpeedIsMeasuredAgainstOnePassOverTheBracketAndOpenCv) {
  const Bracket& b = *bracket_;
  using clock = std::chrono::steady_clock;
  auto best_of = [](int n, auto&& f) {
    double best = 1e30;
    for (int i = 0; i < n; ++i) {
      const auto t0 = clock::now();
      f();
      best = std::min(best, std::chrono::duration<double>(clock::now() - t0).count());
    }
    return best;
  };
  volatile float sink = 0.0f;
  const double pass = best_of(5, [&] {
    float s = 0.0f;
    for (const RgbImage& f : b.frames)
      for (float v : f.rgb) s += v;
    sink = s;
  });
  const CameraResponse r = linear_response(256);
  MergeOptions one, two;
  one.threads = 1;
  two.threads = 2;
  const double t1 = best_of(5, [&] { merge_bracket(b, r, one); });
  const double t2 = best_of(5, [&] { merge_bracket(b, r, two); });
  double cv_deb = 1e30, cv_rob = 1e30;
  for (int i = 0; i < 2; ++i) {
    double s = 0.0;
    opencv_merge(b, OpenCvHdrMethod::Debevec, &r, &s);
    cv_deb = std::min(cv_deb, s);
    opencv_merge(b, OpenCvHdrMethod::Robertson, &r, &s);
    cv_rob = std::min(cv_rob, s);
  }
  std::printf("[ merge speed, 16 x 512x768 ] one plain pass %.1f ms; ours 1 thread %.1f ms (%.2fx pass), "
              "2 threads %.1f ms (%.2fx pass); cv::MergeDebevec %.1f ms (%.1fx ours@2), cv::MergeRobertson %.1f ms "
              "(%.1fx ours@2)\n",
              pass * 1e3, t1 * 1e3, t1 / pass, t2 * 1e3, t2 / pass, cv_deb * 1e3, cv_deb / t2, cv_rob * 1e3,
              cv_rob / t2);
  RecordProperty("merge_2_threads_over_pass", std::to_string(t2 / pass));
  RecordProperty("cv_merge_debevec_over_ours", std::to_string(cv_deb / t2));
  SUCCEED();  // no timing asserts: the numbers are reported
}

}  // namespace
}  // namespace lp
