// Raw request bytes through the HTTP server's parser and request policy
// (http_parse_head, no socket), and every request it accepts through the light server's
// routes (token, /lights with ETags, /status, /metrics, /lights/stream, 404s) with a
// list published, as `stream` serves it.
#include "core/error.h"
#include "core/light_list.h"
#include "fuzz/fuzz_input.h"
#include "live/http_server.h"
#include "live/light_server.h"

namespace {

// Takes the answer; a stream is reported closed at once so that nothing accumulates.
class Exchange final : public lp::HttpExchange {
 public:
  void respond(lp::HttpResponse response) override { status = response.status; }
  std::shared_ptr<lp::HttpDeferred> defer() override {
    struct Deferred : lp::HttpDeferred {
      void send(lp::HttpResponse) override {}
    };
    return std::make_shared<Deferred>();
  }
  std::shared_ptr<lp::HttpStream> stream(lp::HttpResponse response, lp::HttpStreamOptions options) override {
    struct Closed : lp::HttpStream {
      int push(std::shared_ptr<const std::string>) override { return -1; }
      bool closed() const override { return true; }
    };
    status = response.status;
    if (options.on_close) options.on_close();
    return std::make_shared<Closed>();
  }
  int status = 0;
};

lp::LightServer& server() {
  static lp::LightServer* s = [] {
    lp::LightServerOptions o;
    o.port = 0;
    o.token = "secret";
    auto* made = new lp::LightServer(o);
    lp::LightList list;
    list.frame = 7;
    list.method = "q2tree";
    list.lights.push_back({17, {0, 0, 1}, {1, 2, 3}, 0.5});
    made->publish(list, nullptr);
    made->publish_metrics("# TYPE lightprobe_frames_total counter\nlightprobe_frames_total 7\n");
    return made;
  }();
  return *s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const lp::HttpHeadParse parsed = lp::http_parse_head(lp::fuzz::as_text(data, size));
  if (!parsed.request) {
    if (parsed.status != 0 && (parsed.status < 400 || parsed.status > 599)) __builtin_trap();  // refusals are errors
    return 0;
  }
  Exchange ex;
  server().answer(*parsed.request, ex);
  if (ex.status < 200 || ex.status > 599) __builtin_trap();  // every routed request is answered
  return 0;
}
