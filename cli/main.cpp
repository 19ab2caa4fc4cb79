// lightprobe: cameras into live light probes. Subcommands by pipeline stage; see
// ../shared/CONVENTIONS.md "The command line" for the shapes scripts rely on.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cstdio>
#include <exception>

#include "cli/commands.h"
#include "core/error.h"

namespace {

constexpr const char* kDescription =
    "lightprobe: calibrate cameras, capture HDR light probes and turn them into\n"
    "directional lights for renderers, live.\n\n"
    "Example session:\n"
    "  lightprobe synth scene -o scene.exr --size 1024x512\n"
    "  lightprobe info scene.exr\n"
    "  lightprobe sample scene.exr --method q2tree --n 256 -o lights.json --overlay lights.png\n"
    "  lightprobe eval sampling scene.exr --methods all -o eval/\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace lp::cli;
  CLI::App app{kDescription, "lightprobe"};
  app.set_version_flag("--version", std::string("lightprobe ") + LIGHTPROBE_VERSION);
  app.require_subcommand(1);
  // A rig's setup in one file: TOML with a section per command, e.g. [stream] source = "aravis"
  // (usable after the subcommand too: lightprobe stream --config rig.toml).
  app.set_config("--config", "", "TOML file of options, one [section] per command (e.g. [stream])");
  app.fallthrough();
  Output out;
  app.add_flag("--json", out.json, "Print the report as one JSON object on stdout")->configurable(false);
  app.add_flag("!--no-progress", out.progress, "Never draw progress bars");

  // info
  InfoArgs info;
  auto* c_info = app.add_subcommand("info", "Layout, size, dynamic range, power and luminance of maps");
  c_info->add_option("FILE", info.files, "Environment maps (.exr, .hdr, .pfm)")->required();
  c_info->add_option("--layout", info.layout, "Read as this layout: latlong|hemisphere|healpix");
  c_info->add_flag("--json", out.json, "Print the report as JSON");

  // convert
  ConvertArgs conv;
  auto* c_conv = app.add_subcommand("convert", "Convert a map between layouts, sizes, formats and frames");
  c_conv->add_option("IN", conv.input, "Input map, or a directory of cube faces px nx py ny pz nz")->required();
  c_conv->add_option("OUT", conv.output, "Output map (.exr, .hdr, .pfm)")->required();
  c_conv->add_option("--layout", conv.layout, "Target layout: latlong|hemisphere|healpix (default: the input's)");
  c_conv->add_option("--size", conv.size, "Target size WxH (latlong, hemisphere)");
  c_conv->add_option("--nside", conv.nside, "Target HEALPix nside (power of two)");
  c_conv->add_option("--in-layout", conv.in_layout, "Read the input as this layout");
  c_conv->add_option("--rotation", conv.rotation,
                     "Turn the map into the world: 'yaw,pitch,roll' in degrees or 9 numbers (row-major)");
  c_conv->add_flag("--half", conv.half, "Write EXR as half floats");
  c_conv->add_flag("--json", out.json, "Print the report as JSON");

  PreviewArgs prev;
  auto* c_prev = app.add_subcommand("preview", "Tone-mapped PNG/JPEG of a radiance image or map, as stored");
  c_prev->add_option("IMAGE", prev.input, "Radiance image or map (.exr, .hdr, .pfm) or a camera image")->required();
  c_prev->add_option("-o,--output", prev.output, "PNG or JPEG")->required();
  c_prev->add_option("--percentile", prev.percentile, "Luminance percentile shown at 0.8 after Reinhard");
  c_prev->add_flag("--json", out.json, "Print the report as JSON");

  // synth
  auto* c_synth = app.add_subcommand("synth", "Ground-truth makers");
  c_synth->require_subcommand(1);
  SynthSceneArgs scene;
  auto* c_scene = c_synth->add_subcommand("scene", "The procedural sky + sun + area lights scene");
  c_scene->add_option("-o,--output", scene.output, "Output map")->required();
  c_scene->add_option("--layout", scene.layout, "latlong|hemisphere|healpix");
  c_scene->add_option("--size", scene.size, "WxH (latlong, hemisphere)");
  c_scene->add_option("--nside", scene.nside, "HEALPix nside");
  c_scene->add_option("--sun-scale", scene.sun_scale, "Multiply the sun's radiance");
  c_scene->add_flag("--no-sun", scene.no_sun, "Leave the sun out");
  c_scene->add_flag("--json", out.json, "Print the report as JSON");

  SynthSequenceArgs seq;
  auto* c_seq = c_synth->add_subcommand("sequence", "A dynamic sequence with ground truth, one EXR per frame");
  c_seq->add_option("--scenario", seq.scenario,
                    "static-noise|moving-light|swinging-bulb|abrupt-switch|flicker|rising-light|camera-turn");
  c_seq->add_option("--base", seq.base, "Base map file, or 'scene' (the procedural scene at 512x256)");
  c_seq->add_option("--frames", seq.frames, "Number of frames");
  c_seq->add_option("--fps", seq.fps, "Frame rate (flicker aliasing depends on it)");
  c_seq->add_option("--seed", seq.seed, "Noise seed");
  c_seq->add_option("--size", seq.size, "Resample the base to WxH first");
  c_seq->add_option("-o,--output", seq.output_dir, "Output directory (frame_0000.exr ..., truth.json)")->required();
  c_seq->add_flag("--json", out.json, "Print the report as JSON");

  // sample
  SampleArgs samp;
  auto* c_samp = app.add_subcommand("sample", "Environment map -> directional lights");
  c_samp->add_option("MAP", samp.inputs, "A map, several maps (a sequence: NDJSON, one frame each) or a directory")
      ->required();
  c_samp->add_option("--method", samp.method, "pharr|hemigon|q2tree|mediancut");
  c_samp->add_option("--n", samp.n, "Number of lights, or 'auto' with --target-error");
  c_samp->add_option("--target-error", samp.target_error, "With --n auto: largest diffuse error (0.01 = 1 %)");
  c_samp->add_option("--format", samp.format, "json|ndjson|pbrt|mitsuba|gltf|csv (default: from -o's extension)");
  c_samp->add_option("-o,--output", samp.output, "Output file")->required();
  c_samp->add_option("--overlay", samp.overlay, "Also draw the lights on the tone-mapped map (PNG)");
  c_samp->add_option("--layout", samp.layout, "Read the input as this layout");
  c_samp->add_flag("--upper-only", samp.upper_only, "hemigon: sample only the upper hemisphere (sky probes)");
  c_samp->add_flag("--lloyd", samp.lloyd, "hemigon: Lloyd-relaxed Halton points");
  c_samp->add_option("--q2-a", samp.q2_a, "q2tree: luminance exponent a of p = L^a dw^b");
  c_samp->add_option("--q2-b", samp.q2_b, "q2tree: solid-angle exponent b of p = L^a dw^b");
  c_samp->add_flag("--q2-jitter", samp.q2_jitter, "q2tree: deterministic jitter instead of leaf centroids");
  c_samp->add_option("--q2-nside", samp.q2_nside, "q2tree: HEALPix resolution to bin to (0: from the input)");
  c_samp->add_option("--filter", samp.filter,
                     "Temporal FIR filter on power and directions: auto (hemigon only), on, off");
  c_samp->add_option("--fps", samp.fps, "Frame rate of a sequence (the FIR filter is designed for it)");
  c_samp->add_option("--cluster", samp.cluster, "Cluster the lights to at most this many (Havran 2005 4.3)");
  c_samp->add_flag("--json", out.json, "Print the report as JSON");

  // eval
  auto* c_eval = app.add_subcommand("eval", "Speed against accuracy of each method");
  c_eval->require_subcommand(1);
  EvalSamplingArgs evs;
  auto* c_evs = c_eval->add_subcommand("sampling", "Time and error of every sampler and light count");
  c_evs->add_option("MAP", evs.maps, "Maps to evaluate ('scene' for the procedural scene)")->required();
  c_evs->add_option("--methods", evs.methods, "Comma-separated methods or 'all'");
  c_evs->add_option("--n", evs.counts, "Comma-separated light counts");
  c_evs->add_option("-o,--output", evs.output_dir, "Directory for sampling.csv and the charts")->required();
  c_evs->add_option("--repeats", evs.repeats, "Timing repeats per point (0: adaptive)");
  c_evs->add_flag("--no-shadowed", evs.no_shadowed, "Skip the shadowed error (its reference is the slow part)");
  c_evs->add_flag("--json", out.json, "Print the report as JSON");

  EvalTemporalArgs evt;
  auto* c_evt = c_eval->add_subcommand("temporal", "Flicker, jitter and lag of every method on dynamic scenarios");
  c_evt->add_option("MAP", evt.maps, "Base maps ('scene' for the procedural scene)")->required();
  c_evt->add_option("--methods", evt.methods, "Comma-separated methods or 'all'");
  c_evt->add_option("--scenarios", evt.scenarios, "Comma-separated scenarios or 'all'");
  c_evt->add_option("--frames", evt.frames, "Frames per scenario");
  c_evt->add_option("--n", evt.n, "Lights per frame");
  c_evt->add_option("--fps", evt.fps, "Frame rate");
  c_evt->add_option("--filter", evt.filter, "FIR filtering: auto (hemigon only), on, off");
  c_evt->add_option("-o,--output", evt.output_dir, "Directory for temporal.csv and temporal.svg")->required();
  c_evt->add_flag("--json", out.json, "Print the report as JSON");

  EvalEstimatorsArgs eve;
  auto* c_eve = c_eval->add_subcommand("estimators", "MIS, BIS and SMC reflected-radiance estimators: error, temporal noise, time");
  c_eve->add_option("SEQ|MAP", eve.inputs, "Sequence directories, base maps for the scenarios, or 'scene'")->required();
  c_eve->add_option("--estimators", eve.estimators, "Comma-separated: mis, bis, bis-mix, smc, smc-mix (-mix: half the BIS proposals from the map)");
  c_eve->add_option("--budgets", eve.budgets, "Comma-separated samples per estimate (visibility tests)");
  c_eve->add_option("--scenarios", eve.scenarios, "Scenarios built on base maps (comma-separated or 'all')");
  c_eve->add_option("--frames", eve.frames, "Frames per scenario (a directory: its first frames)");
  c_eve->add_option("--repeats", eve.repeats, "Independent runs per estimate (variance across them)");
  c_eve->add_option("--size", eve.size, "Latlong size every map is resampled to (WxH)");
  c_eve->add_option("--bis-m", eve.bis_m, "BIS/SMC-initialisation proposals per sample (M = m N)");
  c_eve->add_option("--seed", eve.seed, "Random seed");
  c_eve->add_option("--ray-cost-us", eve.ray_cost_us, "Modelled microseconds per visibility test, added to the time");
  c_eve->add_flag("--no-sweep", [&](int64_t) { eve.sweep = false; }, "Skip the SMC parameter sweep");
  c_eve->add_flag("--quick", eve.quick, "Demo: 4 frames, 2 runs, budgets 4,16,64, no sweep");
  c_eve->add_option("-o,--output", eve.output_dir, "Directory for estimators.csv/.svg and smc_sweep.csv/.svg")->required();
  c_eve->add_flag("--json", out.json, "Print the report as JSON");

  EvalShadingArgs evsh;
  auto* c_evsh = c_eval->add_subcommand(
      "shading", "Speed-up and error of culled, glossy two-strata and clustered many-light shading");
  auto add_table_options = [](CLI::App* c, ShadingTableArgs& t) {
    c->add_option("--method", t.method, "Progressive sampler for the lights: pharr|hemigon");
    c->add_option("--low-per-high", t.low_per_high, "|L| / |H|: dense lights per glossy-cone light");
    c->add_option("--regions", t.regions, "Culling regions (S_H)");
    c->add_option("--cone-regions", t.cone_regions, "Glossy-cone regions (S_L)");
    c->add_option("--lut", t.lut, "Cube-map LUT texels per face edge");
    c->add_option("--cone", t.cone_deg, "Cone half-angle around the reflected direction, degrees");
    c->add_option("--k", t.k, "At most this many L lights per cone (power rescaled)");
    c->add_option("--q", t.q, "Cluster to at most Q lights (0: |H| / 4)");
  };
  c_evsh->add_option("MAP", evsh.maps, "Maps to evaluate ('scene' for the procedural scene)")->required();
  c_evsh->add_option("--n", evsh.counts, "Comma-separated light counts |H|");
  c_evsh->add_option("--points", evsh.points, "Shading points per timing run (0: automatic)");
  c_evsh->add_flag("--region-copies", evsh.tables.region_copies,
                   "Shade from per-region copies of the lights instead of index lists into one array");
  c_evsh->add_flag("--coherent", evsh.coherent,
                   "Shade points in the order of their normal's region, as neighbouring pixels come (default: random)");
  add_table_options(c_evsh, evsh.tables);
  c_evsh->add_option("-o,--output", evsh.output_dir, "Directory for shading.csv and shading.svg")->required();
  c_evsh->add_flag("--json", out.json, "Print the report as JSON");

  TablesArgs tabl;
  auto* c_tabl = app.add_subcommand("tables", "Shading tables of a map for a renderer (angular regions, glossy sets, clusters)");
  c_tabl->add_option("MAP", tabl.input, "Environment map")->required();
  c_tabl->add_option("--layout", tabl.layout, "Read the map as this layout");
  c_tabl->add_option("--n", tabl.tables.n, "Lights |H| of the diffuse tables");
  add_table_options(c_tabl, tabl.tables);
  c_tabl->add_option("-o,--output", tabl.output, "Output: .json, or the RGBA32F texture file (any other name)")->required();
  c_tabl->add_flag("--json", out.json, "Print the report as JSON");

  // hdr
  auto* c_hdr = app.add_subcommand("hdr", "Exposure brackets and log sensors -> radiance");
  c_hdr->require_subcommand(1);
  HdrResponseArgs hresp;
  auto* c_hresp = c_hdr->add_subcommand("response", "Recover a camera's response curve from brackets");
  c_hresp->add_option("IMAGE", hresp.images, "Bracket frames (8/16-bit PNG, JPEG, TIFF)")->required();
  c_hresp->add_option("--exposure-times", hresp.exposure_times, "Seconds per frame ('1/40' allowed) or a list file; default EXIF");
  c_hresp->add_option("--method", hresp.method, "debevec|robertson");
  c_hresp->add_option("--lambda", hresp.lambda, "Debevec smoothness weight");
  c_hresp->add_option("--ignore-colour", hresp.ignore_colour, "r,g,b of registration borders to leave out");
  c_hresp->add_option("-o,--output", hresp.output, "response.json")->required();
  c_hresp->add_flag("--json", out.json, "Print the report as JSON");
  HdrFuseArgs hfuse;
  auto* c_hfuse = c_hdr->add_subcommand("fuse", "Fuse a bracket (or decode a log sensor frame) into radiance");
  c_hfuse->add_option("IMAGE", hfuse.images, "Bracket frames, or one frame of a log sensor")->required();
  c_hfuse->add_option("--exposure-times", hfuse.exposure_times, "Seconds per frame or a list file; default EXIF");
  c_hfuse->add_option("--response", hfuse.response, "Saved response (hdr response); default: recovered here");
  c_hfuse->add_flag("--linear", hfuse.linear, "Linear sensor: no response curve");
  c_hfuse->add_option("--photometric", hfuse.photometric, "Photometric calibration: absolute units");
  c_hfuse->add_option("--align", hfuse.align, "Align hand-held frames: none|mtb|ecc");
  c_hfuse->add_flag("--deghost", hfuse.deghost, "Drop moving objects from the frames that disagree");
  c_hfuse->add_flag("--no-exposure-weighting", hfuse.no_exposure_weighting,
                    "Plain hat weights instead of noise-aware ones (every frame trusted alike)");
  c_hfuse->add_option("--ignore-colour", hfuse.ignore_colour, "r,g,b of registration borders to leave out");
  c_hfuse->add_option("-o,--output", hfuse.output, "probe.exr")->required();
  c_hfuse->add_flag("--json", out.json, "Print the report as JSON");

  // calib
  auto* c_calib = app.add_subcommand("calib", "Camera calibration");
  c_calib->require_subcommand(1);
  CalibPhotometricArgs cphot;
  auto* c_cphot = c_calib->add_subcommand("photometric", "Absolute scale (or log-sensor curve) from meter readings");
  c_cphot->add_option("READINGS", cphot.readings, "CSV: region,camera_value,measured,unit")->required();
  c_cphot->add_option("--model", cphot.model, "linear|log");
  c_cphot->add_option("--loss", cphot.loss, "Robust loss: huber|cauchy|none");
  c_cphot->add_option("-o,--output", cphot.output, "photometric.json")->required();
  c_cphot->add_flag("--json", out.json, "Print the report as JSON");

  CalibGeometricArgs cgeo;
  auto* c_cgeo = c_calib->add_subcommand("geometric", "Chessboard calibration with model selection by cross-validation");
  c_cgeo->add_option("IMAGE", cgeo.images, "Chessboard views (one camera, one resolution)")->required();
  c_cgeo->add_option("--board", cgeo.board, "COLSxROWS inner corners, e.g. 9x6")->required();
  c_cgeo->add_option("--square", cgeo.square_mm, "Square size, mm")->required();
  c_cgeo->add_option("--model", cgeo.model, "Use this model instead of the selection (see the printed table)");
  c_cgeo->add_flag("--no-mrcal", cgeo.no_mrcal, "OpenCV models only");
  c_cgeo->add_option("--report", cgeo.report_dir, "Directory for the residual and coverage pictures");
  c_cgeo->add_option("--drop-influential", cgeo.drop_influential,
                     "Recalibrate without up to N views flagged influential (highest leverage first)");
  c_cgeo->add_option("-o,--output", cgeo.output, "camera.cameramodel (and .yaml) or camera.yaml")->required();
  c_cgeo->add_flag("--json", out.json, "Print the report as JSON");

  CalibCompareArgs ccmp;
  auto* c_ccmp = c_calib->add_subcommand("compare", "Projection difference (px) between two models of one camera");
  c_ccmp->add_option("A", ccmp.a, "Model file (.cameramodel or OpenCV YAML)")->required();
  c_ccmp->add_option("B", ccmp.b, "Model file")->required();
  c_ccmp->add_option("--step", ccmp.step_px, "Sampling step over the image, px");
  c_ccmp->add_flag("--no-rotation", ccmp.no_rotation, "Do not fit the rotation between the two camera frames");
  c_ccmp->add_flag("--json", out.json, "Print the report as JSON");

  CalibColourArgs ccol;
  auto* c_ccol = c_calib->add_subcommand("colour", "3x3 colour match of the probe camera to a backplate camera");
  c_ccol->add_option("PATCHES", ccol.patches, "CSV: probe_r,probe_g,probe_b,plate_r,plate_g,plate_b")->required();
  c_ccol->add_option("-o,--output", ccol.output, "colour.json")->required();
  c_ccol->add_flag("--json", out.json, "Print the report as JSON");

  SynthBoardsArgs sbo;
  auto* c_sbo = c_synth->add_subcommand("boards", "Chessboard views rendered through a known camera (ground truth)");
  c_sbo->add_option("--views", sbo.views, "Number of views");
  c_sbo->add_option("--board", sbo.board, "COLSxROWS inner corners");
  c_sbo->add_option("--square", sbo.square_mm, "Square size, mm");
  c_sbo->add_option("--noise", sbo.noise, "Image noise (0..1 units)");
  c_sbo->add_option("--fov", sbo.fov, "Image circle, deg (0: the model's own domain)");
  c_sbo->add_option("--camera", sbo.camera, "Camera model file (default: 190 deg Kannala-Brandt 1280x960)");
  c_sbo->add_option("--seed", sbo.seed, "Seed");
  c_sbo->add_option("-o,--output", sbo.output_dir, "Directory for board_NN.png, truth.json, true_camera.yaml")->required();
  c_sbo->add_flag("--json", out.json, "Print the report as JSON");

  SynthBracketArgs sbr;
  auto* c_sbr = c_synth->add_subcommand("bracket", "A bracket with known response, noise and truth from a radiance map");
  c_sbr->add_option("INPUT", sbr.input, "Radiance map or image, or 'scene'");
  c_sbr->add_option("--exposure-times", sbr.exposure_times, "Seconds, default 1/64,1/8,1");
  c_sbr->add_option("--response", sbr.response, "linear|gamma|scurve");
  c_sbr->add_flag("--no-noise", sbr.no_noise, "No shot or read noise");
  c_sbr->add_option("--bit-depth", sbr.bit_depth, "8 or 16");
  c_sbr->add_option("--shake", sbr.shake_px, "Camera shake, max px per frame");
  c_sbr->add_flag("--moving-object", sbr.moving_object, "A bright square moving between frames");
  c_sbr->add_option("--seed", sbr.seed, "Noise seed");
  c_sbr->add_option("-o,--output", sbr.output_dir, "Directory for frames, exposures.csv, truth")->required();
  c_sbr->add_flag("--json", out.json, "Print the report as JSON");

  EvalHdrArgs evh;
  auto* c_evh = c_eval->add_subcommand("hdr", "Error and time of HDR fusion against OpenCV on synthetic brackets");
  c_evh->add_option("MAP", evh.maps, "Radiance maps ('scene' for the procedural scene)")->required();
  c_evh->add_option("--response", evh.response, "Camera response of the synthetic brackets: linear|gamma|scurve");
  c_evh->add_option("-o,--output", evh.output_dir, "Directory for hdr.csv and hdr.svg")->required();
  c_evh->add_flag("--json", out.json, "Print the report as JSON");

  EvalCalibArgs evc;
  auto* c_evc = c_eval->add_subcommand("calib", "Our geometric calibration against OpenCV run alone; synthetic sweep");
  c_evc->add_option("IMAGE", evc.images, "Chessboard views of one camera (optional with --sweep)");
  c_evc->add_option("--board", evc.board, "COLSxROWS inner corners");
  c_evc->add_option("--square", evc.square_mm, "Square size, mm");
  c_evc->add_flag("--sweep", evc.sweep, "Views 4..20 and noise 0.05..0.5 px on synthetic corners: error vs truth");
  c_evc->add_option("-o,--output", evc.output_dir, "Directory for calib_compare.csv, calib_sweep.csv/.svg")->required();
  c_evc->add_flag("--json", out.json, "Print the report as JSON");

  // probe
  auto* c_probe = app.add_subcommand("probe", "Mirror-ball and fisheye probes -> environment maps");
  c_probe->require_subcommand(1);
  ProbeUnwrapArgs pun;
  auto* c_pun = c_probe->add_subcommand("unwrap", "Unwrap a probe image (or a sequence) into a map in the world frame");
  c_pun->add_option("IMAGE", pun.inputs, "Probe image(s) or a directory of frames")->required();
  c_pun->add_option("--type", pun.type, "mirrorball|fisheye");
  c_pun->add_option("--camera", pun.camera, "fisheye: calibrated model (.cameramodel or OpenCV YAML, any lens model)");
  c_pun->add_option("--fov", pun.fov,
                    "fisheye: field of view (deg): of the equidistant default model, or the image circle of --camera; "
                    "ball: the camera's field of view");
  c_pun->add_option("--distance", pun.distance, "ball: camera distance in ball radii (default orthographic)");
  c_pun->add_option("--ball", pun.ball, "ball: 'cx,cy,r' in pixels instead of detection");
  c_pun->add_option("--reflectivity", pun.reflectivity, "ball: reflectivity at normal incidence (chrome ~0.6-0.7)");
  c_pun->add_flag("--fresnel", pun.fresnel, "ball: reflectivity rises towards the rim (Schlick)");
  c_pun->add_option("--blind-spot", pun.blind_spot_deg, "ball: half-angle (deg) masked around the blind spot");
  c_pun->add_flag("--fill", pun.fill, "Fill what the camera cannot see smoothly (mask kept)");
  c_pun->add_flag("--smooth-track", pun.stabilise,
                   "Sequences: smooth the per-frame ball / image-circle track (a fixed probe, noisy detection)");
  c_pun->add_flag("--static-probe", pun.static_probe, "With --smooth-track: one median position for every frame");
  c_pun->add_flag("--fixed-ball", pun.fixed_ball, "Sequences: no tracking, frame 0's geometry for all (for comparison)");
  c_pun->add_option("--colour-match", pun.colour_match, "3x3 colour transform to the backplate (calib colour)");
  c_pun->add_option("--rotation", pun.rotation, "Probe to world: 'yaw,pitch,roll' degrees or 9 numbers");
  c_pun->add_option("--layout", pun.layout, "latlong|hemisphere|healpix");
  c_pun->add_option("--size", pun.size, "WxH");
  c_pun->add_option("--nside", pun.nside, "healpix nside");
  c_pun->add_option("-o,--output", pun.output, "Output map (or directory for a sequence)")->required();
  c_pun->add_flag("--json", out.json, "Print the report as JSON");

  ProbeRegisterArgs preg;
  auto* c_preg = c_probe->add_subcommand("register", "Centre one ball in differently cropped photos (for hdr fuse)");
  c_preg->add_option("IMAGE", preg.images, "Photos of the same mirror ball")->required();
  c_preg->add_option("--size", preg.size, "Output square size, px");
  c_preg->add_option("-o,--output", preg.output_dir, "Directory for the registered photos (PNG)")->required();
  c_preg->add_flag("--json", out.json, "Print the report as JSON");

  SynthProbeArgs spr;
  auto* c_spr = c_synth->add_subcommand("probe", "Ray-trace a mirror ball or fisheye view of a map (ground truth)");
  c_spr->add_option("MAP", spr.input, "A latlong map, or 'scene'");
  c_spr->add_option("--type", spr.type, "mirrorball|fisheye");
  c_spr->add_option("--size", spr.size, "Image WxH");
  c_spr->add_option("--radius", spr.radius, "Ball radius, px");
  c_spr->add_option("--distance", spr.distance, "Camera distance in ball radii (default orthographic)");
  c_spr->add_option("--fov", spr.fov, "Fisheye field of view, deg");
  c_spr->add_option("--noise", spr.noise, "Relative Gaussian noise");
  c_spr->add_option("--frames", spr.frames, "Frames (a jittered sequence)");
  c_spr->add_option("--jitter", spr.jitter, "Ball centre jitter per frame, px");
  c_spr->add_option("--seed", spr.seed, "Noise seed");
  c_spr->add_option("-o,--output", spr.output, "Image (or directory for a sequence)")->required();
  c_spr->add_flag("--json", out.json, "Print the report as JSON");

  EvalUnwrapArgs evu;
  auto* c_evu = c_eval->add_subcommand("unwrap", "Unwrapping error and centre error on synthetic probes");
  c_evu->add_option("MAP", evu.maps, "Latlong maps ('scene' for the procedural scene)")->required();
  c_evu->add_option("-o,--output", evu.output_dir, "Directory for unwrap.csv")->required();
  c_evu->add_flag("--json", out.json, "Print the report as JSON");

  // estimate: lighting without a probe, from camera metadata (docs/metadata.md)
  auto* c_est = app.add_subcommand("estimate", "Lighting without a probe, from camera metadata over space");
  c_est->require_subcommand(1);
  EstimateMetadataArgs emd;
  auto* c_emd = c_est->add_subcommand("metadata", "A recorded track (position, view, exposure, gain, WB per frame) -> quadtree model");
  c_emd->add_option("TRACK", emd.track, "JSONL track (see docs/metadata.md for the schema)")->required();
  c_emd->add_option("-o,--output", emd.output, "Model JSON")->required();
  c_emd->add_option("--photometric", emd.photometric, "Photometric calibration (calib photometric): k for the calibration route");
  c_emd->add_flag("--meter-equation", emd.meter_equation, "Use the ISO 2720 meter equation even if a scale is known");
  c_emd->add_option("--calibration-f-number", emd.calibration_f_number, "Aperture the photometric scale was fitted at");
  c_emd->add_option("--f-number", emd.f_number, "Aperture of frames that record none");
  c_emd->add_option("--ae-target", emd.ae_target, "Mean code value the auto exposure aims at (0..1)");
  c_emd->add_option("--iso-base", emd.iso_base, "ISO at gain 1 (meter equation)");
  c_emd->add_option("--meter-constant", emd.meter_constant, "Reflected-light meter constant K, cd s m^-2");
  c_emd->add_option("--colour-matrix", emd.colour_matrix, "Camera RGB -> Rec. 709: 9 numbers, row-major");
  c_emd->add_option("--root-size", emd.root_size, "Side of the root cell, m (must cover the scene)");
  c_emd->add_option("--min-size", emd.min_size, "Smallest cell side, m");
  c_emd->add_option("--max-weight", emd.max_weight, "Cap on a sector's frame count: old frames fade (0: no cap)");
  c_emd->add_option("--origin", emd.origin, "Root centre X,Y in metres (default: the first frame's position)");
  c_emd->add_flag("--json", out.json, "Print the report as JSON");

  EstimateQueryArgs eq;
  auto* c_eq = c_est->add_subcommand("query", "Six directional lights of a model at a position");
  c_eq->add_option("MODEL", eq.model, "Model JSON (estimate metadata)")->required();
  c_eq->add_option("--at", eq.at, "Position X,Y[,Z] in metres")->required();
  c_eq->add_option("-o,--output", eq.output, "Light list (.json, .pbrt, .xml, .gltf, .csv)")->required();
  c_eq->add_option("--format", eq.format, "json|ndjson|pbrt|mitsuba|gltf|csv (default from -o)");
  c_eq->add_option("--min-frames", eq.min_frames, "Frames that make a sector informed (1: the paper's rule)");
  c_eq->add_option("--shrink", eq.shrink, "Hierarchical shrinkage with this prior weight in frames (0: off)");
  c_eq->add_option("--max-depth", eq.max_depth, "Descend at most this deep (0: the root's global estimate)");
  c_eq->add_flag("--json", out.json, "Print the report as JSON");

  SynthWalkthroughArgs swk;
  auto* c_swk = c_synth->add_subcommand("walkthrough", "A room walked by a metadata camera, with true probes at query points");
  c_swk->add_option("-o,--output", swk.output_dir, "Directory for track.jsonl, probes/, truth.json")->required();
  c_swk->add_option("--fps", swk.fps, "Camera frame rate");
  c_swk->add_option("--speed", swk.speed, "Walking speed, m/s");
  c_swk->add_option("--rays", swk.rays, "Camera rays across the frame");
  c_swk->add_option("--probe-size", swk.probe_size, "Latlong width of the query probes");
  c_swk->add_option("--samples", swk.samples, "Probe rays per pixel edge");
  c_swk->add_flag("--no-mean-code", swk.no_mean_code, "The camera does not report its metered mean (AE assumed on target)");
  c_swk->add_flag("--bright-rgb", swk.bright_rgb, "Record the brightest pixels' colour");
  c_swk->add_flag("--json", out.json, "Print the report as JSON");

  EvalMetadataArgs evm;
  auto* c_evm = c_eval->add_subcommand("metadata", "Diffuse error of the metadata model against real probes along a walk");
  c_evm->add_option("DIR", evm.input_dir, "Directory from synth walkthrough")->required();
  c_evm->add_option("-o,--output", evm.output_dir, "Directory for metadata.csv and metadata.svg")->required();
  c_evm->add_option("--fractions", evm.fractions, "Parts of the path to build the model from");
  c_evm->add_option("--root-size", evm.root_size, "Root cell side, m (0: twice the room's larger side)");
  c_evm->add_option("--min-size", evm.min_size, "Smallest cell side, m");
  c_evm->add_flag("--json", out.json, "Print the report as JSON");

  // stream
  StreamArgs strm;
  auto* c_strm = app.add_subcommand("stream", "Run the whole chain live and serve light lists over HTTP");
  c_strm->add_option("--source", strm.source, "replay:DIR | video:FILE | aravis[:ID] | libcamera[:ID] | v4l2:N");
  c_strm->add_option("--listen", strm.listen, "HOST:PORT to serve on (127.0.0.1 by default; port 0 picks one)");
  c_strm->add_option("--token", strm.token, "Bearer token required on every route (needed beyond localhost)");
  c_strm->add_option("--exposures", strm.exposures, "Bracketing: exposure times cycled by the camera, seconds");
  c_strm->add_option("--bracketing", strm.bracketing,
                     "auto: the camera's sequencer when it has one, else per-frame writes; sequencer; writes")
      ->check(CLI::IsMember({"auto", "sequencer", "writes"}));
  c_strm->add_option("--response", strm.response, "Camera response (hdr response); default linear");
  c_strm->add_option("--photometric", strm.photometric, "Photometric calibration: absolute units");
  c_strm->add_option("--camera", strm.camera, "Calibrated camera model (default: equidistant fisheye)");
  c_strm->add_option("--fov", strm.fov, "Fisheye field of view / image circle, deg");
  c_strm->add_option("--rotation", strm.rotation, "Probe to world: 'yaw,pitch,roll' degrees");
  c_strm->add_flag("--maps", strm.maps, "The source delivers environment maps already (replayed .exr)");
  c_strm->add_option("--layout", strm.layout, "latlong|hemisphere|healpix");
  c_strm->add_option("--size", strm.size, "Map size WxH");
  c_strm->add_option("--nside", strm.nside, "healpix nside");
  c_strm->add_option("--method", strm.method, "pharr|hemigon|q2tree|mediancut");
  c_strm->add_option("--n", strm.n, "Lights per frame");
  c_strm->add_option("--cluster", strm.cluster, "Cluster to at most this many lights");
  c_strm->add_option("--fps", strm.fps, "Replay pacing and the temporal filter's frame rate");
  c_strm->add_flag("--loop", strm.loop, "Replay: start over at the end");
  c_strm->add_option("--duration", strm.duration, "Stop after this many seconds");
  c_strm->add_option("--metadata-model", strm.metadata_model,
                     "Probe-less mode: meter each frame's exposure/gain into this model and serve its lights");
  c_strm->add_option("--position", strm.position, "Metadata mode: where the rig stands, X,Y m");
  c_strm->add_option("--view-dir", strm.view_dir, "Metadata mode: where the camera looks, x,y,z");
  c_strm->add_option("--min-frames", strm.min_frames, "Metadata mode: frames that make a sector informed");
  c_strm->add_flag("--json", out.json, "Print the final report as JSON");

  MergeArgs mrg;
  auto* c_mrg = app.add_subcommand("merge", "Merge the lights of several cameras' servers and serve the result");
  c_mrg->add_option("URL", mrg.urls, "Light servers, http://HOST:PORT")->required();
  c_mrg->add_option("--listen", mrg.listen, "HOST:PORT to serve the merged lights on");
  c_mrg->add_option("--token", mrg.token, "Bearer token for our server");
  c_mrg->add_option("--upstream-token", mrg.upstream_token, "Bearer token for the cameras' servers");
  c_mrg->add_option("--weights", mrg.weights, "Comma-separated weights, one per URL");
  c_mrg->add_option("--n", mrg.n, "Light count of a Q2-tree merge");
  c_mrg->add_option("--timeout", mrg.timeout, "Drop a camera silent for this many seconds");
  c_mrg->add_option("--duration", mrg.duration, "Stop after this many seconds");
  c_mrg->add_flag("--json", out.json, "Print the final report as JSON");

  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;
  }

  try {
    if (*c_info) return run_info(info, out);
    if (*c_prev) return run_preview(prev, out);
    if (*c_conv) return run_convert(conv, out);
    if (*c_scene) return run_synth_scene(scene, out);
    if (*c_samp) return run_sample(samp, out);
    if (*c_evs) return run_eval_sampling(evs, out);
    if (*c_seq) return run_synth_sequence(seq, out);
    if (*c_evt) return run_eval_temporal(evt, out);
    if (*c_eve) return run_eval_estimators(eve, out);
    if (*c_evsh) return run_eval_shading(evsh, out);
    if (*c_tabl) return run_tables(tabl, out);
    if (*c_hresp) return run_hdr_response(hresp, out);
    if (*c_hfuse) return run_hdr_fuse(hfuse, out);
    if (*c_cphot) return run_calib_photometric(cphot, out);
    if (*c_ccol) return run_calib_colour(ccol, out);
    if (*c_cgeo) return run_calib_geometric(cgeo, out);
    if (*c_ccmp) return run_calib_compare(ccmp, out);
    if (*c_sbo) return run_synth_boards(sbo, out);
    if (*c_sbr) return run_synth_bracket(sbr, out);
    if (*c_evh) return run_eval_hdr(evh, out);
    if (*c_evc) return run_eval_calib(evc, out);
    if (*c_pun) return run_probe_unwrap(pun, out);
    if (*c_spr) return run_synth_probe(spr, out);
    if (*c_preg) return run_probe_register(preg, out);
    if (*c_evu) return run_eval_unwrap(evu, out);
    if (*c_emd) return run_estimate_metadata(emd, out);
    if (*c_eq) return run_estimate_query(eq, out);
    if (*c_swk) return run_synth_walkthrough(swk, out);
    if (*c_evm) return run_eval_metadata(evm, out);
    if (*c_strm) return run_stream(strm, out);
    if (*c_mrg) return run_merge(mrg, out);
  } catch (const lp::InputError& e) {
    std::fprintf(stderr, "lightprobe: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lightprobe: internal error: %s\n", e.what());
    return 1;
  }
  return 1;
}
