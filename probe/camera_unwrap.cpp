#include "probe/camera_unwrap.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>

#include "calib/lens_model.h"
#include "core/error.h"

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
                        int height, double max_field_deg) {
  const double min_cos = max_field_deg > 0 ? std::cos(max_field_deg * M_PI / 180) : -2;
  const Mat3 camera_from_world = transpose(world_from_camera);
  return remap_table(layout, width, height, model.width, model.height,
                     [&](Vec3 world) -> std::optional<std::array<double, 2>> {
                       const Vec3 d = camera_from_world * world;
                       const auto p = d.z >= min_cos ? project(model, d) : std::nullopt;
                       if (!p) return std::nullopt;
                       return std::array<double, 2>{p->x + 0.5, p->y + 0.5};  // remap convention
                     });
}

EnvMap unwrap_with_camera(const RgbImage& image, const CameraModel& model, const Mat3& world_from_camera,
                          Layout layout, int width, int height, const CameraUnwrapOptions& options,
                          FillReport* fill_report) {
  if (image.width != model.width || image.height != model.height)
    throw InputError(fmt::format("camera model is for {}x{}, image is {}x{}", model.width, model.height, image.width,
                                 image.height));
  RgbImage out = apply_remap(image, camera_remap(model, world_from_camera, layout, width, height, options.max_field_deg),
                             options.remap);
  EnvMap map = make_envmap(layout, width, height);
  map.units = image.units;
  map.rgb = std::move(out.rgb);
  map.valid = std::move(out.valid);
  if (options.fill.method != FillMethod::None && !map.valid.empty()) fill_invalid(map, options.fill, fill_report);
  return map;
}

}  // namespace lp
