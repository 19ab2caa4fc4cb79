// lightprobe merge: two cameras' servers merged; one goes silent and is dropped; servers
// of different methods and servers that send lists that cannot be merged (issue 22).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "eval/synthetic_scene.h"
#include "live/http_server.h"
#include "live/light_server.h"
#include "live/merge_client.h"
#include "sampling/sampler.h"

namespace lp {
namespace {

double lum_total(const LightList& l) {
  const auto p = total_power(l.lights);
  return luminance(p.data());
}

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
                     [&](const LightList& l, const MergeClientStatus& st) {
                       ++total;
                       if (st.state.used.size() == 2) ++both;
                       if (st.state.used.size() == 1) ++one;
                       if (!l.lights.empty())
                         power_error = std::max(power_error, std::fabs(lum_total(l) / lum_total(lights) - 1));
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
  EXPECT_THROW(run_merge_client({"ftp://x"}, mo, [](const LightList&, const MergeClientStatus&) {}, stop), InputError);
  EXPECT_THROW(run_merge_client({"http://x:99999"}, mo, [](const LightList&, const MergeClientStatus&) {}, stop),
               InputError);
}

// Issue 22: `merge` of a q2tree and a pharr stream died with "terminate called without
// an active exception"; so did an upstream with "lights": [], and 1e308 came out as NaN.
// Now: different methods merge by direction, bad upstreams are skipped with the reason
// (in the status and in the metrics), and the merge goes on.
TEST(MergeClient, DifferentMethodsMergeAndBadUpstreamsAreSkippedWithTheReason) {
  const EnvMap map = render_scene(describe_scene(), Layout::LatLong, 128, 64);
  const LightList q = sample(map, 64, Method::Q2Tree), p = sample(map, 64, Method::Pharr);
  LightList empty = q;
  empty.lights.clear();
  LightList huge = p;
  huge.lights[0].rgb = {1e308, 1e308, 1e308};
  LightList negative = p;
  negative.lights[1].rgb[0] = -1;
  LightServerOptions so;
  so.port = 0;
  std::vector<std::unique_ptr<LightServer>> servers;
  std::vector<std::string> urls;
  for (const LightList* l : std::vector<const LightList*>{&q, &p, &empty, &huge, &negative}) {
    servers.push_back(std::make_unique<LightServer>(so));
    urls.push_back(fmt::format("http://127.0.0.1:{}", servers.back()->start()));
    servers.back()->publish(*l, nullptr);
  }
  // One upstream that answers 200 with something that is not a light list, and bytes
  // that are not UTF-8.
  HttpServer garbage({}, [](const HttpRequest&, HttpExchange& ex) {
    HttpResponse r;
    r.set_body("{\"format\": \"\xff\xfe\", \"lights\": [", "application/json");
    ex.respond(std::move(r));
  });
  urls.push_back(fmt::format("http://127.0.0.1:{}", garbage.start()));

  MergeClientOptions mo;
  mo.poll_interval_s = 0.02;
  mo.merge.n = 64;
  std::atomic<bool> stop{false};
  std::mutex mutex;
  MergeClientStatus last;
  LightList last_list;
  int published = 0;
  std::thread client([&] {
    run_merge_client(urls, mo,
                     [&](const LightList& l, const MergeClientStatus& st) {
                       std::lock_guard lock(mutex);
                       last = st;
                       last_list = l;
                       ++published;
                     },
                     stop);
  });
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < deadline) {
    {
      std::lock_guard lock(mutex);
      if (published >= 5) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  stop = true;
  client.join();
  std::lock_guard lock(mutex);
  ASSERT_GE(published, 5);
  EXPECT_EQ(last.mode, "direction");
  EXPECT_EQ(last.state.used, (std::vector<std::string>{urls[0], urls[1]}));
  ASSERT_EQ(last.inputs.size(), 6u);
  const std::vector<std::string> reasons{"", "", "empty", "too_bright", "negative", "malformed"};
  for (size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(last.inputs[i].state, i < 2 ? "used" : "skipped") << urls[i];
    EXPECT_EQ(last.inputs[i].reason, reasons[i]) << urls[i];
    if (i >= 2) {
      EXPECT_GE(last.inputs[i].skipped.at(reasons[i]), 5u) << urls[i];
    }
  }
  EXPECT_NEAR(lum_total(last_list), 0.5 * (lum_total(q) + lum_total(p)), 1e-9 * lum_total(q));
  for (const Light& l : last_list.lights) ASSERT_NEAR(length(l.direction), 1.0, 1e-12);
  // The reasons in /status (JSON) and /metrics (Prometheus).
  const auto j = nlohmann::json::parse(merge_status_json(last));
  EXPECT_EQ(j["inputs"][3]["reason"], "too_bright");
  EXPECT_EQ(j["inputs"][5]["reason"], "malformed");
  const std::string metrics = merge_metrics_text(last);
  EXPECT_NE(metrics.find(fmt::format("lightprobe_merge_input_skipped_total{{input=\"{}\",reason=\"empty\"}}", urls[2])),
            std::string::npos)
      << metrics;
  EXPECT_NE(metrics.find("lightprobe_merge_inputs_used 2\n"), std::string::npos) << metrics;
  for (auto& s : servers) s->stop();
  garbage.stop();
}

}  // namespace
}  // namespace lp
