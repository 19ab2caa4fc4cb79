#include "probe/fisheye.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>

#include "core/error.h"

namespace lp {
namespace {

FisheyeModel distorted_model() {
  FisheyeModel m;
  m.width = 640;
  m.height = 480;
  m.fx = 151.5;
  m.fy = 149.0;
  m.cx = 321.3;
  m.cy = 238.7;
  m.k = {0.021, -0.012, 0.0031, -0.0004};
  m.max_theta_deg = 95;
  return m;
}

TEST(Fisheye, ProjectAndUnprojectAreInverseOverTheWholeField) {
  const FisheyeModel m = distorted_model();
  double worst = 0;
  int n = 0;
  // Within the field of view (95 degrees); beyond it this polynomial folds back.
  const auto rim = fisheye_project(m, direction_from_angles(95 * M_PI / 180, 0));
  ASSERT_TRUE(rim);
  const double max_r = std::hypot((rim->x - m.cx) / m.fx, (rim->y - m.cy) / m.fy);
  for (double y = 0; y < m.height; y += 7.3)
    for (double x = 0; x < m.width; x += 6.1) {
      if (std::hypot((x - m.cx) / m.fx, (y - m.cy) / m.fy) > max_r) continue;
      const Vec3 d = fisheye_unproject(m, x, y);
      ASSERT_TRUE(std::isfinite(d.x)) << x << "," << y;
      EXPECT_NEAR(length(d), 1.0, 1e-12);
      const auto p = fisheye_project(m, d);
      ASSERT_TRUE(p);
      worst = std::max(worst, std::hypot(p->x - x, p->y - y));
      ++n;
    }
  EXPECT_GT(n, 3000);
  EXPECT_LT(worst, 1e-8);
}

TEST(Fisheye, ProjectionAgreesWithOpenCvFisheyeProjectPointsForRandomDistortion) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uk(-0.05, 0.05), ut(0.0, 85.0 * M_PI / 180), up(0, 2 * M_PI);
  double worst = 0;
  for (int trial = 0; trial < 20; ++trial) {
    FisheyeModel m = distorted_model();
    m.k = {uk(rng), uk(rng) * 0.2, uk(rng) * 0.05, uk(rng) * 0.01};
    std::vector<cv::Point3d> cam;
    std::vector<Vec3> world;
    for (int i = 0; i < 200; ++i) {
      const double t = ut(rng), p = up(rng);
      const Vec3 c{std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
      cam.emplace_back(c.x, c.y, c.z);
      world.push_back(m.world_from_camera * c);
    }
    const cv::Matx33d K(m.fx, 0, m.cx, 0, m.fy, m.cy, 0, 0, 1);
    const cv::Vec4d D(m.k[0], m.k[1], m.k[2], m.k[3]);
    std::vector<cv::Point2d> ref;
    cv::fisheye::projectPoints(cam, ref, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D);
    for (size_t i = 0; i < cam.size(); ++i) {
      const auto q = fisheye_project(m, world[i]);
      ASSERT_TRUE(q);
      worst = std::max(worst, std::hypot(q->x - ref[i].x, q->y - ref[i].y));
    }
  }
  EXPECT_LT(worst, 1e-6);
}

TEST(Fisheye, UnprojectionAgreesWithOpenCvFisheyeUndistortPoints) {
  const FisheyeModel m = distorted_model();
  std::vector<cv::Point2d> pix, norm;
  // cv::fisheye::undistortPoints returns X/Z: keep theta below 80 degrees.
  const auto rim = fisheye_project(m, m.world_from_camera * direction_from_angles(80 * M_PI / 180, 0));
  const double max_r = std::hypot((rim->x - m.cx) / m.fx, (rim->y - m.cy) / m.fy);
  for (double y = 40; y < 440; y += 20)
    for (double x = 120; x < 520; x += 20)
      if (std::hypot((x - m.cx) / m.fx, (y - m.cy) / m.fy) < max_r) pix.emplace_back(x, y);
  ASSERT_GT(pix.size(), 100u);
  const cv::Matx33d K(m.fx, 0, m.cx, 0, m.fy, m.cy, 0, 0, 1);
  const cv::Vec4d D(m.k[0], m.k[1], m.k[2], m.k[3]);
  cv::fisheye::undistortPoints(pix, norm, K, D, cv::noArray(), cv::noArray(),
                               cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 50, 1e-14));
  double worst_deg = 0;
  for (size_t i = 0; i < pix.size(); ++i) {
    const Vec3 ours = transpose(m.world_from_camera) * fisheye_unproject(m, pix[i].x, pix[i].y);
    const Vec3 theirs = normalize(Vec3{norm[i].x, norm[i].y, 1.0});
    worst_deg = std::max(worst_deg, angle_between(ours, theirs) * 180 / M_PI);
  }
  EXPECT_LT(worst_deg, 1e-6);
}

TEST(Fisheye, DefaultOrientationPutsZenithAtTheCentreXUpAndYRight) {
  const FisheyeModel m = equidistant_fisheye(101, 101, 180);
  const auto z = fisheye_project(m, {0, 0, 1});
  ASSERT_TRUE(z);
  EXPECT_NEAR(z->x, 50.0, 1e-12);
  EXPECT_NEAR(z->y, 50.0, 1e-12);
  const auto x = fisheye_project(m, {1, 0, 0});  // on the horizon: the top of the circle
  ASSERT_TRUE(x);
  EXPECT_NEAR(x->x, 50.0, 1e-9);
  EXPECT_NEAR(x->y, 50.0 - 50.5, 1e-9);  // circle radius min(w,h)/2 = 50.5 px
  const auto y = fisheye_project(m, {0, 1, 0});
  ASSERT_TRUE(y);
  EXPECT_NEAR(y->x, 50.0 + 50.5, 1e-9);
  EXPECT_NEAR(y->y, 50.0, 1e-9);
  EXPECT_FALSE(fisheye_project(m, {0.1, 0, -1}));  // below the horizon
}

// A smooth sky with a soft sun: luminance spans 2.5 decades. Its radiance in direction d.
std::array<float, 3> sky_radiance(const Vec3& d) {
  const Vec3 sun = direction_from_angles(40 * M_PI / 180, 60 * M_PI / 180);
  const double a = angle_between(d, sun);
  const double sky = 0.2 + 0.8 * std::max(0.0, d.z) + 0.1 * std::cos(azimuth_of(d));
  const double s = 50.0 * std::exp(-a * a / (2 * 0.12 * 0.12));
  return {float(sky + s), float(0.9 * sky + s), float(1.3 * sky + 0.8 * s)};
}

EnvMap test_sky() {
  EnvMap map = make_latlong(256, 128);
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const auto c = sky_radiance(pixel_direction(map, i));
    map.rgb[3 * i] = c[0], map.rgb[3 * i + 1] = c[1], map.rgb[3 * i + 2] = c[2];
  }
  return map;
}

// Debevec's angular map (the light probe format of his gallery) is the equidistant fisheye
// over 360 degrees: the distance from the centre is the angle from the view direction, the
// rim the direction behind. Rendered here from its definition (radius r = R theta / pi, image
// up +X and right +Y as CONVENTIONS.md's fisheye), it unwraps to the whole sphere with
// `equidistant_fisheye(N, N, 360)`, what `probe unwrap --type fisheye --fov 360` uses.
TEST(Fisheye, AnAngularMapIsTheEquidistantFisheyeOf360Degrees) {
  const int n = 800;
  const double r = n / 2.0;
  RgbImage photo;
  photo.width = photo.height = n;
  photo.rgb.assign(3 * size_t(n) * size_t(n), 0.0f);
  for (int v = 0; v < n; ++v)
    for (int u = 0; u < n; ++u) {
      const double dx = (u + 0.5 - r) / r, dy = (v + 0.5 - r) / r, rho = std::hypot(dx, dy);
      if (rho >= 1 || rho == 0) continue;
      const double theta = rho * M_PI;
      const Vec3 d{std::sin(theta) * -dy / rho, std::sin(theta) * dx / rho, std::cos(theta)};
      const auto c = sky_radiance(d);
      std::copy(c.begin(), c.end(), photo.rgb.begin() + 3 * (size_t(v) * n + u));
    }
  const EnvMap map = unwrap_fisheye(photo, equidistant_fisheye(n, n, 360), Layout::LatLong, 256, 128);
  double sum = 0;
  int count = 0;
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const Vec3 d = pixel_direction(map, i);
    if (zenith_of(d) > 170 * M_PI / 180) continue;  // the last 10 degrees: a thin, stretched ring
    ASSERT_TRUE(map.is_valid(i)) << i;
    const float* a = map.pixel(i);
    const auto b = sky_radiance(d);
    sum += std::abs(std::log10(luminance(a[0], a[1], a[2]) / luminance(b[0], b[1], b[2])));
    ++count;
  }
  const double mean_abs_log10 = sum / count;
  std::printf("angular map: mean abs log10 luminance error %.5f over %d pixels\n", mean_abs_log10, count);
  EXPECT_LT(mean_abs_log10, 0.002);
}

TEST(Fisheye, UnwrappingARenderedFisheyeRecoversTheUpperHemisphere) {
  const EnvMap truth = test_sky();
  const FisheyeModel m = equidistant_fisheye(600, 600, 190);
  const RgbImage photo = render_fisheye(truth, m, 4);
  FisheyeUnwrapReport report;
  const EnvMap map = unwrap_fisheye(photo, m, Layout::LatLong, 256, 128, {}, &report);
  ASSERT_EQ(map.valid.size(), map.pixel_count());
  // Valid: theta up to 95 degrees (rows 0..67); the lower part is masked, not black.
  EXPECT_TRUE(map.is_valid(64 * 256 + 3));
  EXPECT_FALSE(map.is_valid(70 * 256 + 3));
  // Whole rows whose centre is within 95 degrees: rows 0..67, down to theta = 68 * 180 / 128.
  EXPECT_NEAR(report.valid_solid_angle, 2 * M_PI * (1 - std::cos(68 * M_PI / 128)), 1e-6);
  double sum = 0;
  int n = 0;
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    if (!map.is_valid(i) || zenith_of(pixel_direction(map, i)) > 90 * M_PI / 180) continue;
    const float* a = map.pixel(i);
    const float* b = truth.pixel(i);
    sum += std::abs(std::log10(luminance(a[0], a[1], a[2]) / luminance(b[0], b[1], b[2])));
    ++n;
  }
  const double mean_abs_log10 = sum / n;
  std::printf("unwrap mean abs log10 luminance error: %.5f over %d pixels\n", mean_abs_log10, n);
  RecordProperty("mean_abs_log10_error", std::to_string(mean_abs_log10));
  EXPECT_LT(mean_abs_log10, 0.001);  // measured 0.00017
}

TEST(Fisheye, UnwrapCanFillBelowTheHorizonAndReportsTheGuessedShare) {
  const FisheyeModel m = equidistant_fisheye(200, 200, 180);
  const RgbImage photo = render_fisheye(test_sky(), m, 2);
  FisheyeUnwrapReport report;
  FisheyeUnwrapOptions options;
  options.fill.method = FillMethod::PushPull;
  const EnvMap map = unwrap_fisheye(photo, m, Layout::LatLong, 128, 64, options, &report);
  for (float v : map.rgb) ASSERT_TRUE(std::isfinite(v) && v >= 0);
  EXPECT_GT(report.fill.filled_power_share, 0.05);
  EXPECT_LT(report.fill.filled_power_share, 0.5);
  EXPECT_FALSE(map.is_valid(map.pixel_count() - 1));  // mask kept
}

TEST(Fisheye, AModelForAnotherResolutionIsRefused) {
  const FisheyeModel m = equidistant_fisheye(300, 300, 180);
  RgbImage photo;
  photo.width = 640;
  photo.height = 480;
  photo.rgb.assign(640 * 480 * 3, 0.5f);
  try {
    unwrap_fisheye(photo, m, Layout::Hemisphere, 360, 90);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "camera model is for 300x300, image is 640x480");
  }
}

TEST(Fisheye, OpenCvYamlIsReadWithTheConventionKeysAndOtherModelsAreRefused) {
  const auto dir = std::filesystem::temp_directory_path() / ("lp_fisheye_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const FisheyeModel m = distorted_model();
  {
    cv::FileStorage fs((dir / "cam.yaml").string(), cv::FileStorage::WRITE);  // written by OpenCV alone
    fs << "image_width" << 640 << "image_height" << 480;
    fs << "camera_matrix" << cv::Mat(cv::Matx33d(m.fx, 0, m.cx, 0, m.fy, m.cy, 0, 0, 1));
    fs << "distortion_coefficients" << cv::Mat(cv::Vec4d(m.k[0], m.k[1], m.k[2], m.k[3]));
    fs << "distortion_model" << "fisheye";
  }
  const FisheyeModel r = read_fisheye_yaml((dir / "cam.yaml").string());
  EXPECT_EQ(r.width, 640);
  EXPECT_EQ(r.height, 480);
  EXPECT_EQ(r.fx, m.fx);
  EXPECT_EQ(r.cy, m.cy);
  EXPECT_EQ(r.k[3], m.k[3]);
  write_fisheye_yaml((dir / "back.yaml").string(), r);
  EXPECT_EQ(read_fisheye_yaml((dir / "back.yaml").string()).k[2], m.k[2]);
  {
    cv::FileStorage fs((dir / "pinhole.yaml").string(), cv::FileStorage::WRITE);
    fs << "image_width" << 640 << "image_height" << 480 << "distortion_model" << "plumb_bob";
  }
  EXPECT_THROW(read_fisheye_yaml((dir / "pinhole.yaml").string()), InputError);
  EXPECT_THROW(read_fisheye_yaml((dir / "cam.cameramodel").string()), InputError);
  EXPECT_THROW(read_fisheye_yaml((dir / "missing.yaml").string()), InputError);
  std::filesystem::remove_all(dir);
}

// Found by fuzz_opencv_yaml: OpenCV 4.6 ends the process on a key line with an empty key.
TEST(Fisheye, YamlWithAnEmptyKeyIsRefusedBeforeOpenCVCanAbortOnIt) {
  const auto dir = std::filesystem::temp_directory_path() / ("lp_fisheye_key_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "cam.yaml").string();
  std::ofstream(path) << "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ndistortion_model: fisheye\n"
                         "camera_matrix: !!opencv-matrix\n   rows: 3\n   :ols: 3\n   dt: d\n   data: [ 1, 2 ]\n";
  try {
    read_fisheye_yaml(path);
    ADD_FAILURE() << "read";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": line 8: an empty key (not the OpenCV YAML a camera file holds)");
  }
  std::filesystem::remove_all(dir);
}

// Found by fuzz_opencv_yaml: a camera_matrix that is not a matrix made OpenCV throw its own
// exception (an internal error, exit 1); it is bad input naming the file.
TEST(Fisheye, ACameraMatrixThatIsNotAMatrixIsBadInputNamingTheFile) {
  const auto dir = std::filesystem::temp_directory_path() / ("lp_fisheye_bad_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "cam.yaml").string();
  std::ofstream(path) << "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ndistortion_model: fisheye\n"
                         "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1, 2 ]\n"
                         "distortion_coefficients: [ 0, 0, 0, 0 ]\n";
  try {
    read_fisheye_yaml(path);
    ADD_FAILURE() << "a 3x3 matrix with two values was read";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
  }
  // A header that claims 10^10 values (OpenCV would allocate 80 GB before reading data).
  std::ofstream(path) << "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ndistortion_model: fisheye\n"
                         "camera_matrix: !!opencv-matrix\n   rows: 100000\n   cols: 100000\n   dt: d\n   data: [ 1 ]\n"
                         "distortion_coefficients: [ 0, 0, 0, 0 ]\n";
  try {
    read_fisheye_yaml(path);
    ADD_FAILURE() << "a 100000x100000 camera matrix was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("camera_matrix claims 100000x100000"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace lp
