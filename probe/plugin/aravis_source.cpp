// Aravis (GenICam: GigE Vision, USB3 Vision, and Aravis' in-process fake camera) sources.
#include <arv.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "probe/camera_source.h"
#include "probe/genicam_sequencer.h"
#include "probe/plugin/aravis_errors.h"
#include "probe/plugin/aravis_gain.h"

namespace lp {

namespace detail {
std::unique_ptr<CameraSource> open_aravis(const std::string& id, const std::string& spec, const SourceOptions& options);
}

namespace {

void silence_glib_once() {
  static std::once_flag once;
  std::call_once(once, [] {
    auto quiet = [](const gchar*, GLogLevelFlags, const gchar*, gpointer) {};
    const auto levels = GLogLevelFlags(G_LOG_LEVEL_MASK | G_LOG_FLAG_FATAL | G_LOG_FLAG_RECURSION);
    for (const char* domain : {"Aravis", "GLib-GObject", "GLib-GIO"}) g_log_set_handler(domain, levels, quiet, nullptr);
  });
}

// GError -> message, freeing it.
std::string take_error(GError*& error) {
  std::string message = error && error->message ? error->message : "unknown error";
  if (error) g_clear_error(&error);
  return message;
}

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

template <class T>
struct GUnref {
  void operator()(T* p) const {
    if (p) g_object_unref(p);
  }
};

// ---- the fake camera's painter ------------------------------------------------------

struct FakePainter {
  std::mutex mutex;
  FakeScene scene;
  int width = 0, height = 0;      // size of the cached radiance
  std::vector<float> radiance;    // render_fake_scene at (width, height)
  bool dirty = true;
  std::map<ArvBuffer*, double> exposure_us;  // what each filled buffer was exposed at
  ArvFakeCamera* camera = nullptr;
  size_t buffer_size = 0;  // every stream buffer is allocated this big
};

int bayer_channel(const std::string& pattern, int x, int y) {
  // pattern: the two colours of row 0 ("RG", "BG", "GR", "GB"); row 1 is the complement.
  static const std::map<std::string, std::array<int, 4>> layouts = {
      {"RG", {0, 1, 1, 2}}, {"BG", {2, 1, 1, 0}}, {"GR", {1, 0, 2, 1}}, {"GB", {1, 2, 0, 1}}};
  const auto& l = layouts.at(pattern);
  return l[(y & 1) * 2 + (x & 1)];
}

std::string bayer_pattern_of(ArvPixelFormat f) {
  switch (f) {
    case ARV_PIXEL_FORMAT_BAYER_RG_8: case ARV_PIXEL_FORMAT_BAYER_RG_10: case ARV_PIXEL_FORMAT_BAYER_RG_12:
    case ARV_PIXEL_FORMAT_BAYER_RG_16: return "RG";
    case ARV_PIXEL_FORMAT_BAYER_BG_8: case ARV_PIXEL_FORMAT_BAYER_BG_10: case ARV_PIXEL_FORMAT_BAYER_BG_12:
    case ARV_PIXEL_FORMAT_BAYER_BG_16: return "BG";
    case ARV_PIXEL_FORMAT_BAYER_GR_8: case ARV_PIXEL_FORMAT_BAYER_GR_10: case ARV_PIXEL_FORMAT_BAYER_GR_12:
    case ARV_PIXEL_FORMAT_BAYER_GR_16: return "GR";
    case ARV_PIXEL_FORMAT_BAYER_GB_8: case ARV_PIXEL_FORMAT_BAYER_GB_10: case ARV_PIXEL_FORMAT_BAYER_GB_12:
    case ARV_PIXEL_FORMAT_BAYER_GB_16: return "GB";
    default: return "";
  }
}

// Significant bits of an unpacked format (8 or a 16-bit container), 0 when not supported.
int bits_of(ArvPixelFormat f) {
  switch (f) {
    case ARV_PIXEL_FORMAT_MONO_8: case ARV_PIXEL_FORMAT_BAYER_RG_8: case ARV_PIXEL_FORMAT_BAYER_BG_8:
    case ARV_PIXEL_FORMAT_BAYER_GR_8: case ARV_PIXEL_FORMAT_BAYER_GB_8: case ARV_PIXEL_FORMAT_RGB_8_PACKED:
    case ARV_PIXEL_FORMAT_BGR_8_PACKED: return 8;
    case ARV_PIXEL_FORMAT_MONO_10: case ARV_PIXEL_FORMAT_BAYER_RG_10: case ARV_PIXEL_FORMAT_BAYER_BG_10:
    case ARV_PIXEL_FORMAT_BAYER_GR_10: case ARV_PIXEL_FORMAT_BAYER_GB_10: return 10;
    case ARV_PIXEL_FORMAT_MONO_12: case ARV_PIXEL_FORMAT_BAYER_RG_12: case ARV_PIXEL_FORMAT_BAYER_BG_12:
    case ARV_PIXEL_FORMAT_BAYER_GR_12: case ARV_PIXEL_FORMAT_BAYER_GB_12: return 12;
    case ARV_PIXEL_FORMAT_MONO_16: case ARV_PIXEL_FORMAT_BAYER_RG_16: case ARV_PIXEL_FORMAT_BAYER_BG_16:
    case ARV_PIXEL_FORMAT_BAYER_GR_16: case ARV_PIXEL_FORMAT_BAYER_GB_16:
      return 16;
    default: return 0;
  }
}
bool is_rgb(ArvPixelFormat f) {
  return f == ARV_PIXEL_FORMAT_RGB_8_PACKED || f == ARV_PIXEL_FORMAT_BGR_8_PACKED;
}

// Runs on Aravis' fake stream thread, under the fake camera's fill mutex.
void paint_fake(ArvBuffer* buffer, void* data, guint32 exposure_time_us, guint32 gain, ArvPixelFormat format) {
  auto* painter = static_cast<FakePainter*>(data);
  if (!buffer || !painter) return;
  guint32 w = 0, h = 0;
  arv_fake_camera_read_register(painter->camera, ARV_FAKE_CAMERA_REGISTER_WIDTH, &w);
  arv_fake_camera_read_register(painter->camera, ARV_FAKE_CAMERA_REGISTER_HEIGHT, &h);
  size_t size = 0;
  auto* bytes = static_cast<uint8_t*>(const_cast<void*>(arv_buffer_get_data(buffer, &size)));
  if (size == 0) size = painter->buffer_size;  // the fake does not record what it fills
  const int bits = bits_of(format);
  const bool rgb = is_rgb(format);
  const int bytes_per_sample = bits > 8 ? 2 : 1;
  const size_t needed = size_t(w) * h * bytes_per_sample * (rgb ? 3 : 1);
  std::lock_guard lock(painter->mutex);
  painter->exposure_us[buffer] = exposure_time_us;
  if (!bytes || bits == 0 || size < needed || w == 0 || h == 0) return;
  if (painter->dirty || painter->width != int(w) || painter->height != int(h)) {
    RgbImage r = render_fake_scene(painter->scene, int(w), int(h));
    painter->radiance = std::move(r.rgb);
    painter->width = int(w), painter->height = int(h);
    painter->dirty = false;
  }
  const double max_code = std::ldexp(1.0, bits) - 1;
  const double scale = exposure_time_us * 1e-6 * std::pow(10.0, gain / 20.0) * max_code;
  const std::string bayer = bayer_pattern_of(format);
  const bool bgr = format == ARV_PIXEL_FORMAT_BGR_8_PACKED;
  auto code = [&](float radiance) { return std::min(max_code, std::round(radiance * scale)); };
  auto store = [&](size_t index, double value) {
    if (bytes_per_sample == 1)
      bytes[index] = uint8_t(value);
    else {
      const uint16_t v = uint16_t(value);
      std::memcpy(bytes + 2 * index, &v, 2);  // GenICam unpacked formats are little-endian
    }
  };
  const float* rad = painter->radiance.data();
  for (guint32 y = 0; y < h; ++y)
    for (guint32 x = 0; x < w; ++x) {
      const size_t p = size_t(y) * w + x;
      const float* px = rad + 3 * p;
      if (rgb) {
        for (int c = 0; c < 3; ++c) store(3 * p + c, code(px[bgr ? 2 - c : c]));
      } else if (!bayer.empty()) {
        store(p, code(px[bayer_channel(bayer, int(x), int(y))]));
      } else {
        store(p, code(0.2126f * px[0] + 0.7152f * px[1] + 0.0722f * px[2]));
      }
    }
}

// ---- decoding -----------------------------------------------------------------------

RgbImage decode(const void* data, size_t size, int width, int height, ArvPixelFormat format, const std::string& name) {
  const int bits = bits_of(format);
  if (bits == 0) throw InputError("aravis: pixel format " + name + " is not supported (use Mono8/10/12/16, Bayer*8/10/12/16, RGB8)");
  const int channels = is_rgb(format) ? 3 : 1;
  const int depth = bits > 8 ? CV_16U : CV_8U;
  const size_t needed = size_t(width) * height * channels * (bits > 8 ? 2 : 1);
  if (size < needed) throw std::runtime_error("aravis: frame of " + std::to_string(size) + " bytes, " + std::to_string(needed) + " expected for " + name);
  cv::Mat raw(height, width, CV_MAKETYPE(depth, channels), const_cast<void*>(data));
  cv::Mat rgb;
  const std::string bayer = bayer_pattern_of(format);
  if (!bayer.empty()) {
    // OpenCV names a Bayer pattern by row 1, columns 1-2: GenICam RG = OpenCV BG, etc.
    static const std::map<std::string, int> codes = {{"RG", cv::COLOR_BayerBG2RGB}, {"BG", cv::COLOR_BayerRG2RGB},
                                                     {"GR", cv::COLOR_BayerGB2RGB}, {"GB", cv::COLOR_BayerGR2RGB}};
    cv::demosaicing(raw, rgb, codes.at(bayer));
  } else if (channels == 1) {
    cv::cvtColor(raw, rgb, cv::COLOR_GRAY2RGB);
  } else if (format == ARV_PIXEL_FORMAT_BGR_8_PACKED) {
    cv::cvtColor(raw, rgb, cv::COLOR_BGR2RGB);
  } else {
    rgb = raw;
  }
  cv::Mat f;
  rgb.convertTo(f, CV_32FC3, 1.0 / (std::ldexp(1.0, bits) - 1));
  RgbImage image;
  image.width = width, image.height = height;
  image.rgb.assign(f.ptr<float>(), f.ptr<float>() + size_t(width) * height * 3);
  return image;
}

// ---- GenICam features for the sequencer program --------------------------------------

class AravisFeatures final : public GenicamFeatures {
 public:
  explicit AravisFeatures(ArvCamera* camera) : camera_(camera) {}
  bool available(const std::string& f) override {
    GError* error = nullptr;
    const bool yes = arv_camera_is_feature_available(camera_, f.c_str(), &error);
    g_clear_error(&error);
    return yes;
  }
  bool set_enum(const std::string& f, const std::string& v, std::string* e) override {
    GError* error = nullptr;
    arv_camera_set_string(camera_, f.c_str(), v.c_str(), &error);
    return done(error, e);
  }
  bool set_integer(const std::string& f, int64_t v, std::string* e) override {
    GError* error = nullptr;
    arv_camera_set_integer(camera_, f.c_str(), v, &error);
    return done(error, e);
  }
  bool set_float(const std::string& f, double v, std::string* e) override {
    GError* error = nullptr;
    arv_camera_set_float(camera_, f.c_str(), v, &error);
    return done(error, e);
  }
  bool execute(const std::string& c, std::string* e) override {
    GError* error = nullptr;
    arv_camera_execute_command(camera_, c.c_str(), &error);
    return done(error, e);
  }
  std::optional<int64_t> integer_max(const std::string& f) override {
    GError* error = nullptr;
    gint64 lo = 0, hi = 0;
    arv_camera_get_integer_bounds(camera_, f.c_str(), &lo, &hi, &error);
    if (error) {
      g_clear_error(&error);
      return std::nullopt;
    }
    return int64_t(hi);
  }

 private:
  static bool done(GError*& error, std::string* e) {
    if (!error) return true;
    const std::string m = take_error(error);
    if (e) *e = one_line(m);
    return false;
  }
  ArvCamera* camera_;
};

// ---- the source ---------------------------------------------------------------------

class AravisSource final : public CameraSource {
 public:
  AravisSource(std::string id, std::string spec, SourceOptions options)
      : id_(std::move(id)), spec_(std::move(spec)), options_(std::move(options)) {
    painter_.scene = options_.fake_scene;
    open();
  }
  ~AravisSource() override { close(); }

  std::string describe() const override { return description_; }

  std::optional<CameraFrame> next(double timeout_s) override {
    if (!stream_) throw CameraLost(spec_ + ": camera not connected (call reconnect())");
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(std::max(0.0, timeout_s));
    for (;;) {
      if (lost_) throw CameraLost(spec_ + ": camera lost (control link down)");
      const auto left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
      ArvBuffer* buffer = arv_stream_timeout_pop_buffer(stream_.get(), guint64(std::max(0.0, left) * 1e6));
      if (!buffer) {
        if (lost_) throw CameraLost(spec_ + ": camera lost (control link down)");
        return std::nullopt;
      }
      std::optional<double> tagged_us = take_tag(buffer);
      if (arv_buffer_get_status(buffer) != ARV_BUFFER_STATUS_SUCCESS) {
        if (++failed_in_a_row_ > 100) {
          arv_stream_push_buffer(stream_.get(), buffer);
          throw CameraLost(spec_ + ": stream broken (100 incomplete frames in a row)");
        }
        arv_stream_push_buffer(stream_.get(), buffer);
        continue;
      }
      failed_in_a_row_ = 0;
      // Which exposure was this frame taken at?
      double exposure_us = target_us_;
      if (tagged_us) {
        exposure_us = *tagged_us;
      } else if (settle_left_ > 0) {
        --settle_left_;
        arv_stream_push_buffer(stream_.get(), buffer);
        continue;
      }
      int bracket = -1;
      if (sequencer_) {
        bracket = sequencer_index(buffer, tagged_us, exposure_us);
        if (bracket < 0) {  // a frame the sequencer did not take (before it started)
          arv_stream_push_buffer(stream_.get(), buffer);
          if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
          continue;
        }
      } else if (!cycle_.empty()) {
        if (std::abs(exposure_us - target_us_) > 0.5 + 1e-3 * target_us_) {
          // Taken before the last exposure write reached the sensor: not part of the cycle.
          arv_stream_push_buffer(stream_.get(), buffer);
          if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
          continue;
        }
        bracket = int(cycle_index_);
      }
      CameraFrame frame;
      try {
        size_t size = 0;
        const void* data = arv_buffer_get_data(buffer, &size);
        if (size == 0 && fake_) size = buffer_size_;  // the fake camera reports no received size
        frame.image = decode(data, size, arv_buffer_get_image_width(buffer), arv_buffer_get_image_height(buffer),
                             arv_buffer_get_image_pixel_format(buffer), pixel_format_);
      } catch (...) {
        arv_stream_push_buffer(stream_.get(), buffer);
        throw;
      }
      guint64 ts = arv_buffer_get_timestamp(buffer);
      if (ts == 0) ts = arv_buffer_get_system_timestamp(buffer);
      frame.timestamp_s = double(ts) * 1e-9;
      frame.exposure_s = exposure_us * 1e-6;
      frame.gain_db = gain_db_;
      frame.pixel_format = pixel_format_;
      frame.sequence = int64_t(arv_buffer_get_frame_id(buffer));
      frame.bracket_index = bracket;
      arv_stream_push_buffer(stream_.get(), buffer);
      if (!cycle_.empty() && !sequencer_) {
        cycle_index_ = (cycle_index_ + 1) % cycle_.size();
        write_exposure(cycle_[cycle_index_]);
      }
      return frame;
    }
  }

  std::optional<ExposureRange> exposure_range() const override {
    if (!camera_) return std::nullopt;
    double lo_us = 0, hi_us = 0;
    GError* error = nullptr;
    arv_camera_get_exposure_time_bounds(camera_.get(), &lo_us, &hi_us, &error);
    if (error || !(lo_us > 0) || !(hi_us >= lo_us)) {
      g_clear_error(&error);
      return std::nullopt;
    }
    return ExposureRange{lo_us * 1e-6, hi_us * 1e-6};
  }

  void set_exposure_cycle(const std::vector<double>& seconds) override {
    for (double s : seconds)
      if (!(s > 0) || !std::isfinite(s)) throw InputError(spec_ + ": exposure time " + std::to_string(s) + " s is not positive");
    cycle_ = seconds;
    cycle_index_ = 0;
    sequencer_ = false;
    if (cycle_.size() >= 2 && !fake_ && options_.bracketing != "writes") {
      // The camera's own sequencer when it has one: no frame lost to a write's round
      // trip. Sets can only be programmed with acquisition stopped.
      AravisFeatures features(camera_.get());
      const bool acquiring = stream_ != nullptr;
      if (acquiring) arv_camera_stop_acquisition(camera_.get(), nullptr);
      const SequencerSetup setup = start_exposure_sequencer(features, cycle_);
      if (acquiring) {
        GError* error = nullptr;
        arv_camera_start_acquisition(camera_.get(), &error);
        if (error) fail("cannot restart acquisition after programming the sequencer", error);
      }
      if (setup.ok) {
        sequencer_ = true;
        sequence_start_ = -1;
        sequencer_exposure_us_ = setup.exposure_us;
        return;
      }
      if (options_.bracketing == "sequencer") throw InputError(spec_ + ": " + setup.reason);
    } else if (options_.bracketing == "sequencer") {
      throw InputError(spec_ + (fake_ ? ": the fake camera has no sequencer" : ": a sequencer needs at least 2 exposures"));
    }
    if (!cycle_.empty()) write_exposure(cycle_[0]);
  }

  bool reconnect() override {
    close();
    try {
      open();
      return true;
    } catch (const std::exception&) {
      close();
      return false;
    }
  }

  bool set_fake_scene(const FakeScene& scene) override {
    if (fake_ == nullptr) return false;
    std::lock_guard lock(painter_.mutex);
    painter_.scene = scene;
    painter_.dirty = true;
    return true;
  }

 private:
  static void on_control_lost(ArvDevice*, gpointer self) { static_cast<AravisSource*>(self)->lost_ = true; }

  [[noreturn]] void fail(const std::string& what, GError*& error) {
    throw InputError(one_line(spec_ + ": " + what + ": " + take_error(error)));
  }

  void open() {
    silence_glib_once();
    lost_ = false;
    GError* error = nullptr;
    ArvCamera* camera = nullptr;
    if (id_.rfind("Fake_", 0) == 0) {
      // The in-process fake: built directly, so no interface is scanned and nothing
      // goes on the network.
      const std::string serial = id_.substr(5);
      ArvDevice* device = arv_fake_device_new(serial.empty() ? "1" : serial.c_str(), &error);
      if (!device) fail("cannot create the fake camera", error);
      camera = arv_camera_new_with_device(device, &error);
      g_object_unref(device);  // the camera holds its own reference
      if (!camera) fail("cannot open the fake camera", error);
      fake_ = arv_fake_device_get_fake_camera(ARV_FAKE_DEVICE(arv_camera_get_device(camera)));
    } else {
      if (id_.empty() && !options_.aravis_network) {
        arv_enable_interface("Fake");
        arv_disable_interface("GigEVision");
        arv_disable_interface("USB3Vision");
      } else if (id_.empty()) {
        arv_enable_interface("GigEVision");
        arv_enable_interface("USB3Vision");
      }
      if (id_.empty()) {
        arv_update_device_list();
        if (arv_get_n_devices() == 0) throw InputError(spec_ + ": no Aravis camera found");
        camera = arv_camera_new(arv_get_device_id(0), &error);
      } else {
        camera = arv_camera_new(id_.c_str(), &error);
      }
      if (!camera) {
        throw InputError(one_line(spec_ + ": no such Aravis camera" + (error ? std::string(" (") + take_error(error) + ")" : "")));
      }
      if (ArvDevice* device = arv_camera_get_device(camera); device && ARV_IS_FAKE_DEVICE(device))
        fake_ = arv_fake_device_get_fake_camera(ARV_FAKE_DEVICE(device));
    }
    camera_.reset(camera);
    lost_handler_ = g_signal_connect(arv_camera_get_device(camera), "control-lost", G_CALLBACK(on_control_lost), this);

    if (fake_) {
      painter_.camera = fake_;
      arv_fake_camera_set_fill_pattern(fake_, paint_fake, &painter_);
    }
    configure();

    const guint payload = arv_camera_get_payload(camera, &error);
    if (error) fail("payload size", error);
    ArvStream* stream = arv_camera_create_stream(camera, nullptr, nullptr, &error);
    if (!stream) fail("cannot create a stream", error);
    stream_.reset(stream);
    buffer_size_ = payload;
    {
      std::lock_guard lock(painter_.mutex);
      painter_.buffer_size = payload;
    }
    for (int i = 0; i < std::max(2, options_.n_buffers); ++i) arv_stream_push_buffer(stream, arv_buffer_new_allocate(payload));
    arv_camera_set_acquisition_mode(camera, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
    if (error) fail("acquisition mode", error);
    arv_camera_start_acquisition(camera, &error);
    if (error) fail("cannot start acquisition", error);

    const char* vendor = arv_camera_get_vendor_name(camera, nullptr);
    const char* model = arv_camera_get_model_name(camera, nullptr);
    int x = 0, y = 0, w = 0, h = 0;
    arv_camera_get_region(camera, &x, &y, &w, &h, nullptr);
    description_ = spec_ + " (" + (vendor ? vendor : "?") + " " + (model ? model : "?") + ", " + std::to_string(w) + "x" +
                   std::to_string(h) + " " + pixel_format_ + (chunks_ ? ", exposure from chunk data" : "") + gain_note_ + ")";
  }

  // The gain feature (kGainFeatures) in dB into gain_db_, after setting it to --gain-db
  // when `set`. A gain that is not in dB is NaN (the stream divides by exposure time only and
  // says so) and named in the description; --gain-db on such a camera is refused (Aravis
  // would write the dB value as raw steps).
  void read_gain(bool set) {
    ArvCamera* camera = camera_.get();
    ArvDevice* device = arv_camera_get_device(camera);
    gain_db_ = 0;
    gain_note_.clear();
    for (const char* name : kGainFeatures) {
      ArvGcNode* node = arv_device_get_feature(device, name);
      if (!node) continue;
      GError* error = nullptr;
      std::string unit;
      double value = NAN;
      if (ARV_IS_GC_FLOAT(node)) {
        const char* u = arv_gc_float_get_unit(ARV_GC_FLOAT(node));
        unit = u ? u : "";
        const std::optional<double> to_write = options_.gain_db ? gain_feature_value(name, unit, *options_.gain_db) : std::nullopt;
        if (set && to_write) {
          arv_gc_float_set_value(ARV_GC_FLOAT(node), *to_write, &error);
          if (error) fail("gain", error);
        }
        value = arv_gc_float_get_value(ARV_GC_FLOAT(node), &error);
      } else if (ARV_IS_GC_INTEGER(node)) {
        const char* u = arv_gc_integer_get_unit(ARV_GC_INTEGER(node));
        unit = u ? u : "";
        value = double(arv_gc_integer_get_value(ARV_GC_INTEGER(node), &error));
      } else {
        continue;
      }
      g_clear_error(&error);
      const std::optional<double> db = gain_feature_db(name, unit, value);
      if (db) {
        gain_db_ = *db;
      } else {
        if (set && options_.gain_db)
          throw InputError(spec_ + ": the camera's gain (" + name + (unit.empty() ? "" : " in " + unit) +
                           ") is not in dB, so --gain-db cannot set it; set it with the vendor's tool");
        gain_db_ = NAN;  // CameraFrame: a gain that is there but not in dB
        char shown[32];
        std::snprintf(shown, sizeof shown, "%g", value);
        gain_note_ = std::string(", gain ") + name + " " + shown + (unit.empty() ? "" : " " + unit) + " not in dB";
      }
      return;
    }
    if (set && options_.gain_db) throw InputError(spec_ + ": the camera has no gain feature for --gain-db");
  }

  void configure() {
    ArvCamera* camera = camera_.get();
    GError* error = nullptr;
    if (!options_.pixel_format.empty()) {
      arv_camera_set_pixel_format_from_string(camera, options_.pixel_format.c_str(), &error);
      if (error) fail("pixel format " + options_.pixel_format, error);
    }
    const char* pf = arv_camera_get_pixel_format_as_string(camera, &error);
    if (error) fail("pixel format", error);
    pixel_format_ = pf ? pf : "?";
    if (bits_of(arv_camera_get_pixel_format(camera, nullptr)) == 0)
      throw InputError(spec_ + ": pixel format " + pixel_format_ + " is not supported (use Mono8/10/12/16, Bayer*8/10/12/16, RGB8)");
    if (options_.roi) {
      const auto& r = *options_.roi;
      arv_camera_set_region(camera, r.x, r.y, r.width, r.height, &error);
      if (error) fail("region " + std::to_string(r.width) + "x" + std::to_string(r.height) + "+" + std::to_string(r.x) + "+" + std::to_string(r.y), error);
    }
    if (options_.frame_rate > 0 && arv_camera_is_frame_rate_available(camera, nullptr)) {
      arv_camera_set_frame_rate(camera, options_.frame_rate, &error);
      if (error) fail("frame rate", error);
    }
    if (arv_camera_is_exposure_auto_available(camera, nullptr)) arv_camera_set_exposure_time_auto(camera, ARV_AUTO_OFF, nullptr);
    if (arv_camera_is_gain_auto_available(camera, nullptr)) arv_camera_set_gain_auto(camera, ARV_AUTO_OFF, nullptr);
    g_clear_error(&error);
    if (fake_) {
      if (options_.gain_db) {
        arv_camera_set_integer(camera, "GainRaw", gint64(std::lround(*options_.gain_db)), &error);  // the fake paints GainRaw as dB
        if (error) fail("gain", error);
      }
      gain_db_ = double(arv_camera_get_integer(camera, "GainRaw", nullptr));
    } else {
      read_gain(true);
    }
    g_clear_error(&error);
    // Per-frame exposure from chunk data, when the camera has it (the fake paints its own).
    chunks_ = false;
    if (!fake_ && arv_camera_are_chunks_available(camera, nullptr)) {
      arv_camera_set_chunks(camera, "ExposureTime,SequencerSetActive", &error);
      if (error) {  // a camera without the sequencer chunk: exposure alone
        g_clear_error(&error);
        arv_camera_set_chunks(camera, "ExposureTime", &error);
      }
      if (!error) {
        chunk_parser_.reset(arv_camera_create_chunk_parser(camera));
        chunks_ = chunk_parser_ != nullptr;
      }
      g_clear_error(&error);
    }
    if (!options_.exposure_cycle.empty()) {
      set_exposure_cycle(options_.exposure_cycle);
    } else if (!cycle_.empty()) {
      set_exposure_cycle(cycle_);  // keep cycling across a reconnect
    } else if (options_.exposure_s) {
      write_exposure(*options_.exposure_s);
    } else {
      target_us_ = arv_camera_get_exposure_time(camera, nullptr);
    }
  }

  void write_exposure(double seconds) {
    GError* error = nullptr;
    arv_camera_set_exposure_time(camera_.get(), seconds * 1e6, &error);
    if (error) {
      const bool camera_lost = exposure_write_lost_camera(*error, lost_, exposures_taken_.count(seconds) > 0);
      const std::string message = take_error(error);
      if (camera_lost)
        throw CameraLost(one_line(spec_ + ": camera lost (cannot set exposure " + std::to_string(seconds) + " s: " + message + ")"));
      throw InputError(one_line(spec_ + ": cannot set exposure " + std::to_string(seconds) + " s: " + message));
    }
    exposures_taken_.insert(seconds);
    // What the camera really set (rounded to its resolution, clamped to its range).
    target_us_ = arv_camera_get_exposure_time(camera_.get(), &error);
    if (error) {
      g_clear_error(&error);
      target_us_ = seconds * 1e6;
    }
    settle_left_ = options_.exposure_settle_frames;
  }

  // The exposure a buffer was taken at, when the camera says so.
  std::optional<double> take_tag(ArvBuffer* buffer) {
    if (fake_) {
      std::lock_guard lock(painter_.mutex);
      auto it = painter_.exposure_us.find(buffer);
      if (it == painter_.exposure_us.end()) return std::nullopt;
      const double us = it->second;
      painter_.exposure_us.erase(it);
      return us;
    }
    if (chunks_ && arv_buffer_has_chunks(buffer)) {
      GError* error = nullptr;
      const double us = arv_chunk_parser_get_float_value(chunk_parser_.get(), buffer, "ChunkExposureTime", &error);
      if (!error) return us;
      g_clear_error(&error);
    }
    return std::nullopt;
  }

  // Which set of the sequencer took this frame: from chunk data when the camera sends
  // it (the active set, else the exposure), otherwise by counting frame ids from the first
  // frame after the sequencer started (block ids count every exposure, lost ones too).
  // Sets exposure_us to the programmed exposure of that set; -1 when unknown.
  int sequencer_index(ArvBuffer* buffer, std::optional<double> tagged_us, double& exposure_us) {
    const int n = int(sequencer_exposure_us_.size());
    int index = -1;
    if (chunks_ && arv_buffer_has_chunks(buffer)) {
      GError* error = nullptr;
      const gint64 set = arv_chunk_parser_get_integer_value(chunk_parser_.get(), buffer, "ChunkSequencerSetActive", &error);
      if (!error && set >= 0 && set < n) index = int(set);
      g_clear_error(&error);
    }
    if (index < 0 && tagged_us) {
      for (int i = 0; i < n; ++i)
        if (std::abs(*tagged_us - sequencer_exposure_us_[size_t(i)]) <= 0.5 + 1e-3 * sequencer_exposure_us_[size_t(i)])
          index = i;
      if (index < 0) return -1;
    }
    if (index < 0) {
      const int64_t id = int64_t(arv_buffer_get_frame_id(buffer));
      if (sequence_start_ < 0) sequence_start_ = id;
      index = int((id - sequence_start_) % n);
    }
    exposure_us = tagged_us ? *tagged_us : sequencer_exposure_us_[size_t(index)];
    return index;
  }

  void close() {
    if (camera_ && sequencer_ && !lost_) {
      AravisFeatures features(camera_.get());
      if (stream_) arv_camera_stop_acquisition(camera_.get(), nullptr);
      stop_exposure_sequencer(features);
    }
    if (camera_) {
      if (stream_) arv_camera_stop_acquisition(camera_.get(), nullptr);
      if (lost_handler_) g_signal_handler_disconnect(arv_camera_get_device(camera_.get()), lost_handler_);
      lost_handler_ = 0;
    }
    stream_.reset();  // joins the stream thread
    if (fake_) arv_fake_camera_set_fill_pattern(fake_, nullptr, nullptr);  // waits for a fill in progress
    chunk_parser_.reset();
    camera_.reset();
    fake_ = nullptr;
    std::lock_guard lock(painter_.mutex);
    painter_.exposure_us.clear();
    painter_.camera = nullptr;
  }

  std::string id_, spec_;
  SourceOptions options_;
  std::unique_ptr<ArvCamera, GUnref<ArvCamera>> camera_;
  std::unique_ptr<ArvStream, GUnref<ArvStream>> stream_;
  std::unique_ptr<ArvChunkParser, GUnref<ArvChunkParser>> chunk_parser_;
  ArvFakeCamera* fake_ = nullptr;  // owned by the camera's device
  gulong lost_handler_ = 0;
  std::atomic<bool> lost_{false};
  FakePainter painter_;
  std::string description_, pixel_format_;
  std::string gain_note_;  // ", gain GainRaw 120 not in dB: ..." when the gain is not divided out
  bool chunks_ = false;
  double gain_db_ = 0;
  double target_us_ = 0;  // exposure the camera was last set to (read back)
  std::set<double> exposures_taken_;  // exposures this camera has accepted (write_exposure)
  int settle_left_ = 0;
  std::vector<double> cycle_;
  size_t cycle_index_ = 0;
  bool sequencer_ = false;                      // the camera cycles exposures itself
  std::vector<double> sequencer_exposure_us_;   // set -> programmed exposure
  int64_t sequence_start_ = -1;                 // frame id of set 0 without chunk data
  int failed_in_a_row_ = 0;
  size_t buffer_size_ = 0;
};

}  // namespace

namespace detail {
std::unique_ptr<CameraSource> open_aravis(const std::string& id, const std::string& spec, const SourceOptions& options) {
  return std::make_unique<AravisSource>(id, spec, options);
}
}  // namespace detail

}  // namespace lp
