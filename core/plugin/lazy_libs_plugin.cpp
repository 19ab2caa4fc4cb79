// The plugin of core/lazy_libs.h: the only code linked with OpenCV's imgcodecs, videoio and
// video and with mrgingham. Each entry is the library call and nothing else.
#include <mrgingham.hh>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/video/tracking.hpp>
#include <opencv2/videoio.hpp>

#include "core/lazy_libs.h"

namespace {

using namespace lp::lazy;

cv::Mat decode_image(const std::string& bytes) {
  const cv::Mat buf(1, int(bytes.size()), CV_8U, const_cast<char*>(bytes.data()));
  return cv::imdecode(buf, cv::IMREAD_UNCHANGED);
}

bool encode_image(const std::string& ext, const cv::Mat& image, const std::vector<int>& params,
                  std::vector<uint8_t>& bytes) {
  try {
    return cv::imencode(ext, image, bytes, params);
  } catch (const cv::Exception&) {
    return false;  // no encoder for the extension
  }
}

class Capture final : public VideoCapture {
 public:
  bool open_file(const std::string& path) override { return capture_.open(path); }
  bool open_device(int index, int api) override { return capture_.open(index, api); }
  bool is_opened() const override { return capture_.isOpened(); }
  bool read(cv::Mat& frame) override { return capture_.read(frame); }
  double get(int property) const override { return capture_.get(property); }
  bool set(int property, double value) override { return capture_.set(property, value); }
  void release() override { capture_.release(); }

 private:
  cv::VideoCapture capture_;
};

VideoCapture* new_video_capture() { return new Capture; }

int find_chessboard_mrgingham(std::vector<cv::Point2d>& corners, int gridn, const cv::Mat& image, int pyramid_level) {
  std::vector<mrgingham::PointDouble> found;
  const int level = mrgingham::find_chessboard_from_image_array(found, nullptr, gridn, image, pyramid_level);
  corners.clear();
  for (const auto& p : found) corners.emplace_back(p.x, p.y);
  return level;
}

static_assert(kMotionTranslation == cv::MOTION_TRANSLATION && kMotionEuclidean == cv::MOTION_EUCLIDEAN);

double find_transform_ecc(const cv::Mat& templ, const cv::Mat& input, cv::Mat& warp, int motion,
                          cv::TermCriteria criteria, int gauss_filt_size) {
  return cv::findTransformECC(templ, input, warp, motion, criteria, cv::noArray(), gauss_filt_size);
}

const PluginTable kTable{kPluginVersion,    decode_image, encode_image, new_video_capture, find_chessboard_mrgingham,
                         find_transform_ecc};

}  // namespace

// Returns the table as `const void*`: the loader calls every plugin's entry through one
// function type (a call through another type is undefined; UBSan says so).
extern "C" __attribute__((visibility("default"))) const void* lightprobe_lazy_libs() { return &kTable; }
