// The plugin of calib/omnidir_plugin.h: the only code linked with OpenCV's ccalib.
#include <opencv2/ccalib/omnidir.hpp>

#include "calib/omnidir_plugin.h"

namespace lp::detail {
namespace {

double calibrate(const std::vector<cv::Mat>& object_points, const std::vector<cv::Mat>& image_points, cv::Size size,
                 cv::Mat& K, cv::Mat& xi, cv::Mat& D, std::vector<cv::Mat>& rvecs, std::vector<cv::Mat>& tvecs,
                 int flags, cv::TermCriteria criteria, cv::Mat& used) {
  return cv::omnidir::calibrate(object_points, image_points, size, K, xi, D, rvecs, tvecs, flags, criteria, used);
}

constexpr OmnidirPluginTable kTable{kOmnidirPluginVersion, &calibrate};

}  // namespace
}  // namespace lp::detail

extern "C" __attribute__((visibility("default"))) const void* lightprobe_omnidir() { return &lp::detail::kTable; }
