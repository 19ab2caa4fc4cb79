#include "calib/omnidir_plugin.h"

#include "core/lazy_libs.h"

namespace lp::detail {

double omnidir_calibrate(const std::vector<cv::Mat>& object_points, const std::vector<cv::Mat>& image_points,
                         cv::Size size, cv::Mat& K, cv::Mat& xi, cv::Mat& D, std::vector<cv::Mat>& rvecs,
                         std::vector<cv::Mat>& tvecs, int flags, cv::TermCriteria criteria, cv::Mat& used) {
  // LIGHTPROBE_OMNIDIR_PLUGIN_PATH: where the build wrote it (calib/CMakeLists.txt).
  const auto& table = lazy::plugin_table<OmnidirPluginTable, kOmnidirPluginVersion>(
      kOmnidirPluginFile, "lightprobe_omnidir", "cv::omnidir's calibration (Mei's seed)", LIGHTPROBE_OMNIDIR_PLUGIN_PATH);
  return table.calibrate(object_points, image_points, size, K, xi, D, rvecs, tvecs, flags, criteria, used);
}

}  // namespace lp::detail
