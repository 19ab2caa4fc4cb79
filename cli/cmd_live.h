// stream and its probe-less mode (cli/cmd_live_metadata.cpp) share their arguments.
#pragma once

#include <string>

#include "cli/command_table.h"

namespace lp::cli {

struct StreamArgs {
  std::string source = "aravis";    // replay:DIR | video:FILE | aravis[:ID] | libcamera[:ID] | v4l2:N
  std::string listen = "127.0.0.1:8080";
  std::string token;                // required to listen beyond localhost
  std::string exposures;            // bracketing cycle, seconds
  std::string bracketing = "auto";  // auto|sequencer|writes (Aravis: camera sequencer or feature writes)
  std::string response, photometric, camera;
  std::string vignetting;           // calib vignetting's file: each map corrected where it was read
  double fov = 180;
  std::string rotation;
  bool maps = false;                // the source delivers environment maps (replayed .exr)
  std::string layout = "hemisphere";
  bool layout_given = false;  // `--layout hemisphere` written out is not its absence (with --maps)
  std::string size;
  int nside = 0;
  std::string method = "hemigon";
  std::string n = "300";            // a count or "auto" (the fewest within target_error)
  double target_error = 0.01;
  std::string error_measure = "diffuse";  // what target_error holds (sampling/auto_count.h)
  double frame_budget_ms = 0;       // caps --n auto's count (sampling/frame_budget.h)
  int cluster = 0;
  double fps = 0;                   // replay pacing; also the temporal filter's rate
  bool loop = false;
  double duration = 0;              // seconds; 0 = until interrupted (or the replay ends)
  std::string publish;              // mqtt://[user[:pw]@]HOST[:PORT]/PREFIX (live/mqtt_publisher.h)
  std::string name;                 // the camera's name in MQTT topics; default from --source
  int mqtt_qos = 1;
  std::string mqtt_cafile;          // mqtts: CA certificates
  // Probe-less mode (docs/metadata.md): each frame's exposure, gain and image mean update
  // a metadata model (saved to this path) and the server serves its lights at --position.
  std::string metadata_model;
  std::string position = "0,0";     // where the rig stands, X,Y m (a fixed rig: no tracker)
  std::string view_dir = "1,0,0";   // where it looks, world frame
  double min_frames = 1;            // look-up rule (estimate query --min-frames)
};
int run_stream(const StreamArgs& args, const Output& out);
// stream --metadata-model: the probe-less loop.
int run_stream_metadata(const StreamArgs& args, const Output& out);

}  // namespace lp::cli
