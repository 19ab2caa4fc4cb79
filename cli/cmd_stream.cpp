// stream: the whole chain live, serving light lists over HTTP to any number of renderers.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <csignal>
#include <thread>

#include "calib/camera_model.h"
#include "calib/photometric.h"
#include "cli/commands.h"
#include "cli/report.h"
#include "core/error.h"
#include "hdr/response.h"
#include "live/light_server.h"
#include "live/merge_client.h"
#include "live/pipeline.h"
#include "probe/camera_source.h"

namespace lp::cli {

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

void parse_listen(const std::string& text, std::string* host, int* port) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos) throw InputError(fmt::format("--listen must be HOST:PORT, got '{}'", text));
  *host = text.substr(0, colon);
  try {
    size_t used = 0;
    *port = std::stoi(text.substr(colon + 1), &used);
    if (used != text.size() - colon - 1 || *port < 0 || *port > 65535) throw std::invalid_argument("x");
  } catch (const std::exception&) {
    throw InputError(fmt::format("--listen: '{}' is not a port", text.substr(colon + 1)));
  }
}

}  // namespace

int run_stream(const StreamArgs& args, const Output& out) {
  if (!args.metadata_model.empty()) return run_stream_metadata(args, out);  // the probe-less mode
  // Options in, validated before anything starts.
  SourceOptions so;
  so.loop = args.loop;
  so.frame_rate = args.fps;
  so.bracketing = args.bracketing;
  LivePipelineOptions lo;
  if (!args.exposures.empty()) lo.exposure_cycle = parse_numbers(args.exposures, "--exposures");
  for (double t : lo.exposure_cycle)
    if (!(t > 0)) throw InputError("--exposures must be positive seconds");
  if (!args.response.empty()) lo.response = load_response(args.response);
  if (!args.photometric.empty()) lo.photometric = load_photometric(args.photometric);
  if (!args.camera.empty()) lo.camera = read_camera_model(args.camera);
  lo.fov_deg = args.fov;
  if (!args.rotation.empty()) lo.world_from_probe = parse_rotation(args.rotation);
  lo.frames_are_maps = args.maps;
  const auto layout = layout_from_string(args.layout);
  if (!layout) throw InputError(fmt::format("--layout: unknown layout '{}'", args.layout));
  lo.layout = *layout;
  if (!args.size.empty()) parse_size(args.size, "--size", &lo.width, &lo.height);
  else if (*layout == Layout::LatLong) lo.width = 512, lo.height = 256;
  if (*layout == Layout::Healpix) lo.width = args.nside > 0 ? args.nside : 32, lo.height = 1;
  const auto method = method_from_string(args.method);
  if (!method) throw InputError(fmt::format("--method: unknown method '{}'", args.method));
  lo.sampling.method = *method;
  lo.sampling.count = args.n;
  lo.sampling.frame_rate_hz = args.fps > 0 ? args.fps : 21;
  lo.sampling.cluster_max_lights = args.cluster;
  lo.sampling.sampler.upper_only = *layout == Layout::Hemisphere;
  LightServerOptions server_options;
  parse_listen(args.listen, &server_options.host, &server_options.port);
  if (!args.token.empty()) server_options.token = args.token;

  LightServer server(server_options);
  LivePipeline pipeline([&] { return open_source(args.source, so); }, lo,
                        [&](const LightList& lights, std::shared_ptr<const EnvMap> map) { server.publish(lights, map); });
  const int port = server.start();
  pipeline.start();
  say(out, "lightprobe stream: {} -> http://{}:{}/ (lights at /lights, live at /lights/stream, metrics at /metrics)\n",
      args.source, server_options.host, port);
  std::fflush(stdout);
  g_stop = false;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  const auto start = std::chrono::steady_clock::now();
  while (!g_stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    server.publish_metrics(pipeline.metrics());
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (args.duration > 0 && elapsed >= args.duration) break;
  }
  pipeline.stop();
  const LiveStats s = pipeline.stats();
  server.stop();
  say(out, "stream stopped: {} frames in, {} brackets processed, {} dropped whole, {} frames in partial brackets, {} "
           "reconnects{}\n",
      s.frames_in, s.brackets_processed, s.brackets_dropped, s.frames_dropped_partial, s.reconnects,
      s.last_error.empty() ? "" : "; last error: " + s.last_error);
  emit_json(out, {{"port", port}, {"frames_in", s.frames_in}, {"brackets_processed", s.brackets_processed},
                  {"brackets_dropped", s.brackets_dropped}, {"frames_dropped_partial", s.frames_dropped_partial},
                  {"reconnects", s.reconnects}, {"fps", s.fps_out}, {"last_error", s.last_error}});
  return 0;
}

int run_merge(const MergeArgs& args, const Output& out) {
  MergeClientOptions mo;
  mo.timeout_s = args.timeout;
  mo.token = args.upstream_token;
  mo.merge.n = args.n;
  if (!args.weights.empty()) mo.merge.weights = parse_numbers(args.weights, "--weights", args.urls.size());
  LightServerOptions so;
  parse_listen(args.listen, &so.host, &so.port);
  if (!args.token.empty()) so.token = args.token;
  LightServer server(so);
  const int port = server.start();
  say(out, "lightprobe merge: {} cameras -> http://{}:{}/lights\n", args.urls.size(), so.host, port);
  std::fflush(stdout);
  g_stop = false;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::atomic<bool> stop{false};
  uint64_t published = 0;
  std::thread watchdog([&] {
    const auto start = std::chrono::steady_clock::now();
    while (!g_stop && !(args.duration > 0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >= args.duration))
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    stop = true;
  });
  MergeClientStatus last;
  try {
    run_merge_client(args.urls, mo,
                     [&](const LightList& l, const MergeClientStatus& st) {
                       server.publish(l, nullptr);
                       server.publish_metrics(merge_metrics_text(st));
                       server.publish_status("merge", merge_status_json(st));
                       ++published;
                       last = st;
                     },
                     stop);
  } catch (...) {
    g_stop = true;  // a joinable watchdog must not outlive the error (std::terminate)
    watchdog.join();
    throw;
  }
  watchdog.join();
  server.stop();
  size_t skipped = 0;
  for (const MergeInputStatus& in : last.inputs) skipped += in.state == "skipped";
  say(out, "merge stopped: {} lists published; last used {} of {} inputs ({} skipped){}\n", published,
      last.state.used.size(), args.urls.size(), skipped, last.error.empty() ? "" : "; last error: " + last.error);
  emit_json(out, {{"port", port}, {"published", published}, {"used", last.state.used}, {"dropped", last.state.dropped},
                  {"skipped", skipped}, {"mode", last.mode}});
  return 0;
}

}  // namespace lp::cli
