#include "live/http_client_plugin.h"

#include "core/lazy_libs.h"

namespace lp::detail {

const HttpClientPluginTable& http_client_plugin() {
  // LIGHTPROBE_HTTP_CLIENT_PATH: where the build wrote it (live/CMakeLists.txt).
  return lazy::plugin_table<HttpClientPluginTable, kHttpClientPluginVersion>(
      kHttpClientPluginFile, "lightprobe_http_client", "cpp-httplib's HTTP client", LIGHTPROBE_HTTP_CLIENT_PATH);
}

}  // namespace lp::detail
