// The light server (issue 8): routes, streaming with slow clients, limits, the token.
// Every server listens on 127.0.0.1 on a free port and is stopped by its test; every
// request loop is bounded in count and time.
#include "live/light_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <httplib.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <fstream>
#include <iterator>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/image_io.h"
#include "core/light_list.h"
#include "live/web_assets.h"
#include "tests/live/http_attack.h"

namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

lp::LightList make_list(int64_t frame, int n_lights) {
  lp::LightList list;
  list.frame = frame;
  list.timestamp = 1700000000.0 + 0.04 * double(frame);
  list.method = "q2tree";
  for (int i = 0; i < n_lights; ++i) {
    lp::Light light;
    light.id = uint64_t(100 + i);
    const double phi = 0.7 * i + 0.01 * double(frame), z = 0.9 - 1.8 * (i + 0.5) / n_lights;
    const double r = std::sqrt(1 - z * z);
    light.direction = {r * std::cos(phi), r * std::sin(phi), z};
    light.rgb = {1.0 + i, 0.5 + 0.25 * i, 0.125 * (i + 1)};
    light.solid_angle = 0.01 * (i + 1);
    list.lights.push_back(light);
  }
  return list;
}

std::shared_ptr<const lp::EnvMap> make_map() {
  auto map = std::make_shared<lp::EnvMap>(lp::make_latlong(64, 32));
  for (size_t i = 0; i < map->pixel_count(); ++i) {
    float* p = map->pixel(i);
    p[0] = 0.2f + 0.001f * float(i % 64);
    p[1] = 0.3f;
    p[2] = 0.5f + (i == 300 ? 100.0f : 0.0f);
  }
  return map;
}

struct Running {
  std::unique_ptr<lp::LightServer> server;
  int port = 0;
};

Running start_server(lp::LightServerOptions options = {}) {
  options.host = "127.0.0.1";
  options.port = 0;
  Running r;
  r.server = std::make_unique<lp::LightServer>(options);
  r.port = r.server->start();
  return r;
}

std::unique_ptr<httplib::Client> client(int port) {
  auto c = std::make_unique<httplib::Client>("127.0.0.1", port);
  c->set_connection_timeout(5, 0);
  c->set_read_timeout(10, 0);
  c->set_write_timeout(10, 0);
  return c;
}

// The value of an unlabelled Prometheus sample, NaN when absent.
double metric(const std::string& text, const std::string& name) {
  size_t pos = 0;
  while ((pos = text.find(name + " ", pos)) != std::string::npos) {
    if (pos == 0 || text[pos - 1] == '\n') return std::stod(text.substr(pos + name.size() + 1));
    pos += name.size();
  }
  return NAN;
}

// Waits (bounded) until pred() holds.
template <class Pred>
bool eventually(Pred pred, std::chrono::milliseconds limit = 5000ms) {
  const auto deadline = Clock::now() + limit;
  while (Clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::sleep_for(5ms);
  }
  return pred();
}

// A raw connection to the server on 127.0.0.1, for what httplib::Client will not send.
int raw_connect(int port, int rcvbuf = 0) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  if (rcvbuf > 0) ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
  timeval tv{5, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(uint16_t(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// Sends `request` as is and returns the status code of the answer (0 when none came).
int raw_status(int port, const std::string& request) {
  const int fd = raw_connect(port);
  if (fd < 0) return 0;
  size_t sent = 0;
  while (sent < request.size()) {
    const ssize_t n = ::send(fd, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;
    sent += size_t(n);
  }
  std::string answer;
  char buf[4096];
  for (int i = 0; i < 100 && answer.find("\r\n") == std::string::npos; ++i) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    answer.append(buf, size_t(n));
  }
  ::close(fd);
  if (answer.rfind("HTTP/1.", 0) != 0 || answer.size() < 12) return 0;
  return std::stoi(answer.substr(9, 3));
}

bool is_4xx(const httplib::Result& res) { return res && res->status >= 400 && res->status < 500; }

TEST(LightServer, LightsIs503BeforeTheFirstFrameThenRoundTrips) {
  auto s = start_server();
  auto c = client(s.port);
  auto res = c->Get("/lights");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 503);
  EXPECT_NE(res->get_header_value("Content-Type").find("application/json"), std::string::npos);
  EXPECT_TRUE(nlohmann::json::parse(res->body).contains("error"));

  const lp::LightList sent = make_list(42, 5);
  s.server->publish(sent, nullptr);
  res = c->Get("/lights");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  EXPECT_NE(res->get_header_value("Content-Type").find("application/json"), std::string::npos);
  const lp::LightList got = lp::light_list_from_json(res->body, "GET /lights");
  EXPECT_EQ(got.frame, 42);
  EXPECT_EQ(got.method, "q2tree");
  EXPECT_DOUBLE_EQ(got.timestamp, sent.timestamp);
  ASSERT_EQ(got.lights.size(), sent.lights.size());
  for (size_t i = 0; i < got.lights.size(); ++i) {
    EXPECT_EQ(got.lights[i].id, sent.lights[i].id);
    EXPECT_NEAR(got.lights[i].direction.x, sent.lights[i].direction.x, 1e-12);
    EXPECT_NEAR(got.lights[i].direction.z, sent.lights[i].direction.z, 1e-12);
    EXPECT_NEAR(got.lights[i].rgb[1], sent.lights[i].rgb[1], 1e-12);
    EXPECT_NEAR(got.lights[i].solid_angle, sent.lights[i].solid_angle, 1e-12);
  }
  // HEAD answers too, without a body.
  res = c->Head("/lights");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_TRUE(res->body.empty());
  s.server->stop();
}

// Reads /lights/stream (SSE) on a thread of its own and collects the frames in order.
struct SseReader {
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<int64_t> frames;
  std::atomic<bool> quit{false};
  std::atomic<bool> connected{false};
  std::string pending;
  std::thread thread;

  void start(int port, const std::string& path = "/lights/stream") {
    thread = std::thread([this, port, path] {
      auto c = client(port);
      c->Get(path, [this](const char* data, size_t len) {
        connected = true;
        pending.append(data, len);
        size_t end;
        while ((end = pending.find("\n\n")) != std::string::npos) {
          const std::string event = pending.substr(0, end);
          pending.erase(0, end + 2);
          size_t line_start = 0;
          while (line_start < event.size()) {
            size_t line_end = event.find('\n', line_start);
            if (line_end == std::string::npos) line_end = event.size();
            const std::string line = event.substr(line_start, line_end - line_start);
            if (line.rfind("data: ", 0) == 0) {
              const lp::LightList list = lp::light_list_from_json(line.substr(6), "SSE event");
              std::lock_guard lock(mutex);
              frames.push_back(list.frame);
              cv.notify_all();
            }
            line_start = line_end + 1;
          }
        }
        return !quit.load();
      });
    });
  }
  bool wait_for(int64_t frame, std::chrono::milliseconds limit = 5000ms) {
    std::unique_lock lock(mutex);
    return cv.wait_for(lock, limit, [&] { return !frames.empty() && frames.back() >= frame; });
  }
  std::vector<int64_t> snapshot() {
    std::lock_guard lock(mutex);
    return frames;
  }
  void join() {
    quit = true;
    if (thread.joinable()) thread.join();
  }
};

TEST(LightServer, StreamDeliversListsInOrderAndASlowClientNeverStallsPublish) {
  lp::LightServerOptions options;
  options.stream_queue = 8;
  auto s = start_server(options);
  SseReader fast;
  fast.start(s.port);
  ASSERT_TRUE(eventually([&] { return s.server->stats().stream_clients == 1 && fast.connected.load(); }));

  // In order, one at a time: each list arrives before the next is published.
  constexpr int kOrdered = 20;
  for (int f = 1; f <= kOrdered; ++f) {
    s.server->publish(make_list(f, 3), nullptr);
    ASSERT_TRUE(fast.wait_for(f)) << "frame " << f << " never arrived";
  }
  std::vector<int64_t> expected(kOrdered);
  for (int f = 1; f <= kOrdered; ++f) expected[size_t(f - 1)] = f;
  EXPECT_EQ(fast.snapshot(), expected);

  // A second client that sends its request and never reads (tiny receive buffer).
  const int slow = raw_connect(s.port, 4096);
  ASSERT_GE(slow, 0);
  const std::string request = "GET /lights/stream HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  ASSERT_EQ(::send(slow, request.data(), request.size(), MSG_NOSIGNAL), ssize_t(request.size()));
  ASSERT_TRUE(eventually([&] { return s.server->stats().stream_clients == 2; }));

  // 1000 big lists as fast as possible (about 40 MB for the slow client to swallow).
  constexpr int kBurst = 1000;
  std::vector<lp::LightList> lists;
  lists.reserve(kBurst);
  for (int i = 0; i < kBurst; ++i) lists.push_back(make_list(kOrdered + 1 + i, 300));
  const auto t0 = Clock::now();
  double slowest = 0;
  for (int i = 0; i < kBurst && Clock::now() - t0 < 60s; ++i) {
    const auto p0 = Clock::now();
    s.server->publish(lists[size_t(i)], nullptr);
    slowest = std::max(slowest, std::chrono::duration<double>(Clock::now() - p0).count());
  }
  const double total = std::chrono::duration<double>(Clock::now() - t0).count();
  EXPECT_LT(total, 20.0) << "publishing " << kBurst << " lists took " << total << " s";
  EXPECT_LT(slowest, 1.0) << "one publish() took " << slowest << " s";
  EXPECT_EQ(s.server->stats().lists_published, uint64_t(kOrdered + kBurst));

  // The fast client still ends on the newest list, in increasing order.
  const int64_t last = kOrdered + kBurst;
  ASSERT_TRUE(fast.wait_for(last, 20000ms));
  const auto frames = fast.snapshot();
  EXPECT_TRUE(std::is_sorted(frames.begin(), frames.end()));
  EXPECT_EQ(std::adjacent_find(frames.begin(), frames.end()), frames.end());  // no duplicates
  EXPECT_EQ(frames.back(), last);

  // The slow client's losses are counted in /metrics.
  auto c = client(s.port);
  auto res = c->Get("/metrics");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  const double dropped = metric(res->body, "lightprobe_server_stream_lists_dropped_total");
  EXPECT_GT(dropped, 0) << res->body;
  EXPECT_EQ(metric(res->body, "lightprobe_server_stream_clients"), 2) << res->body;

  // A client that goes away is cleaned up.
  ::close(slow);
  EXPECT_TRUE(eventually([&] { return s.server->stats().stream_clients == 1; }, 10000ms));

  const auto stop0 = Clock::now();
  s.server->stop();  // ends the fast client's stream too
  fast.join();
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - stop0).count(), 10.0);
  EXPECT_EQ(s.server->stats().stream_clients, 0);
}

TEST(LightServer, NdjsonStreamSendsOneListPerLine) {
  auto s = start_server();
  s.server->publish(make_list(7, 2), nullptr);
  std::mutex mutex;
  std::vector<int64_t> frames;
  std::string pending, content_type;
  std::atomic<bool> quit{false};
  std::thread reader([&] {
    auto c = client(s.port);
    c->Get(
        "/lights/stream?format=ndjson", httplib::Headers{},
        [&](const httplib::Response& r) {
          content_type = r.get_header_value("Content-Type");
          return true;
        },
        [&](const char* data, size_t len) {
          pending.append(data, len);
          size_t end;
          while ((end = pending.find('\n')) != std::string::npos) {
            const lp::LightList list = lp::light_list_from_json(pending.substr(0, end), "NDJSON line");
            pending.erase(0, end + 1);
            std::lock_guard lock(mutex);
            frames.push_back(list.frame);
          }
          return !quit.load();
        });
  });
  // The current list comes first, then the new ones.
  ASSERT_TRUE(eventually([&] { std::lock_guard l(mutex); return frames.size() == 1; }));
  s.server->publish(make_list(8, 2), nullptr);
  ASSERT_TRUE(eventually([&] { std::lock_guard l(mutex); return frames.size() == 2; }));
  s.server->publish(make_list(9, 2), nullptr);
  ASSERT_TRUE(eventually([&] { std::lock_guard l(mutex); return frames.size() == 3; }));
  {
    std::lock_guard l(mutex);
    EXPECT_EQ(frames, (std::vector<int64_t>{7, 8, 9}));
  }
  s.server->stop();
  quit = true;
  reader.join();
  EXPECT_NE(content_type.find("application/x-ndjson"), std::string::npos);
}

TEST(LightServer, ProbePngIsAPngOfTheLatestMap) {
  auto s = start_server();
  auto c = client(s.port);
  auto res = c->Get("/probe.png");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 503);
  s.server->publish(make_list(1, 4), nullptr);
  res = c->Get("/probe.png");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 503);  // no map to preview

  s.server->publish(make_list(2, 4), make_map());
  for (int i = 0; i < 3; ++i) {  // rendered once, then cached
    res = c->Get("/probe.png");
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200);
    EXPECT_EQ(res->get_header_value("Content-Type"), "image/png");
    ASSERT_GE(res->body.size(), 8u);
    EXPECT_EQ(res->body.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  }
  s.server->stop();
}

// Issue 18: pollers that have the current answer get 304 and no body.
TEST(LightServer, ETagsTurnRepeatedPollsInto304s) {
  auto s = start_server();
  s.server->publish(make_list(1, 4), make_map());
  const auto get = [&](const std::string& path, const std::string& inm = "", const char* method = "GET") {
    const std::string h = inm.empty() ? "" : "If-None-Match: " + inm + "\r\n";
    return lp::test::raw_request(s.port, std::string(method) + " " + path + " HTTP/1.1\r\nHost: x\r\n" + h + "\r\n", 10);
  };
  for (const char* path : {"/lights", "/probe.png", "/probe.exr", "/status"}) {
    const auto first = get(path);
    ASSERT_EQ(first.status, 200) << path;
    const std::string etag = lp::test::header_of(first.answer, "ETag");
    ASSERT_FALSE(etag.empty()) << path;
    EXPECT_EQ(lp::test::header_of(first.answer, "Cache-Control"), "no-cache") << path;
    // The same tag, alone, weak, in a list, or "*": 304 with the tag and no body.
    const std::string weak = etag.rfind("W/", 0) == 0 ? etag : "W/" + etag;
    for (const std::string& inm : {etag, weak, "\"nope\", " + etag, std::string("*")}) {
      const auto again = get(path, inm);
      EXPECT_EQ(again.status, 304) << path << " If-None-Match: " << inm;
      EXPECT_EQ(lp::test::header_of(again.answer, "ETag"), etag) << path;
      EXPECT_EQ(lp::test::body_of(again.answer), "") << path;
      EXPECT_EQ(lp::test::header_of(again.answer, "Content-Length"), "") << path;
    }
    EXPECT_EQ(get(path, etag, "HEAD").status, 304) << path;
    EXPECT_EQ(get(path, "\"nope\"").status, 200) << path;
  }
  // /status is a weak tag: it leaves out what changes with every request (uptime...).
  EXPECT_EQ(lp::test::header_of(get("/status").answer, "ETag").rfind("W/\"", 0), 0u);
  // Something new: new tags, full answers. (The PNG waits out its rate limit first.)
  std::vector<std::string> old_tags;
  for (const char* path : {"/lights", "/probe.png", "/probe.exr", "/status"})
    old_tags.push_back(lp::test::header_of(get(path).answer, "ETag"));
  std::this_thread::sleep_for(300ms);
  s.server->publish(make_list(2, 4), make_map());
  int k = 0;
  for (const char* path : {"/lights", "/probe.png", "/probe.exr", "/status"}) {
    const auto after = get(path, old_tags[size_t(k)]);
    EXPECT_EQ(after.status, 200) << path;
    EXPECT_NE(lp::test::header_of(after.answer, "ETag"), old_tags[size_t(k++)]) << path;
  }
  // Another server's tags never match this one's (a random prefix per server).
  auto other = start_server();
  other.server->publish(make_list(2, 4), nullptr);
  const auto theirs = lp::test::raw_request(other.port, "GET /lights HTTP/1.1\r\nHost: x\r\n\r\n", 10);
  EXPECT_NE(lp::test::header_of(theirs.answer, "ETag"), lp::test::header_of(get("/lights").answer, "ETag"));
  other.server->stop();
  s.server->stop();
}

// Issue 18: the live float map as an EXR, as core/image_io writes one.
TEST(LightServer, ProbeExrIsTheLatestFloatMapWithItsLayoutAndUnits) {
  auto s = start_server();
  auto res = lp::test::raw_request(s.port, "GET /probe.exr HTTP/1.1\r\nHost: x\r\n\r\n", 10);
  EXPECT_EQ(res.status, 503);
  s.server->publish(make_list(1, 4), nullptr);
  EXPECT_EQ(lp::test::raw_request(s.port, "GET /probe.exr HTTP/1.1\r\nHost: x\r\n\r\n", 10).status, 503);
  auto map = std::make_shared<lp::EnvMap>(*make_map());
  map->units = lp::Units::Radiance;
  map->rgb[7] = 12345.678f;  // float, not half
  s.server->publish(make_list(2, 4), map);
  res = lp::test::raw_request(s.port, "GET /probe.exr HTTP/1.1\r\nHost: x\r\n\r\n", 10);
  ASSERT_EQ(res.status, 200);
  EXPECT_EQ(lp::test::header_of(res.answer, "Content-Type"), "image/x-exr");
  const std::string body = lp::test::body_of(res.answer);
  EXPECT_EQ(body, lp::encode_envmap_exr(*map));  // the bytes write_envmap writes
  const std::string path = ::testing::TempDir() + "/probe_from_server.exr";
  lp::write_file_atomically(path, body);
  const lp::EnvMap back = lp::read_envmap(path);
  EXPECT_EQ(back.layout, lp::Layout::LatLong);
  EXPECT_EQ(back.units, lp::Units::Radiance);
  ASSERT_EQ(back.width, map->width);
  ASSERT_EQ(back.height, map->height);
  EXPECT_EQ(back.rgb, map->rgb);
  // A frame without a map keeps the last map.
  s.server->publish(make_list(3, 4), nullptr);
  res = lp::test::raw_request(s.port, "GET /probe.exr HTTP/1.1\r\nHost: x\r\n\r\n", 10);
  EXPECT_EQ(lp::test::body_of(res.answer), body);
  std::remove(path.c_str());
  s.server->stop();
}

TEST(LightServer, PageIsSelfContainedAndSendsTheTokenAsAHeader) {
  auto s = start_server();
  auto c = client(s.port);
  auto res = c->Get("/");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  EXPECT_NE(res->get_header_value("Content-Type").find("text/html"), std::string::npos);
  // Everything through fetch() with the Authorization header: the stream read from a
  // fetch body (EventSource cannot send headers), the picture as a blob URL.
  EXPECT_NE(res->body.find("getReader()"), std::string::npos);
  EXPECT_NE(res->body.find("\"Authorization\": \"Bearer \" + token"), std::string::npos);
  EXPECT_NE(res->body.find("location.hash"), std::string::npos);
  EXPECT_NE(res->body.find("createObjectURL"), std::string::npos);
  EXPECT_EQ(res->body.find("access_token"), std::string::npos);
  EXPECT_NE(res->body.find("/lights/stream"), std::string::npos);
  EXPECT_NE(res->body.find("/probe.png"), std::string::npos);
  EXPECT_EQ(res->body.find("src=\"http"), std::string::npos);
  EXPECT_EQ(res->body.find("<link"), std::string::npos);
  EXPECT_EQ(res->body.find("@import"), std::string::npos);

  res = c->Get("/status");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  const auto status = nlohmann::json::parse(res->body);
  EXPECT_TRUE(status.contains("fps"));
  EXPECT_TRUE(status["frame"].is_null());
  s.server->stop();
}

// Issue 18: the page's 3D preview loads three.js from the server itself (no network), as
// a module that imports its core by a relative name; both are public like the page.
TEST(LightServer, ServesTheEmbeddedThreeJsWithoutTheToken) {
  lp::LightServerOptions o;
  o.token = "t0ken";
  auto s = start_server(o);
  const auto get = [&](const std::string& path, const std::string& extra = "") {
    return lp::test::raw_request(s.port, "GET " + path + " HTTP/1.1\r\nHost: x\r\n" + extra + "\r\n", 30);
  };
  const std::string dir = LIGHTPROBE_THREE_JS_DIR;
  const bool on_disk = std::ifstream(dir + "/three.module.js").good() && std::ifstream(dir + "/three.core.js").good();
  ASSERT_EQ(lp::have_three_js(), on_disk) << "the build embeds three.js exactly when " << dir << " has it";
  for (const char* name : {"three.module.js", "three.core.js"}) {
    const auto res = get(std::string("/three/") + name);
    if (!on_disk) {  // a build without npm's three: 404, and the page says the preview is off
      EXPECT_EQ(res.status, 404) << name;
      continue;
    }
    ASSERT_EQ(res.status, 200) << name;
    EXPECT_EQ(lp::test::header_of(res.answer, "Content-Type"), "text/javascript; charset=utf-8");
    std::ifstream file(dir + "/" + name, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
    EXPECT_GT(bytes.size(), 100000u) << name;
    EXPECT_TRUE(lp::test::body_of(res.answer) == bytes) << name << ": not the embedded file byte for byte";
    const std::string etag = lp::test::header_of(res.answer, "ETag");
    ASSERT_FALSE(etag.empty());
    EXPECT_EQ(get(std::string("/three/") + name, "If-None-Match: " + etag + "\r\n").status, 304) << name;
  }
  // Nothing else under /three/ (404, also without the token: the page tells "not built in"
  // from "no token" by it), and the token still guards the data.
  EXPECT_EQ(get("/three/../lights").status, 404);
  EXPECT_EQ(get("/three/three.webgpu.js").status, 404);
  EXPECT_EQ(get("/lights").status, 401);
  const auto page = get("/");
  ASSERT_EQ(page.status, 200);
  EXPECT_NE(lp::test::body_of(page.answer).find("import(url(\"/three/three.module.js\"))"), std::string::npos);
  s.server->stop();
}

TEST(LightServer, MetricsHoldThePipelinesAndTheServersOwn) {
  auto s = start_server();
  s.server->publish_metrics("# TYPE lightprobe_pipeline_fps gauge\nlightprobe_pipeline_fps 29.5\n");
  s.server->publish(make_list(3, 2), nullptr);
  auto c = client(s.port);
  c->Get("/lights");
  // A request is counted once its response has gone out, which under load can be after a
  // following /metrics was rendered: ask again (bounded) until the /lights one shows.
  auto res = c->Get("/metrics");
  ASSERT_TRUE(res);
  for (int i = 0; i < 40 && metric(res->body, "lightprobe_server_requests_total") < 1; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
    res = c->Get("/metrics");
    ASSERT_TRUE(res);
  }
  ASSERT_EQ(res->status, 200);
  EXPECT_NE(res->get_header_value("Content-Type").find("text/plain"), std::string::npos);
  EXPECT_EQ(metric(res->body, "lightprobe_pipeline_fps"), 29.5);
  EXPECT_GE(metric(res->body, "lightprobe_server_requests_total"), 1);
  EXPECT_GE(metric(res->body, "lightprobe_server_clients_connected"), 1);
  EXPECT_EQ(metric(res->body, "lightprobe_server_stream_clients"), 0);
  EXPECT_EQ(metric(res->body, "lightprobe_server_stream_lists_dropped_total"), 0);
  EXPECT_EQ(metric(res->body, "lightprobe_server_lists_published_total"), 1);
  EXPECT_EQ(metric(res->body, "lightprobe_server_frame"), 3);
  s.server->stop();
}

TEST(LightServer, BadRequestsGet4xxAndTheServerCarriesOn) {
  auto s = start_server();
  s.server->publish(make_list(5, 2), nullptr);
  auto c = client(s.port);

  auto res = c->Get("/no/such/path");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 404);
  res = c->Post("/lights", "x=1", "application/x-www-form-urlencoded");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 405);
  EXPECT_EQ(res->get_header_value("Allow"), "GET, HEAD");
  res = c->Post("/lights");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 405);
  res = c->Delete("/lights");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 405);
  res = c->Get("/lights/stream?format=xml");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 400);

  // A 1 MB header and a 1 MB URL.
  const std::string huge(1 << 20, 'a');
  res = c->Get("/lights", httplib::Headers{{"X-Huge", huge}});
  EXPECT_TRUE(is_4xx(res)) << (res ? res->status : -1);
  res = c->Get("/lights?" + huge);
  EXPECT_TRUE(is_4xx(res)) << (res ? res->status : -1);
  // Many headers that add up to 1 MB.
  httplib::Headers many;
  for (int i = 0; i < 256; ++i) many.emplace("X-H" + std::to_string(i), std::string(4000, 'b'));
  res = c->Get("/lights", many);
  EXPECT_TRUE(is_4xx(res)) << (res ? res->status : -1);
  // A body bigger than any payload we take.
  res = c->Post("/lights", std::string(1 << 20, 'c'), "application/octet-stream");
  EXPECT_TRUE(is_4xx(res)) << (res ? res->status : -1);

  // Garbage and unknown methods, sent raw.
  EXPECT_EQ(raw_status(s.port, "FOO /lights HTTP/1.1\r\nHost: x\r\n\r\n") / 100, 4);
  EXPECT_EQ(raw_status(s.port, "this is not http\r\n\r\n") / 100, 4);
  EXPECT_EQ(raw_status(s.port, "TRACE /lights HTTP/1.1\r\nHost: x\r\n\r\n") / 100, 4);

  // Still serving.
  auto fresh = client(s.port);
  res = fresh->Get("/lights");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  s.server->stop();
}

TEST(LightServer, TokenGuardsEveryRouteButThePageWithTheExactBearerScheme) {
  lp::LightServerOptions options;
  options.token = "s3cret";
  auto s = start_server(options);
  s.server->publish(make_list(1, 2), make_map());
  auto c = client(s.port);
  for (const char* path : {"/lights", "/lights/stream", "/probe.png", "/metrics", "/status", "/nope"}) {
    auto res = c->Get(path);
    ASSERT_TRUE(res) << path;
    EXPECT_EQ(res->status, 401) << path;
    EXPECT_EQ(res->get_header_value("WWW-Authenticate"), "Bearer realm=\"lightprobe\"") << path;
    res = c->Get(path, httplib::Headers{{"Authorization", "Bearer wrong"}});
    ASSERT_TRUE(res) << path;
    EXPECT_EQ(res->status, 401) << path;
  }
  for (const char* path : {"/lights", "/probe.png", "/metrics", "/status"}) {
    auto res = c->Get(path, httplib::Headers{{"Authorization", "Bearer s3cret"}});
    ASSERT_TRUE(res) << path;
    EXPECT_EQ(res->status, 200) << path;
  }
  // The page is static and holds no data: it loads without the token (a browser cannot
  // send a header when it opens a URL) and reads the token from the URL fragment.
  auto res = c->Get("/");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  // Issue 22: only the capitalised scheme, one space, the token exactly; no query token.
  for (const char* auth : {"bearer s3cret", "BEARER s3cret", "Bearer  s3cret", "Bearer s3cre",
                           "Bearer s3crett", "Basic czNjcmV0", "s3cret", "Bearer"}) {
    res = c->Get("/lights", httplib::Headers{{"Authorization", auth}});
    ASSERT_TRUE(res) << auth;
    EXPECT_EQ(res->status, 401) << "'" << auth << "' was accepted";
  }
  res = c->Get("/lights?access_token=s3cret");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 401) << "the query token is accepted";
  s.server->stop();
}

// A query the route does not take was dropped with 200: ?frame=3 served the latest list,
// ?FORMAT=ndjson an SSE stream, ?format=%zz the default. Each is a 400 now.
TEST(LightServer, QueryParametersARouteDoesNotTakeAre400) {
  auto s = start_server();
  s.server->publish(make_list(5, 2), nullptr);
  auto c = client(s.port);
  for (const char* target : {"/lights?frame=3", "/lights?n=5", "/status?format=xml", "/metrics?format=json",
                             "/sh?x", "/probe.png?width=64", "/lights/stream?FORMAT=ndjson",
                             "/lights/stream?format=%zz", "/lights/stream?format=ndjson&format=sse",
                             "/lights/stream?since=5"}) {
    auto res = c->Get(target);
    ASSERT_TRUE(res) << target;
    EXPECT_EQ(res->status, 400) << target << ": " << res->body;
    EXPECT_NE(res->body.find("\"error\""), std::string::npos) << target;
  }
  auto res = c->Get("/lights");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  s.server->stop();
}

TEST(LightServer, AServerWithoutMapsSaysSoInsteadOfAskingToRetry) {
  lp::LightServerOptions options;
  options.serves_maps = false;  // merge
  auto s = start_server(options);
  s.server->publish(make_list(5, 2), nullptr);
  auto c = client(s.port);
  for (const char* path : {"/probe.png", "/probe.exr"}) {
    auto res = c->Get(path);
    ASSERT_TRUE(res) << path;
    EXPECT_EQ(res->status, 404) << path;
    EXPECT_FALSE(res->has_header("Retry-After")) << path;
  }
  s.server->stop();
}

TEST(LightServer, RefusesToListenBeyondLoopbackWithoutAToken) {
  lp::LightServerOptions options;
  options.host = "0.0.0.0";
  options.port = 0;
  try {
    lp::LightServer server(options);
    server.start();
    FAIL() << "listening on 0.0.0.0 without a token was allowed";
  } catch (const lp::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("listening on 0.0.0.0 needs --token"), std::string::npos) << e.what();
  }
  options.host = "192.168.1.10";
  EXPECT_THROW(lp::LightServer{options}, lp::InputError);
  // With a token the options are accepted (not started: tests only listen on 127.0.0.1).
  options.host = "0.0.0.0";
  options.token = "t";
  EXPECT_NO_THROW(lp::LightServer{options});
  // Bad numbers.
  lp::LightServerOptions bad;
  bad.limits.max_connections = 0;
  EXPECT_THROW(lp::LightServer{bad}, lp::InputError);
  bad = {};
  bad.stream_queue = 0;
  EXPECT_THROW(lp::LightServer{bad}, lp::InputError);
}

TEST(LightServer, StopIsIdempotentAndTheDestructorStops) {
  auto s = start_server();
  EXPECT_GT(s.port, 0);
  EXPECT_EQ(s.server->port(), s.port);
  s.server->stop();
  s.server->stop();
  auto t = start_server();
  t.server.reset();  // destructor stops
  lp::LightServer never_started;
  never_started.stop();
}

}  // namespace
