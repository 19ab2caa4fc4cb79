// Load and soak, bounded: clients hammer /lights and /lights/stream on loopback while the
// fake camera streams through the full pipeline; the pipeline keeps its frame rate, no
// request fails, no bracket is mixed, memory does not grow.
#include <gtest/gtest.h>
#include <httplib.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "live/light_server.h"
#include "live/pipeline.h"

namespace lp {
namespace {

long resident_kb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return 0;
}

TEST(Load, ClientsHammeringTheServerDoNotStallThePipeline) {
  LightServerOptions so;
  so.port = 0;
  LightServer server(so);
  LivePipelineOptions o;
  o.exposure_cycle = {0.0002, 0.002, 0.02};
  o.sampling.method = Method::Q2Tree;
  o.sampling.count = 128;
  SourceOptions src;
  LivePipeline p([&] { return open_source("aravis:Fake_1", src); }, o,
                 [&](const LightList& l, std::shared_ptr<const EnvMap> m) { server.publish(l, m); });
  const int port = server.start();
  p.start();
  std::this_thread::sleep_for(std::chrono::seconds(1));  // warm up
  const long rss_before = resident_kb();
  const uint64_t processed_before = p.stats().brackets_processed;

  std::atomic<bool> stop{false};
  std::atomic<long> ok{0}, failed{0};
  std::vector<std::thread> clients;
  for (int c = 0; c < 4; ++c)
    clients.emplace_back([&] {
      httplib::Client cl("127.0.0.1", port);
      cl.set_read_timeout(2, 0);
      for (int i = 0; i < 100000 && !stop; ++i) {
        auto r = cl.Get("/lights");
        (r && r->status == 200 ? ok : failed)++;
      }
    });
  // A stream client that reads, too.
  std::atomic<long> streamed{0};
  std::thread streamer([&] {
    httplib::Client cl("127.0.0.1", port);
    cl.set_read_timeout(3, 0);
    cl.Get("/lights/stream?format=ndjson", [&](const char* data, size_t n) {
      for (size_t i = 0; i < n; ++i) streamed += data[i] == '\n';
      return !stop.load();
    });
  });
  const auto t0 = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(std::chrono::seconds(4));
  stop = true;
  for (auto& t : clients) t.join();
  streamer.join();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const LiveStats s = p.stats();
  const double pipeline_fps = double(s.brackets_processed - processed_before) / seconds;
  const long rss_after = resident_kb();
  p.stop();
  server.stop();
  // Frames of a bracket still being assembled or queued are unaccounted while running:
  // the books balance once the pipeline has stopped.
  const LiveStats final_stats = p.stats();
  std::printf("load: %.0f requests/s on /lights (%ld ok, %ld failed), %ld lists streamed, pipeline %.1f brackets/s, "
              "RSS %ld -> %ld kB\n",
              double(ok) / seconds, ok.load(), failed.load(), streamed.load(), pipeline_fps, rss_before, rss_after);
  EXPECT_EQ(failed.load(), 0);
  EXPECT_GT(ok.load(), 100);
  EXPECT_GT(streamed.load(), 5);
  EXPECT_GT(pipeline_fps, 2.0);  // the fake camera brackets at ~8/s; requests must not stop the back end
  EXPECT_EQ(final_stats.frames_in,
            3 * (final_stats.brackets_processed + final_stats.brackets_dropped) + final_stats.frames_dropped_partial);
  EXPECT_LT(rss_after - rss_before, 64 * 1024);  // no growth beyond caches (64 MB)
}

}  // namespace
}  // namespace lp
