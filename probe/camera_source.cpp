// open_source(): spec -> source. The sources live in replay_source.cpp (replay:, video:,
// v4l2:) and, loaded on first use, in the camera plugin (probe/plugin/: aravis_source.cpp,
// libcamera_source.cpp; probe/camera_plugin.h).
#include "probe/camera_source.h"

#include "core/error.h"
#include "core/lazy_libs.h"
#include "probe/camera_plugin.h"

namespace lp {

namespace detail {
std::unique_ptr<CameraSource> open_replay(const std::string& dir, const std::string& spec, const SourceOptions& options);
std::unique_ptr<CameraSource> open_video(const std::string& file, const std::string& spec, const SourceOptions& options);
std::unique_ptr<CameraSource> open_v4l2(int index, const std::string& spec, const SourceOptions& options);
#ifdef LIGHTPROBE_CAMERAS_PATH
constexpr const char* kCameraPluginBuildPath = LIGHTPROBE_CAMERAS_PATH;  // where the build wrote it
#else
constexpr const char* kCameraPluginBuildPath = nullptr;
#endif

const CameraPluginTable& camera_plugin() {
  return lazy::plugin_table<CameraPluginTable, kCameraPluginVersion>(
      kCameraPluginFile, "lightprobe_cameras", "the Aravis and libcamera sources", kCameraPluginBuildPath);
}
}  // namespace detail

std::unique_ptr<CameraSource> open_source(const std::string& spec, const SourceOptions& options) {
  const auto colon = spec.find(':');
  const std::string kind = spec.substr(0, colon);
  const std::string arg = colon == std::string::npos ? "" : spec.substr(colon + 1);
  const bool has_arg = colon != std::string::npos;
  if (options.n_buffers < 1) throw InputError(spec + ": n_buffers must be at least 1");
  if (options.frame_rate < 0) throw InputError(spec + ": frame rate must not be negative");
  if (kind == "replay") {
    if (arg.empty()) throw InputError(spec + ": replay needs a directory (replay:DIR)");
    return detail::open_replay(arg, spec, options);
  }
  if (kind == "video") {
    if (arg.empty()) throw InputError(spec + ": video needs a file (video:FILE)");
    return detail::open_video(arg, spec, options);
  }
  if (kind == "v4l2") {
    size_t used = 0;
    int index = -1;
    try {
      index = std::stoi(arg, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != arg.size() || index < 0) throw InputError(spec + ": v4l2 needs a device number (v4l2:N for /dev/videoN)");
    return detail::open_v4l2(index, spec, options);
  }
  if (kind == "aravis") {
    if (has_arg && arg.empty()) throw InputError(spec + ": empty camera id (aravis or aravis:ID)");
    return detail::camera_plugin().open_aravis(arg, spec, options);
  }
  if (kind == "libcamera") {
    if (has_arg && arg.empty()) throw InputError(spec + ": empty camera id (libcamera or libcamera:ID)");
    return detail::camera_plugin().open_libcamera(arg, spec, options);
  }
  throw InputError("unknown camera source '" + spec +
                   "' (expected replay:DIR, video:FILE, aravis[:ID], libcamera[:ID] or v4l2:N)");
}

bool set_fake_scene(CameraSource& source, const FakeScene& scene) { return source.set_fake_scene(scene); }

}  // namespace lp
