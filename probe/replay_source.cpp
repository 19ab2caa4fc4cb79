// Recorded sources: replay:DIR (image files), video:FILE and v4l2:N (cv::VideoCapture).
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>  // the CAP_ numbers; the capture is core/lazy_libs.h
#include <sstream>
#include <thread>

#include "core/error.h"
#include "core/file_io.h"
#include "core/lazy_libs.h"
#include "core/sensor_white_level.h"
#include "core/timestamps.h"
#include "core/warnings.h"
#include "probe/camera_source.h"
#include "probe/fisheye.h"

namespace lp {

namespace fs = std::filesystem;

namespace detail {
std::unique_ptr<CameraSource> open_replay(const std::string& dir, const std::string& spec, const SourceOptions& options);
std::unique_ptr<CameraSource> open_video(const std::string& file, const std::string& spec, const SourceOptions& options);
std::unique_ptr<CameraSource> open_v4l2(int index, const std::string& spec, const SourceOptions& options);
}  // namespace detail

namespace {

using Clock = std::chrono::steady_clock;

// A sidecar: one number per line in file order, or "name<sep>number" lines
// (sep: comma, semicolon, tab or spaces). A first line that is not numeric is a header.
// Numbers are plain decimals (core/timestamps.h parse_seconds: no hex, no suffix).
struct Sidecar {
  std::vector<double> in_order;
  std::map<std::string, double> by_name;  // file name and stem
  bool empty() const { return in_order.empty() && by_name.empty(); }
  std::optional<double> lookup(const fs::path& file, size_t index) const {
    if (!by_name.empty()) {
      for (const std::string& key : {file.filename().string(), file.stem().string()})
        if (auto it = by_name.find(key); it != by_name.end()) return it->second;
      return std::nullopt;
    }
    if (index < in_order.size()) return in_order[index];
    return std::nullopt;
  }
};

// Exposures (`positive`) must be > 0; timestamps must increase strictly in file order.
Sidecar read_sidecar(const fs::path& path, bool positive) {
  Sidecar sidecar;
  std::istringstream in(read_text_file(path.string()));
  std::string line;
  int line_number = 0;
  bool seen_data = false;
  std::vector<TimedLine> times;  // in file order, for the timestamps' order check
  while (std::getline(in, line)) {
    ++line_number;
    if (auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    for (char& c : line)
      if (c == ',' || c == ';' || c == '\t' || c == '\r') c = ' ';
    std::istringstream fields(line);
    std::vector<std::string> tokens;
    for (std::string t; fields >> t;) tokens.push_back(t);
    if (tokens.empty()) continue;
    const std::string where = path.string() + ":" + std::to_string(line_number);
    std::optional<double> value;
    std::string name;
    if (tokens.size() == 1) {
      value = parse_seconds(tokens[0]);
    } else if (tokens.size() == 2) {
      name = tokens[0];
      value = parse_seconds(tokens[1]);
    } else {
      throw InputError(where + ": expected 'seconds' or 'name,seconds'");
    }
    if (!value) {
      if (!seen_data) continue;  // header
      throw InputError(where + ": '" + tokens.back() + "' is not a number");
    }
    if (positive && !(*value > 0)) throw InputError(where + ": exposure " + tokens.back() + " is not positive");
    seen_data = true;
    times.push_back({*value, line_number});
    if (name.empty()) {
      sidecar.in_order.push_back(*value);
    } else {
      sidecar.by_name[name] = *value;
      sidecar.by_name[fs::path(name).stem().string()] = *value;
    }
  }
  if (!sidecar.in_order.empty() && !sidecar.by_name.empty())
    throw InputError(path.string() + ": mixes 'seconds' and 'name,seconds' lines");
  if (!positive && sidecar.by_name.empty()) check_increasing(path.string(), times);  // named: in frame order, later
  return sidecar;
}

int cycle_position(const std::vector<double>& cycle, double exposure) {
  if (!(exposure > 0)) return -1;
  for (size_t i = 0; i < cycle.size(); ++i)
    if (std::abs(exposure - cycle[i]) <= 0.01 * cycle[i]) return int(i);
  return -1;
}

void check_cycle(const std::string& spec, const std::vector<double>& seconds) {
  for (double s : seconds)
    if (!(s > 0) || !std::isfinite(s)) throw InputError(spec + ": exposure time " + std::to_string(s) + " s is not positive");
}

// Waits until `due` or the timeout; false on timeout.
bool wait_until(Clock::time_point due, double timeout_s) {
  const auto limit = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::max(0.0, timeout_s)));
  if (due > limit) {
    std::this_thread::sleep_until(limit);
    return false;
  }
  std::this_thread::sleep_until(due);
  return true;
}

// ---- replay:DIR ---------------------------------------------------------------------

class ReplaySource final : public CameraSource {
 public:
  ReplaySource(const std::string& dir, std::string spec, const SourceOptions& options)
      : spec_(std::move(spec)), options_(options), start_(Clock::now()) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) throw InputError(spec_ + ": " + dir + " is not a directory");
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
      if (!entry.is_regular_file()) continue;
      const std::string name = entry.path().string();
      if (is_camera_image_file(name) || is_radiance_file(name)) files_.push_back(entry.path());
    }
    if (ec) throw InputError(spec_ + ": cannot list " + dir + ": " + ec.message());
    if (files_.empty()) throw InputError(spec_ + ": no images (.png .jpg .tif .exr .hdr .pfm) in " + dir);
    std::sort(files_.begin(), files_.end(), [](const fs::path& a, const fs::path& b) {
      return frame_name_less(a.filename().string(), b.filename().string());
    });
    const fs::path exposures = fs::path(dir) / "exposures.csv", timestamps = fs::path(dir) / "timestamps.txt";
    if (fs::exists(exposures)) exposures_ = read_sidecar(exposures, true);
    if (fs::exists(timestamps)) timestamps_ = read_sidecar(timestamps, false);
    if (!exposures_.in_order.empty() && exposures_.in_order.size() < files_.size())
      throw InputError(exposures.string() + ": " + std::to_string(exposures_.in_order.size()) + " exposures for " +
                       std::to_string(files_.size()) + " images");
    if (!timestamps_.in_order.empty() && timestamps_.in_order.size() < files_.size())
      throw InputError(timestamps.string() + ": " + std::to_string(timestamps_.in_order.size()) + " timestamps for " +
                       std::to_string(files_.size()) + " images");
    if (!timestamps_.by_name.empty()) check_named_times(timestamps.string());
    cycle_ = options_.exposure_cycle;
    check_cycle(spec_, cycle_);
  }

  std::string describe() const override {
    return spec_ + " (" + std::to_string(files_.size()) + " images" + (exposures_.empty() ? "" : ", exposures.csv") +
           (timestamps_.empty() ? "" : ", timestamps.txt") + (options_.loop ? ", looping" : "") + ")";
  }

  std::optional<CameraFrame> next(double timeout_s) override {
    if (finished()) return std::nullopt;
    const size_t index = size_t(delivered_ % int64_t(files_.size()));
    const int64_t pass = delivered_ / int64_t(files_.size());
    const fs::path& file = files_[index];
    // Paced at --fps when given, else at the recorded times (timestamps.txt), else free.
    const auto recorded = timestamps_.lookup(file, index);
    if (pass > 0 && recorded && span_s_ < 0) span_s_ = loop_span();
    double due_s = -1;
    if (options_.frame_rate > 0) {
      due_s = double(delivered_) / options_.frame_rate;
    } else if (recorded) {
      if (!first_time_s_) first_time_s_ = *recorded;
      due_s = *recorded + double(pass) * std::max(0.0, span_s_) - *first_time_s_;
    }
    if (due_s >= 0) {
      const auto due = start_ + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(due_s));
      if (!wait_until(due, timeout_s)) return std::nullopt;
    }
    CameraFrame frame;
    if (is_radiance_file(file.string())) {
      frame.image = read_rgb_image(file.string());
      // A fused bracket records the EXIF turn its frames were shown by: the stream unwraps
      // fisheyes in their sensor's frame, so it is turned back (as probe unwrap does).
      if (frame.image.orientation != 1) {
        if (!orientation_said_) warn(fused_turn_undone_note(file.string(), frame.image.orientation));
        orientation_said_ = true;
        frame.image = turned_back_to_sensor(std::move(frame.image));
      }
      frame.pixel_format = "RGBFloat";
    } else {
      // The stream unwraps a fisheye in its sensor's frame, where the calibration and "image up
      // is +X" hold: a camera pointing up records an arbitrary EXIF Orientation, and applied, a
      // frame tagged upside down was unwrapped turned 180 degrees in azimuth (probe unwrap
      // reads fisheyes so since stop 57).
      CameraImage image = read_camera_image(file.string(), true);
      if (image.orientation != 1 && !orientation_said_) {
        orientation_said_ = true;
        warn(orientation_not_applied_note(file.string(), image.orientation));
      }
      frame.image.width = image.width, frame.image.height = image.height;
      frame.image.rgb = std::move(image.rgb);
      frame.pixel_format = image.bit_depth > 8 ? "RGB16" : "RGB8";
      // A recorded Mono12 camera saved as 16-bit files: its clipped highlights sat at
      // 4095 / 65535, which the decode took for valid values.
      if (image.bit_depth == 16)
        frame.pixel_format = "RGB" + std::to_string(white_level_.read(frame.image.rgb, spec_ + ": " + file.string()));
    }
    frame.exposure_s = exposures_.lookup(file, index).value_or(0.0);
    frame.sequence = delivered_;
    if (recorded) {
      // Later passes of a loop continue the clock: shifted by the recording's span plus one period.
      frame.timestamp_s = *recorded + double(pass) * std::max(0.0, span_s_);
    } else if (options_.frame_rate > 0) {
      frame.timestamp_s = double(delivered_) / options_.frame_rate;
    } else {
      frame.timestamp_s = std::chrono::duration<double>(Clock::now() - start_).count();
    }
    frame.bracket_index = cycle_position(cycle_, frame.exposure_s);
    ++delivered_;
    return frame;
  }

  void set_exposure_cycle(const std::vector<double>& seconds) override {
    check_cycle(spec_, seconds);
    cycle_ = seconds;
  }

  bool finished() const override { return !options_.loop && delivered_ >= int64_t(files_.size()); }

 private:
  // "name seconds" timestamps: one for every image, increasing in the images' (name) order.
  void check_named_times(const std::string& path) const {
    for (size_t i = 0; i < files_.size(); ++i) {
      const auto t = timestamps_.lookup(files_[i], i);
      if (!t) throw InputError(path + ": no time for " + files_[i].filename().string());
      if (i > 0 && !(*t > *timestamps_.lookup(files_[i - 1], i - 1)))
        throw InputError(path + ": the time of " + files_[i].filename().string() + " is not after that of " +
                         files_[i - 1].filename().string() + "; times must increase strictly");
    }
  }

  double loop_span() const {
    std::vector<double> t;
    for (size_t i = 0; i < files_.size(); ++i)
      if (auto v = timestamps_.lookup(files_[i], i)) t.push_back(*v);
    if (t.size() < 2) return 1.0;
    const auto [lo, hi] = std::minmax_element(t.begin(), t.end());
    return (*hi - *lo) * double(t.size()) / double(t.size() - 1);
  }

  std::string spec_;
  SourceOptions options_;
  std::vector<fs::path> files_;
  Sidecar exposures_, timestamps_;
  std::vector<double> cycle_;
  Clock::time_point start_;
  int64_t delivered_ = 0;
  double span_s_ = -1;
  std::optional<double> first_time_s_;  // the first recorded time: the pacing's origin
  SequenceWhiteLevel white_level_;  // of 16-bit frames, decided at the first
  bool orientation_said_ = false;    // a frame's EXIF Orientation left unapplied, said once
};

// ---- video:FILE and v4l2:N ----------------------------------------------------------

RgbImage to_rgb(const cv::Mat& bgr, std::string& pixel_format) {
  cv::Mat rgb;
  if (bgr.channels() == 1)
    cv::cvtColor(bgr, rgb, cv::COLOR_GRAY2RGB);
  else if (bgr.channels() == 4)
    cv::cvtColor(bgr, rgb, cv::COLOR_BGRA2RGB);
  else
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  const bool deep = rgb.depth() == CV_16U;
  pixel_format = deep ? "RGB16" : "RGB8";
  cv::Mat f;
  rgb.convertTo(f, CV_32FC3, deep ? 1.0 / 65535 : 1.0 / 255);
  if (!f.isContinuous()) f = f.clone();
  RgbImage image;
  image.width = f.cols, image.height = f.rows;
  image.rgb.assign(f.ptr<float>(), f.ptr<float>() + size_t(f.total()) * 3);
  return image;
}

class CaptureSource final : public CameraSource {
 public:
  // Video file.
  CaptureSource(const std::string& file, std::string spec, const SourceOptions& options)
      : spec_(std::move(spec)), options_(options), file_(file), start_(Clock::now()) {
    if (!fs::is_regular_file(file)) throw InputError(spec_ + ": no such file " + file);
    open_file();
    const fs::path p(file);
    for (const fs::path& sidecar : {fs::path(p).replace_extension(".exposures.csv"), p.parent_path() / "exposures.csv"})
      if (fs::exists(sidecar)) {
        exposures_ = read_sidecar(sidecar, true);
        if (!exposures_.by_name.empty()) throw InputError(sidecar.string() + ": a video's exposures are one number per line, in frame order");
        exposures_name_ = sidecar.filename().string();
        break;
      }
    cycle_ = options_.exposure_cycle;
    check_cycle(spec_, cycle_);
  }
  // Live device.
  CaptureSource(int index, std::string spec, const SourceOptions& options)
      : spec_(std::move(spec)), options_(options), device_(index), start_(Clock::now()) {
    const std::string node = "/dev/video" + std::to_string(index);
    if (!fs::exists(node)) throw InputError(spec_ + ": no camera " + node + " (no such device)");
    if (!capture_->open_device(index, cv::CAP_V4L2) || !capture_->is_opened()) throw InputError(spec_ + ": cannot open " + node);
    if (options_.frame_rate > 0) capture_->set(cv::CAP_PROP_FPS, options_.frame_rate);
    if (options_.roi && options_.roi->width > 0 && options_.roi->height > 0) {
      capture_->set(cv::CAP_PROP_FRAME_WIDTH, options_.roi->width);
      capture_->set(cv::CAP_PROP_FRAME_HEIGHT, options_.roi->height);
    }
    if (options_.exposure_s) write_exposure(*options_.exposure_s);
    cycle_ = options_.exposure_cycle;
    check_cycle(spec_, cycle_);
    if (!cycle_.empty()) write_exposure(cycle_[0]);
  }

  std::string describe() const override {
    const int w = int(capture_->get(cv::CAP_PROP_FRAME_WIDTH)), h = int(capture_->get(cv::CAP_PROP_FRAME_HEIGHT));
    std::string d = spec_ + " (" + std::to_string(w) + "x" + std::to_string(h);
    if (device_ < 0) {
      d += ", " + std::to_string(frame_count_) + " frames";
      if (!exposures_.empty()) d += ", " + exposures_name_;
      if (options_.loop) d += ", looping";
    }
    return d + ")";
  }

  std::optional<CameraFrame> next(double timeout_s) override {
    if (finished()) return std::nullopt;
    if (device_ < 0 && options_.frame_rate > 0) {
      const auto due = start_ + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(double(delivered_) / options_.frame_rate));
      if (!wait_until(due, timeout_s)) return std::nullopt;
    }
    cv::Mat image;
    if (!capture_->read(image) || image.empty()) {
      if (device_ >= 0) throw CameraLost(spec_ + ": the camera stopped delivering frames");
      if (!options_.loop || frame_index_ == 0) {
        ended_ = true;
        return std::nullopt;
      }
      open_file();  // rewind (seeking is unreliable on some containers)
      ++pass_;
      frame_index_ = 0;
      if (!capture_->read(image) || image.empty()) {
        ended_ = true;
        return std::nullopt;
      }
    }
    CameraFrame frame;
    frame.image = to_rgb(image, frame.pixel_format);
    frame.sequence = delivered_;
    if (device_ < 0) {
      const double fps = capture_->get(cv::CAP_PROP_FPS);
      const double period = fps > 0 ? 1.0 / fps : 0.0;
      if (pass_ == 0 && frame_index_ + 1 > frame_count_) frame_count_ = frame_index_ + 1;
      frame.timestamp_s = double(frame_index_) * period + double(pass_) * double(frame_count_) * period;
      if (size_t(frame_index_) < exposures_.in_order.size()) frame.exposure_s = exposures_.in_order[size_t(frame_index_)];
    } else {
      frame.timestamp_s = std::chrono::duration<double>(Clock::now() - start_).count();
      frame.exposure_s = exposure_s_;
    }
    frame.bracket_index = cycle_position(cycle_, frame.exposure_s);
    ++frame_index_;
    ++delivered_;
    if (device_ >= 0 && !cycle_.empty() && frame.bracket_index >= 0)
      write_exposure(cycle_[size_t(frame.bracket_index + 1) % cycle_.size()]);
    return frame;
  }

  void set_exposure_cycle(const std::vector<double>& seconds) override {
    check_cycle(spec_, seconds);
    cycle_ = seconds;
    if (device_ >= 0 && !cycle_.empty()) write_exposure(cycle_[0]);
  }

  bool finished() const override { return ended_; }

 private:
  void open_file() {
    capture_->release();
    if (!capture_->open_file(file_) || !capture_->is_opened()) throw InputError(spec_ + ": cannot decode video " + file_);
    const double n = capture_->get(cv::CAP_PROP_FRAME_COUNT);
    if (n > 0) frame_count_ = std::max(frame_count_, int64_t(n));
  }
  // V4L2 exposure: manual mode, CAP_PROP_EXPOSURE in units of 100 us. Only what the
  // driver reports back is recorded.
  void write_exposure(double seconds) {
    capture_->set(cv::CAP_PROP_AUTO_EXPOSURE, 1);  // V4L2_EXPOSURE_MANUAL
    capture_->set(cv::CAP_PROP_EXPOSURE, seconds * 1e4);
    exposure_s_ = capture_->get(cv::CAP_PROP_EXPOSURE) * 1e-4;
  }

  std::string spec_;
  SourceOptions options_;
  std::string file_;
  int device_ = -1;
  std::unique_ptr<lazy::VideoCapture> capture_ = lazy::make_video_capture();
  Sidecar exposures_;
  std::string exposures_name_;
  std::vector<double> cycle_;
  Clock::time_point start_;
  int64_t delivered_ = 0, frame_index_ = 0, pass_ = 0, frame_count_ = 0;
  double exposure_s_ = 0;
  bool ended_ = false;
};

}  // namespace

namespace detail {
std::unique_ptr<CameraSource> open_replay(const std::string& dir, const std::string& spec, const SourceOptions& options) {
  return std::make_unique<ReplaySource>(dir, spec, options);
}
std::unique_ptr<CameraSource> open_video(const std::string& file, const std::string& spec, const SourceOptions& options) {
  return std::make_unique<CaptureSource>(file, spec, options);
}
std::unique_ptr<CameraSource> open_v4l2(int index, const std::string& spec, const SourceOptions& options) {
  return std::make_unique<CaptureSource>(index, spec, options);
}
}  // namespace detail

}  // namespace lp
