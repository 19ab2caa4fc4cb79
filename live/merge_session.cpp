#include "live/merge_session.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

#include "core/error.h"
#include "core/interrupt.h"
#include "core/warnings.h"

namespace lp {

std::vector<double> merge_session_weights(const MergeSessionOptions& o, std::string* from) {
  const std::vector<double>& explicit_weights = o.mqtt.merge.merge.weights;
  if (o.camera_positions.empty() && !o.target) {
    if (from) *from = explicit_weights.empty() ? "equal" : "--weights";
    return explicit_weights;
  }
  if (o.camera_positions.empty() || !o.target)
    throw InputError("--camera-positions and --target go together: where the cameras stand and the point being lit");
  if (!o.subscribe.empty())
    throw InputError(o.subscribe_flag + ": cameras on a topic come and go by name; --camera-positions needs server URLs");
  if (!explicit_weights.empty()) throw InputError("--weights or --camera-positions, not both: positions make the weights");
  if (o.camera_positions.size() != o.urls.size())
    throw InputError(fmt::format("--camera-positions: {} positions for {} cameras", o.camera_positions.size(), o.urls.size()));
  if (from) *from = "camera positions";
  return position_weights(o.camera_positions, *o.target, o.position_power);
}

MergeSessionReport run_merge_session(const MergeSessionOptions& options, const std::function<void(int port)>& started) {
  if (!options.subscribe.empty() && !(options.urls.empty() && options.mqtt.merge.merge.weights.empty()))
    throw InputError(options.subscribe_flag + ": merges whichever cameras publish; no server URLs or --weights with it");
  if (options.urls.empty() && options.subscribe.empty()) throw InputError("merge needs server URLs or --subscribe");
  MergeSessionReport report;
  MqttMergeOptions merge_options = options.mqtt;
  merge_options.merge.merge.weights = report.weights = merge_session_weights(options, &report.weights_from);
  LightServerOptions server_options = options.server;
  server_options.serves_maps = false;  // merged lists have no map behind them
  LightServer server(server_options);
  report.port = server.start();
  if (started) started(report.port);
  defer_interrupts();  // a signal stops the watchdog below: the summary is returned
  std::atomic<bool> stop{false}, failed{false};
  std::thread watchdog([&] {
    const auto start = std::chrono::steady_clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
    while (!interrupt_signal() && !failed && !(options.duration_s > 0 && elapsed() >= options.duration_s))
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    stop = true;
  });
  // --n sets the count of a Q2-tree or direction merge; cameras of one index-keyed method
  // are merged light by light, keeping their count: an --n that does nothing is said once,
  // when the first merge shows it.
  const bool n_given = options.mqtt.merge.merge.n != MergeAvailableOptions{}.n;
  bool n_unused_said = false;
  const auto serve = [&](const LightList& l, const MergeClientStatus& st) {
    if (n_given && !n_unused_said && st.mode == "index") {
      n_unused_said = true;
      warn(fmt::format("--n {} is not used: the cameras' lists are merged light by light (index), which keeps their "
                       "own light count",
                       options.mqtt.merge.merge.n));
    }
    server.publish(l, nullptr);
    server.publish_metrics(merge_metrics_text(st));
    server.publish_status("merge", merge_status_json(st));
    ++report.published;
    report.last = st;
  };
  try {
    if (options.subscribe.empty()) run_merge_client(options.urls, merge_options.merge, serve, stop);
    else run_mqtt_merge(options.subscribe, options.subscribe_flag, merge_options, serve, stop);
  } catch (...) {
    failed = true;  // a joinable watchdog must not outlive the error (std::terminate)
    watchdog.join();
    throw;
  }
  watchdog.join();
  server.stop();
  for (const MergeInputStatus& in : report.last.inputs) report.skipped += in.state == "skipped";
  report.inputs = std::max(options.urls.size(), report.last.inputs.size());
  return report;
}

std::string MergeSessionReport::summary() const {
  return fmt::format("merge stopped: {} lists published; last used {} of {} inputs ({} skipped); weights {}{}{}{}\n",
                     published, last.state.used.size(), inputs, skipped, weights_from,
                     weights.empty() ? "" : fmt::format(" {:.4g}", fmt::join(weights, ",")),
                     last.error.empty() ? "" : "; last error: " + last.error,
                     published > 0 ? "" : "; no input ever gave a light list (is each one a running lightprobe stream?)");
}

nlohmann::json MergeSessionReport::to_json() const {
  return {{"port", port}, {"published", published}, {"used", last.state.used}, {"dropped", last.state.dropped},
          {"skipped", skipped}, {"mode", last.mode}, {"weights", weights}, {"weights_from", weights_from}};
}

}  // namespace lp
