// The camera drivers, loaded on first use: Aravis (GigE Vision, USB3 Vision) and libcamera
// pull GLib, GIO, libusb, ICU, libxml2, GnuTLS and LTTng (whose start-up reads every loaded
// library's ELF notes and starts threads): 24 shared libraries that every command, even
// `--version`, loaded for a camera it did not open. They live in a plugin
// (liblightprobe_cameras.so, probe/plugin/), which open_source() loads for an aravis[:ID]
// or libcamera[:ID] source; it is found where core/lazy_libs.h looks for its plugin.
//
// Internal to probe/: only camera_source.cpp and the plugin include this.
#pragma once

#include <memory>
#include <string>

#include "probe/camera_source.h"

namespace lp::detail {

// What the plugin exports (its one symbol, `lightprobe_cameras`, returns it). The version
// changes whenever the table or the CameraSource interface does.
struct CameraPluginTable {
  int version;
  std::unique_ptr<CameraSource> (*open_aravis)(const std::string& id, const std::string& spec, const SourceOptions& options);
  std::unique_ptr<CameraSource> (*open_libcamera)(const std::string& id, const std::string& spec,
                                                  const SourceOptions& options);
};
inline constexpr int kCameraPluginVersion = 1;
inline constexpr const char* kCameraPluginFile = "liblightprobe_cameras.so";

// The plugin's table, loaded once; throws std::runtime_error when it cannot be loaded.
const CameraPluginTable& camera_plugin();

}  // namespace lp::detail
