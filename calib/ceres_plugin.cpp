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
  static const CeresPluginTable* table = static_cast<const CeresPluginTable*>(lazy::open_plugin(
      kCeresPluginFile, "lightprobe_ceres", "the Ceres solves of calibration", kCeresPluginBuildPath,
      [](const void* t) { return static_cast<const CeresPluginTable*>(t)->version == kCeresPluginVersion; }));
  return *table;
}

}  // namespace lp::detail
