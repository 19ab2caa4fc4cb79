#include "hdr/camera_files_plugin.h"

#include "core/lazy_libs.h"

namespace lp::detail {

const CameraFilesPluginTable& camera_files_plugin() {
  // LIGHTPROBE_CAMERA_FILES_PATH: where the build wrote it (hdr/CMakeLists.txt).
  return lazy::plugin_table<CameraFilesPluginTable, kCameraFilesPluginVersion>(
      kCameraFilesPluginFile, "lightprobe_camera_files", "LibRaw's RAW development and Exiv2's EXIF reading",
      LIGHTPROBE_CAMERA_FILES_PATH);
}

}  // namespace lp::detail
