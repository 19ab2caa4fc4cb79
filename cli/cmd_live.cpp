// stream: the whole chain live, serving light lists over HTTP to any number of renderers.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <memory>

#include "calib/camera_model.h"
#include "calib/photometric.h"
#include "calib/vignetting.h"
#include "cli/cmd_live.h"
#include "cli/commands.h"
#include "cli/report.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/limits.h"
#include "core/map_sequence.h"
#include "core/warnings.h"
#include "hdr/bracket.h"
#include "hdr/response.h"
#include "live/merge_session.h"
#include "live/stream_session.h"
#include "live/mqtt_publisher.h"
#include "live/pipeline.h"
#include "probe/camera_source.h"

namespace lp::cli {

struct MergeArgs {
  MergeSessionOptions mo;           // URLs or topic, timeout, n, upstream token, MQTT, duration bound directly
  std::string listen = "127.0.0.1:8090";
  std::string token;                // for our server
  std::string weights;              // one per URL
  std::string camera_positions, target;  // X,Y,Z per URL (';' between) and the point lit: position weights
};

namespace {

std::string fs_name(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

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

// What either mode reads, and which options belong to one mode, one source or MQTT only:
// given elsewhere they did nothing, with exit 0 (an audit found twenty such).
void refuse_options_the_stream_never_reads(const StreamArgs& a) {
  const StreamArgs d;
  if (!(a.duration >= 0)) throw InputError(fmt::format("--duration must be 0 (until stopped) or more seconds, got {}", a.duration));
  if (!(a.fps >= 0) || !std::isfinite(a.fps))
    throw InputError(fmt::format("--fps must be 0 (the source's own pace) or more, got {}", a.fps));
  std::string host;
  int port = 0;
  parse_listen(a.listen, &host, &port);
  auto refuse = [](std::initializer_list<std::pair<bool, const char*>> options, const std::string& why) {
    for (const auto& [given, option] : options)
      if (given) throw InputError(fmt::format("{} {}", option, why));
  };
  const bool metadata = !a.metadata_model.empty();
  if (metadata) {
    refuse({{!a.publish.empty(), "--publish"}, {!a.exposures.empty(), "--exposures"}, {a.bracketing != d.bracketing, "--bracketing"},
            {!a.response.empty(), "--response"}, {!a.camera.empty(), "--camera"}, {a.fov != d.fov, "--fov"},
            {!a.vignetting.empty(), "--vignetting"}, {!a.rotation.empty(), "--rotation"}, {a.maps, "--maps"}, {a.layout_given, "--layout"},
            {!a.size.empty(), "--size"}, {a.nside != d.nside, "--nside"}, {a.method != d.method, "--method"},
            {a.n != d.n, "--n"}, {a.target_error != d.target_error, "--target-error"},
            {a.error_measure != d.error_measure, "--error-measure"}, {a.frame_budget_ms != d.frame_budget_ms, "--frame-budget-ms"},
            {a.cluster != d.cluster, "--cluster"}},
           "belongs to the probe chain, which --metadata-model replaces (it meters exposure and gain alone)");
    if (!(a.min_frames >= 1) || !std::isfinite(a.min_frames))
      throw InputError(fmt::format("--min-frames must be >= 1, got {}", a.min_frames));
  } else {
    refuse({{a.position != d.position, "--position"}, {a.view_dir != d.view_dir, "--view-dir"}, {a.min_frames != d.min_frames, "--min-frames"}},
           "applies only with --metadata-model");
  }
  if (a.publish.empty())
    refuse({{a.name != d.name, "--name"}, {a.mqtt_qos != d.mqtt_qos, "--mqtt-qos"}, {a.mqtt_cafile != d.mqtt_cafile, "--mqtt-cafile"}},
           "applies only with --publish (MQTT)");
  else if (!a.mqtt_cafile.empty() && a.publish.rfind("mqtts://", 0) != 0)
    throw InputError("--mqtt-cafile is for TLS (mqtts://), and --publish names a plain mqtt:// broker");
  const bool replay = a.source.rfind("replay:", 0) == 0, video = a.source.rfind("video:", 0) == 0;
  const bool aravis = a.source == "aravis" || a.source.rfind("aravis:", 0) == 0;
  if (a.loop && !replay && !video) throw InputError(fmt::format("--loop replays a recording; {} is a live camera", a.source));
  if (a.bracketing != d.bracketing && !aravis)
    throw InputError(fmt::format("--bracketing chooses how an Aravis camera brackets; {} is not one", a.source));
  if (a.bracketing != d.bracketing && a.exposures.empty()) throw InputError("--bracketing needs --exposures (a bracket)");
  if (a.maps)
    refuse({{!a.rotation.empty(), "--rotation"}, {!a.response.empty(), "--response"}, {!a.camera.empty(), "--camera"},
            {!a.vignetting.empty(), "--vignetting"}, {a.fov != d.fov, "--fov"}, {!a.exposures.empty(), "--exposures"}},
           "applies to camera frames; with --maps the frames are maps already");
  else if (!(a.fov > 0 && a.fov <= 360))
    throw InputError(fmt::format("--fov must be a field of view in (0, 360] degrees, got {}", a.fov));
  if (!metadata && a.cluster > 0 && a.n != "auto") {
    try {
      if (a.cluster >= std::stoi(a.n))
        throw InputError(fmt::format("--cluster {} keeps every one of --n {} lights: clustering does nothing", a.cluster, a.n));
    } catch (const std::logic_error&) {  // --n is checked where it is read
    }
  }
}

int run_stream(const StreamArgs& args, const Output& out) {
  refuse_options_the_stream_never_reads(args);
  if (!args.metadata_model.empty()) return run_stream_metadata(args, out);  // the probe-less mode
  // Options in, validated before anything starts.
  StreamSessionOptions st;
  SourceOptions& so = st.source_options;
  so.loop = args.loop, so.frame_rate = args.fps, so.bracketing = args.bracketing;
  LivePipelineOptions& lo = st.pipeline;
  if (args.exposures == "auto") lo.auto_exposures = true;  // planned from each map (hdr/auto_bracket.h)
  else if (!args.exposures.empty()) lo.exposure_cycle = parse_numbers(args.exposures, "--exposures");
  for (size_t k = 0; k < lo.exposure_cycle.size(); ++k) {
    const double t = lo.exposure_cycle[k];
    if (!(t > 0)) throw InputError("--exposures must be positive seconds");
    // Every bracket would be dropped ("the same exposure time"), the stream serving no light.
    for (size_t j = 0; j < k; ++j)
      if (lo.exposure_cycle[j] == t)
        throw InputError(fmt::format("--exposures: {} s is given twice; each frame of a bracket needs its own", t));
  }
  if (args.response == "srgb")
    lo.response = srgb_response(256);
  else if (!args.response.empty())
    lo.response = load_response(args.response);
  if (!args.photometric.empty()) lo.photometric = load_photometric(args.photometric), lo.photometric_file = args.photometric;
  if (!args.camera.empty()) lo.camera = read_camera_model(args.camera), lo.camera_file = args.camera;
  if (!args.vignetting.empty()) lo.vignetting = load_vignetting(args.vignetting), lo.vignetting_file = args.vignetting;
  // Replayed photos in Display P3 or Adobe RGB streamed as if sRGB: their colours, from the
  // first photo's ICC profile, as probe unwrap and hdr fuse read them.
  std::string colour_profile;  // reported: what the colours were converted from
  if (args.source.rfind("replay:", 0) == 0 && !args.maps) {
    std::vector<std::string> frames;
    try {
      frames = find_images({args.source.substr(7)});  // in the replay's order
    } catch (const InputError&) {
      // The replay source refuses a folder without frames, in its own words.
    }
    if (!frames.empty() && is_camera_image_file(frames.front()))
      if (auto profile = read_colour_profile(frames.front())) lo.to_rec709 = profile->to_rec709, colour_profile = profile->name;
    // Float frames are radiance already: a response curve was skipped for them without a word.
    if (!frames.empty() && is_radiance_file(frames.front()) && !args.response.empty())
      throw InputError(fmt::format("--response: {} holds float frames ({}), radiance already; a response maps camera codes",
                                   args.source, fs_name(frames.front())));
  }
  lo.fov_deg = args.fov;
  lo.fov_given = args.fov != StreamArgs{}.fov;
  if (!args.rotation.empty()) lo.world_from_probe = parse_rotation(args.rotation);
  lo.frames_are_maps = args.maps;
  const auto layout = layout_from_string(args.layout);
  if (!layout) throw InputError(fmt::format("--layout: unknown layout '{}'", args.layout));
  lo.layout = *layout;
  refuse_misplaced_geometry(*layout, args.size, args.nside);
  if (!args.size.empty()) parse_image_size(args.size, "--size", &lo.width, &lo.height);
  else if (*layout == Layout::LatLong) lo.width = 512, lo.height = 256;
  if (*layout == Layout::Healpix) lo.width = given_nside(args.nside) > 0 ? args.nside : 32, lo.height = 1;
  if (*layout == Layout::Healpix) check_nside("--nside", lo.width);
  // Replayed maps are not resampled: without a geometry given they take the first map's own
  // (the default hemisphere 360x90 refused every latlong map), and a geometry given that the
  // maps do not have is refused before the stream starts.
  if (args.maps && args.source.rfind("replay:", 0) == 0) {
    std::vector<std::string> maps;
    try {
      maps = find_images({args.source.substr(7)});
    } catch (const InputError&) {
      // The replay source refuses a folder without frames, in its own words.
    }
    if (!maps.empty() && is_radiance_file(maps.front())) {
      const EnvMap first = read_envmap(maps.front());
      const int width = first.layout == Layout::Healpix ? first.nside : first.width;  // the pipeline's healpix size
      const int height = first.layout == Layout::Healpix ? 1 : first.height;
      const StreamArgs unset;
      if (!args.layout_given && args.size.empty() && args.nside == unset.nside) {
        lo.layout = first.layout, lo.width = width, lo.height = height;
      } else if (first.layout != lo.layout || width != lo.width || height != lo.height) {
        throw InputError(fmt::format("{} is {}, the pipeline expects {}: with --maps, --layout and --size (or --nside) "
                                     "describe the maps replayed (nothing is resampled); leave them out to take the maps' own",
                                     maps.front(), describe_size(first),
                                     describe_size(make_envmap(lo.layout, lo.width, lo.height))));
      }
    }
  }
  check_light_count("--cluster", args.cluster);
  const auto method = method_from_string(args.method);
  if (!method) throw InputError(fmt::format("--method: unknown method '{}'", args.method));
  lo.sampling.method = *method;
  lo.sampling.count = light_count(args.n);
  lo.sampling.auto_count = lo.sampling.count == 0;
  lo.sampling.auto_options.target_error = args.target_error;
  // Refused before anything starts: a negative or NaN duration or frame rate ran the stream
  // until it was killed, and a target error of 0 or less failed every frame of a stream
  // that kept serving nothing new.
  if (!(args.duration >= 0)) throw InputError(fmt::format("--duration must be 0 (until stopped) or more seconds, got {}", args.duration));
  if (!(args.fps >= 0)) throw InputError(fmt::format("--fps must be 0 (the source's own pace) or more, got {}", args.fps));
  if (lo.sampling.auto_count && !(args.target_error > 0))
    throw InputError(fmt::format("--target-error must be positive, got {}", args.target_error));
  lo.sampling.auto_options.measure = error_measure_from_string(args.error_measure);
  // What only --n auto reads is refused with a fixed count, not ignored (as sample does).
  const StreamArgs defaults;
  for (const auto& [given, option] : {std::pair{args.target_error != defaults.target_error, "--target-error"},
                                      std::pair{args.error_measure != defaults.error_measure, "--error-measure"},
                                      std::pair{args.frame_budget_ms != defaults.frame_budget_ms, "--frame-budget-ms"}})
    if (given && !lo.sampling.auto_count) throw InputError(fmt::format("{} applies only with --n auto", option));
  lo.sampling.budget.budget_ms = args.frame_budget_ms;
  lo.sampling.frame_rate_hz = args.fps > 0 ? args.fps : 21, lo.sampling.cluster_max_lights = args.cluster;
  lo.sampling.sampler.upper_only = lo.layout == Layout::Hemisphere;
  parse_listen(args.listen, &st.server.host, &st.server.port);
  if (!args.token.empty()) st.server.token = args.token;
  st.source = args.source;
  st.publish = args.publish;
  st.mqtt.camera = mqtt_camera_name(args.name, args.source, "--name");
  st.mqtt.qos = args.mqtt_qos, st.mqtt.client.cafile = args.mqtt_cafile;
  st.method_name = args.method, st.duration_s = args.duration;
  // Aravis' simulated camera has no lens to calibrate; any other camera's frames are unwrapped
  // through a guessed one without --camera. Said once the stream is up, so that an input
  // refused before it starts is still one line.
  const bool guessed_lens = !lo.camera && !args.maps && args.source.rfind("aravis:Fake", 0) != 0;
  const StreamSessionReport r = run_stream_session(st, [&](int port) {
    if (guessed_lens)
      warn(fmt::format("no --camera: frames are unwrapped as an ideal equidistant fisheye of {:g} deg whose image "
                       "circle fits the frame's short side (calibrate the lens: calib geometric)",
                       args.fov));
    say(out, "lightprobe stream: {} -> http://{}:{}/ (lights at /lights, live at /lights/stream, metrics at /metrics)\n",
        args.source, st.server.host, port);
    std::fflush(stdout);
  });
  say(out, "{}", r.summary());
  nlohmann::json report = r.to_json();
  if (!colour_profile.empty()) report["colour_profile"] = colour_profile;
  emit_json(out, report);
  if (!r.error.empty()) throw InputError(r.error);  // a bad frame or a refused login, after the summary
  return 0;
}

int run_merge(const MergeArgs& args, const Output& out) {
  MergeSessionOptions mo = args.mo;
  if (!(mo.duration_s >= 0)) throw InputError(fmt::format("--duration must be 0 (until stopped) or more seconds, got {}", mo.duration_s));
  check_light_count("--n", mo.mqtt.merge.merge.n);
  const double timeout = mo.mqtt.merge.timeout_s;
  if (!(timeout > 0) || !std::isfinite(timeout))
    throw InputError(fmt::format("--timeout must be a positive number of seconds, got {}", timeout));
  if (!args.weights.empty()) {
    mo.mqtt.merge.merge.weights = parse_numbers(args.weights, "--weights", mo.urls.size());
    for (double w : mo.mqtt.merge.merge.weights)  // a weight of 0 or less merged nothing, every round
      if (!(w > 0) || !std::isfinite(w)) throw InputError(fmt::format("--weights must be positive, got '{}'", args.weights));
  }
  // MQTT's options without a topic, a camera server's token with one: read by nothing.
  const MergeArgs d;
  if (mo.subscribe.empty()) {
    for (const auto& [given, option] : {std::pair{mo.mqtt.qos != d.mo.mqtt.qos, "--mqtt-qos"},
                                        std::pair{mo.mqtt.client.cafile != d.mo.mqtt.client.cafile, "--mqtt-cafile"}})
      if (given) throw InputError(fmt::format("{} applies only with --subscribe (MQTT)", option));
  } else if (!mo.mqtt.merge.token.empty()) {
    throw InputError("--upstream-token is for the cameras' HTTP servers; with --subscribe the lists come from the broker");
  }
  std::string xyz = args.camera_positions;
  std::replace(xyz.begin(), xyz.end(), ';', ',');
  const auto p = xyz.empty() ? std::vector<double>{} : parse_numbers(xyz, "--camera-positions", 3 * mo.urls.size());
  for (size_t i = 0; i < p.size(); i += 3) mo.camera_positions.push_back({p[i], p[i + 1], p[i + 2]});
  if (!args.target.empty()) {
    const auto t = parse_numbers(args.target, "--target", 3);
    mo.target = Vec3{t[0], t[1], t[2]};
  }
  parse_listen(args.listen, &mo.server.host, &mo.server.port);
  if (!args.token.empty()) mo.server.token = args.token;
  const MergeSessionReport r = run_merge_session(mo, [&](int port) {
    say(out, "lightprobe merge: {} -> http://{}:{}/lights\n",
        mo.subscribe.empty() ? fmt::format("{} cameras", mo.urls.size()) : "cameras on MQTT", mo.server.host, port);
    std::fflush(stdout);
  });
  say(out, "{}", r.summary());
  emit_json(out, r.to_json());
  return 0;
}

std::vector<Command> live_commands() {
  return {
      {"stream", "Run the whole chain live and serve light lists over HTTP",
       "lightprobe stream --source aravis:Fake_1 --exposures auto\nlightprobe stream --source aravis --exposures 0.0002,0.002,0.02 --camera fisheye.yaml --fov 185\nlightprobe stream --config rig.toml",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<StreamArgs>();
         f.opt("--source", a->source, "replay:DIR | video:FILE | aravis[:ID] | libcamera[:ID] | v4l2:N");
         f.opt("--listen", a->listen, "HOST:PORT to serve on (127.0.0.1 by default; port 0 picks one)");
         f.opt("--token", a->token, "Bearer token required on every route (needed beyond localhost)").non_empty();
         f.opt("--exposures", a->exposures, "Bracketing: exposure times cycled by the camera, seconds; or 'auto': the fewest that cover the scene, re-planned as it changes");
         f.opt("--bracketing", a->bracketing, "auto: the camera's sequencer when it has one, else per-frame writes; sequencer; writes").one_of({"auto", "sequencer", "writes"});
         f.opt("--response", a->response, "Camera response: a response.json (hdr response), or srgb for codes written as sRGB (a phone's JPEGs); default linear");
         f.opt("--photometric", a->photometric, "Photometric calibration: absolute units");
         f.opt("--camera", a->camera, "Calibrated camera model (default: equidistant fisheye)");
         f.opt("--vignetting", a->vignetting, "The lens's vignetting (calib vignetting), corrected in every map");
         f.opt("--fov", a->fov, "Fisheye field of view / image circle, deg (with --camera only when given: else the image circle found in the first frame bounds the lens)");
         f.opt("--rotation", a->rotation, "Probe to world: 'yaw,pitch,roll' degrees");
         f.flag("--maps", a->maps, "The source delivers environment maps already (replayed .exr, not resampled: their own layout and size unless --layout/--size/--nside are given)");
         f.opt("--layout", a->layout, "latlong|hemisphere|healpix").given(a->layout_given);
         f.opt("--size", a->size, "Map size WxH");
         f.opt("--nside", a->nside, "healpix nside");
         f.opt("--method", a->method, "pharr|hemigon|q2tree|mediancut");
         f.opt("--n", a->n, "Lights per frame, or 'auto': the fewest within --target-error, with hysteresis");
         f.opt("--target-error", a->target_error, "With --n auto: largest error (0.01 = 1 %)");
         f.opt("--error-measure", a->error_measure, "What --target-error holds: diffuse|glossy10|glossy100|shadowed|worst");
         f.opt("--frame-budget-ms", a->frame_budget_ms, "With --n auto: fewer lights when the back end takes longer");
         f.opt("--cluster", a->cluster, "Cluster to at most this many lights");
         f.opt("--fps", a->fps, "Replay pacing and the temporal filter's frame rate");
         f.flag("--loop", a->loop, "Replay: start over at the end");
         f.opt("--duration", a->duration, "Stop after this many seconds");
         f.opt("--publish", a->publish, "Also publish to an MQTT broker: mqtt[s]://[USER[:PASSWORD]@]HOST[:PORT]/PREFIX (topics PREFIX/NAME/lights, PREFIX/NAME/status)");
         f.opt("--name", a->name, "The camera's NAME in MQTT topics (default: from --source, aravis:Fake_1 -> aravis-Fake_1)");
         f.opt("--mqtt-qos", a->mqtt_qos, "QoS of the published lists, 0 or 1").one_of({"0", "1"});
         f.opt("--mqtt-cafile", a->mqtt_cafile, "mqtts: CA certificates (PEM); default the system's");
         f.opt("--metadata-model", a->metadata_model, "Probe-less mode: meter each frame's exposure/gain into this model and serve its lights");
         f.opt("--position", a->position, "Metadata mode: where the rig stands, X,Y m");
         f.opt("--view-dir", a->view_dir, "Metadata mode: where the camera looks, x,y,z");
         f.opt("--min-frames", a->min_frames, "Metadata mode: frames that make a sector informed");
         return [a](const Output& out) { return run_stream(*a, out); };
       }},
      {"merge", "Merge the lights of several cameras' servers and serve the result",
       "lightprobe merge http://cam1:8080 http://cam2:8080 --listen 127.0.0.1:8090\nlightprobe merge --subscribe mqtt://broker:1883/studio/+/lights",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<MergeArgs>();
         f.arg("URL", a->mo.urls, "Light servers, http://HOST:PORT");
         f.opt("--subscribe", a->mo.subscribe, "Instead of URLs: the cameras on an MQTT broker, mqtt[s]://[USER[:PASSWORD]@]HOST[:PORT]/PREFIX/+/lights (publishes PREFIX/merged/lights)");
         f.opt("--mqtt-qos", a->mo.mqtt.qos, "QoS of the subscription and the merged lists, 0 or 1").one_of({"0", "1"});
         f.opt("--mqtt-cafile", a->mo.mqtt.client.cafile, "mqtts: CA certificates (PEM); default the system's");
         f.opt("--listen", a->listen, "HOST:PORT to serve the merged lights on");
         f.opt("--token", a->token, "Bearer token for our server").non_empty();
         f.opt("--upstream-token", a->mo.mqtt.merge.token, "Bearer token for the cameras' servers").non_empty();
         f.opt("--weights", a->weights, "Comma-separated weights, one per URL");
         f.opt("--camera-positions", a->camera_positions, "Where each URL's camera stands, X,Y,Z;X,Y,Z;... (with --target: weights 1/distance^2)");
         f.opt("--target", a->target, "X,Y,Z: the point being lit, for --camera-positions");
         f.opt("--n", a->mo.mqtt.merge.merge.n, "Light count of a Q2-tree merge");
         f.opt("--timeout", a->mo.mqtt.merge.timeout_s, "Drop a camera silent for this many seconds");
         f.opt("--duration", a->mo.duration_s, "Stop after this many seconds");
         return [a](const Output& out) { return run_merge(*a, out); };
       }},
  };
}

}  // namespace lp::cli
