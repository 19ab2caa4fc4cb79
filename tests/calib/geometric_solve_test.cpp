// The fast solve reaches the same minimum (calib/geometric.h solve_model_once and the
// warm-started outlier rounds of calibrate): against cv::fisheye where it is exact (every
// ray within 90 deg), against a cold solve of the final inliers, and against the truth.
#include <gtest/gtest.h>

#include <cmath>

#include "calib/geometric.h"
#include "calib/synthetic_boards.h"
#include "tests/calib/test_cameras.h"

namespace lp {
namespace {

using calib_test::kb190;

const BoardSpec kBoard{10, 7, 40};

TEST(GeometricSolve, OneKannalaBrandtSolveIsCvFisheyesMinimumWithinNinetyDegrees) {
  const CameraModel truth = kb190();
  // Corners within 85 deg: cv::fisheye's model is then the same function as ours, so both
  // minimise the same cost and must land on the same intrinsics.
  const auto views = project_board_views(truth, kBoard, 12, 70, 600, 0.2, 3, 85);
  ASSERT_GE(views.size(), 10u);
  // A flat board, as cv::fisheye's: the same cost (the board warp is a parameter OpenCV has not).
  CalibrateOptions flat;
  flat.board_warp = false;
  const SingleSolve ours = solve_model_once(views, kBoard, truth.width, truth.height, "LENSMODEL_KANNALA_BRANDT", flat);
  ASSERT_TRUE(ours.ok) << ours.error;
  const PeerCalibration* cv = nullptr;
  const auto peers = calibrate_opencv_alone(views, kBoard, truth.width, truth.height, 16);
  for (const auto& p : peers)
    if (p.name == "cv::fisheye") cv = &p;
  ASSERT_TRUE(cv && cv->ok);
  const ProjectionDiff d = projection_difference(ours.model, cv->model, {}, 16, false);
  std::printf("  ours vs cv::fisheye: rms %.2e px (max %.2e); RMS %.6f vs %.6f px; %.3f vs %.3f s\n", d.rms_px,
              d.max_px, ours.rms_px, cv->rms_px, ours.seconds, cv->seconds);
  // 1e-3 px: the tolerance the faster Ceres settings were accepted at (docs/calibration.md).
  EXPECT_LT(d.rms_px, 1e-3);
  EXPECT_GT(d.samples, 1000);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(ours.model.intrinsics[i], cv->model.intrinsics[i], 1e-3) << i;
  // Never a worse fit than OpenCV's (ours starts from it).
  EXPECT_LE(ours.rms_px, cv->rms_px + 1e-9);
  // And near the truth: 0.2 px noise over ~800 corners, error a few tenths of a pixel.
  const ProjectionDiff t = projection_difference(ours.model, truth, {}, 16);
  EXPECT_LT(t.median_px, 0.3);
}

TEST(GeometricSolve, WarmOutlierRoundsReachTheColdSolvesMinimum) {
  // A 20 px corner makes calibrate run more than one outlier round, the later ones warm
  // from the previous fit. Reference: a cold solve of the same corners with the outlier
  // moved onto the final model's projection (a zero residual does not move a minimum), so
  // both minimise the same cost.
  const CameraModel truth = kb190();
  auto views = project_board_views(truth, kBoard, 12, 80, 600, 0.1, 7, 93);
  ASSERT_GE(views.size(), 10u);
  views[4][23][0] += 20;
  CalibrateOptions opt;
  opt.model = "LENSMODEL_KANNALA_BRANDT";
  opt.leverage = false;
  opt.uncertainty = false;
  opt.board_warp_auto = false;  // solve_model_once below fits the warp: the same cost
  const CalibrationResult r = calibrate(views, kBoard, truth.width, truth.height, opt);
  ASSERT_EQ(r.corners_rejected, 1);
  EXPECT_GE(r.outlier_rounds, 2);
  for (const auto& c : r.residuals)
    if (c.outlier) {
      views[size_t(c.view)][size_t(c.corner)][0] -= c.dx;
      views[size_t(c.view)][size_t(c.corner)][1] -= c.dy;
    }
  const SingleSolve cold = solve_model_once(views, kBoard, truth.width, truth.height, opt.model);
  ASSERT_TRUE(cold.ok) << cold.error;
  const ProjectionDiff d = projection_difference(r.model, cold.model, {}, 16, false);
  std::printf("  warm rounds vs cold solve: rms %.2e px, max %.2e px; RMS %.6f vs %.6f\n", d.rms_px, d.max_px,
              r.model.rms_reprojection_px, cold.rms_px);
  EXPECT_LT(d.rms_px, 1e-3);
  EXPECT_NEAR(r.model.rms_reprojection_px, cold.rms_px * std::sqrt(double(r.corners_total) / (r.corners_total - 1)),
              1e-4);
  // The noise jackknife serves only the selection: not computed for a forced model.
  EXPECT_TRUE(std::isnan(r.cv_noise_px));
}

}  // namespace
}  // namespace lp
