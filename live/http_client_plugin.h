// cpp-httplib's client, loaded on first use. libcpp-httplib links OpenSSL and Brotli (5
// libraries; libcrypto builds its tables at load), which every lightprobe command loaded
// at start though only `merge` polls other servers over HTTP (merge_client.cpp; the
// server side is our own, http_server.h). The client lives in a plugin instead
// (liblightprobe_http_client.so, live/plugin/), which the first merge loads; it is found
// where core/lazy_libs.h looks for its plugin.
//
// Internal to live/: only merge_client.cpp and the plugin include it.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

namespace lp::detail {

// One keep-alive connection to http://host:port, every wait bounded by timeout_s.
class HttpGetClient {
 public:
  virtual ~HttpGetClient() = default;
  // GET `path`; `progress(bytes so far)` returning false aborts it. False when no answer
  // came (refused, timed out, aborted); else the status and the body.
  virtual bool get(const std::string& path, const std::function<bool(uint64_t)>& progress, int& status,
                   std::string& body) = 0;
};

// What the plugin exports (its one symbol, `lightprobe_http_client`, returns it). The
// version changes whenever the table or the interface above does.
struct HttpClientPluginTable {
  int version;
  // A client; `bearer_token` empty for none.
  HttpGetClient* (*new_client)(const std::string& host, int port, double timeout_s, const std::string& bearer_token);
};
inline constexpr int kHttpClientPluginVersion = 1;
inline constexpr const char* kHttpClientPluginFile = "liblightprobe_http_client.so";

// The plugin's table, loaded once; throws std::runtime_error when it cannot be loaded.
const HttpClientPluginTable& http_client_plugin();

}  // namespace lp::detail
