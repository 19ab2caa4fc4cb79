// The whole chain from Aravis' in-process fake camera (a simulated bracketing camera) to
// the light server, as `lightprobe stream --source aravis:Fake_1` runs it.
#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "core/error.h"
#include "live/light_server.h"
#include "live/pipeline.h"
#include "live/stream_session.h"
#include <nlohmann/json.hpp>

namespace lp {
namespace {

TEST(Stream, TheFakeCameraIsFusedUnwrappedSampledAndServed) {
  LightServerOptions so;
  so.port = 0;
  LightServer server(so);
  LivePipelineOptions o;
  o.exposure_cycle = {0.0002, 0.002, 0.02};  // a 3-exposure bracket, 3.3 stops apart
  o.sampling.method = Method::Q2Tree;  // region powers: the sun's leaf is the brightest light
  o.sampling.count = 64;
  o.sampling.sampler.upper_only = true;
  SourceOptions src;
  LivePipeline p([&] { return open_source("aravis:Fake_1", src); }, o,
                 [&](const LightList& l, std::shared_ptr<const EnvMap> m) { server.publish(l, m); });
  const int port = server.start();
  p.start();
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(2, 0);
  int status = 0;
  std::string body;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    auto r = client.Get("/lights");
    if (r && r->status == 200) {
      status = r->status;
      body = r->body;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  server.publish_metrics(p.metrics());
  auto metrics = client.Get("/metrics");
  p.stop();
  ASSERT_EQ(status, 200) << "no lights within 20 s; last error: " << p.stats().last_error;
  const LightList list = light_list_from_json(body, "/lights");
  EXPECT_GE(list.lights.size(), 62u);
  // The fake paints a sun at 50 deg elevation: the brightest light is there (z = sin 50).
  const Light* brightest = &list.lights[0];
  for (const Light& l : list.lights)
    if (l.luminance() > brightest->luminance()) brightest = &l;
  EXPECT_NEAR(brightest->direction.z, std::sin(50 * M_PI / 180), 0.1);
  const LiveStats s = p.stats();
  EXPECT_GT(s.brackets_processed, 0u);
  EXPECT_EQ(s.frames_in, 3 * (s.brackets_processed + s.brackets_dropped) + s.frames_dropped_partial);
  ASSERT_TRUE(metrics);
  EXPECT_NE(metrics->body.find("lightprobe_frames_in_total"), std::string::npos);
}

// The page's operator view reads the camera and its brackets from /status ("pipeline").
TEST(StreamSession, PipelineStatusSaysWhetherTheCameraDeliversAndCountsItsBrackets) {
  LiveStats st;
  st.frames_in = 31;
  st.brackets_processed = 9;
  st.brackets_dropped = 1;
  st.frames_dropped_partial = 1;
  st.reconnects = 2;
  st.last_error = "camera lost: gone";
  const nlohmann::json live = pipeline_status_json(st, "aravis:Fake_1", 0.3);
  EXPECT_EQ(live["camera_state"], "streaming");
  EXPECT_EQ(live["source"], "aravis:Fake_1");
  EXPECT_EQ(live["frames_in"], 31);
  EXPECT_EQ(live["brackets_processed"], 9);
  EXPECT_EQ(live["brackets_dropped"], 1);
  EXPECT_EQ(live["frames_dropped_partial"], 1);
  EXPECT_EQ(live["reconnects"], 2);
  EXPECT_EQ(live["last_error"], "camera lost: gone");
  EXPECT_EQ(pipeline_status_json(st, "aravis:Fake_1", 1.99)["camera_state"], "streaming");
  EXPECT_EQ(pipeline_status_json(st, "aravis:Fake_1", 7.4)["camera_state"], "no frame for 7 s");
  // A replay paced at 0.4 fps is streaming 2.5 s after its last frame, not lost.
  EXPECT_EQ(pipeline_status_json(st, "replay:maps", 2.5, 7.5)["camera_state"], "streaming");
}

}  // namespace
}  // namespace lp
