// Issue 18 item 1: the live chain's light lists carry the SH9 of their map, and GET /sh
// serves it as `lightprobe sh` writes sh.json, with an ETag. Through LightServer::answer
// (no socket) and a LivePipeline replaying maps of known content.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/light_list.h"
#include "core/spherical_harmonics.h"
#include "live/http_server.h"
#include "live/light_server.h"
#include "live/pipeline.h"

namespace lp {
namespace {

constexpr int kW = 64, kH = 32;

// A replay of latlong maps: frame i is a uniform sky of radiance (1 + i) (0.5, 1, 2) with
// one bright pixel, so that its SH has more than the constant band.
class MapReplay : public CameraSource {
 public:
  explicit MapReplay(int frames) : frames_(frames) {}
  std::string describe() const override { return "maps"; }
  void set_exposure_cycle(const std::vector<double>&) override {}
  bool finished() const override { return produced_ >= frames_; }
  std::optional<CameraFrame> next(double) override {
    if (produced_ >= frames_) return std::nullopt;
    const int i = produced_++;
    CameraFrame f;
    f.sequence = i;
    f.image.width = kW;
    f.image.height = kH;
    f.image.units = Units::Radiance;
    for (int p = 0; p < kW * kH; ++p)
      for (float c : {0.5f, 1.0f, 2.0f}) f.image.rgb.push_back(float(1 + i) * c);
    f.image.rgb[3 * (5 * kW + 9) + 1] += 500.0f;
    return f;
  }

 private:
  int frames_, produced_ = 0;
};

// Collects the one answer a handler gives.
class Answer final : public HttpExchange {
 public:
  void respond(HttpResponse r) override { response = std::move(r); }
  std::shared_ptr<HttpDeferred> defer() override { throw std::logic_error("not expected"); }
  std::shared_ptr<HttpStream> stream(HttpResponse, HttpStreamOptions) override { throw std::logic_error("not expected"); }
  Answer() { response.status = 0; }  // 0: no answer yet
  HttpResponse response;
  std::string body() const { return response.body ? *response.body : ""; }
  std::string header(const std::string& name) const {
    for (const auto& [k, v] : response.headers)
      if (k == name) return v;
    return "";
  }
};

Answer get(LightServer& server, const std::string& path, const std::string& if_none_match = "") {
  const std::string inm = if_none_match.empty() ? "" : "If-None-Match: " + if_none_match + "\r\n";
  const HttpHeadParse p = http_parse_head("GET " + path + " HTTP/1.1\r\nHost: x\r\n" + inm + "\r\n");
  EXPECT_TRUE(p.request) << path;
  Answer a;
  if (p.request) server.answer(*p.request, a);
  return a;
}

TEST(LiveSh, TheServerHandsOutProjectSh9OfThePublishedMapAsShJson) {
  LightServerOptions so;
  so.port = 0;
  LightServer server(so);
  EXPECT_EQ(get(server, "/sh").response.status, 503);  // nothing published yet

  LivePipelineOptions o;
  o.frames_are_maps = true;
  o.layout = Layout::LatLong;
  o.width = kW;
  o.height = kH;
  o.sampling.method = Method::Q2Tree;
  o.sampling.count = 12;
  o.queue_brackets = 100;  // nothing dropped
  std::mutex mutex;
  std::shared_ptr<const EnvMap> last_map;
  int64_t last_frame = -1;
  LivePipeline pipeline([] { return std::make_unique<MapReplay>(5); }, o,
                        [&](const LightList& list, std::shared_ptr<const EnvMap> map) {
                          server.publish(list, map);
                          std::lock_guard lock(mutex);
                          last_map = map;
                          last_frame = list.frame;
                        });
  pipeline.start();
  pipeline.wait();
  ASSERT_EQ(pipeline.stats().brackets_processed, 5u) << pipeline.stats().last_error;
  ASSERT_EQ(last_frame, 4);

  // /sh is byte for byte what `lightprobe sh MAP -o sh.json` writes for the last map.
  const Answer sh = get(server, "/sh");
  ASSERT_EQ(sh.response.status, 200) << sh.body();
  EXPECT_EQ(sh.response.content_type, "application/json");
  const Sh9 expected = project_sh9(*last_map);
  EXPECT_EQ(sh.body(), sh9_to_json(expected, Units::Radiance));
  Units units = Units::Relative;
  const Sh9 served = sh9_from_json(sh.body(), "GET /sh", &units);
  EXPECT_EQ(units, Units::Radiance);
  // An independent reference: a uniform sky of radiance c has L00 = c Y00 4 pi = 2 sqrt(pi) c,
  // and one extra pixel of value P and solid angle dw adds P Y_lm(d) dw.
  const size_t spot = 5 * kW + 9;
  const double dw = pixel_solid_angle(*last_map, spot);
  const auto y = sh9_basis(pixel_direction(*last_map, spot));
  for (int c = 0; c < 3; ++c) {
    const double uniform = 5.0 * std::array<double, 3>{0.5, 1, 2}[size_t(c)];
    const double spike = c == 1 ? 500.0 * dw : 0.0;
    EXPECT_NEAR(served.coefficients[0][size_t(c)], 2 * std::sqrt(M_PI) * uniform + spike * y[0], 1e-5 * uniform);
    // Band 1: zero for the uniform sky by symmetry; the spike alone.
    for (int k = 1; k < 4; ++k) EXPECT_NEAR(served.coefficients[size_t(k)][size_t(c)], spike * y[size_t(k)], 1e-5 * uniform);
  }

  // The list carries the same SH9, as the map's ("content": "map").
  const LightList list = light_list_from_json(get(server, "/lights").body(), "GET /lights");
  EXPECT_EQ(list.frame, 4);
  ASSERT_TRUE(list.sh9);
  EXPECT_EQ(list.sh9_content, Sh9Content::Map);
  for (int k = 0; k < kSh9Count; ++k)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(list.sh9->coefficients[size_t(k)][size_t(c)], expected.coefficients[size_t(k)][size_t(c)],
                  1e-12 * std::abs(expected.coefficients[0][size_t(c)]));
  // And /metrics times it as a stage of its own.
  EXPECT_NE(pipeline.metrics().find("lightprobe_stage_duration_seconds_count{stage=\"sh9\"} 5"), std::string::npos);
}

TEST(LiveSh, ShHasAnETagPollersGet304AndOnlyTheMapsShIsServed) {
  LightServerOptions so;
  so.port = 0;
  LightServer server(so);
  EnvMap map = make_latlong(16, 8);
  for (size_t i = 0; i < map.rgb.size(); ++i) map.rgb[i] = 0.25f + float(i % 7);
  LightList list;
  list.frame = 1;
  list.lights.push_back({5, {0, 0, 1}, {1, 1, 1}, 0.1});
  list.sh9 = project_sh9(map);
  list.sh9_content = Sh9Content::Map;
  server.publish(list, nullptr);

  const Answer first = get(server, "/sh");
  ASSERT_EQ(first.response.status, 200);
  const std::string etag = first.header("ETag");
  ASSERT_FALSE(etag.empty());
  EXPECT_EQ(first.header("Cache-Control"), "no-cache");
  EXPECT_NE(etag, get(server, "/lights").header("ETag"));  // a tag per route
  const Answer again = get(server, "/sh", etag);
  EXPECT_EQ(again.response.status, 304);
  EXPECT_EQ(again.body(), "");
  EXPECT_EQ(again.header("ETag"), etag);
  EXPECT_EQ(get(server, "/sh", "W/" + etag).response.status, 304);
  EXPECT_EQ(get(server, "/sh", "\"other\"").response.status, 200);

  // A new frame: a new tag, the full answer to the old one.
  list.frame = 2;
  list.sh9 = scaled(*list.sh9, 2);
  server.publish(list, nullptr);
  const Answer next = get(server, "/sh", etag);
  ASSERT_EQ(next.response.status, 200);
  EXPECT_NE(next.header("ETag"), etag);
  EXPECT_EQ(next.body(), sh9_to_json(*list.sh9, Units::Relative));

  // A residual is not the map's SH, and a list without SH has none: 404, not a wrong answer.
  list.sh9_content = Sh9Content::Residual;
  server.publish(list, nullptr);
  EXPECT_EQ(get(server, "/sh").response.status, 404);
  list.sh9.reset();
  server.publish(list, nullptr);
  EXPECT_EQ(get(server, "/sh").response.status, 404);
}

}  // namespace
}  // namespace lp
