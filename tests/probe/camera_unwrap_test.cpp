// Unwrapping through a calib/ camera model agrees with the probe stage's own fisheye path.
#include <gtest/gtest.h>

#include "core/error.h"
#include "eval/synthetic_scene.h"
#include "probe/camera_unwrap.h"
#include "probe/fisheye.h"
#include "probe/unwrap_accuracy.h"

namespace lp {
namespace {

TEST(CameraUnwrap, AKannalaBrandtModelUnwrapsLikeTheFisheyePath) {
  const EnvMap world = render_scene(describe_scene(), Layout::LatLong, 512, 256);
  const FisheyeModel fish = equidistant_fisheye(400, 400, 190);
  const RgbImage image = render_fisheye(world, fish, 2);
  const CameraModel model = camera_model_from_fisheye(fish);
  CameraUnwrapOptions o;
  o.max_field_deg = 95;  // the lens' 190 deg image circle
  const EnvMap a = unwrap_with_camera(image, model, upward_camera_world_from_camera(), Layout::LatLong, 256, 128, o);
  const EnvMap b = unwrap_fisheye(image, fish, Layout::LatLong, 256, 128, {});
  // Same geometry: the same pixels valid, the same values to float rounding.
  size_t valid_a = 0, differ = 0;
  for (size_t i = 0; i < a.pixel_count(); ++i) {
    valid_a += a.is_valid(i);
    if (a.is_valid(i) != b.is_valid(i)) ++differ;
  }
  EXPECT_LE(differ, valid_a / 200);  // only edge pixels may differ (domain test rounding)
  const EnvMap truth = render_scene(describe_scene(), Layout::LatLong, 256, 128);
  EXPECT_LT(unwrap_error(a, truth).mean_abs_log10, 0.01);
}

TEST(CameraUnwrap, AModelOfTheWrongResolutionIsRefused) {
  CameraModel model;
  model.lensmodel = "LENSMODEL_KANNALA_BRANDT";
  model.intrinsics = {100, 100, 99.5, 99.5, 0, 0, 0, 0};
  model.width = model.height = 200;
  RgbImage image;
  image.width = 320;
  image.height = 200;
  image.rgb.assign(320 * 200 * 3, 0.5f);
  EXPECT_THROW(unwrap_with_camera(image, model, upward_camera_world_from_camera(), Layout::LatLong, 64, 32),
               InputError);
}

}  // namespace
}  // namespace lp
