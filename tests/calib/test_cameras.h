// Cameras the calibration tests share.
#pragma once

#include <algorithm>
#include <array>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "calib/board_detect.h"
#include "calib/calibration_problem.h"
#include "calib/camera_model.h"

#include <opencv2/calib3d.hpp>

namespace lp::calib_test {

// 190 deg Kannala-Brandt fisheye on a 1280x960 sensor: the 95 deg ray lands 554 px from
// the centre (a circle cropped at top and bottom).
inline CameraModel kb190() {
  return {"LENSMODEL_KANNALA_BRANDT", {330, 331, 641.3, 478.6, 0.02, -0.01, 0.003, -0.0005}, 1280, 960};
}

// Corners of `board` at each pose (rvec, tvec: camera_from_board, mm) through `truth`, with
// Gaussian noise of noise_px on each coordinate (deterministic per seed); empty when a
// corner cannot be imaged. For sets rebuilt from an audit's poses.
inline std::vector<std::vector<std::array<double, 2>>> corners_at_poses(const CameraModel& truth,
                                                                        const BoardSpec& board,
                                                                        const std::vector<std::array<double, 6>>& poses,
                                                                        double noise_px, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, noise_px);
  std::vector<std::vector<std::array<double, 2>>> views;
  for (const auto& p : poses) {
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(p[0], p[1], p[2]), R);
    views.emplace_back();
    for (int k = 0; k < board.cols * board.rows; ++k) {
      const auto b = board_point(board, k);
      const cv::Vec3d X = R * cv::Vec3d(b[0], b[1], b[2]) + cv::Vec3d(p[3], p[4], p[5]);
      const auto q = project(truth, Vec3{X[0], X[1], X[2]});
      if (!q) return {};
      views.back().push_back(std::array<double, 2>{q->x + noise(rng), q->y + noise(rng)});
    }
  }
  return views;
}

// A wide rational lens behind 6000x3376 px (corners to 75 deg off the axis, k4 = 1.1) and the
// poses of 14 views of a 14x14 board of 30 mm squares (camera_from_board, mm) that
// `lightprobe synth boards` rendered through it: where the rational model's usual starts
// stop at 15x the noise.
inline CameraModel wide_rational_6000() {
  return {"LENSMODEL_OPENCV8", {1900, 1901, 3010.5, 1680.2, 0.8, 0.2, 3e-4, -2e-4, 0.01, 1.1, 0.45, 0.04}, 6000, 3376};
}
inline const BoardSpec kWideRationalBoard{14, 14, 30};
inline std::vector<std::array<double, 6>> wide_rational_poses() {
  return {{-0.423543, -0.831215, -1.92775, 43.5674, 171.465, 412.392}, {1.35684, 0.130316, 1.89722, 830.299, 425.883, 251.551},
          {-0.109129, 0.00878989, 2.30117, 248.131, -9.20521, 390.713}, {0.83465, 0.827023, 0.687677, 708.746, -870.073, 750.336},
          {0.365143, -0.316005, -2.0036, -251.486, 292.013, 357.65},    {1.18357, 0.479303, 2.83257, 352.998, 223.546, 529.46},
          {0.567941, 0.302424, -2.62569, -348.788, -62.1544, 881.176},  {0.296817, -0.204341, 1.2483, 131.056, -437.886, 502.848},
          {0.119847, -0.478797, 2.59632, 782.029, -166.116, 448.882},   {-0.232041, 0.629547, -0.992948, 185.11, 120.531, 591.94},
          {0.223143, -0.589212, -2.39421, -765.174, 377.124, 635.009},  {-0.739674, -0.366421, -1.79071, 254.406, 243.186, 350.281},
          {0.702688, 0.422847, 0.884963, 552.549, 68.5504, 784.038},    {0.0485299, -0.191793, 1.90535, 512.268, -257.928, 406.448}};
}

// Detections as detect_boards gives them, from corners projected through `cam`: image i is
// named prefix + "view_<i>.png".
inline BoardDetections detections_of(const std::vector<std::vector<std::array<double, 2>>>& corners,
                                     const CameraModel& cam, const std::string& prefix = "") {
  BoardDetections d;
  for (size_t i = 0; i < corners.size(); ++i) {
    d.images.push_back(prefix + "view_" + std::to_string(i) + ".png");
    BoardDetection b;
    b.found = !corners[i].empty();
    b.corners = corners[i];
    b.method = "projected";
    d.per_image.push_back(b);
    d.found += b.found;
  }
  d.corners = corners;
  d.width = cam.width;
  d.height = cam.height;
  return d;
}

// The shared real chessboard sets (../shared/data, each folder's PROVENANCE.md gives the
// board): name, folder, file-name prefix of the images, board.
struct RealSet {
  const char* name;
  std::string dir, prefix;
  BoardSpec board;
};
inline std::vector<RealSet> real_sets() {
  const std::string data = LIGHTPROBE_SHARED_DATA;
  return {{"stereo left", data + "/calib-opencv-stereo-9x6", "left", {9, 6, 25}},
          {"stereo right", data + "/calib-opencv-stereo-9x6", "right", {9, 6, 25}},
          {"fisheye1", data + "/calib-ocamcalib-fisheye1", "Fisheye1_", {6, 8, 32.5}},
          {"Ladybug", data + "/calib-ocamcalib-omni-samples/Ladybug", "", {5, 8, 30}},
          {"VMRImage", data + "/calib-ocamcalib-omni-samples/VMRImage", "", {6, 7, 30}},
          {"KaidanOmni", data + "/calib-ocamcalib-omni-samples/KaidanOmni", "", {7, 11, 30}},
          {"MiniOmni", data + "/calib-ocamcalib-omni-samples/MiniOmni", "", {7, 11, 30}},
          {"Fisheye190deg", data + "/calib-ocamcalib-omni-samples/Fisheye190deg", "", {6, 7, 30}}};
}
// The images of a set in their natural order (Fisheye1_2 before Fisheye1_10); empty when
// the folder is missing.
inline std::vector<std::string> real_set_images(const RealSet& set) {
  std::vector<std::pair<long, std::string>> files;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(set.dir, ec)) {
    const std::string f = e.path().filename().string();
    const std::string ext = e.path().extension().string();
    if (f.rfind(set.prefix, 0) != 0 || (ext != ".jpg" && ext != ".bmp" && ext != ".png" && ext != ".gif")) continue;
    const size_t d = f.find_first_of("0123456789", set.prefix.size());
    files.push_back({d == std::string::npos ? 0 : std::atol(f.c_str() + d), e.path().string()});
  }
  std::sort(files.begin(), files.end());
  std::vector<std::string> images;
  for (const auto& f : files) images.push_back(f.second);
  return images;
}

// The corners of every view of `set` with a board (detect_boards) and the images' size; no
// views when the folder has no images.
struct RealSetViews {
  std::vector<std::vector<std::array<double, 2>>> views;
  int width = 0, height = 0;
};
inline RealSetViews real_set_views(const RealSet& set) {
  RealSetViews out;
  const std::vector<std::string> images = real_set_images(set);
  if (images.empty()) return out;
  const BoardDetections det = detect_boards(images, set.board);
  for (const auto& c : det.corners)
    if (!c.empty()) out.views.push_back(c);
  out.width = det.width;
  out.height = det.height;
  return out;
}

// The calibration problem of a real set's views: its board and image size, default options.
inline CalibrationProblem real_set_problem(const RealSet& set, const RealSetViews& views) {
  CalibrationProblem pr;
  pr.board = set.board;
  pr.width = views.width;
  pr.height = views.height;
  return pr;
}

}  // namespace lp::calib_test
