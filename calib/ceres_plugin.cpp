#include "calib/ceres_plugin.h"

#include "core/lazy_libs.h"

namespace lp::detail {
namespace {
#ifdef LIGHTPROBE_CERES_PLUGIN_PATH
constexpr const char* kCeresPluginBuildPath = LIGHTPROBE_CERES_PLUGIN_PATH;  // where the build wrote it
#else
constexpr const char* kCeresPluginBuildPath = nullptr;
#endif
}  // namespace

const CeresPluginTable& ceres_plugin() {
  return lazy::plugin_table<CeresPluginTable, kCeresPluginVersion>(
      kCeresPluginFile, "lightprobe_ceres", "the Ceres solves of calibration", kCeresPluginBuildPath);
}

}  // namespace lp::detail
