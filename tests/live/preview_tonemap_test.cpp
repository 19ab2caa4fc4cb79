// Issue 18 item 4: /probe.png's exposure is smoothed over time (Havran et al. 2005 §5,
// core/temporal_tonemap.h) and its unseen parts are hatched. An abrupt switch: a lamp at
// the zenith turns on at frame kSwitch and the map's luminance power jumps 10x. The lights
// follow at once; the preview's unchanged sky darkens by a bounded step per frame and
// settles within the stated 4.61 time constants, where a per-picture exposure (time
// constant 0, the preview before) jumps in one frame.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "core/image_io.h"
#include "core/temporal_tonemap.h"
#include "core/tonemap.h"
#include "live/light_server.h"
#include "sampling/frame_pipeline.h"
#include "tests/live/http_attack.h"

namespace lp {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int kW = 64, kH = 16;  // hemisphere map; the preview is kPw x kPh latlong
constexpr int kPw = 2 * kW, kPh = kW;
constexpr int kSwitch = 5, kFrames = kSwitch + 55;
constexpr double kFps = 21, kTau = 0.5;

// The upper hemisphere: a sky of luminance 0.5..1 (brighter towards the horizon), and from
// frame kSwitch on a lamp over its two top rows carrying 9 x the sky's power.
std::shared_ptr<const EnvMap> frame_map(int frame) {
  auto map = std::make_shared<EnvMap>(make_hemisphere(kW, kH));
  for (size_t i = 0; i < map->pixel_count(); ++i) {
    const float y = 0.5f + 0.5f * float(i / kW) / float(kH);
    for (int c = 0; c < 3; ++c) map->pixel(i)[c] = y;
  }
  if (frame >= kSwitch) {
    const double sky = total_luminance_power(*map);
    double lamp_sr = 0;
    for (size_t i = 0; i < 2 * kW; ++i) lamp_sr += pixel_solid_angle(*map, i);
    for (size_t i = 0; i < 2 * kW; ++i)
      for (int c = 0; c < 3; ++c) map->pixel(i)[c] += float(9 * sky / lamp_sr);
  }
  return map;
}

struct Preview {
  std::vector<float> codes;  // kPw x kPh RGB code values in [0, 1]
  float green(int u, int v) const { return codes[3 * (size_t(v) * kPw + size_t(u)) + 1]; }
  double mean(int row0, int row1) const {
    double s = 0;
    for (int v = row0; v < row1; ++v)
      for (int u = 0; u < kPw; ++u) s += green(u, v);
    return s / double((row1 - row0) * kPw);
  }
};

// Publishes every frame (timestamps 1/21 s apart) and fetches the preview of each.
std::vector<Preview> previews(double time_constant_s) {
  LightServerOptions o;
  o.host = "127.0.0.1";
  o.port = 0;
  o.preview_width = kPw;
  o.preview_max_rate = 1e6;  // a picture per frame
  o.preview_time_constant_s = time_constant_s;
  LightServer server(o);
  const int port = server.start();
  const std::string file = ::testing::TempDir() + fmt::format("/preview_{}.png", port);
  std::vector<Preview> out;
  for (int i = 0; i < kFrames; ++i) {
    LightList list;  // no lights: the picture is the map alone
    list.frame = i;
    list.timestamp = 1.7e9 + i / kFps;
    server.publish(list, frame_map(i));
    // Until the picture of this publish (generation i + 1) comes; a cached one is older.
    const std::string want = fmt::format("-p{}\"", i + 1);
    const auto deadline = Clock::now() + std::chrono::seconds(30);
    test::RawAnswer a;
    do {
      a = test::raw_request(port, "GET /probe.png HTTP/1.1\r\nHost: x\r\n\r\n", 10);
      if (test::header_of(a.answer, "ETag").find(want) != std::string::npos) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    } while (Clock::now() < deadline);
    EXPECT_EQ(a.status, 200);
    EXPECT_NE(test::header_of(a.answer, "ETag").find(want), std::string::npos) << "frame " << i;
    write_file_atomically(file, test::body_of(a.answer));
    const RgbImage png = read_rgb_image(file);
    EXPECT_EQ(png.width, kPw);
    EXPECT_EQ(png.height, kPh);
    out.push_back({png.rgb});
  }
  std::remove(file.c_str());
  server.stop();
  return out;
}

TEST(PreviewToneMap, AnAbruptSwitchChangesTheLightsAtOnceAndThePreviewSmoothly) {
  // The lights: the sampler's total power jumps 10x from one frame to the next.
  FramePipelineOptions fo;
  fo.method = Method::Q2Tree;
  fo.count = 16;
  FramePipeline sampler(fo);
  const double before = total_power(sampler.process(*frame_map(kSwitch - 1), 0, 0).lights)[1];
  const double after = total_power(sampler.process(*frame_map(kSwitch), 1, 1 / kFps).lights)[1];
  EXPECT_NEAR(after / before, 10.0, 1e-3);

  // The per-frame exposure target steps by r; the filter moves by at most alpha of it.
  const double r = frame_tone_parameters(image_view(*frame_map(kSwitch))).exposure() /
                   frame_tone_parameters(image_view(*frame_map(kSwitch - 1))).exposure();
  ASSERT_LT(r, 0.5);  // the lamp darkens the exposure: the case where a preview pumps
  const double alpha = 1 - std::exp(-1 / (kFps * kTau));
  const double quantum = 0.01;  // 8-bit codes: log steps of ~1/255 over codes ~0.4

  const std::vector<Preview> smooth = previews(kTau), per_picture = previews(0);
  ASSERT_EQ(smooth.size(), size_t(kFrames));
  // The sky (preview rows 8..27, 22.5 to 78.75 deg from the zenith: away from the lamp's
  // 11.25 deg cap, rows 0..3, and the horizon) never changes in the map; its picture may
  // only follow the exposure.
  std::vector<double> sky, sky_now;
  for (int i = 0; i < kFrames; ++i) {
    sky.push_back(smooth[size_t(i)].mean(8, 28));
    sky_now.push_back(per_picture[size_t(i)].mean(8, 28));
  }
  // Per frame the exposure moves by at most a factor r^alpha, and a code by no more than
  // the exposure (kY / (1 + kY) and the sRGB curve both grow slower than linearly).
  double worst = 0;
  for (int i = 1; i < kFrames; ++i) worst = std::max(worst, std::abs(std::log(sky[size_t(i)] / sky[size_t(i - 1)])));
  EXPECT_LE(worst, alpha * std::abs(std::log(r)) + quantum);
  // A per-picture exposure (time constant 0) pumps: the whole step in one frame.
  const double jump = std::abs(std::log(sky_now[kSwitch] / sky_now[kSwitch - 1]));
  EXPECT_GT(jump, 3 * (alpha * std::abs(std::log(r)) + quantum));
  EXPECT_GT(worst, 0.5 * alpha * jump);  // the smoothed one does adapt, a step at a time
  // Settled within 4.61 tau (49 frames at 21 fps): within 1 % of the step (in log) of the
  // per-picture exposure's view of the same frame.
  const int settled = kSwitch + int(std::ceil(4.61 * kTau * kFps));
  ASSERT_LT(settled, kFrames);
  EXPECT_LE(std::abs(std::log(sky[size_t(settled)] / sky_now[size_t(settled)])), 0.01 * std::abs(std::log(r)) + quantum);
  // Not before: 10 frames after the switch it is still on its way.
  EXPECT_GT(std::abs(std::log(sky[kSwitch + 10] / sky_now[kSwitch + 10])), 0.2 * jump);
  std::printf("preview_tonemap: exposure step %.3f (log), per-picture sky jump %.3f (log code), smoothed: worst "
              "frame %.3f (bound %.3f), 10 frames on %.3f, %d frames on %.4f\n",
              std::log(r), jump, worst, alpha * std::abs(std::log(r)) + quantum,
              std::log(sky[kSwitch + 10] / sky_now[kSwitch + 10]), settled - kSwitch,
              std::log(sky[size_t(settled)] / sky_now[size_t(settled)]));
  // Before the switch both agree (the first frame sets the state).
  EXPECT_NEAR(sky[kSwitch - 1], sky_now[kSwitch - 1], 1e-6);

  // The lower hemisphere, never seen, is hatched: two grey levels on diagonals, none black.
  const Preview& p = smooth.back();
  const float line = float(srgb_code(0.35f)) / 255, ground = float(srgb_code(0.07f)) / 255;
  int lines = 0, grounds = 0;
  const int first = kPh / 2 + 2;  // below the horizon, clear of its resampled edge
  for (int v = first; v < kPh; ++v)
    for (int u = 0; u < kPw; ++u) {
      const float g = p.green(u, v);
      lines += std::abs(g - line) < 1e-3f;
      grounds += std::abs(g - ground) < 1e-3f;
      if (u + 1 < kPw && v > first) {  // constant along the diagonals u + v = const
        EXPECT_EQ(g, p.green(u + 1, v - 1)) << u << "," << v;
      }
    }
  EXPECT_EQ(lines + grounds, (kPh - first) * kPw);
  EXPECT_GT(lines, 0);
  EXPECT_GT(grounds, lines);
}

}  // namespace
}  // namespace lp
