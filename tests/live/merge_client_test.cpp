// lightprobe merge: two cameras' servers merged; one goes silent and is dropped.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include <fmt/format.h>
#include <cmath>
#include "core/error.h"

#include "eval/synthetic_scene.h"
#include "live/light_server.h"
#include "live/merge_client.h"
#include "sampling/sampler.h"

namespace lp {
namespace {

TEST(MergeClient, MergesTwoServersAndDropsOneThatGoesSilent) {
  const EnvMap map = render_scene(describe_scene(), Layout::LatLong, 128, 64);
  const LightList lights = sample(map, 64, Method::Q2Tree);
  LightServerOptions so;
  so.port = 0;
  LightServer a(so), b(so);
  const int pa = a.start(), pb = b.start();
  a.publish(lights, nullptr);
  b.publish(lights, nullptr);
  MergeClientOptions mo;
  mo.poll_interval_s = 0.02;
  mo.timeout_s = 0.3;
  mo.merge.n = 64;
  std::atomic<bool> stop{false};
  std::atomic<int> both{0}, one{0}, total{0};
  double power_error = 0;
  std::thread client([&] {
    run_merge_client({fmt::format("http://127.0.0.1:{}", pa), fmt::format("http://127.0.0.1:{}", pb)}, mo,
                     [&](const LightList& l, const MergeState& st) {
                       ++total;
                       if (st.used.size() == 2) ++both;
                       if (st.used.size() == 1) ++one;
                       if (!l.lights.empty())
                         power_error = std::max(power_error, std::fabs(total_power(l.lights)[1] / total_power(lights.lights)[1] - 1));
                     },
                     stop);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  b.stop();  // camera b goes away
  std::this_thread::sleep_for(std::chrono::milliseconds(900));
  stop = true;
  client.join();
  a.stop();
  EXPECT_GT(both.load(), 0);
  EXPECT_GT(one.load(), 0);  // b dropped, the output went on with a
  EXPECT_LT(power_error, 1e-9);  // merging identical cameras keeps the power
  EXPECT_THROW(run_merge_client({"ftp://x"}, mo, [](const LightList&, const MergeState&) {}, stop), InputError);
}

}  // namespace
}  // namespace lp
