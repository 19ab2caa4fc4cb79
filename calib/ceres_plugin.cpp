#include "calib/ceres_plugin.h"

#include "core/lazy_libs.h"

namespace lp::detail {

const CeresPluginTable& ceres_plugin() {
  // LIGHTPROBE_CERES_PLUGIN_PATH: where the build wrote it (calib/CMakeLists.txt).
  return lazy::plugin_table<CeresPluginTable, kCeresPluginVersion>(
      kCeresPluginFile, "lightprobe_ceres", "the Ceres solves of calibration", LIGHTPROBE_CERES_PLUGIN_PATH);
}

}  // namespace lp::detail
