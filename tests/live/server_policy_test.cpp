// Issue 22's server findings, one test each, against a light server on 127.0.0.1:0 with
// raw sockets (tests/live/http_attack.h): a request that used to abort the process,
// slow and numerous clients that used to take /lights down, bodies and expectations
// answered late or wrongly. Every server is stopped by its test; every wait is bounded.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/light_list.h"
#include "live/http_server.h"
#include "live/light_server.h"
#include "tests/live/http_attack.h"

namespace lp {
namespace {

using test::raw_request;
using test::RawAnswer;

LightList small_list(int64_t frame) {
  LightList list;
  list.frame = frame;
  list.timestamp = 1700000000.0;
  list.method = "pharr";
  for (int i = 0; i < 50; ++i) {
    Light l;
    l.id = uint64_t(i);
    l.direction = {0, 0, 1};
    l.rgb = {1, 1, 1};
    l.solid_angle = 0.1;
    list.lights.push_back(l);
  }
  return list;
}

std::unique_ptr<LightServer> started(LightServerOptions options, int* port) {
  options.host = "127.0.0.1";
  options.port = 0;
  auto s = std::make_unique<LightServer>(options);
  *port = s->start();
  s->publish(small_list(1), nullptr);
  return s;
}

std::string get(const std::string& target, const std::string& headers = "") {
  return "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + headers + "\r\n";
}

// Finding 1: curl 'http://127.0.0.1:PORT/%ff' aborted stream and merge (nlohmann
// type_error.316, invalid UTF-8), with or without a token.
TEST(ServerPolicy, BytesThatAreNotUtf8AreAnsweredNotFatal) {
  for (const bool with_token : {false, true}) {
    LightServerOptions o;
    if (with_token) o.token = "t0ken";
    int port = 0;
    auto s = started(o, &port);
    const std::string auth = with_token ? "Authorization: Bearer t0ken\r\n" : "";
    struct Case {
      std::string request;
      int status;
    };
    const std::vector<Case> cases{
        {get("/%ff", auth), 404},
        {get("/%ff%fe%80/x", auth), 404},
        {get("/\xff\xfe", auth), 404},
        {get("/%c3%28", auth), 404},
        {get("/lights/stream?format=%ff", auth), 400},
        {get("/lights", auth + "X-Junk: \xff\xfe\r\n"), 200},
        {get("/%zz", auth), 400},
        {get("/%f", auth), 400},
        {"G\xffT / HTTP/1.1\r\nHost: x\r\n\r\n", 400},
    };
    for (const Case& c : cases) {
      const RawAnswer a = raw_request(port, c.request, 5);
      EXPECT_EQ(a.status, c.status) << c.request;
      if (a.status >= 400) {
        // The error is JSON that parses (the bad bytes replaced, not thrown on).
        const auto j = nlohmann::json::parse(test::body_of(a.answer), nullptr, false);
        EXPECT_TRUE(!j.is_discarded() && j.contains("error")) << test::body_of(a.answer);
      }
    }
    // Without the token the same paths are 401, and the server is still there.
    if (with_token) {
      EXPECT_EQ(raw_request(port, get("/%ff"), 5).status, 401);
    }
    EXPECT_EQ(raw_request(port, get("/lights", auth), 5).status, 200);
    s->stop();
  }
}

// Finding 3: 40 sockets sending a header line every 2 s kept /lights from answering
// within 1 s on 9 of 11 polls (200 of them: 18 of 19); 500 connections at once were
// answered 294 times and the rest closed with nothing. The acceptance criterion: every
// /lights answered within 100 ms (p95 here, all printed) while 200 slowloris sockets and
// waves of 500 connections hang on, and every connection answered (200, 503 or 408).
TEST(ServerPolicy, SlowAndNumerousClientsCannotTakeLightsDown) {
  // Both ends of ~700 connections live in this process: raise the file limit for them.
  rlimit rl{};
  ::getrlimit(RLIMIT_NOFILE, &rl);
  rl.rlim_cur = std::min<rlim_t>(rl.rlim_max, 65536);
  ::setrlimit(RLIMIT_NOFILE, &rl);
  if (rl.rlim_cur < 4096) GTEST_SKIP() << "the file limit (" << rl.rlim_cur << ") is below the 4096 this test needs";
  int port = 0;
  auto s = started({}, &port);
  test::AttackOptions o;  // 200 slowloris from 127.0.0.2, waves of 500 from 127.0.0.3
  const test::AttackReport r = test::run_attack(port, o);
  std::printf("attack: %zu polls of /lights, %d failed; latency p50 %.2f ms, p95 %.2f ms, max %.2f ms\n",
              r.poll_seconds.size(), r.polls_failed, 1e3 * r.percentile(0.5), 1e3 * r.percentile(0.95),
              1e3 * r.percentile(1.0));
  std::printf("attack: slowloris %d: %d answered (%d with 503, the rest 408), %d closed silently, %d still open\n",
              r.slow_connected, r.slow_got_status, r.slow_got_503, r.slow_closed_silently, r.slow_still_open);
  std::printf("attack: crowd %d connections: %d x 200, %d x 503, %d other, %d closed silently, %d unanswered\n",
              r.crowd_total, r.crowd_200, r.crowd_503, r.crowd_other, r.crowd_closed_silently, r.crowd_no_answer);
  std::printf("attack: all poll latencies (ms):");
  for (double t : r.poll_seconds) std::printf(" %.1f", 1e3 * t);
  std::printf("\n");
  const HttpServerStats st = s->stats().http;
  std::printf("attack: server: %llu accepted, %llu rejected per address, %llu globally, %llu head timeouts\n",
              (unsigned long long)st.connections_accepted, (unsigned long long)st.rejected_per_address,
              (unsigned long long)st.rejected_global, (unsigned long long)st.head_timeouts);
  ASSERT_GE(r.poll_seconds.size(), 20u);
  EXPECT_EQ(r.polls_failed, 0);
  EXPECT_LT(r.percentile(0.95), 0.100);
  // Slowloris: 64 get a slot each (the per-address cap) and then 408 once their head
  // takes longer than the deadline; the other 136 get 503 at once. Nobody is cut off silently.
  EXPECT_EQ(r.slow_connected, o.slow_clients);
  EXPECT_EQ(r.slow_closed_silently, 0);
  EXPECT_EQ(r.slow_got_503, o.slow_clients - 64);
  EXPECT_EQ(r.slow_got_status, o.slow_clients);  // the head deadline (5 s) passes within the run
  EXPECT_GE(st.head_timeouts, 1u);
  // The crowd: 64 served per wave, the rest told 503; none closed with nothing.
  EXPECT_GE(r.crowd_total, 2 * o.crowd);
  EXPECT_EQ(r.crowd_closed_silently, 0);
  EXPECT_EQ(r.crowd_other, 0);
  EXPECT_LE(r.crowd_no_answer, r.crowd_total / 50);
  EXPECT_GT(r.crowd_503, 0);
  EXPECT_GT(r.crowd_200, 0);
  s->stop();
}

TEST(ServerPolicy, ConnectionCapsAnswer503WithRetryAfter) {
  LightServerOptions o;
  o.limits.max_connections_per_address = 3;
  o.limits.max_connections = 5;
  int port = 0;
  auto s = started(o, &port);
  // Idle connections that hold their slots (the first request shows the slot is held).
  std::vector<int> held;
  const auto hold = [&](const char* source) {
    const int fd = test::start_connect(source, port);
    pollfd p{fd, POLLOUT, 0};
    ::poll(&p, 1, 2000);
    held.push_back(fd);
  };
  for (int i = 0; i < 3; ++i) hold("127.0.0.5");
  ASSERT_TRUE([&] {
    for (int i = 0; i < 200; ++i) {
      if (s->stats().clients_connected == 3) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }());
  RawAnswer a = raw_request(port, get("/lights"), 5, true, "127.0.0.5");
  EXPECT_EQ(a.status, 503) << a.answer;
  EXPECT_EQ(test::header_of(a.answer, "Retry-After"), "1");
  EXPECT_NE(test::body_of(a.answer).find("too many connections from 127.0.0.5 (at most 3)"), std::string::npos)
      << a.answer;
  // Another address is still served, up to the global cap of 5.
  EXPECT_EQ(raw_request(port, get("/lights"), 5, true, "127.0.0.6").status, 200);
  for (int i = 0; i < 2; ++i) hold("127.0.0.6");
  for (int i = 0; i < 200 && s->stats().clients_connected < 5; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  a = raw_request(port, get("/lights"), 5, true, "127.0.0.7");
  EXPECT_EQ(a.status, 503) << a.answer;
  EXPECT_NE(test::body_of(a.answer).find("server busy"), std::string::npos) << a.answer;
  EXPECT_EQ(test::header_of(a.answer, "Connection"), "close");
  // Slots come back when connections close.
  for (int fd : held) ::close(fd);
  bool served = false;
  for (int i = 0; i < 200 && !served; ++i) {
    served = raw_request(port, get("/lights"), 5, true, "127.0.0.5").status == 200;
    if (!served) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_TRUE(served);
  const HttpServerStats st = s->stats().http;
  EXPECT_GE(st.rejected_per_address, 1u);
  EXPECT_GE(st.rejected_global, 1u);
  s->stop();
}

TEST(ServerPolicy, SlowRequestHeadsGet408AndIdleConnectionsAreClosed) {
  LightServerOptions o;
  o.limits.header_line_timeout_s = 0.3;
  o.limits.request_head_timeout_s = 1.0;
  o.limits.keep_alive_timeout_s = 0.5;
  int port = 0;
  auto s = started(o, &port);
  // (a) The request line, then nothing: 408 once the next line is 0.3 s late.
  RawAnswer a = raw_request(port, "GET /lights HTTP/1.1\r\n", 5, false);
  EXPECT_EQ(a.status, 408) << a.answer;
  EXPECT_TRUE(a.closed);
  EXPECT_GT(a.seconds, 0.25);
  EXPECT_LT(a.seconds, 1.5);
  // (b) A header line every 0.2 s (each within the line timeout): 408 at the 1 s deadline
  // for the whole head.
  const int fd = test::start_connect("127.0.0.1", port);
  const auto t0 = test::AttackClock::now();
  std::string answer;
  for (int i = 0; i < 40 && answer.empty(); ++i) {
    const std::string line = i == 0 ? "GET /lights HTTP/1.1\r\n" : "X-Slow: " + std::to_string(i) + "\r\n";
    ::send(fd, line.data(), line.size(), MSG_NOSIGNAL);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    char buf[4096];
    const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
    if (n > 0) answer.assign(buf, size_t(n));
  }
  const double took = std::chrono::duration<double>(test::AttackClock::now() - t0).count();
  ::close(fd);
  EXPECT_EQ(test::status_of(answer), 408) << answer;
  EXPECT_GT(took, 0.9);
  EXPECT_LT(took, 2.5);
  // (c) A connection that says nothing is closed after the idle timeout, without a word.
  a = raw_request(port, "", 5, false);
  EXPECT_TRUE(a.closed);
  EXPECT_EQ(a.answer, "");
  EXPECT_GT(a.seconds, 0.4);
  EXPECT_LT(a.seconds, 2.0);
  EXPECT_GE(s->stats().http.head_timeouts, 2u);
  EXPECT_EQ(raw_request(port, get("/lights"), 5).status, 200);
  s->stop();
}

// Finding 3, continued: Content-Length: -1 got its 413 after 5 s; Expect: 100-continue
// with 1 GB got "100 Continue". Now every body and expectation is refused at once.
TEST(ServerPolicy, BodiesAndExpectationsAreRefusedAtOnce) {
  int port = 0;
  auto s = started({}, &port);
  struct Case {
    std::string request;
    int status;
  };
  const std::vector<Case> cases{
      {get("/lights", "Content-Length: -1\r\n"), 400},
      {get("/lights", "Content-Length: 5, 6\r\n"), 400},
      {get("/lights", "Content-Length: abc\r\n"), 400},
      {get("/lights", "Content-Length: 99999999999999999999999999\r\n"), 413},
      {get("/lights", "Content-Length: 5\r\n"), 413},
      {get("/lights", "Transfer-Encoding: chunked\r\n"), 413},
      {get("/lights", "Content-Length: 1073741824\r\nExpect: 100-continue\r\n"), 417},
      {"POST /lights HTTP/1.1\r\nHost: x\r\nContent-Length: 1073741824\r\nExpect: 100-continue\r\n\r\n", 417},
      {get("/lights", "Expect: something-else\r\n"), 417},
      {"POST /lights HTTP/1.1\r\nHost: x\r\nContent-Length: 1073741824\r\n\r\n", 405},
      {"PUT /lights HTTP/1.1\r\nHost: x\r\nContent-Length: 3\r\n\r\nabc", 405},
      {"GET /lights HTTP/2.0\r\nHost: x\r\n\r\n", 505},
      {"GET /lights\r\nHost: x\r\n\r\n", 400},
      {"GET lights HTTP/1.1\r\nHost: x\r\n\r\n", 400},
      {"GET /lights HTTP/1.1\r\n Folded: x\r\n\r\n", 400},
      {"GET /lights HTTP/1.1\r\nNo colon here\r\n\r\n", 400},
      {"GET /" + std::string(9000, 'a') + " HTTP/1.1\r\n\r\n", 414},
      {get("/lights", "X-Big: " + std::string(40000, 'b') + "\r\n"), 431},
  };
  for (const Case& c : cases) {
    const RawAnswer a = raw_request(port, c.request, 10);
    EXPECT_EQ(a.status, c.status) << c.request.substr(0, 120);
    EXPECT_LT(a.seconds, 1.0) << c.request.substr(0, 120);  // at once, not after a read timeout
    EXPECT_EQ(a.answer.find("100 Continue"), std::string::npos) << c.request.substr(0, 120);
    if (c.status == 405) {
      EXPECT_EQ(test::header_of(a.answer, "Allow"), "GET, HEAD");
    }
  }
  // Expect: 100-continue without a body is harmless; HEAD has no body.
  EXPECT_EQ(raw_request(port, get("/lights", "Expect: 100-continue\r\n"), 5).status, 200);
  const RawAnswer head = raw_request(port, "HEAD /lights HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n", 5, false);
  EXPECT_EQ(head.status, 200);
  EXPECT_EQ(test::body_of(head.answer), "");
  EXPECT_GT(std::stoul(test::header_of(head.answer, "Content-Length")), 100u);
  s->stop();
}

// The HTTP core itself: keep-alive with pipelining, HTTP/1.0, a client that half-closes
// after its request, answers from another thread, a handler that throws.
TEST(HttpServer, PipelinesDefersAndSurvivesHandlersThatThrow) {
  std::vector<std::thread> workers;
  std::shared_ptr<HttpDeferred> dropped;
  HttpServer server({}, [&](const HttpRequest& req, HttpExchange& ex) {
    if (req.path == "/throw") throw std::runtime_error("boom");
    if (req.path == "/later") {
      workers.emplace_back([d = ex.defer()] {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        HttpResponse r;
        r.set_body("later\n", "text/plain");
        d->send(r);
      });
      return;
    }
    if (req.path == "/never") {
      ex.defer();  // destroyed unkept: 500
      return;
    }
    HttpResponse r;
    r.set_body("path " + req.path + " q " + req.query_param("q").value_or("-") + "\n", "text/plain");
    ex.respond(std::move(r));
  });
  const int port = server.start();
  // Two requests in one packet: two answers, in order, on one connection.
  RawAnswer a = raw_request(port, get("/a?q=1") + get("/b?q=x%20y", "Connection: close\r\n"), 5, false);
  EXPECT_TRUE(a.closed);
  const size_t first = a.answer.find("path /a q 1"), second = a.answer.find("path /b q x y");
  EXPECT_NE(first, std::string::npos) << a.answer;
  EXPECT_NE(second, std::string::npos) << a.answer;
  EXPECT_LT(first, second);
  // HTTP/1.0 closes after the answer; a half-closed client still gets its answer.
  a = raw_request(port, "GET /c HTTP/1.0\r\n\r\n", 5, false);
  EXPECT_TRUE(a.closed);
  EXPECT_EQ(a.answer.rfind("HTTP/1.0 200 OK", 0), 0u) << a.answer;
  {
    const int fd = test::start_connect("127.0.0.1", port);
    pollfd p{fd, POLLOUT, 0};
    ::poll(&p, 1, 2000);
    const std::string req = get("/half");
    ::send(fd, req.data(), req.size(), MSG_NOSIGNAL);
    ::shutdown(fd, SHUT_WR);
    std::string got;
    char buf[4096];
    for (int i = 0; i < 100; ++i) {
      pollfd q{fd, POLLIN, 0};
      if (::poll(&q, 1, 50) <= 0) continue;
      const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
      if (n <= 0) break;
      got.append(buf, size_t(n));
    }
    ::close(fd);
    EXPECT_NE(got.find("path /half"), std::string::npos) << got;
  }
  EXPECT_NE(raw_request(port, get("/later"), 5).answer.find("later"), std::string::npos);
  EXPECT_EQ(raw_request(port, get("/never"), 5).status, 500);
  EXPECT_EQ(raw_request(port, get("/throw"), 5).status, 500);
  EXPECT_EQ(raw_request(port, get("/after"), 5).status, 200);
  EXPECT_GE(server.stats().handler_errors, 1u);
  server.stop();
  for (auto& t : workers) t.join();
}

}  // namespace
}  // namespace lp
