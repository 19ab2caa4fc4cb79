// http_parse_head and LightServer::answer: the server's request parser and routes without
// a socket (the HTTP fuzz target's entry points), checked against what the served
// connection answers in server_policy_test.cpp and light_server_test.cpp.
#include <gtest/gtest.h>

#include <string>

#include "core/light_list.h"
#include "live/http_server.h"
#include "live/light_server.h"

namespace lp {
namespace {

TEST(HttpParseHead, DecodesThePathAndKeepsTheQueryRaw) {
  const HttpHeadParse p =
      http_parse_head("\r\nGET /lights%2Fstream?format=nd%6Ason HTTP/1.0\r\nHost: x\r\nX-Two:  a b \t\r\n\r\n");
  ASSERT_TRUE(p.request) << p.status << " " << p.message;
  EXPECT_EQ(p.request->method, "GET");
  EXPECT_EQ(p.request->path, "/lights/stream");
  EXPECT_EQ(p.request->query, "format=nd%6Ason");
  EXPECT_EQ(p.request->query_param("format"), "ndjson");
  EXPECT_EQ(p.request->minor_version, 0);
  ASSERT_EQ(p.request->headers.size(), 2u);
  EXPECT_EQ(p.request->headers[1].first, "x-two");
  EXPECT_EQ(p.request->headers[1].second, "a b");
}

TEST(HttpParseHead, AnIncompleteHeadIsNeitherARequestNorARefusal) {
  const HttpHeadParse p = http_parse_head("GET / HTTP/1.1\r\nHost: x\r\n");
  EXPECT_FALSE(p.request);
  EXPECT_EQ(p.status, 0);
}

TEST(HttpParseHead, RefusesAsTheServerDoes) {
  const auto status = [](const std::string& head) { return http_parse_head(head).status; };
  EXPECT_EQ(status("GET / HTTP/2.0\r\n\r\n"), 505);
  EXPECT_EQ(status("GET / HTTX/1.1\r\n\r\n"), 400);
  EXPECT_EQ(status("GET /%zz HTTP/1.1\r\n\r\n"), 400);
  EXPECT_EQ(status("GET / HTTP/1.1\r\nContent-Length: -1\r\n\r\n"), 400);
  EXPECT_EQ(status("GET / HTTP/1.1\r\nContent-Length: 5\r\n\r\n"), 413);
  EXPECT_EQ(status("GET / HTTP/1.1\r\nExpect: 100-continue\r\nContent-Length: 1000000000\r\n\r\n"), 417);
  EXPECT_EQ(status("POST / HTTP/1.1\r\n\r\n"), 405);
  EXPECT_EQ(status("GET / HTTP/1.1\r\n folded\r\n\r\n"), 400);
  EXPECT_EQ(status("GET " + std::string(9000, 'a') + " HTTP/1.1\r\n\r\n"), 414);
  HttpLimits small;
  small.max_head_bytes = 64;
  EXPECT_EQ(http_parse_head("GET / HTTP/1.1\r\nX: " + std::string(100, 'a'), small).status, 431);  // before its end
}

// Collects the one answer a handler gives.
class Answer final : public HttpExchange {
 public:
  void respond(HttpResponse r) override { response = std::move(r); }
  std::shared_ptr<HttpDeferred> defer() override { throw std::logic_error("not expected"); }
  std::shared_ptr<HttpStream> stream(HttpResponse, HttpStreamOptions) override { throw std::logic_error("not expected"); }
  HttpResponse response = [] { HttpResponse r; r.status = 0; return r; }();  // 0: no answer yet
};

int route(LightServer& server, const std::string& head) {
  const HttpHeadParse p = http_parse_head(head);
  EXPECT_TRUE(p.request) << head;
  Answer a;
  if (p.request) server.answer(*p.request, a);
  return a.response.status;
}

TEST(LightServerAnswer, RoutesWithTheTokenWithoutASocket) {
  LightServerOptions o;
  o.port = 0;
  o.token = "t0ken";
  LightServer server(o);
  EXPECT_EQ(route(server, "GET /lights HTTP/1.1\r\nAuthorization: Bearer t0ken\r\n\r\n"), 503);  // nothing yet
  LightList list;
  list.frame = 3;
  list.lights.push_back({5, {0, 0, 1}, {1, 1, 1}, 0.1});
  server.publish(list, nullptr);
  EXPECT_EQ(route(server, "GET /lights HTTP/1.1\r\nAuthorization: Bearer t0ken\r\n\r\n"), 200);
  EXPECT_EQ(route(server, "GET /lights HTTP/1.1\r\nAuthorization: bearer t0ken\r\n\r\n"), 401);
  EXPECT_EQ(route(server, "GET /%ff HTTP/1.1\r\nAuthorization: Bearer t0ken\r\n\r\n"), 404);
  EXPECT_EQ(route(server, "GET / HTTP/1.1\r\n\r\n"), 200);  // the page is public
}

// The Accept header's q for a media type, against RFC 9110's rules (section 12.5.1): the
// most specific range wins, whatever its order; q=0 refuses; parameters other than q do not
// narrow a range; a header that does not parse is ignored.
TEST(HttpRequest, AcceptQualityTakesTheMostSpecificRange) {
  const auto q = [](const std::string& accept, std::string_view type) {
    const HttpHeadParse p = http_parse_head("GET / HTTP/1.1\r\n" + accept + "\r\n\r\n");
    EXPECT_TRUE(p.request) << accept;
    return p.request ? p.request->accept_quality(type) : -1.0;
  };
  EXPECT_EQ(q("X-None: 1", "application/json"), 1);  // no Accept header: anything
  EXPECT_EQ(q("Accept: */*", "image/png"), 1);
  EXPECT_EQ(q("Accept: image/png", "application/json"), 0);
  EXPECT_EQ(q("Accept: image/*;q=0.5, image/png;q=0.2", "image/png"), 0.2);  // exact beats type/*
  EXPECT_EQ(q("Accept: image/*;q=0.5, image/png;q=0.2", "image/x-exr"), 0.5);
  EXPECT_EQ(q("Accept: application/json;q=0, */*", "application/json"), 0);  // refused outright
  EXPECT_EQ(q("Accept: APPLICATION/JSON; Q=0.7", "application/json"), 0.7);  // case-insensitive
  // Prometheus' scrape: its version parameter does not narrow text/plain.
  EXPECT_DOUBLE_EQ(q("Accept: application/openmetrics-text;version=1.0.0;q=0.5,text/plain;version=0.0.4;q=0.4,*/*;q=0.1",
                     "text/plain"),
                   0.4);
  EXPECT_EQ(q("Accept: text/event-stream", "application/x-ndjson"), 0);  // what EventSource sends
  // Not parseable: ignored, as no header.
  EXPECT_EQ(q("Accept: json", "image/png"), 1);
  EXPECT_EQ(q("Accept: image/png;q=2", "application/json"), 1);
  EXPECT_EQ(q("Accept: image/png;q=abc", "application/json"), 1);
}

// A client that reads one type gets 406 from a route that serves another, not a body it
// cannot read with 200; the stream's format follows the header when ?format= is absent.
TEST(LightServerAnswer, RoutesAnswerTheAcceptHeader) {
  LightServerOptions o;
  o.port = 0;
  LightServer server(o);
  LightList list;
  list.frame = 3;
  list.lights.push_back({5, {0, 0, 1}, {1, 1, 1}, 0.1});
  server.publish(list, nullptr);
  const auto answer = [&](const std::string& head) {
    const HttpHeadParse p = http_parse_head(head);
    EXPECT_TRUE(p.request) << head;
    Answer a;
    if (p.request) server.answer(*p.request, a);
    return a.response;
  };
  EXPECT_EQ(answer("GET /lights HTTP/1.1\r\nAccept: application/json\r\n\r\n").status, 200);
  EXPECT_EQ(answer("GET /lights HTTP/1.1\r\nAccept: text/html,*/*;q=0.8\r\n\r\n").status, 200);  // a browser
  const HttpResponse png_only = answer("GET /lights HTTP/1.1\r\nAccept: image/png\r\n\r\n");
  EXPECT_EQ(png_only.status, 406);
  ASSERT_TRUE(png_only.body);
  EXPECT_NE(png_only.body->find("/lights is application/json"), std::string::npos) << *png_only.body;
  EXPECT_EQ(answer("GET /status HTTP/1.1\r\nAccept: application/json;q=0\r\n\r\n").status, 406);
  EXPECT_EQ(answer("GET /probe.png HTTP/1.1\r\nAccept: application/json\r\n\r\n").status, 406);
  EXPECT_EQ(answer("GET /metrics HTTP/1.1\r\nAccept: application/openmetrics-text;version=1.0.0;q=0.5,"
                   "text/plain;version=0.0.4;q=0.4,*/*;q=0.1\r\n\r\n")
                .status,
            200);
  EXPECT_EQ(answer("HEAD /lights/stream HTTP/1.1\r\n\r\n").content_type, "text/event-stream");
  EXPECT_EQ(answer("HEAD /lights/stream HTTP/1.1\r\nAccept: application/x-ndjson\r\n\r\n").content_type,
            "application/x-ndjson");
  EXPECT_EQ(answer("HEAD /lights/stream HTTP/1.1\r\nAccept: text/event-stream\r\n\r\n").content_type,
            "text/event-stream");
  EXPECT_EQ(answer("HEAD /lights/stream?format=ndjson HTTP/1.1\r\nAccept: */*\r\n\r\n").content_type,
            "application/x-ndjson");
  EXPECT_EQ(answer("HEAD /lights/stream?format=ndjson HTTP/1.1\r\nAccept: text/event-stream\r\n\r\n").status, 406);
  EXPECT_EQ(answer("HEAD /lights/stream HTTP/1.1\r\nAccept: application/json\r\n\r\n").status, 406);
}

}  // namespace
}  // namespace lp
