// The light server's pictures of the latest map: /probe.png (tone-mapped with an exposure
// smoothed over time, its lights drawn: sampling/overlay.h) and /probe.exr (the float map as core/image_io writes EXR:
// layout, units and nside in its header). Each is rendered lazily on a thread of its own
// (never on the server's loop), once per new map at most (the PNG at most max_png_rate
// times a second), cached, and given to every request that waits for it, with an ETag:
// a request whose If-None-Match holds it gets 304 and no body.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "core/envmap.h"
#include "core/light_list.h"
#include "live/http_server.h"

namespace lp {

// The newest published frame that carries a map.
struct MapFrame {
  uint64_t generation = 0;  // rises with every publish
  std::shared_ptr<const EnvMap> map;
  std::shared_ptr<const LightList> lights;
};

struct MapViewOptions {
  int png_width = 0;          // 0: the map's width for latlong (<= 1024), else 1024
  double max_png_rate = 4;    // PNG renders per second at most
  // The PNG's exposure adapts over this time constant (core/temporal_tonemap.h, timed by
  // the lists' timestamps), not per picture; 0: per picture (the same operator). Unseen
  // parts are hatched.
  double png_time_constant_s = 0.5;
  std::string etag_prefix;    // distinguishes this server's tags from an earlier run's
};

enum class MapView { Png, Exr };

class MapViews {
 public:
  explicit MapViews(MapViewOptions options);
  ~MapViews();  // stop()
  void start();
  // Ends the render thread; requests still waiting get 503.
  void stop();
  // Answers `ex` (now, or later from the render thread) with `view` of `frame`.
  void answer(MapView view, const MapFrame& frame, const HttpRequest& req, HttpExchange& ex);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace lp
