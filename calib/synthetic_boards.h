// Ground truth for board detection and calibration (`lightprobe synth boards`): chessboard
// views rendered through a known camera model.
//
// Each output pixel is unprojected through the camera, the ray intersected with the board
// plane and coloured by the chessboard square it hits (4x4 supersampled where a pixel
// straddles an edge), inside a white margin one square wide on a grey background; then
// Gaussian blur and Gaussian noise. Pixels outside the lens's field (unproject fails, or
// the ray is beyond field_deg / 2 from the axis) are black, like a fisheye's image circle.
// Poses are random but deterministic per seed: the board centre at a random pixel of the
// image circle (image corners included), tilted 0-50 deg from facing the camera, at a
// distance where it spans 10-60 % of the image width's field of view, every corner and the
// margin inside the image. Board frame: inner corner (r, c) at (c, r, 0) * square_mm.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calib/board_detect.h"
#include "calib/camera_model.h"
#include "calib/lens_model.h"
#include "core/image_io.h"

namespace lp {

struct SyntheticBoardsOptions {
  int views = 20;
  BoardSpec board{9, 6, 30};
  // 190 deg Kannala-Brandt fisheye, 1280x960.
  CameraModel camera{lens_type_name(LensType::KannalaBrandt), {360, 360, 639.5, 479.5, 0.02, -0.005, 0, 0}, 1280, 960};
  double field_deg = 190;     // full angle of the image circle; 0: the model's own domain
  double noise_sigma = 0.01;  // image noise, [0, 1] units
  double blur_px = 0.7;       // Gaussian sigma
  uint64_t seed = 1;
  double min_tilt_deg = 0, max_tilt_deg = 50;
  double min_cover = 0.10, max_cover = 0.60;  // board width / image width, in field angle
};

struct SyntheticBoards {
  std::vector<CameraImage> images;
  // Per view, row-major over the board (cols per row), in board order (not canonicalised).
  std::vector<std::vector<std::array<double, 2>>> true_corners;
  std::vector<std::array<double, 6>> poses;  // rvec, tvec: camera_from_board, mm
};

// The lens as functions, so the renderer can run against any projection (tests, models
// that live elsewhere). Conventions as calib/camera_model.h.
struct LensFunctions {
  std::function<std::optional<Pixel>(Vec3)> project;
  std::function<std::optional<Vec3>(Pixel)> unproject;
};

// Throws InputError for bad options (no views, board < 3x3, camera without a size).
SyntheticBoards synthesize_boards(const SyntheticBoardsOptions& options, const LensFunctions& lens);

// Through options.camera (calib/camera_model.h project/unproject).
inline SyntheticBoards synthesize_boards(const SyntheticBoardsOptions& options) {
  const CameraModel& camera = options.camera;
  return synthesize_boards(options, LensFunctions{
                                        [&camera](Vec3 d) { return project(camera, d); },
                                        [&camera](Pixel p) { return unproject(camera, p); }});
}

// Writes `boards` made with `options` into `dir` (created): board_NN.png (8-bit codes),
// truth.json (board, square, camera, and per view its file, true corners and
// camera_from_board pose) and true_camera.yaml (left out when the lens model has no OpenCV
// form). The ground truth of `lightprobe synth boards`.
void write_synthetic_boards(const std::string& dir, const SyntheticBoardsOptions& options,
                            const SyntheticBoards& boards);

}  // namespace lp

namespace lp {

// Corners only (no rendering): `views` boards of `board` at `distance_mm`, centres on a
// golden-angle spiral out to max_theta_deg off the axis, each tilted 15-35 deg, shrunk
// towards the axis until every corner is within max_corner_deg of the axis and 2 px inside
// the image; Gaussian noise_px on each coordinate (deterministic per seed). Views that
// cannot be placed are left out. warp: the board is not flat but flexed as mrcal models it
// (BoardWarp, board_detect.h), each corner moved along the board's normal; the views'
// placement is that of the flat board. For calibration sweeps (eval calib) and tests.
std::vector<std::vector<std::array<double, 2>>> project_board_views(const CameraModel& camera, const BoardSpec& board,
                                                                    int views, double max_theta_deg,
                                                                    double distance_mm, double noise_px,
                                                                    uint64_t seed, double max_corner_deg = 93,
                                                                    const BoardWarp& warp = {});

}  // namespace lp
