#include "hdr/camera_files_plugin.h"

#include "core/lazy_libs.h"

namespace lp::detail {
namespace {
#ifdef LIGHTPROBE_CAMERA_FILES_PATH
constexpr const char* kCameraFilesBuildPath = LIGHTPROBE_CAMERA_FILES_PATH;  // where the build wrote it
#else
constexpr const char* kCameraFilesBuildPath = nullptr;
#endif
}  // namespace

const CameraFilesPluginTable& camera_files_plugin() {
  return lazy::plugin_table<CameraFilesPluginTable, kCameraFilesPluginVersion>(
      kCameraFilesPluginFile, "lightprobe_camera_files", "LibRaw's RAW development and Exiv2's EXIF reading",
      kCameraFilesBuildPath);
}

}  // namespace lp::detail
