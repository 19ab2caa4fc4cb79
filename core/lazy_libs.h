// The heavy libraries, loaded on first use: OpenCV's image codecs and video I/O,
// mrgingham's chessboard finder and OpenCV's ECC alignment (video module). Linked into the
// executable they, with cv::omnidir's ccalib, pulled about 270 shared libraries (GDAL through
// imgcodecs, FFmpeg and GStreamer through videoio, Qt through ccalib's highgui, and mrgingham
// links imgcodecs), and every command, even `--version`, paid 0.2 s and 96 MB to load them.
// They live in a plugin instead (liblightprobe_lazy_libs.so, core/plugin/), which the first
// call here loads: a command that reads no camera image, video or chessboard loads none of
// them. cv::omnidir has a plugin of its own (calib/omnidir_plugin.h, since stop 37), so that
// a calibration needing only it does not load the codecs too.
//
// The plugin is looked for in $LIGHTPROBE_PLUGIN_DIR, beside the executable, in ../lib
// from it, then where the build wrote it. When it cannot be loaded, the first call throws
// std::runtime_error naming the places it looked and the loader's message.
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace lp::lazy {

// cv::imdecode(bytes, IMREAD_UNCHANGED); an empty Mat when it cannot decode.
cv::Mat decode_image(const std::string& bytes);
// cv::imencode(ext, image, params); false when no encoder takes `ext` or encoding fails.
bool encode_image(const std::string& ext, const cv::Mat& image, const std::vector<int>& params,
                  std::vector<uint8_t>& bytes);

// cv::VideoCapture, behind an interface the plugin implements (CAP_* numbers as in
// <opencv2/videoio.hpp>).
class VideoCapture {
 public:
  virtual ~VideoCapture() = default;
  virtual bool open_file(const std::string& path) = 0;
  virtual bool open_device(int index, int api) = 0;
  virtual bool is_opened() const = 0;
  virtual bool read(cv::Mat& frame) = 0;
  virtual double get(int property) const = 0;
  virtual bool set(int property, double value) = 0;
  virtual void release() = 0;
};
std::unique_ptr<VideoCapture> make_video_capture();

// mrgingham::find_chessboard_from_image_array(corners, nullptr, gridn, image, level):
// the pyramid level used, or < 0 when no board was found.
int find_chessboard_mrgingham(std::vector<cv::Point2d>& corners, int gridn, const cv::Mat& image, int pyramid_level);

// cv::findTransformECC(templ, input, warp, motion, criteria, noArray(), gauss_filt_size);
// throws cv::Exception as it does. OpenCV's video module (with its DNN module and protobuf
// behind it) is loaded for this one function. motion: cv::MOTION_* below.
inline constexpr int kMotionTranslation = 0, kMotionEuclidean = 1;
double find_transform_ecc(const cv::Mat& templ, const cv::Mat& input, cv::Mat& warp, int motion,
                          cv::TermCriteria criteria, int gauss_filt_size);

// What the plugin exports (its one symbol, `lightprobe_lazy_libs`, returns it). The
// version changes whenever the table does, so that a stale plugin is refused.
struct PluginTable {
  int version;
  cv::Mat (*decode_image)(const std::string&);
  bool (*encode_image)(const std::string&, const cv::Mat&, const std::vector<int>&, std::vector<uint8_t>&);
  VideoCapture* (*new_video_capture)();
  int (*find_chessboard_mrgingham)(std::vector<cv::Point2d>&, int, const cv::Mat&, int);
  double (*find_transform_ecc)(const cv::Mat&, const cv::Mat&, cv::Mat&, int, cv::TermCriteria, int);
};
inline constexpr int kPluginVersion = 3;
inline constexpr const char* kPluginFile = "liblightprobe_lazy_libs.so";

// Loads the plugin now (idempotent): commands may call it up front to fail before work.
void load_plugin();

// Any of the project's plugins (this one, probe/camera_plugin.h's): opens `file` from the
// places above (build_path last: where the build wrote it, or nullptr) and returns what its
// entry point `entry` (an extern "C" `const void* entry()`) returns, or throws std::runtime_error
// naming the plugin, what it holds, the places tried and the loader's message. `accept`
// says whether the table is this build's (the version check).
const void* open_plugin(const std::string& file, const char* entry, const std::string& holds, const char* build_path,
                        bool (*accept)(const void* table));

// A function of a system library that is not linked (mrcal, libmosquitto: the forwarders
// of calib/mrcal_loader.cpp, live/mosquitto_loader.cpp), the library opened with dlopen on
// the first call and never closed. Throws std::runtime_error naming the library and `what`
// it is ("mrcal 2.x") when the library or the symbol is missing.
void* library_symbol(const char* library, const char* name, const char* what);

// A plugin's table (a struct whose first member is `int version`), opened once by the
// first call (open_plugin above) and accepted when its version is `Version`.
template <class Table, int Version>
const Table& plugin_table(const std::string& file, const char* entry, const std::string& holds, const char* build_path) {
  static const Table* table = static_cast<const Table*>(open_plugin(
      file, entry, holds, build_path, [](const void* t) { return static_cast<const Table*>(t)->version == Version; }));
  return *table;
}

}  // namespace lp::lazy
