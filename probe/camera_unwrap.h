// Unwrapping through any calibrated camera model (calib/camera_model.h: mrcal's models,
// Kannala-Brandt, Mei's omnidirectional model), e.g. a fisheye looking up or a wide-angle
// camera looking sideways. The camera's rotation into the world is given separately.
#pragma once

#include <array>
#include <optional>

#include "calib/camera_model.h"
#include "core/envmap.h"
#include "core/image_io.h"
#include "probe/fill.h"
#include "probe/fisheye.h"
#include "probe/remap.h"

namespace lp {

// CONVENTIONS' fisheye frame: camera looking straight up (+Z), image up (row 0) is +X,
// image right is +Y. Camera frame: x right, y down, z forward.
Mat3 upward_camera_world_from_camera();

// The probe/fisheye.h model (equidistant or calibrated Kannala-Brandt) as a CameraModel,
// so the fisheye path and calibrated cameras share one unwrap.
CameraModel camera_model_from_fisheye(const FisheyeModel& fisheye);

// Per output map pixel, the source pixel (remap convention: centres at +0.5); directions
// the model cannot image, or that fall outside the image, are invalid (NaN).
// max_field_deg > 0 also masks rays further than that from the optical axis (a fisheye's
// image circle: the model alone does not know where the lens stops imaging), and
// image_circle (cx, cy, r) the pixels beyond the circle. Directions where a model that can
// fold (OpenCV's polynomials, CAHVOR(E), the spline) does not unproject back to within half
// a degree are invalid too.
RemapTable camera_remap(const CameraModel& model, const Mat3& world_from_camera, Layout layout, int width,
                        int height, double max_field_deg = 0,
                        const std::optional<std::array<double, 3>>& image_circle = std::nullopt);

// The image circle of a calibrated lens in a frame, as camera_remap's image_circle (cx, cy,
// r less 1 px of soft edge): only a clean disc on black (find_image_circle fits within 1.5 px
// on three quarters of its rays); nothing for a full-frame image or a scene without one.
std::optional<std::array<double, 3>> lens_image_circle(const RgbImage& frame);

struct CameraUnwrapOptions {
  double max_field_deg = 0;  // 0: no limit beyond the model's own domain
  // The lens's image circle in the frame (a disc on black): pixels beyond it are not the
  // scene, whatever the model projects there. None: the whole frame is image.
  std::optional<std::array<double, 3>> image_circle;  // cx, cy, r in pixels
  FillOptions fill{.method = FillMethod::None};
  RemapOptions remap;
};

// Throws InputError when the image size differs from the model's
// ("camera model is for WxH, image is W'xH'").
EnvMap unwrap_with_camera(const RgbImage& image, const CameraModel& model, const Mat3& world_from_camera,
                          Layout layout, int width, int height, const CameraUnwrapOptions& options = {},
                          FillReport* fill_report = nullptr);

}  // namespace lp
