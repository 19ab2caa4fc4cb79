// Unwrapping through any calibrated camera model (calib/camera_model.h: mrcal's models,
// Kannala-Brandt, Mei's omnidirectional model), e.g. a fisheye looking up or a wide-angle
// camera looking sideways. The camera's rotation into the world is given separately.
#pragma once

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
// image circle: the model alone does not know where the lens stops imaging).
RemapTable camera_remap(const CameraModel& model, const Mat3& world_from_camera, Layout layout, int width,
                        int height, double max_field_deg = 0);

struct CameraUnwrapOptions {
  double max_field_deg = 0;  // 0: no limit beyond the model's own domain
  FillOptions fill{.method = FillMethod::None};
  RemapOptions remap;
};

// Throws InputError when the image size differs from the model's
// ("camera model is for WxH, image is W'xH'").
EnvMap unwrap_with_camera(const RgbImage& image, const CameraModel& model, const Mat3& world_from_camera,
                          Layout layout, int width, int height, const CameraUnwrapOptions& options = {},
                          FillReport* fill_report = nullptr);

}  // namespace lp
