// The subcommands of `lightprobe`, one function each over plain argument structs.
// Only main.cpp knows CLI11 (slow to compile); handlers turn arguments into options,
// validate, load, make one library call, write, report.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/vec3.h"
#include "sampling/sampler.h"

namespace lp::cli {

// Where reports go: with --json one JSON object on stdout; human text on stdout
// otherwise (stderr when --json).
struct Output {
  bool json = false;
  bool progress = true;  // progress bars (shown only on a terminal anyway)
};

struct InfoArgs {
  std::vector<std::string> files;
  std::string layout;  // override
};
int run_info(const InfoArgs& args, const Output& out);

struct ConvertArgs {
  std::string input, output;
  std::string layout;    // target layout
  std::string size;      // WxH
  int nside = 0;
  std::string in_layout; // override of the input's layout
  std::string rotation;  // "yaw,pitch,roll" degrees or 9 numbers
  bool half = false;     // EXR half floats
};
int run_convert(const ConvertArgs& args, const Output& out);

struct PreviewArgs {
  std::string input, output;
  double percentile = 0.99;
};
int run_preview(const PreviewArgs& args, const Output& out);

struct SynthSceneArgs {
  std::string output;
  std::string layout = "latlong";
  std::string size;                 // default 1024x512 (latlong), 360x90 (hemisphere)
  int nside = 0;
  double sun_scale = 1.0;
  bool no_sun = false;
};
int run_synth_scene(const SynthSceneArgs& args, const Output& out);

struct SampleArgs {
  std::vector<std::string> inputs;  // one map, several maps (a sequence) or a directory
  std::string method = "pharr";
  std::string n = "256";            // a count or "auto"
  double target_error = 0.01;
  std::string format;               // json|ndjson|pbrt|mitsuba|gltf|csv (default from -o)
  std::string output;
  std::string overlay;              // PNG of the lights on the map
  std::string layout;               // input layout override
  bool upper_only = false;
  bool lloyd = false;
  double q2_a = 1.0, q2_b = 0.25;
  bool q2_jitter = false;
  int q2_nside = 0;
  std::string filter = "auto";      // FIR filtering of power and directions: auto|on|off
  double fps = 21;                  // frame rate the filter is designed for
  int cluster = 0;                  // cluster to at most this many lights (0: off)
};
int run_sample(const SampleArgs& args, const Output& out);

struct EvalSamplingArgs {
  std::vector<std::string> maps;    // "scene" renders the procedural scene
  std::string methods = "all";
  std::string counts = "16,32,64,128,256,512,1024,2048,4096";
  std::string output_dir;
  int repeats = 0;                  // 0: adaptive (at least 5, ~0.2 s per point)
  bool no_shadowed = false;
};
int run_eval_sampling(const EvalSamplingArgs& args, const Output& out);

struct SynthSequenceArgs {
  std::string scenario = "moving-light";
  std::string base = "scene";       // a map file or "scene"
  int frames = 48;
  double fps = 21;
  uint64_t seed = 7;
  std::string size;                 // resample the base first (WxH)
  std::string output_dir;
};
int run_synth_sequence(const SynthSequenceArgs& args, const Output& out);

struct EvalTemporalArgs {
  std::vector<std::string> maps;    // base maps; "scene" for the procedural scene
  std::string methods = "all";
  std::string scenarios = "all";
  int frames = 48;
  int n = 256;
  double fps = 21;
  std::string filter = "auto";
  std::string output_dir;
};
int run_eval_temporal(const EvalTemporalArgs& args, const Output& out);

struct HdrResponseArgs {
  std::vector<std::string> images;
  std::string exposure_times;       // "1/10,1/40" or a list file; default: EXIF
  std::string method = "debevec";   // debevec|robertson
  double lambda = 50;
  std::string ignore_colour;        // "r,g,b" of registration borders to leave out
  std::string output;
};
int run_hdr_response(const HdrResponseArgs& args, const Output& out);

struct HdrFuseArgs {
  std::vector<std::string> images;
  std::string exposure_times;
  std::string response;             // saved response; default: recovered from this bracket
  bool linear = false;              // a linear sensor: no response curve
  std::string photometric;          // calibration: absolute units (or a log sensor's decode)
  std::string align = "none";       // none|mtb|ecc
  bool deghost = false;
  bool no_exposure_weighting = false;
  std::string ignore_colour;
  std::string output;
};
int run_hdr_fuse(const HdrFuseArgs& args, const Output& out);

struct CalibPhotometricArgs {
  std::string readings;
  std::string model = "linear";     // linear|log
  std::string loss = "huber";       // huber|cauchy|none
  std::string output;
};
int run_calib_photometric(const CalibPhotometricArgs& args, const Output& out);

struct SynthBracketArgs {
  std::string input = "scene";      // a radiance image/map or "scene"
  std::string exposure_times;       // default 1/64,1/8,1
  std::string response = "gamma";   // linear|gamma|scurve
  bool no_noise = false;
  int bit_depth = 8;
  int shake_px = 0;
  bool moving_object = false;
  uint64_t seed = 1;
  std::string output_dir;
};
int run_synth_bracket(const SynthBracketArgs& args, const Output& out);

struct EvalHdrArgs {
  std::vector<std::string> maps;    // radiance maps/images, or "scene"
  std::string response = "gamma";
  std::string output_dir;
};
int run_eval_hdr(const EvalHdrArgs& args, const Output& out);

// eval calib: our calibration next to OpenCV run alone on the same detected corners
// (images given), and/or a sweep on synthetic corners (views x noise -> error vs truth).
struct EvalCalibArgs {
  std::vector<std::string> images;  // one camera's chessboard views; may be empty with --sweep
  std::string board = "9x6";
  double square_mm = 30;
  bool sweep = false;
  std::string output_dir;
};
int run_eval_calib(const EvalCalibArgs& args, const Output& out);

struct ProbeUnwrapArgs {
  std::vector<std::string> inputs;  // an image, several, or a directory (a sequence)
  std::string type = "mirrorball";  // mirrorball|fisheye
  std::string camera;               // fisheye: OpenCV fisheye YAML (default: equidistant)
  double fov = 0;                   // fisheye: equidistant field of view; ball: camera fov
  double distance = 0;              // ball: camera distance in ball radii (0: orthographic)
  std::string ball;                 // "cx,cy,r" instead of detection
  double reflectivity = 1.0;
  bool fresnel = false;
  double blind_spot_deg = 15;
  bool fill = false;
  bool stabilise = false;           // smooth the per-frame ball / circle track
  bool static_probe = false;        // with stabilise: one median position for all frames
  bool fixed_ball = false;          // use frame 0's geometry for every frame (no tracking)
  std::string colour_match;         // 3x3 transform to the backplate camera (calib colour)
  std::string rotation;
  std::string layout = "latlong";
  std::string size;
  int nside = 0;
  std::string output;               // a map, or a directory for a sequence
};
int run_probe_unwrap(const ProbeUnwrapArgs& args, const Output& out);

struct CalibGeometricArgs {
  std::vector<std::string> images;
  std::string board;                // COLSxROWS inner corners
  double square_mm = 0;
  std::string model;                // override the selection
  bool no_mrcal = false;
  std::string report_dir;           // pictures; default beside the output
  std::string output;               // camera.cameramodel or camera.yaml
  int drop_influential = 0;         // recalibrate without up to N flagged views, worst first
};
int run_calib_geometric(const CalibGeometricArgs& args, const Output& out);

struct CalibCompareArgs {
  std::string a, b;                 // two model files of one camera
  int step_px = 4;
  bool no_rotation = false;
};
int run_calib_compare(const CalibCompareArgs& args, const Output& out);

struct SynthBoardsArgs {
  int views = 20;
  std::string board = "9x6";
  double square_mm = 30;
  double noise = 0.01;
  double fov = 190;
  std::string camera;               // a model file; default a 190 deg Kannala-Brandt 1280x960
  uint64_t seed = 1;
  std::string output_dir;
};
int run_synth_boards(const SynthBoardsArgs& args, const Output& out);

struct CalibColourArgs {
  std::string patches;              // CSV probe_r,probe_g,probe_b,plate_r,plate_g,plate_b
  std::string output;
};
int run_calib_colour(const CalibColourArgs& args, const Output& out);

struct ProbeRegisterArgs {
  std::vector<std::string> images;  // photos of one ball, cropped differently
  int size = 512;                   // output square, px
  std::string output_dir;
};
int run_probe_register(const ProbeRegisterArgs& args, const Output& out);

struct SynthProbeArgs {
  std::string input = "scene";
  std::string type = "mirrorball";
  std::string size = "512x512";
  double radius = 0;                // ball radius px (0: 40 % of the short side)
  double distance = 0;              // 0: orthographic
  double fov = 190;                 // fisheye
  double noise = 0;
  int frames = 1;
  double jitter = 1.0;              // ball centre jitter px per frame (sequences)
  uint64_t seed = 1;
  std::string output;
};
int run_synth_probe(const SynthProbeArgs& args, const Output& out);

struct EvalUnwrapArgs {
  std::vector<std::string> maps;
  std::string output_dir;
};
int run_eval_unwrap(const EvalUnwrapArgs& args, const Output& out);

struct StreamArgs {
  std::string source = "aravis";    // replay:DIR | video:FILE | aravis[:ID] | libcamera[:ID] | v4l2:N
  std::string listen = "127.0.0.1:8080";
  std::string token;                // required to listen beyond localhost
  std::string exposures;            // bracketing cycle, seconds
  std::string bracketing = "auto";  // auto|sequencer|writes (Aravis: camera sequencer or feature writes)
  std::string response, photometric, camera;
  double fov = 180;
  std::string rotation;
  bool maps = false;                // the source delivers environment maps (replayed .exr)
  std::string layout = "hemisphere";
  std::string size;
  int nside = 0;
  std::string method = "hemigon";
  int n = 300;
  int cluster = 0;
  double fps = 0;                   // replay pacing; also the temporal filter's rate
  bool loop = false;
  double duration = 0;              // seconds; 0 = until interrupted (or the replay ends)
  // Probe-less mode (docs/metadata.md): each frame's exposure, gain and image mean update
  // a metadata model (saved to this path) and the server serves its lights at --position.
  std::string metadata_model;
  std::string position = "0,0";     // where the rig stands, X,Y m (a fixed rig: no tracker)
  std::string view_dir = "1,0,0";   // where it looks, world frame
  double min_frames = 1;            // look-up rule (estimate query --min-frames)
};
int run_stream(const StreamArgs& args, const Output& out);
// stream --metadata-model: the probe-less loop (cli/cmd_stream_metadata.cpp).
int run_stream_metadata(const StreamArgs& args, const Output& out);

struct MergeArgs {
  std::vector<std::string> urls;    // light servers: http://HOST:PORT
  std::string listen = "127.0.0.1:8090";
  std::string token;                // for our server
  std::string upstream_token;       // for the cameras' servers
  std::string weights;              // one per URL (e.g. from camera positions)
  int n = 256;                      // q2tree light count of the merge
  double timeout = 2.0;             // drop a camera silent this long
  double duration = 0;
};
int run_merge(const MergeArgs& args, const Output& out);

struct EvalEstimatorsArgs {
  std::vector<std::string> inputs;  // base maps ("scene": the procedural scene) or sequence directories
  // bis-mix / smc-mix: BIS, and SMC's BIS initialisation, with half the proposals from the map
  std::string estimators = "mis,bis,bis-mix,smc,smc-mix";
  std::string budgets = "4,16,64,256";  // samples with a visibility test per estimate
  std::string scenarios = "moving-light,abrupt-switch,flicker";  // applied to base maps
  int frames = 12;                  // per scenario (a directory: its first `frames` maps)
  int repeats = 4;                  // independent runs per estimate (variance across them)
  std::string size = "256x128";     // every map is resampled to this latlong size first
  int bis_m = 8;                    // BIS proposals per resampled sample (M = bis_m N)
  double ray_cost_us = 0;           // modelled cost of one visibility test, added to the measured time
  bool sweep = true;                // the SMC parameter sweep (budget 16)
  bool quick = false;               // demo: 4 frames, 2 repeats, budgets 4,16,64, no sweep
  uint64_t seed = 1;
  std::string output_dir;
};
int run_eval_estimators(const EvalEstimatorsArgs& args, const Output& out);
// Many-light shading (Havran 2005 section 4): culling regions, glossy sets, clustering.
struct ShadingTableArgs {
  std::string method = "pharr";     // a progressive sampler: pharr|hemigon
  int n = 256;                      // |H| (the lights of the diffuse tables)
  int low_per_high = 8;             // |L| / |H|
  int regions = 256;                // S_H culling regions
  int cone_regions = 512;           // S_L regions
  int lut = 64;                     // cube-map LUT texels per face edge
  double cone_deg = 8;              // cone half-angle gamma/2 around the reflected direction
  int k = 256;                      // at most k L lights per cone
  int q = 0;                        // clustering to at most Q lights (0: |H| / 4)
  bool region_copies = false;       // shader reads per-region copies instead of index lists
};

struct EvalShadingArgs {
  std::vector<std::string> maps;    // "scene" renders the procedural scene
  std::string counts = "64,256,1024,4096";
  ShadingTableArgs tables;          // n is taken from counts
  int points = 0;                   // shading points per timing run (0: ~8M light evaluations)
  bool coherent = false;            // shade points in the order of their normal's region
  std::string output_dir;
};
int run_eval_shading(const EvalShadingArgs& args, const Output& out);

struct TablesArgs {
  std::string input;                // a map
  std::string layout;               // input layout override
  ShadingTableArgs tables;
  std::string output;               // .json, or the binary texture (.lpst / anything else)
};
int run_tables(const TablesArgs& args, const Output& out);
// estimate metadata / query, synth walkthrough, eval metadata: lighting without a probe,
// from camera metadata over a floor quadtree (seed 003; docs/metadata.md).
struct EstimateMetadataArgs {
  std::string track;                // JSONL track (estimate/metadata_track.h)
  std::string output;               // model.json
  std::string photometric;          // calib photometric result: k for the calibration route
  bool meter_equation = false;      // ignore any photometric scale (also the track's)
  double calibration_f_number = -1; // -1: the track header's (or 0)
  double f_number = -1, ae_target = -1, iso_base = -1, meter_constant = -1;  // -1: the track's
  std::string colour_matrix;        // 9 numbers, camera RGB -> Rec. 709 (default: the track's, else none)
  double root_size = 32, min_size = 1, max_weight = 0;
  std::string origin;               // "X,Y"; default the first frame's position
};
int run_estimate_metadata(const EstimateMetadataArgs& args, const Output& out);

struct EstimateQueryArgs {
  std::string model;
  std::string at;                   // "X,Y" or "X,Y,Z" (z ignored: the model is 2D)
  std::string output;               // light list; format from --format or the extension
  std::string format;
  double min_frames = 1;            // frames that make a sector informed (1: the paper's rule)
  double shrink = 0;                // > 0: hierarchical shrinkage with this prior weight
  int max_depth = -1;
};
int run_estimate_query(const EstimateQueryArgs& args, const Output& out);

struct SynthWalkthroughArgs {
  std::string output_dir;
  double fps = 10, speed = 0.7;
  int rays = 16;                    // camera rays across
  int probe_size = 128;             // latlong width of the query probes
  int samples = 4;                  // per pixel edge
  bool no_mean_code = false;        // the camera does not report its metered mean
  bool bright_rgb = false;          // record the brightest pixels' colour
};
int run_synth_walkthrough(const SynthWalkthroughArgs& args, const Output& out);

struct EvalMetadataArgs {
  std::string input_dir;            // from synth walkthrough
  std::string output_dir;
  std::string fractions = "0.1,0.25,0.5,0.75,1";
  double root_size = 0;             // 0: twice the room's larger side
  double min_size = 1;
};
int run_eval_metadata(const EvalMetadataArgs& args, const Output& out);

// Shared parsing helpers; throw lp::InputError naming the option.
// --methods: comma-separated method names or "all".
std::vector<Method> parse_method_list(const std::string& text);
void parse_size(const std::string& text, const char* option, int* width, int* height);
std::vector<int> parse_int_list(const std::string& text, const char* option);
// --rotation: "yaw,pitch,roll" in degrees or 9 numbers (row-major world_from_probe).
Mat3 parse_rotation(const std::string& text);
// Comma-separated numbers, exactly `count` of them (0: any).
std::vector<double> parse_numbers(const std::string& text, const char* option, size_t count = 0);

}  // namespace lp::cli
