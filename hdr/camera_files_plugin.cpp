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
  static const CameraFilesPluginTable* table = static_cast<const CameraFilesPluginTable*>(lazy::open_plugin(
      kCameraFilesPluginFile, "lightprobe_camera_files", "LibRaw's RAW development and Exiv2's EXIF reading",
      kCameraFilesBuildPath,
      [](const void* t) { return static_cast<const CameraFilesPluginTable*>(t)->version == kCameraFilesPluginVersion; }));
  return *table;
}

}  // namespace lp::detail
