// libcamera sources (Raspberry Pi and other V4L2 subdevice pipelines). Per-request
// controls give true per-frame exposure cycling; the exposure each frame was taken at is
// read back from the request's metadata.
//
// Not exercised here (0.0.3 lists no camera on this machine): only the "no camera" and
// "no such camera" paths are tested.
#include <sys/mman.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <libcamera/libcamera.h>
#include <mutex>

#include "core/error.h"
#include "probe/camera_source.h"

namespace lp {

namespace detail {
std::unique_ptr<CameraSource> open_libcamera(const std::string& id, const std::string& spec, const SourceOptions& options);
}

namespace {

// libcamera allows one CameraManager per process: shared by every source.
std::shared_ptr<libcamera::CameraManager> camera_manager() {
  static std::mutex mutex;
  static std::weak_ptr<libcamera::CameraManager> shared;
  std::lock_guard lock(mutex);
  if (auto manager = shared.lock()) return manager;
  libcamera::logSetTarget(libcamera::LoggingTargetNone);  // the library prints nothing
  auto manager = std::shared_ptr<libcamera::CameraManager>(new libcamera::CameraManager, [](libcamera::CameraManager* m) {
    m->stop();
    delete m;
  });
  if (const int ret = manager->start(); ret != 0)
    throw InputError("libcamera: cannot start the camera manager (error " + std::to_string(ret) + ")");
  shared = manager;
  return manager;
}

class LibcameraSource final : public CameraSource {
 public:
  LibcameraSource(const std::string& id, std::string spec, const SourceOptions& options)
      : spec_(std::move(spec)), options_(options) {
    try {
      init(id);
    } catch (...) {
      teardown();
      throw;
    }
  }
  ~LibcameraSource() override { teardown(); }

 private:
  void init(const std::string& id) {
    manager_ = camera_manager();
    const auto cameras = manager_->cameras();
    if (cameras.empty()) throw InputError(spec_ + ": no libcamera camera found");
    if (id.empty()) {
      camera_ = cameras.front();
    } else {
      camera_ = manager_->get(id);
      if (!camera_) {
        std::string found;
        for (const auto& c : cameras) found += (found.empty() ? "" : ", ") + c->id();
        throw InputError(spec_ + ": no libcamera camera '" + id + "' (found: " + found + ")");
      }
    }
    if (camera_->acquire() != 0) throw InputError(spec_ + ": camera " + camera_->id() + " is in use");
    acquired_ = true;
    camera_->disconnected.connect(this, &LibcameraSource::on_disconnected);
    camera_->requestCompleted.connect(this, &LibcameraSource::on_request_completed);

    config_ = camera_->generateConfiguration({libcamera::StreamRole::Viewfinder});
    if (!config_ || config_->size() == 0) throw InputError(spec_ + ": no usable stream configuration");
    libcamera::StreamConfiguration& sc = config_->at(0);
    sc.pixelFormat = libcamera::formats::BGR888;  // bytes R, G, B
    if (options_.roi && options_.roi->width > 0 && options_.roi->height > 0)
      sc.size = libcamera::Size(unsigned(options_.roi->width), unsigned(options_.roi->height));
    sc.bufferCount = unsigned(std::max(2, options_.n_buffers));
    if (config_->validate() == libcamera::CameraConfiguration::Invalid) throw InputError(spec_ + ": stream configuration refused");
    if (sc.pixelFormat != libcamera::formats::BGR888 && sc.pixelFormat != libcamera::formats::RGB888)
      throw InputError(spec_ + ": camera cannot deliver RGB (offers " + sc.pixelFormat.toString() + ")");
    if (camera_->configure(config_.get()) != 0) throw InputError(spec_ + ": cannot configure the camera");
    stream_ = sc.stream();
    allocator_ = std::make_unique<libcamera::FrameBufferAllocator>(camera_);
    if (allocator_->allocate(stream_) < 0) throw InputError(spec_ + ": cannot allocate frame buffers");
    for (const auto& buffer : allocator_->buffers(stream_)) {
      auto request = camera_->createRequest(requests_.size());
      if (!request || request->addBuffer(stream_, buffer.get()) != 0) throw InputError(spec_ + ": cannot create a capture request");
      const auto& plane = buffer->planes()[0];
      void* map = mmap(nullptr, plane.length, PROT_READ, MAP_SHARED, plane.fd.get(), plane.offset);
      if (map == MAP_FAILED) throw InputError(spec_ + ": cannot map a frame buffer");
      maps_.push_back({map, plane.length});
      requests_.push_back(std::move(request));
      requested_.push_back(-1);
    }
    cycle_ = options_.exposure_cycle;
    for (double s : cycle_)
      if (!(s > 0)) throw InputError(spec_ + ": exposure time " + std::to_string(s) + " s is not positive");
    if (camera_->start() != 0) throw InputError(spec_ + ": cannot start the camera");
    started_ = true;
    for (size_t i = 0; i < requests_.size(); ++i) queue(i);
    description_ = spec_ + " (libcamera " + camera_->id() + ", " + sc.size.toString() + " " + sc.pixelFormat.toString() + ")";
  }

  void teardown() {
    if (started_) camera_->stop();
    started_ = false;
    if (camera_) {
      camera_->requestCompleted.disconnect(this);
      camera_->disconnected.disconnect(this);
    }
    for (const auto& [ptr, length] : maps_) munmap(ptr, length);
    requests_.clear();
    allocator_.reset();
    maps_.clear();
    if (acquired_) camera_->release();
    acquired_ = false;
  }

 public:
  std::string describe() const override { return description_; }

  std::optional<CameraFrame> next(double timeout_s) override {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(std::max(0.0, timeout_s)));
    for (;;) {
      libcamera::Request* request = nullptr;
      {
        std::unique_lock lock(mutex_);
        if (!done_.wait_until(lock, deadline, [&] { return lost_ || !completed_.empty(); })) return std::nullopt;
        if (lost_) throw CameraLost(spec_ + ": camera disconnected");
        request = completed_.front();
        completed_.pop_front();
      }
      const size_t slot = size_t(request->cookie());
      if (request->status() != libcamera::Request::RequestComplete) {
        if (request->status() == libcamera::Request::RequestCancelled && !started_) throw CameraLost(spec_ + ": capture stopped");
        queue(slot);
        continue;
      }
      CameraFrame frame;
      const auto& md = request->metadata();
      const int requested = requested_[slot];
      if (auto e = md.get(libcamera::controls::ExposureTime)) frame.exposure_s = *e * 1e-6;
      if (auto g = md.get(libcamera::controls::AnalogueGain)) frame.gain_db = 20 * std::log10(std::max(1e-6f, *g));
      libcamera::FrameBuffer* buffer = request->buffers().begin()->second;
      const auto& fm = buffer->metadata();
      frame.sequence = int64_t(fm.sequence);
      frame.timestamp_s = double(fm.timestamp) * 1e-9;
      if (auto t = md.get(libcamera::controls::SensorTimestamp)) frame.timestamp_s = double(*t) * 1e-9;
      if (requested >= 0 && size_t(requested) < cycle_.size()) {
        // Controls reach the sensor a few frames late: only frames really taken at the
        // requested exposure belong to the cycle.
        if (frame.exposure_s > 0 && std::abs(frame.exposure_s - cycle_[size_t(requested)]) > 0.05 * cycle_[size_t(requested)]) {
          queue(slot);
          continue;
        }
        frame.bracket_index = requested;
      }
      const auto& sc = config_->at(0);
      const bool bgr_bytes = sc.pixelFormat == libcamera::formats::RGB888;  // bytes B, G, R
      frame.pixel_format = "RGB8";
      frame.image.width = int(sc.size.width), frame.image.height = int(sc.size.height);
      frame.image.rgb.resize(size_t(sc.size.width) * sc.size.height * 3);
      const auto* bytes = static_cast<const uint8_t*>(maps_[slot].first);
      for (unsigned y = 0; y < sc.size.height; ++y) {
        const uint8_t* row = bytes + size_t(y) * sc.stride;
        float* out = &frame.image.rgb[size_t(y) * sc.size.width * 3];
        for (unsigned x = 0; x < sc.size.width; ++x)
          for (int c = 0; c < 3; ++c) out[3 * x + c] = row[3 * x + (bgr_bytes ? 2 - c : c)] / 255.0f;
      }
      queue(slot);
      return frame;
    }
  }

  void set_exposure_cycle(const std::vector<double>& seconds) override {
    for (double s : seconds)
      if (!(s > 0) || !std::isfinite(s)) throw InputError(spec_ + ": exposure time " + std::to_string(s) + " s is not positive");
    cycle_ = seconds;
    next_index_ = 0;
  }

 private:
  void on_disconnected() {
    std::lock_guard lock(mutex_);
    lost_ = true;
    done_.notify_all();
  }
  void on_request_completed(libcamera::Request* request) {
    std::lock_guard lock(mutex_);
    completed_.push_back(request);
    done_.notify_all();
  }
  // Requeues a request with the next exposure of the cycle (or the fixed one).
  void queue(size_t slot) {
    libcamera::Request* request = requests_[slot].get();
    request->reuse(libcamera::Request::ReuseBuffers);
    auto& controls = request->controls();
    requested_[slot] = -1;
    double exposure = options_.exposure_s.value_or(0.0);
    if (!cycle_.empty()) {
      requested_[slot] = int(next_index_);
      exposure = cycle_[next_index_];
      next_index_ = (next_index_ + 1) % cycle_.size();
    }
    if (exposure > 0) {
      controls.set(libcamera::controls::AeEnable, false);
      controls.set(libcamera::controls::ExposureTime, int32_t(std::lround(exposure * 1e6)));
    }
    if (options_.gain_db) controls.set(libcamera::controls::AnalogueGain, float(std::pow(10.0, *options_.gain_db / 20)));
    if (camera_->queueRequest(request) != 0) {
      std::lock_guard lock(mutex_);
      lost_ = true;
    }
  }

  std::string spec_, description_;
  SourceOptions options_;
  std::shared_ptr<libcamera::CameraManager> manager_;
  std::shared_ptr<libcamera::Camera> camera_;
  std::unique_ptr<libcamera::CameraConfiguration> config_;
  std::unique_ptr<libcamera::FrameBufferAllocator> allocator_;
  libcamera::Stream* stream_ = nullptr;
  std::vector<std::unique_ptr<libcamera::Request>> requests_;
  std::vector<std::pair<void*, size_t>> maps_;
  std::vector<int> requested_;  // cycle position each request asked for, -1 none
  std::vector<double> cycle_;
  size_t next_index_ = 0;
  bool acquired_ = false, started_ = false;
  std::mutex mutex_;
  std::condition_variable done_;
  std::deque<libcamera::Request*> completed_;
  bool lost_ = false;
};

}  // namespace

namespace detail {
std::unique_ptr<CameraSource> open_libcamera(const std::string& id, const std::string& spec, const SourceOptions& options) {
  return std::make_unique<LibcameraSource>(id, spec, options);
}
}  // namespace detail

}  // namespace lp
