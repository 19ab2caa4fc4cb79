#include "live/map_views.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "core/image_io.h"
#include "core/image_view.h"
#include "core/picture_io.h"
#include "core/temporal_tonemap.h"
#include "sampling/overlay.h"

namespace lp {
namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* kCacheControl = "no-cache";  // keep it, but ask (If-None-Match) every time

// One view's cache and the requests waiting for it (under Impl::mutex).
struct Cached {
  Cached(const char* type, char t, double rate) : content_type(type), tag(t), max_rate(rate) {}
  const char* content_type;
  char tag;
  double max_rate;  // renders per second at most; 0: every new map
  uint64_t generation = 0;
  Clock::time_point time{};
  std::shared_ptr<const std::string> body;
  std::string etag;
  struct Waiter {
    std::shared_ptr<HttpDeferred> answer;
    std::optional<std::string> if_none_match;
  };
  std::vector<Waiter> waiting;
  MapFrame frame;  // the newest frame asked for

  bool fresh(uint64_t g, Clock::time_point now) const {
    if (!body) return false;
    if (generation == g || max_rate <= 0) return generation == g;
    return now - time < std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / max_rate));
  }
  HttpResponse response(const std::string* if_none_match) const {
    if (http_etag_matches(if_none_match, etag)) return http_not_modified(etag, kCacheControl);
    HttpResponse r;
    r.body = body;
    r.content_type = content_type;
    r.headers = {{"ETag", etag}, {"Cache-Control", kCacheControl}};
    return r;
  }
};

}  // namespace

struct MapViews::Impl {
  MapViewOptions options;
  std::mutex mutex;
  std::condition_variable cv;
  std::thread thread;
  bool quit = false, running = false;
  Cached png{"image/png", 'p', 4}, exr{"image/x-exr", 'e', 0};
  // The PNG's exposure over time; only the render thread touches these.
  std::optional<TemporalToneMapper> tone;
  double tone_time = NAN;  // timestamp of the list the exposure was last adapted to

  std::shared_ptr<const std::string> render(Cached& c, const MapFrame& f) {
    if (&c == &exr) return std::make_shared<const std::string>(encode_envmap_exr(*f.map));
    const EnvMap& map = *f.map;
    int width = options.png_width;
    if (width <= 0) width = map.layout == Layout::LatLong ? std::min(map.width, 1024) : 1024;
    width = std::max(2, width - width % 2);
    static const std::vector<Light> none;
    OverlayOptions o;
    o.unseen = UnseenStyle::Hatch;
    if (tone) {
      const double t = f.lights ? f.lights->timestamp : NAN;
      o.exposure = tone->update(image_view(map), t - tone_time).exposure();
      tone_time = t;
    }
    const std::vector<float> rgb = render_overlay(map, f.lights ? f.lights->lights : none, width, o);
    return std::make_shared<const std::string>(encode_display_png(width, width / 2, rgb));
  }

  // Renders what is waiting, answers the waiters; the lock is released while rendering.
  void serve(Cached& c, std::unique_lock<std::mutex>& lock) {
    auto waiting = std::move(c.waiting);
    c.waiting.clear();
    const MapFrame f = c.frame;
    if (!c.fresh(f.generation, Clock::now()) && f.map) {
      lock.unlock();
      std::shared_ptr<const std::string> body;
      try {
        body = render(c, f);
      } catch (const std::exception&) {
        // The waiters get 500 (their promises die unkept).
      }
      lock.lock();
      if (!body) return;
      c.body = body;
      c.generation = f.generation;
      c.time = Clock::now();
      c.etag = fmt::format("\"{}-{}{}\"", options.etag_prefix, c.tag, f.generation);
    }
    for (auto& w : waiting) w.answer->send(c.response(w.if_none_match ? &*w.if_none_match : nullptr));
  }

  void loop() {
    std::unique_lock lock(mutex);
    while (true) {
      cv.wait(lock, [&] { return quit || !png.waiting.empty() || !exr.waiting.empty(); });
      if (quit) break;
      if (!png.waiting.empty()) serve(png, lock);
      if (!exr.waiting.empty()) serve(exr, lock);
    }
    for (Cached* c : {&png, &exr}) {
      for (auto& w : c->waiting) {
        HttpResponse r;
        r.status = 503;
        r.set_body(http_error_json("server is stopping"), "application/json");
        w.answer->send(r);
      }
      c->waiting.clear();
    }
  }
};

MapViews::MapViews(MapViewOptions options) : impl_(std::make_unique<Impl>()) {
  impl_->options = std::move(options);
  impl_->png.max_rate = impl_->options.max_png_rate > 0 ? impl_->options.max_png_rate : 4;
  TemporalToneMapOptions t;  // time constant 0: the same operator, adapted per picture
  t.time_constant_s = std::max(0.0, impl_->options.png_time_constant_s);
  impl_->tone.emplace(t);
}

MapViews::~MapViews() { stop(); }

void MapViews::start() {
  std::lock_guard lock(impl_->mutex);
  if (impl_->running) return;
  impl_->running = true;
  impl_->quit = false;
  impl_->thread = std::thread([this] { impl_->loop(); });
}

void MapViews::stop() {
  if (!impl_) return;
  {
    std::lock_guard lock(impl_->mutex);
    if (!impl_->running) return;
    impl_->quit = true;
    impl_->running = false;
  }
  impl_->cv.notify_all();
  if (impl_->thread.joinable()) impl_->thread.join();
}

void MapViews::answer(MapView view, const MapFrame& frame, const HttpRequest& req, HttpExchange& ex) {
  Impl& s = *impl_;
  Cached& c = view == MapView::Png ? s.png : s.exr;
  std::lock_guard lock(s.mutex);
  if (c.fresh(frame.generation, Clock::now()) || !frame.map) {
    if (!c.body) {
      HttpResponse r;
      r.status = 503;
      r.set_body(http_error_json("no map published yet"), "application/json");
      r.headers.emplace_back("Retry-After", "1");
      return ex.respond(std::move(r));
    }
    return ex.respond(c.response(req.header("if-none-match")));
  }
  if (frame.generation >= c.frame.generation) c.frame = frame;
  const std::string* inm = req.header("if-none-match");
  c.waiting.push_back({ex.defer(), inm ? std::optional<std::string>(*inm) : std::nullopt});
  s.cv.notify_one();
}

}  // namespace lp
