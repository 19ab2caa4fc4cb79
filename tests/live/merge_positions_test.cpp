// merge --camera-positions --target (issue 20 item 4): each camera weighted by its
// distance to the point being lit (Nikodym et al. 2013, section 4), through the session's
// options and a merge of two live servers.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <thread>

#include <fmt/format.h>

#include "core/error.h"
#include "tests/core/test_files.h"
#include "eval/synthetic_scene.h"
#include "live/light_server.h"
#include "live/merge_client.h"
#include "live/merge_session.h"
#include "sampling/sampler.h"

namespace lp {
namespace {

using test_files::input_error;

MergeSessionOptions two_cameras() {
  MergeSessionOptions o;
  o.urls = {"http://a:1", "http://b:1"};
  o.camera_positions = {{0, 0, 0}, {1, 0, 0}};
  o.target = Vec3{0.25, 0, 0};
  return o;
}

TEST(MergePositions, WeightsComeFromWhereTheCamerasStandAndPositionsThatDoNotFitAreRefused) {
  std::string from;
  // 1/0.25^2 = 16 and 1/0.75^2 = 16/9: 0.9 and 0.1.
  const auto w = merge_session_weights(two_cameras(), &from);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_NEAR(w[0], 0.9, 1e-12);
  EXPECT_NEAR(w[1], 0.1, 1e-12);
  EXPECT_EQ(from, "camera positions");
  auto cubic = two_cameras();
  cubic.position_power = 3;  // 64 and 64/27: 27/28 and 1/28
  EXPECT_NEAR(merge_session_weights(cubic)[0], 27.0 / 28.0, 1e-12);

  MergeSessionOptions plain;
  plain.urls = {"http://a:1", "http://b:1"};
  EXPECT_TRUE(merge_session_weights(plain, &from).empty());
  EXPECT_EQ(from, "equal");
  auto no_target = two_cameras();
  no_target.target.reset();
  EXPECT_NE(input_error([&] { merge_session_weights(no_target); }).find("go together"), std::string::npos);
  auto three = two_cameras();
  three.urls.push_back("http://c:1");
  EXPECT_EQ(input_error([&] { merge_session_weights(three); }), "--camera-positions: 2 positions for 3 cameras");
  auto both = two_cameras();
  both.mqtt.merge.merge.weights = {1, 1};
  EXPECT_NE(input_error([&] { merge_session_weights(both); }).find("not both"), std::string::npos);
  auto topic = two_cameras();
  topic.subscribe = "mqtt://127.0.0.1:1883/studio/+/lights";
  EXPECT_NE(input_error([&] { merge_session_weights(topic); }).find("--subscribe"), std::string::npos);
}

// Two cameras see the same scene at different brightness (x1 and x3): the merge for a
// point a quarter of the way from the first is 0.9 x1 + 0.1 x3 = 1.2 times the first's
// power, where equal weights would give 2.
TEST(MergePositions, TwoLiveServersMergeWithTheWeightsOfTheirPositions) {
  SceneOptions bright;
  bright.sky_scale = 3;
  bright.sun_rgb = {600000.0, 540000.0, 450000.0};
  const LightList dim = sample(render_scene(describe_scene(), Layout::LatLong, 128, 64), 64, Method::Pharr);
  const LightList lit = sample(render_scene(describe_scene(bright), Layout::LatLong, 128, 64), 64, Method::Pharr);
  LightServerOptions so;
  so.port = 0;
  LightServer a(so), b(so);
  const int pa = a.start(), pb = b.start();
  a.publish(dim, nullptr);
  b.publish(lit, nullptr);
  MergeSessionOptions session = two_cameras();
  session.urls = {fmt::format("http://127.0.0.1:{}", pa), fmt::format("http://127.0.0.1:{}", pb)};
  MergeClientOptions mo;
  mo.poll_interval_s = 0.02;
  mo.timeout_s = 30;  // a loaded machine (ASan) must not drop a camera
  mo.merge.weights = merge_session_weights(session);
  std::atomic<bool> stop{false};
  std::atomic<double> ratio{0};
  std::thread client([&] {
    run_merge_client(session.urls, mo,
                     [&](const LightList& l, const MergeClientStatus& st) {
                       if (st.state.used.size() != 2) return;
                       ratio = luminance(total_power(l.lights).data()) / luminance(total_power(dim.lights).data());
                       stop = true;
                     },
                     stop);
  });
  for (int i = 0; i < 3000 && !stop; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  stop = true;
  client.join();
  a.stop();
  b.stop();
  EXPECT_NEAR(ratio.load(), 1.2, 1e-6);
}

}  // namespace
}  // namespace lp
