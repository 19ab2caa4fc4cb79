#include "live/web_assets.h"

#include <fmt/format.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace lp {

// Defined in the source live/CMakeLists.txt generates: the embedded files, or empty views.
std::string_view embedded_three_module();
std::string_view embedded_three_core();
std::string_view embedded_three_hash();  // of both files (SHA-256, 16 hex digits)

namespace {

struct Asset {
  std::string_view path;
  std::shared_ptr<const std::string> body;  // copied once from the embedded bytes
  std::string etag;                         // the files' hash and the name: stable across runs and servers
};

const Asset* find_asset(std::string_view path) {
  // Built on first use (magic statics are thread-safe): the 2 MB copied once, not per request.
  static const auto assets = [] {
    std::vector<Asset> out;
    for (auto [name, bytes] : {std::pair{std::string_view("/three/three.module.js"), &embedded_three_module},
                               std::pair{std::string_view("/three/three.core.js"), &embedded_three_core}}) {
      const std::string_view b = bytes();
      if (b.empty()) continue;
      out.push_back({name, std::make_shared<const std::string>(b), fmt::format("\"{}{}\"", embedded_three_hash(), name)});
    }
    return out;
  }();
  for (const Asset& a : assets)
    if (a.path == path) return &a;
  return nullptr;
}

}  // namespace

bool have_three_js() { return !embedded_three_module().empty() && !embedded_three_core().empty(); }

bool answer_web_asset(const HttpRequest& request, HttpExchange& exchange) {
  if (request.path.rfind("/three/", 0) != 0) return false;
  const Asset* asset = find_asset(request.path);
  if (!asset) {  // public too, so that the page can tell "not built in" from "no token"
    HttpResponse r;
    r.status = 404;
    r.set_body(http_error_json(have_three_js() ? "no such file under /three/" : "this lightprobe was built without three.js"),
               "application/json");
    exchange.respond(std::move(r));
    return true;
  }
  if (http_etag_matches(request.header("if-none-match"), asset->etag)) {
    exchange.respond(http_not_modified(asset->etag, "no-cache"));
    return true;
  }
  HttpResponse r;
  r.body = asset->body;
  r.content_type = "text/javascript; charset=utf-8";  // what module scripts must be served as
  r.headers = {{"ETag", asset->etag}, {"Cache-Control", "no-cache"}};
  exchange.respond(std::move(r));
  return true;
}

}  // namespace lp
