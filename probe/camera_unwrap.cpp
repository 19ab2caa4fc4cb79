#include "probe/camera_unwrap.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>

#include "calib/lens_model.h"
#include "core/error.h"
#include "probe/stabilise.h"

namespace lp {

Mat3 upward_camera_world_from_camera() {
  // x_cam (image right) -> +Y, y_cam (image down) -> -X, z_cam (forward) -> +Z.
  return Mat3{{0, -1, 0, 1, 0, 0, 0, 0, 1}};
}

CameraModel camera_model_from_fisheye(const FisheyeModel& f) {
  CameraModel m;
  m.lensmodel = lens_type_name(LensType::KannalaBrandt);
  m.intrinsics = {f.fx, f.fy, f.cx, f.cy, f.k[0], f.k[1], f.k[2], f.k[3]};
  m.width = f.width;
  m.height = f.height;
  return m;
}

RemapTable camera_remap(const CameraModel& model, const Mat3& world_from_camera, Layout layout, int width,
                        int height, double max_field_deg, const std::optional<std::array<double, 3>>& image_circle) {
  const double min_cos = max_field_deg > 0 ? std::cos(max_field_deg * M_PI / 180) : -2;
  const Mat3 camera_from_world = transpose(world_from_camera);
  // Kannala-Brandt and Mei check their own domain, and the pinhole, stereographic and
  // lat/lon projections cannot fold. A polynomial (OpenCV5/8) or splined fit
  // used beyond the field it was fitted on can fold back: its radius peaks and falls, and
  // a ray 56 deg off axis landed 13 px from the centre, writing one pixel into the map at
  // several directions. A direction counts only where the pixel unprojects back to it.
  const LensType type = LensModel::parse(model.lensmodel).type();
  const bool may_fold = type == LensType::OpenCV4 || type == LensType::OpenCV5 || type == LensType::OpenCV8 ||
                        type == LensType::OpenCV12 || type == LensType::Cahvor || type == LensType::Cahvore ||
                        type == LensType::SplinedStereographic;
  const double max_fold_cos = std::cos(0.5 * M_PI / 180);  // half a degree: far above any solver's round trip
  return remap_table(layout, width, height, model.width, model.height,
                     [&](Vec3 world) -> std::optional<std::array<double, 2>> {
                       const Vec3 d = camera_from_world * world;
                       const auto p = d.z >= min_cos ? project(model, d) : std::nullopt;
                       if (!p) return std::nullopt;
                       if (image_circle) {  // beyond the lens's circle: the black of the frame, not the scene
                         const double dx = p->x + 0.5 - (*image_circle)[0], dy = p->y + 0.5 - (*image_circle)[1];
                         if (dx * dx + dy * dy > (*image_circle)[2] * (*image_circle)[2]) return std::nullopt;
                       }
                       if (may_fold) {
                         const auto back = unproject(model, *p);
                         if (!back || dot(normalize(*back), normalize(d)) < max_fold_cos) return std::nullopt;
                       }
                       return std::array<double, 2>{p->x + 0.5, p->y + 0.5};  // remap convention
                     });
}

std::optional<std::array<double, 3>> lens_image_circle(const RgbImage& frame) {
  try {
    const FindCircleOptions fo;
    const ImageCircle c = find_image_circle(frame, fo);
    if (c.rms_residual_px < 1.5 && c.boundary_points * 4 >= fo.rays * 3) return std::array<double, 3>{c.cx, c.cy, c.r - 1.0};
  } catch (const InputError&) {  // no disc: the frame is image edge to edge
  }
  return std::nullopt;
}

EnvMap unwrap_with_camera(const RgbImage& image, const CameraModel& model, const Mat3& world_from_camera,
                          Layout layout, int width, int height, const CameraUnwrapOptions& options,
                          FillReport* fill_report) {
  if (image.width != model.width || image.height != model.height)
    throw InputError(fmt::format("camera model is for {}x{}, image is {}x{}", model.width, model.height, image.width,
                                 image.height));
  RgbImage out = apply_remap(
      image, camera_remap(model, world_from_camera, layout, width, height, options.max_field_deg, options.image_circle),
      options.remap);
  EnvMap map = make_envmap(layout, width, height);
  map.units = image.units;
  map.rgb = std::move(out.rgb);
  map.valid = std::move(out.valid);
  if (options.fill.method != FillMethod::None && !map.valid.empty()) fill_invalid(map, options.fill, fill_report);
  return map;
}

}  // namespace lp
