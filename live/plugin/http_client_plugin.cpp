// The plugin of live/http_client_plugin.h: the only code linked with cpp-httplib (and
// through it OpenSSL and Brotli). The client's settings moved here from merge_client.cpp
// unchanged.
#include <httplib.h>

#include <ctime>
#include <memory>

#include "live/http_client_plugin.h"

namespace lp::detail {
namespace {

class Client final : public HttpGetClient {
 public:
  Client(const std::string& host, int port, double timeout_s, const std::string& bearer_token)
      : client_(host, port), token_(bearer_token) {
    const auto secs = time_t(timeout_s);
    const auto usecs = time_t((timeout_s - double(secs)) * 1e6);
    client_.set_connection_timeout(secs, usecs);
    client_.set_read_timeout(secs, usecs);
    client_.set_write_timeout(secs, usecs);
    client_.set_keep_alive(true);
    if (!token_.empty()) client_.set_bearer_token_auth(token_.c_str());
  }
  bool get(const std::string& path, const std::function<bool(uint64_t)>& progress, int& status,
           std::string& body) override {
    httplib::Result r =
        client_.Get(path, httplib::Headers{}, [&](uint64_t current, uint64_t) { return progress(current); });
    if (!r) return false;
    status = r->status;
    body = std::move(r->body);
    return true;
  }

 private:
  httplib::Client client_;
  std::string token_;
};

HttpGetClient* new_client(const std::string& host, int port, double timeout_s, const std::string& bearer_token) {
  return new Client(host, port, timeout_s, bearer_token);
}

constexpr HttpClientPluginTable kTable{kHttpClientPluginVersion, &new_client};

}  // namespace
}  // namespace lp::detail

extern "C" __attribute__((visibility("default"))) const void* lightprobe_http_client() { return &lp::detail::kTable; }
