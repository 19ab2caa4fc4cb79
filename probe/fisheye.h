// Fisheye cameras (Kannala-Brandt, as cv::fisheye) -> environment maps in the world frame.
//
// Model (cv::fisheye, OpenCV "Fisheye camera model" docs; Kannala & Brandt 2006): a
// point (X, Y, Z) in the camera frame (x right, y down, z along the optical axis) has
//   theta   = atan2(sqrt(X^2 + Y^2), Z)            angle from the optical axis
//   theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)
//   u = fx theta_d X / sqrt(X^2 + Y^2) + cx,   v = fy theta_d Y / sqrt(X^2 + Y^2) + cy
// in OpenCV pixel coordinates, where pixel centres are at INTEGERS (as the camera
// matrix of every OpenCV calibration). fisheye_project / fisheye_unproject use these
// coordinates, so they agree with cv::fisheye::projectPoints; fisheye_remap converts to
// the remap engine's convention (centres at +0.5). Skew (alpha) is taken as 0.
// Unlike cv::fisheye, theta is computed with atan2, so directions up to max_theta_deg
// (which may exceed 90 for a > 180 degree lens) project.
//
// Frame (CONVENTIONS.md): by default the camera looks straight up (+Z), image up
// (towards row 0, camera -y) is world +X, image right (camera +x) is world +Y, i.e.
// world_from_camera = Rz(90 deg) = [[0,-1,0],[1,0,0],[0,0,1]]. --rotation composes
// on the left: world_from_camera = R * default.
//
// Files: OpenCV FileStorage YAML/XML with image_width, image_height, camera_matrix,
// distortion_coefficients (4 values) and distortion_model fisheye (calib/lens_model.h). mrcal
// .cameramodel files are refused with a one-line InputError (mrcal has no
// Kannala-Brandt model; export OpenCV YAML).
#pragma once

#include <array>
#include <optional>
#include <string>

#include "core/envmap.h"
#include "core/image_io.h"
#include "core/vec3.h"
#include "probe/fill.h"
#include "probe/remap.h"

namespace lp {

// Default fisheye orientation of CONVENTIONS.md (see above).
Mat3 default_fisheye_world_from_camera();

struct FisheyeModel {
  int width = 0, height = 0;         // image size the model was calibrated for
  double fx = 0, fy = 0, cx = 0, cy = 0;  // OpenCV camera matrix (pixel centres at integers)
  std::array<double, 4> k{0, 0, 0, 0};    // Kannala-Brandt k1..k4
  double max_theta_deg = 90;         // field of view half-angle; beyond it: invalid
  Mat3 world_from_camera = default_fisheye_world_from_camera();
};

// Plain equidistant fisheye (theta_d = theta, k = 0): the image circle of radius
// min(width, height) / 2 centred in the image holds the field of view fov_deg
// (full angle), which is also the model's max_theta_deg * 2.
FisheyeModel equidistant_fisheye(int width, int height, double fov_deg);

// OpenCV FileStorage YAML (keys above). Throws InputError on a missing file or key, a
// distortion model other than Kannala-Brandt's (fisheye), or a .cameramodel file.
FisheyeModel read_fisheye_yaml(const std::string& path);
// The same keys, readable by cv::FileStorage alone.
void write_fisheye_yaml(const std::string& path, const FisheyeModel& model);

struct ImagePoint {
  double x = 0, y = 0;
};

// Unit world direction seen at OpenCV pixel coordinates (x, y). theta is found from
// theta_d by Newton's method (to 1e-12 rad); NaN components when it does not converge
// (a distortion polynomial that folds back before this theta_d).
Vec3 fisheye_unproject(const FisheyeModel& model, double x, double y);
// OpenCV pixel coordinates of a world direction (need not be unit); nullopt beyond
// max_theta_deg. The point may lie outside the image.
std::optional<ImagePoint> fisheye_project(const FisheyeModel& model, Vec3 direction);

// Remap table from a fisheye image of model.width x model.height to a map of the
// layout and size (make_envmap's arguments); output pixels whose centre direction is
// beyond max_theta or off the image are NaN (invalid).
RemapTable fisheye_remap(const FisheyeModel& model, Layout layout, int width, int height);

struct FisheyeUnwrapOptions {
  // Invalid pixels (beyond the field of view, below the horizon) are filled after the
  // remap when fill.method != None. Default: no fill (the mask says what is missing).
  FillOptions fill{.method = FillMethod::None};
  RemapOptions remap;
};
struct FisheyeUnwrapReport {
  double valid_solid_angle = 0;  // sr covered by the camera
  FillReport fill;
};

// Unwrap a fisheye image into a map (bilinear, with the validity mask of the remap and
// of the image). Throws InputError("camera model is for WxH, image is W'xH'") when the
// image size differs from the model's.
EnvMap unwrap_fisheye(const RgbImage& image, const FisheyeModel& model, Layout layout, int width, int height,
                      const FisheyeUnwrapOptions& options = {}, FisheyeUnwrapReport* report = nullptr);

// A fisheye is unwrapped in its sensor's frame, where its calibration and "image up is +X"
// (CONVENTIONS.md) hold; a camera pointing up records an arbitrary EXIF Orientation. The one
// line said (once) where an image is read for a fisheye unwrap (probe unwrap, the stream's
// replay): a camera image's tag left unapplied, or a fused photo's recorded turn
// (RgbImage::orientation, hdr fuse) undone.
std::string orientation_not_applied_note(const std::string& file, int orientation);
std::string fused_turn_undone_note(const std::string& file, int orientation);

// Synthetic fisheye photo of a map (ground truth for tests and `synth probe`): each
// pixel averages samples_per_edge^2 sub-pixel rays, each looking the map up bilinearly
// (latlong / hemisphere; nearest for healpix). Rays beyond max_theta or on invalid map
// pixels add black, so the image is black outside the image circle as a real one.
RgbImage render_fisheye(const EnvMap& map, const FisheyeModel& model, int samples_per_edge = 4);

}  // namespace lp
