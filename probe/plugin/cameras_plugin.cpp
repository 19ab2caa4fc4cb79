// The plugin of probe/camera_plugin.h: the only code linked with Aravis and libcamera.
#include "probe/camera_plugin.h"

namespace lp::detail {
std::unique_ptr<CameraSource> open_aravis(const std::string& id, const std::string& spec, const SourceOptions& options);
std::unique_ptr<CameraSource> open_libcamera(const std::string& id, const std::string& spec, const SourceOptions& options);
}  // namespace lp::detail

namespace {
const lp::detail::CameraPluginTable kTable{lp::detail::kCameraPluginVersion, lp::detail::open_aravis,
                                           lp::detail::open_libcamera};
}  // namespace

// `const void*`: the loader calls every plugin's entry through one function type.
extern "C" __attribute__((visibility("default"))) const void* lightprobe_cameras() {
  return &kTable;
}
