// Projection uncertainty (calib/projection_uncertainty.h) against the actual error of
// calibrations from corners with known Gaussian noise, projected through a known camera.
#include "calib/projection_uncertainty.h"

#include <gtest/gtest.h>

#include "tests/calib/test_cameras.h"

#include <cmath>
#include <random>

#include "calib/geometric.h"
#include "core/error.h"

namespace lp {
namespace {

using calib_test::kb190;

using Corners = std::vector<std::vector<std::array<double, 2>>>;

Vec3 rotate(Vec3 axis, double angle, Vec3 v) {
  const double c = std::cos(angle), s = std::sin(angle);
  return c * v + s * cross(axis, v) + (1 - c) * dot(axis, v) * axis;
}

// Boards spread over the field on a golden-angle spiral (off-axis up to max_theta_deg),
// tilted 15-35 deg, shrunk towards the axis until every corner is inside the image.
Corners make_views(const CameraModel& cam, const BoardSpec& board, int nviews, double max_theta_deg, double distance,
                   double noise_px, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, noise_px);
  std::uniform_real_distribution<double> jitter(0.0, 1.0);
  Corners out;
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < nviews; ++i) {
    double theta = max_theta_deg * M_PI / 180 * std::sqrt((i + 0.5) / nviews);
    const double phi = i * golden + 0.3 * jitter(rng);
    for (int attempt = 0; attempt < 40; ++attempt, theta *= 0.95) {
      const Vec3 dir = direction_from_angles(theta, phi);
      const Vec3 a = std::abs(dir.y) > 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
      Vec3 e1 = normalize(cross(a, dir));
      Vec3 e2 = cross(dir, e1);
      const Vec3 axis = normalize(std::cos(1.3 * i) * e1 + std::sin(1.3 * i) * e2);
      const double tilt = (15 + 20 * ((i * 7) % 5) / 4.0) * M_PI / 180;
      e1 = rotate(axis, tilt, e1);
      e2 = rotate(axis, tilt, e2);
      const double cx = (board.cols - 1) * board.square_mm / 2, cy = (board.rows - 1) * board.square_mm / 2;
      std::vector<std::array<double, 2>> v;
      for (int r = 0; r < board.rows; ++r)
        for (int c = 0; c < board.cols; ++c) {
          const Vec3 P = distance * dir + (c * board.square_mm - cx) * e1 + (r * board.square_mm - cy) * e2;
          const auto q = project(cam, P);
          if (!q || std::acos(P.z / length(P)) > 93 * M_PI / 180 || q->x < 2 || q->y < 2 || q->x > cam.width - 3 ||
              q->y > cam.height - 3)
            break;
          v.push_back({q->x + gauss(rng), q->y + gauss(rng)});
        }
      if (int(v.size()) == board.cols * board.rows) {
        out.push_back(v);
        break;
      }
    }
  }
  return out;
}

// Grid points within 30 px of some corner: where the boards were.
std::vector<std::array<double, 2>> near_corners(const std::vector<std::array<double, 2>>& grid, const Corners& views) {
  std::vector<std::array<double, 2>> out;
  for (const auto& g : grid) {
    bool near = false;
    for (const auto& v : views)
      for (const auto& q : v) near = near || std::hypot(g[0] - q[0], g[1] - q[1]) < 30;
    if (near) out.push_back(g);
  }
  return out;
}

const BoardSpec kBoard{10, 7, 40};

// Over several noise draws (one draw's error field has few degrees of freedom: 8
// intrinsics), the predicted spread must match the actual error against the truth.
TEST(ProjectionUncertainty, PredictsTheErrorAgainstTheTrueModel) {
  const CameraModel truth = kb190();
  double act2 = 0, lin2 = 0, mf2 = 0, jk2 = 0, cv2 = 0, pcv_lin2 = 0, pcv_jk2 = 0, rep2 = 0, pcand2 = 0;
  int draws = 0;
  for (unsigned seed = 1; seed <= 4; ++seed) {
    const Corners views = make_views(truth, kBoard, 14, 80, 600, 0.2, seed);
    ASSERT_EQ(views.size(), 14u);
    CalibrateOptions opt;
    opt.model = "LENSMODEL_KANNALA_BRANDT";
    opt.uncertainty_nx = 32;
    opt.uncertainty_ny = 24;
    const CalibrationResult r = calibrate(views, kBoard, truth.width, truth.height, opt);
    const UncertaintyReport& u = r.uncertainty;
    ASSERT_TRUE(u.linear_ok) << u.linear_error;
    EXPECT_NEAR(u.sigma_px, 0.2, 0.02);
    // Actual error over the covered grid points, rotation fitted out there.
    const auto grid = u.rotation_fitted.pixel;
    const auto covered = near_corners(grid, views);
    const auto d = projection_difference_vectors(r.model, truth, covered, grid);
    double a = 0, l = 0, m = 0, j = 0;
    int k = 0;
    for (size_t i = 0; i < grid.size(); ++i) {
      bool in = false;
      for (const auto& c : covered) in = in || (c[0] == grid[i][0] && c[1] == grid[i][1]);
      if (!in || !std::isfinite(d[i][0])) continue;
      a += d[i][0] * d[i][0] + d[i][1] * d[i][1];
      l += std::pow(u.rotation_fitted.rms_px[i], 2);
      m += std::pow(u.mean_frames.rms_px[i], 2);
      j += std::pow(u.jackknife.rms_px[i], 2);
      ++k;
    }
    ASSERT_GT(k, 50);
    std::printf("  seed %u: actual %.3f  linear(rot) %.3f  linear(mean frames) %.3f  jackknife %.3f px;  cv %.3f "
                "predicted linear %.3f jackknife %.3f\n",
                seed, std::sqrt(a / k), std::sqrt(l / k), std::sqrt(m / k), std::sqrt(j / k), r.cross_validation_px,
                u.predicted_cv_linear_px, u.predicted_cv_jackknife_px);
    act2 += a / k;
    lin2 += l / k;
    mf2 += m / k;
    jk2 += j / k;
    cv2 += r.cross_validation_px * r.cross_validation_px;
    rep2 += u.cv_repeated_px * u.cv_repeated_px;
    EXPECT_EQ(u.cv_splits, 4);
    pcv_lin2 += u.predicted_cv_linear_px * u.predicted_cv_linear_px;
    // The table's per-candidate forecast (full fit, 2 sigma) agrees with the one from the
    // halves' own covariances, and forecasts the repeated cross-validation the same way.
    ASSERT_EQ(r.table.size(), 1u);
    const double cand = r.table[0].linear_forecast_cv_px;
    EXPECT_GT(cand / u.predicted_cv_linear_px, 0.7) << cand;
    EXPECT_LT(cand / u.predicted_cv_linear_px, 1.4) << cand;
    pcand2 += cand * cand;
    pcv_jk2 += u.predicted_cv_jackknife_px * u.predicted_cv_jackknife_px;
    ++draws;
  }
  const double lin = std::sqrt(lin2 / act2), jk = std::sqrt(jk2 / act2), mf = std::sqrt(mf2 / act2);
  std::printf("  predicted / actual: linear(rot) %.2f  mean frames %.2f  jackknife %.2f;  predicted / measured cv: "
              "linear %.2f jackknife %.2f\n",
              lin, mf, jk, std::sqrt(pcv_lin2 / cv2), std::sqrt(pcv_jk2 / cv2));
  std::printf("  predicted / cross-validation over 4 splits: linear %.2f jackknife %.2f, table's linear %.2f\n",
              std::sqrt(pcv_lin2 / rep2), std::sqrt(pcv_jk2 / rep2), std::sqrt(pcand2 / rep2));
  EXPECT_GT(std::sqrt(pcand2 / rep2), 1 / 1.5);
  EXPECT_LT(std::sqrt(pcand2 / rep2), 1.5);
  // Measured: linear (rotation fitted out) 1.08, mean frames 1.25 (it keeps the frame
  // uncertainty that fitting the rotation removes), jackknife 1.27; cross-validation
  // forecasts 1.03 (linear) and 1.18 (jackknife). With Gaussian noise and the right model
  // the linear estimate is exact to first order: a factor 1.5 either way allows for four
  // draws of an error field with few degrees of freedom, while a sigma or a covariance off
  // by 2x fails.
  EXPECT_GT(lin, 1 / 1.5);
  EXPECT_LT(lin, 1.5);
  EXPECT_GT(jk, 0.5);
  EXPECT_LT(jk, 2.0);
  EXPECT_GT(std::sqrt(pcv_lin2 / cv2), 1 / 1.5);
  EXPECT_LT(std::sqrt(pcv_lin2 / cv2), 1.5);
  EXPECT_GT(std::sqrt(pcv_jk2 / cv2), 0.5);
  EXPECT_LT(std::sqrt(pcv_jk2 / cv2), 2.0);
  // Against the cross-validation repeated over 4 balanced splits (measured 0.88 linear,
  // 1.00 jackknife).
  EXPECT_GT(std::sqrt(pcv_lin2 / rep2), 1 / 1.5);
  EXPECT_LT(std::sqrt(pcv_lin2 / rep2), 1.5);
  EXPECT_GT(std::sqrt(pcv_jk2 / rep2), 1 / 1.5);
  EXPECT_LT(std::sqrt(pcv_jk2 / rep2), 1.5);
}

// The jackknife against its definition computed apart: each leave-one-out model's difference
// vectors from the full model (projection_difference_vectors, rotation fitted over the covered
// pixels), their covariance per pixel times (n - 1) / n. The grid at the covered pixels comes
// from the same unprojection as the rotation's fit; on one core and on every core alike.
TEST(ProjectionUncertainty, TheJackknifeIsTheSpreadOfTheLeaveOneOutDifferences) {
  const CameraModel full = kb190();
  std::mt19937 rng(7);
  std::normal_distribution<double> n01(0, 1);
  std::vector<CameraModel> loo(9, full);
  for (CameraModel& m : loo) {
    m.intrinsics[0] += 0.4 * n01(rng), m.intrinsics[1] += 0.4 * n01(rng);
    m.intrinsics[2] += 0.3 * n01(rng), m.intrinsics[3] += 0.3 * n01(rng);
    for (size_t k = 4; k < m.intrinsics.size(); ++k) m.intrinsics[k] += 2e-3 * n01(rng);
  }
  const auto grid = grid_pixels(full, 16, 12);
  std::vector<std::array<double, 2>> covered;
  for (double y = 0.3 * full.height; y < 0.7 * full.height; y += 23)
    for (double x = 0.3 * full.width; x < 0.7 * full.width; x += 23) covered.push_back({x, y});
  ASSERT_GT(covered.size(), 50u);
  // The definition, for `pixels`.
  const auto reference = [&](const std::vector<std::array<double, 2>>& pixels) {
    std::vector<std::vector<std::array<double, 2>>> d;
    for (const CameraModel& m : loo) d.push_back(projection_difference_vectors(m, full, covered, pixels));
    std::vector<double> rms(pixels.size());
    const double n = double(loo.size());
    for (size_t p = 0; p < pixels.size(); ++p) {
      double mx = 0, my = 0;
      for (const auto& v : d) mx += v[p][0] / n, my += v[p][1] / n;
      double ss = 0;
      for (const auto& v : d) ss += std::pow(v[p][0] - mx, 2) + std::pow(v[p][1] - my, 2);
      rms[p] = std::sqrt(ss * (n - 1) / n);
    }
    return rms;
  };
  const auto want_grid = reference(grid), want_covered = reference(covered);
  UncertaintyGrid at_covered, at_covered_serial;
  const UncertaintyGrid g = jackknife_uncertainty(full, loo, covered, grid, 16, 12, &at_covered, true);
  const UncertaintyGrid serial = jackknife_uncertainty(full, loo, covered, grid, 16, 12, &at_covered_serial, false);
  const UncertaintyGrid alone = jackknife_uncertainty(full, loo, covered, covered, int(covered.size()), 1);
  ASSERT_EQ(g.rms_px.size(), grid.size());
  ASSERT_EQ(at_covered.rms_px.size(), covered.size());
  int finite = 0;
  for (size_t p = 0; p < grid.size(); ++p) {
    if (!std::isfinite(want_grid[p])) continue;
    ++finite;
    EXPECT_NEAR(g.rms_px[p], want_grid[p], 1e-9 * (1 + want_grid[p])) << p;
    EXPECT_EQ(serial.rms_px[p], g.rms_px[p]) << p;
  }
  EXPECT_GT(finite, 60);  // the 190 deg lens images a circle: the grid's corners have no ray
  double spread = 0;
  for (size_t p = 0; p < covered.size(); ++p) {
    EXPECT_NEAR(at_covered.rms_px[p], want_covered[p], 1e-9 * (1 + want_covered[p])) << p;
    EXPECT_EQ(at_covered.rms_px[p], alone.rms_px[p]) << p;  // the same as asking for it alone
    EXPECT_EQ(at_covered_serial.rms_px[p], at_covered.rms_px[p]) << p;
    spread += at_covered.rms_px[p] / double(covered.size());
  }
  std::printf("  mean jackknife over the covered pixels %.3f px, %d grid points with a ray\n", spread, finite);
  EXPECT_GT(spread, 0.1);  // the perturbations show: a zero grid would not pass
  EXPECT_EQ(at_covered.median_px, alone.median_px);
}

TEST(ProjectionUncertainty, NoiseFreeCornersHaveNoUncertaintyAndSplinedIsRefused) {
  const CameraModel truth = kb190();
  const Corners views = make_views(truth, kBoard, 8, 70, 600, 0.0, 3);
  CalibrateOptions opt;
  opt.model = "LENSMODEL_KANNALA_BRANDT";
  opt.leverage = false;
  const CalibrationResult r = calibrate(views, kBoard, truth.width, truth.height, opt);
  ASSERT_TRUE(r.uncertainty.linear_ok);
  EXPECT_LT(r.uncertainty.sigma_px, 1e-4);
  EXPECT_LT(r.uncertainty.rotation_fitted.median_px, 1e-3);
  EXPECT_EQ(r.uncertainty.headline, "linear");  // no leave-one-out fits without leverage
  CameraModel spl;
  spl.lensmodel = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=6_fov_x_deg=200";
  spl.intrinsics.assign(size_t(intrinsics_count(spl.lensmodel)), 0.0);
  const LinearCovariance none = linearised_covariance(spl, kBoard, {});
  EXPECT_FALSE(none.ok);
  // No numbers that look like a perfect calibration where there is no estimate.
  const UncertaintyGrid g = linear_uncertainty_rotation_fitted(none, spl, {}, 16, grid_pixels(truth, 4, 3), 4, 3);
  EXPECT_TRUE(std::isnan(g.median_px));
  EXPECT_TRUE(std::isnan(g.centre_px));
  SolvedView bad;
  bad.px.resize(3);
  bad.inlier.resize(3, 1);
  EXPECT_THROW(linearised_covariance(truth, kBoard, {bad}), InputError);
}

}  // namespace
}  // namespace lp
