// stream --n auto --target-error (issue 20 item 2): the live back end picks the fewest
// lights within the target per frame, with the offline mode's hysteresis, and reports the
// count, its error and its changes (stats, /status section "light_count", metrics).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <mutex>

#include <unistd.h>

#include "core/accuracy.h"
#include "core/image_io.h"
#include "eval/synthetic_scene.h"
#include "live/pipeline.h"
#include "live/stream_session.h"
#include "sampling/auto_count.h"

namespace fs = std::filesystem;

namespace lp {
namespace {

TEST(LiveAutoCount, TheStreamKeepsTheFewestLightsWithinTheTargetAndReportsThem) {
  const EnvMap map = render_scene(describe_scene(), Layout::Hemisphere, 180, 45);
  const fs::path dir = fs::path(::testing::TempDir()) / ("lightprobe_live_auto_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (int f = 0; f < 12; ++f) write_envmap((dir / ("map" + std::to_string(10 + f) + ".exr")).string(), map);

  LivePipelineOptions o;
  o.frames_are_maps = true;
  o.width = 180;
  o.height = 45;
  o.sampling.method = Method::Pharr;
  o.sampling.sampler.upper_only = true;
  o.sampling.auto_count = true;
  o.sampling.auto_options.target_error = 0.02;
  o.queue_brackets = 16;
  std::mutex m;
  std::vector<LightList> lists;
  LivePipeline p([&] { return open_source("replay:" + dir.string()); }, o,
                 [&](const LightList& l, std::shared_ptr<const EnvMap>) {
                   std::lock_guard<std::mutex> lock(m);
                   lists.push_back(l);
                 });
  p.start();
  p.wait();
  const LiveStats s = p.stats();
  ASSERT_EQ(lists.size(), 12u) << s.last_error;

  // The reference: the same search on the map, by the library, from a fresh sampler.
  AccuracyOptions ao;
  ao.shadowed = false;
  const AccuracyReference reference = make_accuracy_reference(map, ao);
  SamplerOptions so;
  so.upper_only = true;
  auto sampler = make_sampler(Method::Pharr, so);
  sampler->prepare(map);
  const AutoCountResult offline = choose_light_count(*sampler, reference, o.sampling.auto_options);
  ASSERT_TRUE(offline.reached);
  EXPECT_TRUE(s.auto_count);
  EXPECT_EQ(s.lights, offline.count);
  EXPECT_EQ(s.count_changes, 0u);  // a still scene: the hysteresis holds the count
  EXPECT_NEAR(s.count_error, offline.error, 1e-12);
  EXPECT_LE(s.count_error, 0.02);
  for (const LightList& l : lists) {
    EXPECT_EQ(int(l.lights.size()), offline.count);
    EXPECT_LE(light_error(reference, l.lights).diffuse, 0.02);
  }
  const nlohmann::json j = light_count_json(s);
  EXPECT_EQ(j["mode"], "auto");
  EXPECT_EQ(j["lights"], offline.count);
  EXPECT_EQ(j["target_error"], 0.02);
  EXPECT_EQ(j["measure"], "diffuse");
  EXPECT_NE(p.metrics().find("lightprobe_lights " + std::to_string(offline.count)), std::string::npos);
  EXPECT_NE(p.metrics().find("lightprobe_light_error_target 0.02"), std::string::npos) << p.metrics();
  EXPECT_EQ(p.metrics().find("lightprobe_light_budget_cap"), std::string::npos);  // no budget, no gauge
  fs::remove_all(dir);
}

// /status's light_count section with a frame budget: the budget, its cap and whether it held
// the count down are shown; without one, no budget keys at all.
TEST(LiveAutoCount, StatusShowsTheFrameBudgetOnlyWhenOneIsSet) {
  LiveStats s;
  s.auto_count = true;
  s.lights = 16;
  EXPECT_FALSE(light_count_json(s).contains("frame_budget_ms"));
  s.count_budget_ms = 5;
  s.count_budget_cap = 16;
  s.count_budget_limited = true;
  const nlohmann::json j = light_count_json(s);
  EXPECT_EQ(j["frame_budget_ms"], 5.0);
  EXPECT_EQ(j["budget_cap"], 16);
  EXPECT_EQ(j["budget_limited"], true);
}

}  // namespace
}  // namespace lp
