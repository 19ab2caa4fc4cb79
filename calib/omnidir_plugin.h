// cv::omnidir::calibrate (OpenCV contrib's ccalib), loaded on first use: Mei's seed on wide
// and catadioptric lenses (calibration_seed.cpp) and `eval calib`'s OpenCV peer are its only
// callers. ccalib links highgui, and through it Qt: 160 shared libraries and 0.15-0.25 s to
// load. Until stop 37 it shared core/lazy_libs.h's plugin with the image and video codecs
// (265 libraries, 0.25-0.4 s), so a calibration that needed only omnidir loaded FFmpeg,
// GStreamer and GDAL too. It lives in its own plugin (liblightprobe_omnidir.so,
// calib/plugin/), found where core/lazy_libs.h looks for its plugins.
//
// Internal to calib/: only calibration_seed.cpp and the plugin include it.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace lp::detail {

// cv::omnidir::calibrate, the same arguments; throws cv::Exception as it does, and
// std::runtime_error when the plugin cannot be loaded.
double omnidir_calibrate(const std::vector<cv::Mat>& object_points, const std::vector<cv::Mat>& image_points,
                         cv::Size size, cv::Mat& K, cv::Mat& xi, cv::Mat& D, std::vector<cv::Mat>& rvecs,
                         std::vector<cv::Mat>& tvecs, int flags, cv::TermCriteria criteria, cv::Mat& used);

// What the plugin exports (its one symbol, `lightprobe_omnidir`, returns it).
struct OmnidirPluginTable {
  int version;
  double (*calibrate)(const std::vector<cv::Mat>&, const std::vector<cv::Mat>&, cv::Size, cv::Mat&, cv::Mat&,
                      cv::Mat&, std::vector<cv::Mat>&, std::vector<cv::Mat>&, int, cv::TermCriteria, cv::Mat&);
};
inline constexpr int kOmnidirPluginVersion = 1;
inline constexpr const char* kOmnidirPluginFile = "liblightprobe_omnidir.so";

}  // namespace lp::detail
