#include "core/image_view.h"

#include "core/envmap.h"
#include "core/image_io.h"

namespace lp {

ImageView image_view(const EnvMap& map) {
  return packed_view(map.rgb.data(), map.width, map.height, 3, map.valid.empty() ? nullptr : map.valid.data());
}

ImageView image_view(const RgbImage& image) {
  return packed_view(image.rgb.data(), image.width, image.height, 3,
                     image.valid.empty() ? nullptr : image.valid.data());
}

ImageView image_view(const CameraImage& image) { return packed_view(image.rgb.data(), image.width, image.height); }

}  // namespace lp
