// Issue 22, "garbage accepted", "exit codes and messages" and "signals": what a hostile or
// careless user gives the commands is refused in one line naming the file (exit 2, nothing
// written), and SIGINT / SIGTERM end a command with 130 / 143 and no temp file left.
#include <nlohmann/json.hpp>

#include <array>
#include <chrono>
#include <csignal>
#include <string>
#include <tuple>
#include <thread>

#include <fcntl.h>

#include "core/envmap.h"
#include "core/image_io.h"
#include "tests/cli/cli_run.h"

namespace lp::cli_test {
namespace {

std::string pinhole_model(const fs::path& path, const std::string& fx) {
  std::ofstream(path) << "{ 'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [" << fx
                      << ", 600, 319.5, 239.5], 'extrinsics': [0, 0, 0, 0, 0, 0], 'imagersize': [640, 480] }\n";
  return path.string();
}

TEST(GarbageCli, CameraFilesWithAFocalLengthThatIsNotPositiveAreRefusedNamingTheFile) {
  const fs::path dir = fresh_dir("focal");
  const std::string good = pinhole_model(dir / "good.cameramodel", "600");
  for (const std::string fx : {"0", "-600"}) {
    const std::string bad = pinhole_model(dir / "bad.cameramodel", fx);
    const CliRun r = lightprobe("calib compare " + good + " " + bad);
    expect_one_line_error(r, bad);
    EXPECT_NE(r.err.find("focal length fx"), std::string::npos) << r.err;
  }
}

TEST(GarbageCli, CalibCompareOverNoSampleSaysSoInsteadOfAnRmsOfZero) {
  const fs::path dir = fresh_dir("compare");
  const std::string a = pinhole_model(dir / "a.cameramodel", "600"), b = pinhole_model(dir / "b.cameramodel", "610");
  ASSERT_EQ(lightprobe("calib compare " + a + " " + b).code, 0);
  // A step larger than the image leaves no pixel to compare.
  const CliRun r = lightprobe("calib compare " + a + " " + b + " --step 100000");
  expect_one_line_error(r, "--step must be 1..160 px");
  EXPECT_EQ(r.out.find("RMS"), std::string::npos) << r.out;
}

TEST(GarbageCli, TimestampsThatAreNotOneIncreasingDecimalPerLineAreRefusedWithTheLine) {
  const fs::path dir = scratch() / "seq";
  fs::remove_all(dir);
  ASSERT_EQ(lightprobe("synth sequence --scenario static-noise --frames 3 --size 32x16 -o " + dir.string()).code, 0);
  const fs::path out = scratch() / "seq.ndjson";
  const std::string bad_lines[][2] = {
      {"0\n0.2\n0.1\n", "timestamps.txt:3"},  // backwards
      {"1\n1\n1\n", "timestamps.txt:2"},      // all equal
      {"0\n0.05x\n0.1\n", "timestamps.txt:2"},
      {"0\n0.1 0.2\n0.3\n", "timestamps.txt:2"},  // two columns
      {std::string("0\n0.1\0\n0.2\n", 11), "timestamps.txt:2"},  // a NUL byte
      {"0\n0x10\n20\n", "timestamps.txt:2"},  // hex (was read as 16 s)
  };
  for (const auto& [text, where] : bad_lines) {
    std::ofstream(dir / "timestamps.txt", std::ios::binary) << text;
    fs::remove(out);
    expect_one_line_error(lightprobe("sample " + dir.string() + " --method q2tree --n 12 -o " + out.string()), where);
    EXPECT_FALSE(fs::exists(out));
  }
  // Comments and blank lines stay allowed.
  std::ofstream(dir / "timestamps.txt") << "# seconds\n0\n\n0.05\n1e-1\n";
  EXPECT_EQ(lightprobe("sample " + dir.string() + " --method q2tree --n 12 -o " + out.string()).code, 0);
}

TEST(GarbageCli, StreamReplayRefusesAGarbageFrameAndPacesByTimestamps) {
  const fs::path dir = fresh_dir("replay");
  ASSERT_EQ(lightprobe("synth scene --size 64x32 -o " + (dir / "a.exr").string()).code, 0);
  std::ofstream(dir / "b.exr") << "not an image\n";
  const CliRun r = lightprobe("stream --maps --source replay:" + dir.string() + " --duration 5 --listen 127.0.0.1:0");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_EQ(line_count(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("b.exr"), std::string::npos) << r.err;
  // Bad timestamps are refused with their line before anything streams.
  fs::remove(dir / "b.exr");
  fs::copy_file(dir / "a.exr", dir / "c.exr");
  std::ofstream(dir / "timestamps.txt") << "5\n0x10\n";
  expect_one_line_error(lightprobe("stream --maps --source replay:" + dir.string() + " --duration 5 --listen 127.0.0.1:0"),
                        "timestamps.txt:2");
}

// Replayed maps take their own layout and size when none is given: the default hemisphere
// 360x90 refused every latlong map ("replayed map is 64x32, the pipeline expects ..."). A
// geometry given that the maps do not have is refused, saying what the options describe.
TEST(GarbageCli, StreamReplayOfMapsTakesTheirOwnLayoutAndSize) {
  const fs::path dir = fresh_dir("replay_maps");
  ASSERT_EQ(lightprobe("synth scene --size 64x32 -o " + (dir / "a.exr").string()).code, 0);
  fs::copy_file(dir / "a.exr", dir / "b.exr");
  const CliRun r = lightprobe("stream --maps --source replay:" + dir.string() + " --duration 2 --listen 127.0.0.1:0 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("\"brackets_processed\":2"), std::string::npos) << r.out;
  expect_one_line_error(lightprobe("stream --maps --source replay:" + dir.string() +
                                   " --layout latlong --size 128x64 --duration 2 --listen 127.0.0.1:0"),
                        "with --maps, --layout and --size (or --nside) describe the maps replayed");
  // The default layout written out is a geometry given, not its absence.
  expect_one_line_error(lightprobe("stream --maps --source replay:" + dir.string() +
                                   " --layout hemisphere --duration 2 --listen 127.0.0.1:0"),
                        "with --maps, --layout and --size (or --nside) describe the maps replayed");
}

// A fisheye without --camera or --fov was unwrapped through a guessed lens (equidistant,
// 180 deg, its circle inscribed in the frame) with exit 0.
TEST(GarbageCli, AFisheyeWithoutItsLensIsRefusedAndAnIdealOneIsUnwrappedAsGiven) {
  const fs::path dir = fresh_dir("fisheye_lens");
  const std::string image = (dir / "sky.exr").string(), out = (dir / "sky_map.exr").string();
  ASSERT_EQ(lightprobe("synth probe scene --type fisheye --fov 190 --size 128x128 -o " + image).code, 0);
  expect_one_line_error(lightprobe("probe unwrap " + image + " --type fisheye --layout hemisphere -o " + out),
                        "--type fisheye needs the lens: --camera MODEL");
  EXPECT_FALSE(fs::exists(out));
  const CliRun r = lightprobe("probe unwrap " + image + " --type fisheye --fov 190 --layout hemisphere -o " + out);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_TRUE(fs::exists(out));
  // A stream guesses the lens too, but runs (a rig is set up live): it says so, once it is up.
  const fs::path frames = dir / "frames";
  ASSERT_EQ(lightprobe("synth bracket scene --exposure-times 0.01,0.1 -o " + frames.string()).code, 0);
  const std::string stream = "stream --duration 1 --listen 127.0.0.1:0 --exposures 0.01,0.1 --source ";
  const CliRun guessed = lightprobe(stream + "replay:" + frames.string());
  EXPECT_EQ(guessed.code, 0) << guessed.err;
  EXPECT_EQ(line_count(guessed.err), 1) << guessed.err;
  EXPECT_NE(guessed.err.find("warning: no --camera: frames are unwrapped as an ideal equidistant fisheye of 180 deg"),
            std::string::npos)
      << guessed.err;
  const CliRun fake = lightprobe(stream + "aravis:Fake_1");
  EXPECT_EQ(fake.code, 0) << fake.err;
  EXPECT_EQ(fake.err.find("no --camera"), std::string::npos) << "Aravis' simulated camera has no lens: " << fake.err;
}

// Numbers out of range were taken for a default, flipped, or ran a stream until it was
// killed, with exit 0 (found by giving every numeric option -1, nan and 0).
TEST(GarbageCli, NumbersOutOfRangeAreRefusedNotTakenForDefaults) {
  const fs::path dir = fresh_dir("out_of_range");
  const std::string image = (dir / "sky.exr").string(), out = (dir / "out.exr").string();
  ASSERT_EQ(lightprobe("synth probe scene --type fisheye --fov 190 --size 64x64 -o " + image).code, 0);
  expect_one_line_error(lightprobe("probe unwrap " + image + " --type fisheye --fov -190 --layout hemisphere -o " + out),
                        "--fov must be a field of view in degrees, got -190");
  expect_one_line_error(lightprobe("probe unwrap " + image + " --type mirrorball --distance -3 --layout hemisphere -o " + out),
                        "--distance must be 0 (orthographic) or more, got -3");
  // A negative --nside was taken for the default (healpix 64) with exit 0.
  expect_one_line_error(lightprobe("probe unwrap " + image + " --type fisheye --fov 190 --layout healpix --nside -8 -o " + out),
                        "--nside must be a power of two (0: the default), got -8");
  expect_one_line_error(lightprobe("convert " + image + " " + out + " --layout healpix --nside -4"), "got -4");
  // Ground truth that says what it rendered: these were taken for the defaults, or flipped.
  for (const auto& [flag, message] : std::vector<std::pair<std::string, std::string>>{
           {"--radius -5", "--radius must be 0 (the default) or more, got -5"},
           {"--distance nan", "--distance must be 0 (orthographic) or more, got nan"},
           {"--noise -0.1", "--noise must be 0 or more, got -0.1"},
           {"--type fisheye --fov -190", "--fov must be in (0, 360] degrees, got -190"}})
    expect_one_line_error(lightprobe("synth probe scene --size 64x64 " + flag + " -o " + out), message);
  expect_one_line_error(lightprobe("synth boards --views 2 --noise nan -o " + (dir / "boards").string()),
                        "--noise must be 0 or more, got nan");
  expect_one_line_error(lightprobe("synth boards --views 2 --fov -190 -o " + (dir / "boards").string()),
                        "--fov must be in [0, 360] degrees (0: the model's own), got -190");
  const fs::path frames = dir / "frames";
  ASSERT_EQ(lightprobe("synth bracket scene --exposure-times 0.01,0.1 -o " + frames.string()).code, 0);
  // Refused before the stream starts: these ran it until it was killed (timeouts here).
  for (const auto& [flag, message] : std::vector<std::pair<std::string, std::string>>{
           {" --duration -1", "--duration must be 0 (until stopped) or more seconds, got -1"},
           {" --fps nan", "--fps must be 0 (the source's own pace) or more, got nan"},
           {" --n auto --target-error -0.01", "--target-error must be positive, got -0.01"}})
    expect_one_line_error(lightprobe("stream --listen 127.0.0.1:0 --source replay:" + frames.string() + flag), message);
  expect_one_line_error(lightprobe("merge http://127.0.0.1:1 --listen 127.0.0.1:0 --duration nan"),
                        "--duration must be 0 (until stopped) or more seconds, got nan");
  EXPECT_FALSE(fs::exists(out));
}

// An option the chosen method never reads was ignored with exit 0: `--method pharr --q2-a 2`
// gave pharr's lists, which the user took for the exponent's effect.
TEST(GarbageCli, OptionsTheChosenMethodDoesNotReadAreRefusedNotIgnored) {
  const fs::path dir = fresh_dir("unused_options");
  const std::string map = (dir / "map.exr").string(), out = (dir / "lights.json").string();
  ASSERT_EQ(lightprobe("synth scene --size 64x32 -o " + map).code, 0);
  for (const auto& [flags, message] : std::vector<std::pair<std::string, std::string>>{
           {"--method pharr --q2-a 2", "--q2-a applies only to --method q2tree, not pharr"},
           {"--method hemigon --q2-nside 16", "--q2-nside applies only to --method q2tree, not hemigon"},
           {"--method mediancut --q2-jitter", "--q2-jitter applies only to --method q2tree, not mediancut"},
           {"--method q2tree --lloyd", "--lloyd applies only to --method hemigon, not q2tree"},
           {"--method pharr --upper-only", "--upper-only applies only to --method hemigon, not pharr"},
           {"--method pharr --light-cap 10", "--light-cap applies only with --residual sh9"},
           {"--method pharr --n 16 --target-error 0.05", "--target-error applies only with --n auto"},
           {"--method pharr --error-measure glossy10", "--error-measure applies only with --n auto"},
           {"--method hemigon --n 16 --residual sh9 --lloyd", "--lloyd applies only without --residual"},
           {"--method pharr --n 16 --residual sh9 --cluster 4", "--cluster applies only without --residual"}})
    expect_one_line_error(lightprobe("sample " + map + " " + flags + " -o " + out), message);
  EXPECT_FALSE(fs::exists(out));
  // What the method does read still runs (a control for the refusals above).
  EXPECT_EQ(lightprobe("sample " + map + " --method q2tree --n 16 --q2-a 0.5 --q2-nside 16 -o " + out).code, 0);
  EXPECT_EQ(lightprobe("sample " + map + " --method pharr --n 8 --residual sh9 --light-cap 10 -o " + out).code, 0);
  EXPECT_EQ(lightprobe("sample " + map + " --method pharr --n auto --target-error 0.05 -o " + out).code, 0);
  const fs::path frames = dir / "frames";
  ASSERT_EQ(lightprobe("synth bracket scene --exposure-times 0.01,0.1 -o " + frames.string()).code, 0);
  expect_one_line_error(lightprobe("stream --listen 127.0.0.1:0 --source replay:" + frames.string() +
                                   " --n 64 --frame-budget-ms 5"),
                        "--frame-budget-ms applies only with --n auto");
  // eval temporal the same; a misspelt --filter ran as auto, a negative --repeats as adaptive.
  const std::string eval_out = (dir / "eval").string();
  expect_one_line_error(lightprobe("eval temporal scene --methods pharr --frames 4 --target-error 0.05 -o " + eval_out),
                        "--target-error applies only with --n auto");
  expect_one_line_error(lightprobe("eval temporal scene --methods pharr --frames 4 --filter of -o " + eval_out),
                        "--filter must be auto, on or off, got 'of'");
  expect_one_line_error(lightprobe("eval sampling " + map + " --methods pharr --n 8 --repeats -1 -o " + eval_out),
                        "--repeats must be 0 (adaptive) or more, got -1");
}

// The same for the probe's type and the map's layout: `--type fisheye --reflectivity 0.6`
// wrote a map no darker, and `--layout healpix --size 64x32` a healpix map of the default
// nside, both with exit 0.
TEST(GarbageCli, OptionsTheProbeTypeOrLayoutDoesNotReadAreRefusedNotIgnored) {
  const fs::path dir = fresh_dir("unused_probe_options");
  const std::string ball = (dir / "ball.exr").string(), fish = (dir / "fish.exr").string(), out = (dir / "map.exr").string();
  ASSERT_EQ(lightprobe("synth probe scene --size 96x96 -o " + ball).code, 0);
  ASSERT_EQ(lightprobe("synth probe scene --type fisheye --fov 180 --size 96x96 -o " + fish).code, 0);
  for (const auto& [input, flags, message] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {fish, "--type fisheye --fov 180 --reflectivity 0.6", "--reflectivity applies only to --type mirrorball"},
           {fish, "--type fisheye --fov 180 --distance 3", "--distance applies only to --type mirrorball"},
           {fish, "--type fisheye --fov 180 --fresnel", "--fresnel applies only to --type mirrorball"},
           {fish, "--type fisheye --fov 180 --blind-spot 30", "--blind-spot applies only to --type mirrorball"},
           {fish, "--type fisheye --fov 180 --ball 48,48,40", "--ball applies only to --type mirrorball"},
           {ball, "--type mirrorball --camera lens.yaml", "--camera applies only to --type fisheye"},
           {ball, "--static-probe", "--static-probe applies only with --smooth-track"},
           {ball, "--fixed-ball --smooth-track", "--fixed-ball and --smooth-track: give one"},
           {ball, "--layout latlong --nside 8", "--nside applies only to --layout healpix"},
           {ball, "--layout healpix --size 64x32", "--size does not apply to healpix: use --nside"}})
    expect_one_line_error(lightprobe("probe unwrap " + input + " " + flags + " -o " + out), message);
  expect_one_line_error(lightprobe("synth scene --layout latlong --nside 8 -o " + out), "--nside applies only to --layout healpix");
  EXPECT_FALSE(fs::exists(out));
  // Controls: each option where it applies.
  EXPECT_EQ(lightprobe("probe unwrap " + ball + " --reflectivity 0.6 --blind-spot 30 --size 64x32 -o " + out).code, 0);
  EXPECT_EQ(lightprobe("probe unwrap " + fish + " --type fisheye --fov 180 --layout healpix --nside 8 -o " + out).code, 0);
}

// A --config file's misspelt key or section was ignored: `metod = "mediancut"` ran the
// default method with exit 0. A rig file's sections for other commands are theirs.
TEST(GarbageCli, AConfigFileWithAKeyOrSectionNoCommandHasIsRefusedNamingIt) {
  const fs::path dir = fresh_dir("config");
  const std::string map = (dir / "map.hdr").string();
  EnvMap m = make_envmap(Layout::LatLong, 64, 32);
  std::fill(m.rgb.begin(), m.rgb.end(), 1.0f);
  write_envmap(map, m);
  const std::string sample = "sample " + map + " --n 8 -o " + (dir / "lights.json").string() + " --config ";
  auto config = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return (dir / name).string();
  };
  const std::string key = config("key.toml", "[sample]\nmetod = \"mediancut\"\n");
  expect_one_line_error(lightprobe(sample + key), key + ": 'metod' is not an option of sample");
  const std::string section = config("section.toml", "[smaple]\nmethod = \"mediancut\"\n");
  expect_one_line_error(lightprobe(sample + section), section + ": [smaple] is not a command");
  const std::string nested = config("nested.toml", "[probe.unwrap]\ntipe = \"fisheye\"\n");
  expect_one_line_error(lightprobe(sample + nested), nested + ": 'tipe' is not an option of probe unwrap");
  const std::string top = config("top.toml", "metod = \"mediancut\"\n");
  expect_one_line_error(lightprobe(sample + top), top + ": 'metod' is not an option every command takes");
  expect_one_line_error(lightprobe(sample + (dir / "missing.toml").string()), "missing.toml");
  const std::string open = config("open.toml", "[sample\nmethod = \"mediancut\"\n");
  expect_one_line_error(lightprobe(sample + open), open + ": '[sample' is not a section header (a ']' is missing)");
  const std::string twice = config("twice.toml", "[sample]\nmethod = \"pharr\"\nmethod = \"mediancut\"\n");
  expect_one_line_error(lightprobe(sample + twice), "sample: --method: At Most 1 required but received 2 (the command line with " + twice);
  EXPECT_FALSE(fs::exists(dir / "lights.json"));
  const std::string rig = config("rig.toml",
                                 "max-pixels = 100000000\n[stream]\nsource = \"aravis:Fake_1\"\nn = 64\n"
                                 "[probe.unwrap]\ntype = \"fisheye\"\n[sample]\nmethod = \"mediancut\"\n");
  const CliRun r = lightprobe("--json " + sample + rig);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["method"], "mediancut");
  EXPECT_EQ(nlohmann::json::parse(r.out)["lights"], 8) << "the [stream] section's n is the stream's";
}

TEST(GarbageCli, JsonFilesOfTheWrongFormatNameTheFileAndWhatIsWrong) {
  const fs::path dir = fresh_dir("json");
  const fs::path bad = dir / "bad.json";
  std::ofstream(bad) << R"({"format": 5})";
  ASSERT_EQ(lightprobe("synth scene --size 64x32 -o " + (dir / "map.exr").string()).code, 0);
  ASSERT_EQ(lightprobe("preview " + (dir / "map.exr").string() + " -o " + (dir / "map.png").string()).code, 0);
  // A bracket of the preview and a brighter one (a file twice is refused before its options are read).
  ASSERT_EQ(lightprobe("preview " + (dir / "map.exr").string() + " --percentile 0.3 -o " + (dir / "bright.png").string()).code, 0);
  const std::string map = (dir / "map.png").string() + " " + (dir / "bright.png").string();
  // A response, a photometric calibration and a colour match, each through its command.
  const CliRun response = lightprobe("hdr fuse " + map + " --exposure-times 0.1,0.2 --response " +
                                     bad.string() + " -o " + (dir / "out.exr").string());
  expect_one_line_error(response, bad.string() + ": not a lightprobe.response/1 file (\"format\" is 5)");
  const CliRun photometric = lightprobe("hdr fuse " + map + " --exposure-times 0.1,0.2 --photometric " +
                                        bad.string() + " -o " + (dir / "out.exr").string());
  expect_one_line_error(photometric, bad.string() + ": not a lightprobe.photometric/1 file");
  EXPECT_FALSE(fs::exists(dir / "out.exr"));
  std::ofstream(bad) << "{\"format\": \"lightprobe.response/1\", \"levels\": \"many\"}";
  const CliRun typed = lightprobe("hdr fuse " + map + " --exposure-times 0.1,0.2 --response " +
                                  bad.string() + " -o " + (dir / "out.exr").string());
  expect_one_line_error(typed, bad.string() + ": \"levels\" is \"many\", not a count of code values");
  EXPECT_EQ(typed.err.find("json.exception"), std::string::npos) << typed.err;
}

TEST(GarbageCli, BracketsWithNothingWellExposedOrAWrongTimeTwiceAreRefused) {
  const fs::path dir = fresh_dir("bracket");
  // Three all-black frames (PNG, 8 bit; --linear, so no response is recovered from them):
  // nothing was measured.
  const fs::path png = dir / "black.png";
  write_display_image(png.string(), 8, 4, std::vector<float>(3 * 8 * 4, 0.0f));
  fs::copy_file(png, dir / "black2.png");
  fs::copy_file(png, dir / "black3.png");
  const std::string frames = png.string() + " " + (dir / "black2.png").string() + " " + (dir / "black3.png").string();
  const CliRun r = lightprobe("hdr fuse " + frames + " --linear --exposure-times 0.01,0.1,1 -o " + (dir / "fused.exr").string());
  expect_one_line_error(r, "no pixel is well exposed");
  EXPECT_FALSE(fs::exists(dir / "fused.exr"));
  // One exposure time on two frames whose codes say otherwise (0.5 and 0.25, linear): a wrong
  // time, both named.
  const fs::path half = dir / "half.png", quarter = dir / "quarter.png", again = dir / "half_again.png";
  write_display_image(half.string(), 8, 4, std::vector<float>(3 * 8 * 4, 0.5f));
  write_display_image(quarter.string(), 8, 4, std::vector<float>(3 * 8 * 4, 0.25f));
  fs::copy_file(half, again);
  const CliRun same = lightprobe("hdr fuse " + half.string() + " " + quarter.string() +
                                 " --linear --exposure-times 0.1,0.1 -o " + (dir / "fused.exr").string());
  expect_one_line_error(same, half.string() + " and " + quarter.string() + ": the same exposure 0.1 s");
  EXPECT_FALSE(fs::exists(dir / "fused.exr"));
  // The same time on two frames that agree: the later one is used once, said in one warning.
  const CliRun twice = lightprobe("hdr fuse " + half.string() + " " + again.string() + " " + quarter.string() +
                                  " --linear --exposure-times 0.1,0.1,0.05 -o " + (dir / "fused.exr").string());
  EXPECT_EQ(twice.code, 0) << twice.err;
  EXPECT_NE(twice.err.find("warning: 1 frame repeats the exposure of an earlier one, each exposure used once: " +
                           again.string() + " = " + half.string() + " (0.1 s)"),
            std::string::npos)
      << twice.err;
  EXPECT_TRUE(fs::exists(dir / "fused.exr"));
}

// One time twice in --exposures: every bracket would be dropped for it ("the same exposure
// time") and the stream would serve no light; refused before the camera opens.
TEST(GarbageCli, StreamExposuresGivenTwiceAreRefused) {
  expect_one_line_error(lightprobe("stream --source aravis:Fake_1 --exposures 0.01,0.01,0.04 --duration 1"),
                        "--exposures: 0.01 s is given twice");
}

TEST(GarbageCli, AMirrorBallOutsideTheImageIsRefusedNotUnwrappedToNothing) {
  const fs::path dir = fresh_dir("ball");
  const fs::path ball = dir / "ball.exr", out = dir / "map.exr";
  ASSERT_EQ(lightprobe("synth probe scene --type mirrorball --size 128x128 -o " + ball.string()).code, 0);
  const CliRun r = lightprobe("probe unwrap " + ball.string() + " --type mirrorball --ball 5000,5000,40 --size 64x32 -o " +
                              out.string());
  expect_one_line_error(r, ball.string());
  EXPECT_NE(r.err.find("no valid pixel"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  // The same ball where it is: a map, and no warning.
  const CliRun ok = lightprobe("probe unwrap " + ball.string() + " --type mirrorball --size 64x32 -o " + out.string());
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_EQ(ok.err.find("warning"), std::string::npos) << ok.err;
}

// ---- signals ---------------------------------------------------------------------------

struct Child {
  pid_t pid = -1;
};

// `lightprobe ARGS` in a child process with stdout and stderr to files in the scratch dir.
Child spawn(const std::vector<std::string>& args) {
  Child c;
  c.pid = ::fork();
  if (c.pid == 0) {
    const int out = ::open((scratch() / "child.out").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = ::open((scratch() / "child.err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(out, 1);
    ::dup2(err, 2);
    // As a background job of a non-interactive shell starts: SIGINT ignored.
    std::signal(SIGINT, SIG_IGN);
    std::vector<char*> argv{const_cast<char*>(LIGHTPROBE_CLI), const_cast<char*>("--no-progress")};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(LIGHTPROBE_CLI, argv.data());
    ::_exit(127);
  }
  return c;
}

int wait_code(const Child& c) {
  int status = 0;
  ::waitpid(c.pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

bool running(const Child& c) {
  int status = 0;
  return ::waitpid(c.pid, &status, WNOHANG) == 0;
}

std::vector<fs::path> temp_files_in(const fs::path& dir) {
  std::vector<fs::path> found;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find(".tmp-") != std::string::npos) found.push_back(e.path());
  return found;
}

// A probe with a few slightly negative pixels (out-of-gamut colour, noise below black) is
// sampled with one warning line and the negatives read as 0: the lights carry the power of
// the map so clamped. Negatives holding more than 1 % of a channel's power are refused.
TEST(GarbageCli, SlightNegativesAreSampledWithAWarningAndStrongOnesRefused) {
  const fs::path dir = fresh_dir("negatives");
  EnvMap map = make_latlong(64, 32);
  for (size_t i = 0; i < map.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) map.pixel(i)[c] = 1.0f + 0.01f * float((i * 7 + size_t(c)) % 13);
  EnvMap slight = map, strong = map;
  slight.pixel(10 * 64 + 20)[0] = -1e-3f;
  slight.pixel(11 * 64 + 21)[2] = -2e-6f;
  for (size_t i = 0; i < 64; ++i) strong.pixel(16 * 64 + i)[1] = -2.0f;
  write_envmap((dir / "slight.exr").string(), slight);
  write_envmap((dir / "strong.exr").string(), strong);

  const fs::path lights = dir / "lights.json";
  const CliRun ok = lightprobe("sample " + (dir / "slight.exr").string() + " --method q2tree --n 16 -o " +
                               lights.string() + " --json");
  ASSERT_EQ(ok.code, 0) << ok.err;
  EXPECT_EQ(line_count(ok.err), 1) << ok.err;
  EXPECT_NE(ok.err.find("lightprobe: warning: " + (dir / "slight.exr").string() +
                        ": 2 pixels with negative values (lowest -0.001"),
            std::string::npos)
      << ok.err;
  EnvMap clamped = slight;
  clamp_negative_values(clamped);
  const auto power = total_power(clamped);
  std::array<double, 3> sum{0, 0, 0};
  const nlohmann::json list = nlohmann::json::parse(slurp(lights));
  ASSERT_EQ(list["lights"].size(), 15u);
  for (const auto& l : list["lights"])
    for (int c = 0; c < 3; ++c) sum[size_t(c)] += l["rgb"][size_t(c)].get<double>();
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(sum[size_t(c)], power[size_t(c)], 1e-5 * power[size_t(c)]) << c;

  const fs::path out = dir / "strong.json";
  const CliRun refused = lightprobe("sample " + (dir / "strong.exr").string() + " --method q2tree --n 16 -o " + out.string());
  expect_one_line_error(refused, (dir / "strong.exr").string() + ": 64 pixels with negative values (lowest -2)");
  EXPECT_NE(refused.err.find("not radiance"), std::string::npos) << refused.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST(GarbageCli, SigintEndsALongSampleWith130EvenWhenStartedWithSigintIgnored) {
  const fs::path dir = fresh_dir("sigint");
  const fs::path seq = dir / "seq", out = dir / "lights.ndjson";
  ASSERT_EQ(lightprobe("synth sequence --scenario static-noise --frames 60 --size 256x128 -o " + seq.string()).code, 0);
  const Child c = spawn({"sample", seq.string(), "--method", "pharr", "--n", "4096", "-o", out.string()});
  // Until main installs its handlers the inherited SIG_IGN holds (a loaded machine can take
  // seconds to start a process): wait for SIGINT to show as caught in /proc.
  for (int i = 0; i < 3000 && running(c); ++i) {
    const std::string status = slurp("/proc/" + std::to_string(c.pid) + "/status");
    const size_t at = status.find("SigCgt:");
    if (at != std::string::npos && (std::stoull(status.substr(at + 7), nullptr, 16) & (1ull << (SIGINT - 1)))) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  ASSERT_TRUE(running(c)) << "the run ended before the signal: make it longer";
  ::kill(c.pid, SIGINT);
  EXPECT_EQ(wait_code(c), 130) << slurp(scratch() / "child.err");
  EXPECT_FALSE(fs::exists(out));
  EXPECT_TRUE(temp_files_in(dir).empty());
}

TEST(GarbageCli, SigtermDuringALargeWriteLeavesNoTempFileAndExits143) {
  const fs::path dir = fresh_dir("sigterm");
  // PFM is written uncompressed: 100 MB at 4096x2048, a write long enough to be caught.
  const fs::path scene = dir / "scene.exr", out = dir / "big.pfm";
  ASSERT_EQ(lightprobe("synth scene --size 512x256 -o " + scene.string()).code, 0);
  // Caught mid-write when the temp file shows; a few tries, as the write is short.
  bool caught = false;
  for (int attempt = 0; attempt < 5 && !caught; ++attempt) {
    const Child c = spawn({"convert", scene.string(), out.string(), "--layout", "latlong", "--size", "4096x2048"});
    while (running(c)) {
      if (!temp_files_in(dir).empty()) {
        ::kill(c.pid, SIGTERM);
        caught = true;
        break;
      }
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    const int code = wait_code(c);
    if (caught) {
      EXPECT_EQ(code, 143) << slurp(scratch() / "child.err");
    }
    EXPECT_TRUE(temp_files_in(dir).empty());
    fs::remove(out);
  }
  EXPECT_TRUE(caught) << "no temp file seen in 5 runs";
}

}  // namespace
}  // namespace lp::cli_test
