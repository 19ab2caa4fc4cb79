// Inputs that hdr and calib took with exit 0 and answered wrongly (an audit of stop 51):
// the same frame twice, times in milliseconds, options the mode never reads, calibrations
// fitted on the wrong code scale, a colour chart of greys, a transposed camera matrix. Each
// is now refused in one line naming the problem, or, where the input may be right, warned
// about in one.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>
#include <sstream>
#include <map>

#include "core/image_io.h"
#include "tests/cli/cli_run.h"

namespace lp::cli_test {
namespace {

// A synthetic 8-bit bracket of three frames (1/64, 1/8, 1 s) with its exposures.csv.
const fs::path& bracket_dir() {
  static const fs::path dir = [] {
    const fs::path d = scratch() / "bracket";
    fs::remove_all(d);
    const CliRun r = lightprobe("synth bracket scene -o " + d.string());
    EXPECT_EQ(r.code, 0) << r.err;
    return d;
  }();
  return dir;
}

std::string frames() {
  const fs::path& d = bracket_dir();
  return (d / "frame_00.png").string() + " " + (d / "frame_01.png").string() + " " + (d / "frame_02.png").string();
}

std::string write(const fs::path& path, const std::string& text) {
  std::ofstream(path) << text;
  return path.string();
}

TEST(UnreadOptionsCli, ABracketOfOnePictureTwiceIsRefused) {
  const fs::path dir = fresh_dir("twice");
  const fs::path& b = bracket_dir();
  const std::string out = (dir / "x.exr").string();
  const std::string f0 = (b / "frame_00.png").string(), f2 = (b / "frame_02.png").string();
  expect_one_line_error(lightprobe("hdr fuse " + f0 + " " + f0 + " " + f2 + " --exposure-times 1/64,1/8,1 -o " + out),
                        "frame_00.png: given twice (as image 1 and 2)");
  // The same picture under another name: half a stop longer and nowhere brighter.
  fs::copy_file(b / "frame_00.png", dir / "copy.png");
  expect_one_line_error(
      lightprobe("hdr fuse " + f0 + " " + (dir / "copy.png").string() + " " + f2 + " --exposure-times 1/64,1/8,1 -o " + out),
      "are the same picture");
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(lightprobe("hdr fuse " + frames() + " --exposure-times " + (b / "exposures.csv").string() + " -o " + out).code, 0);
}

TEST(UnreadOptionsCli, AnExposureListInAnotherUnitThanSecondsIsRefused) {
  const fs::path dir = fresh_dir("units");
  for (const std::string header : {"file,exposure_ms", "file,time (us)", "name,milliseconds"}) {
    const std::string list = write(dir / "ms.csv", header + "\nframe_00.png,15.625\nframe_01.png,125\nframe_02.png,1000\n");
    expect_one_line_error(lightprobe("hdr fuse " + frames() + " --exposure-times " + list + " -o " + (dir / "x.exr").string()),
                          "names its times in another unit than seconds");
  }
  const std::string seconds = write(dir / "s.csv", "file,exposure_s\nframe_00.png,0.015625\nframe_01.png,0.125\nframe_02.png,1\n");
  EXPECT_EQ(lightprobe("hdr fuse " + frames() + " --exposure-times " + seconds + " -o " + (dir / "x.exr").string()).code, 0);
}

// A given time two stops from the photo's EXIF is used, and said (the Kartik photos differ in
// size, so the bracket is then refused for that: the warning comes first).
TEST(UnreadOptionsCli, AGivenTimeFarFromThePhotosOwnIsSaid) {
  const std::string k = shared("hdr-mirrorball-kartik/");
  const CliRun r = lightprobe("hdr fuse " + k + "ball_1-10s.jpg " + k + "ball_1-40s.jpg " + k +
                              "ball_1-160s.jpg --exposure-times 1/10,1/40,1/40 -o " + (scratch() / "k.exr").string());
  EXPECT_NE(r.err.find("ball_1-160s.jpg: --exposure-times gives 0.025 s, its EXIF 0.00625 s (+2.0 stops)"), std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("ball_1-40s.jpg: --exposure-times"), std::string::npos) << r.err;
}

TEST(UnreadOptionsCli, HdrOptionsTheModeNeverReadsAreRefused) {
  const fs::path dir = fresh_dir("modes");
  const fs::path& b = bracket_dir();
  const std::string out = " -o " + (dir / "x.exr").string();
  const std::string times = " --exposure-times " + (b / "exposures.csv").string();
  const std::string response = (dir / "r.json").string();
  ASSERT_EQ(lightprobe("hdr response " + frames() + times + " -o " + response).code, 0);
  expect_one_line_error(lightprobe("hdr fuse " + frames() + times + " --response " + response + " --linear" + out),
                        "contradict: a linear bracket has no response curve");
  expect_one_line_error(lightprobe("hdr response " + frames() + times + " --method robertson --lambda 5000 -o " + response),
                        "--lambda is Debevec's smoothness weight");
  expect_one_line_error(lightprobe("hdr fuse " + frames() + times + " --ignore-colour 0,0,254.7" + out), "--ignore-colour");
  // --align's search limit: pixels, and only with --align.
  expect_one_line_error(lightprobe("hdr fuse " + frames() + times + " --max-shift 40" + out),
                        "--max-shift is a limit of --align mtb|ecc");
  expect_one_line_error(lightprobe("hdr response " + frames() + times + " --align mtb --max-shift -3 -o " + response),
                        "--max-shift takes pixels");
  EXPECT_EQ(lightprobe("hdr fuse " + frames() + times + " --align mtb --max-shift 8" + out).code, 0);
  fs::remove(dir / "x.exr");
  // A log sensor's calibration decodes one frame: the bracket's options are refused.
  const std::string readings = write(dir / "log.csv", "region,camera_value,measured,unit\na,0.2,10,cd/m2\nb,0.35,40,cd/m2\n"
                                                      "c,0.5,160,cd/m2\nd,0.65,640,cd/m2\ne,0.8,2560,cd/m2\n");
  const std::string log_cal = (dir / "log_cal.json").string();
  ASSERT_EQ(lightprobe("calib photometric " + readings + " --model log -o " + log_cal).code, 0);
  const std::string one = (b / "frame_01.png").string();
  for (const std::string option :
       {"--align mtb", "--max-shift 40", "--deghost", "--linear", "--ignore-colour 0,0,255", "--exposure-times 0.5"})
    expect_one_line_error(lightprobe("hdr fuse " + one + " --photometric " + log_cal + " " + option + out),
                          option.substr(0, option.find(' ')) + " is an option of brackets");
  expect_one_line_error(lightprobe("hdr fuse " + (b / "truth.exr").string() + " --photometric " + log_cal + out),
                        "truth.exr: a log sensor's frame is its camera codes");
  EXPECT_EQ(lightprobe("hdr fuse " + one + " --photometric " + log_cal + out).code, 0);
  EXPECT_FALSE(fs::exists(dir / "y.exr"));
}

TEST(UnreadOptionsCli, PhotometricReadingsOnTheWrongScaleOrUnitAreRefused) {
  const fs::path dir = fresh_dir("photometric");
  // 8-bit codes 51..204 for a log sensor: the curve decoded every [0, 1] frame to a flat map.
  const std::string codes = write(dir / "codes.csv", "region,camera_value,measured,unit\na,51,10,cd/m2\nb,89,40,cd/m2\n"
                                                     "c,128,160,cd/m2\nd,166,640,cd/m2\ne,204,2560,cd/m2\n");
  expect_one_line_error(lightprobe("calib photometric " + codes + " --model log -o " + (dir / "c.json").string()),
                        "codes.csv: camera value 51 of 'a' is not a code in [0, 1]");
  // A lux reading on an image region: the region's value is a mean luminance, not E_rel.
  const std::string map = (dir / "map.exr").string();
  ASSERT_EQ(lightprobe("synth scene --size 64x32 -o " + map).code, 0);
  const std::string lux = write(dir / "lux.csv", "region,camera_value,measured,unit\n\"map.exr:10,10,8,8\",,5000,lux\n"
                                                 "\"map.exr:30,10,8,8\",,4000,lux\n");
  expect_one_line_error(lightprobe("calib photometric " + lux + " -o " + (dir / "k.json").string()),
                        "is an image region, whose value is a mean luminance");
  EXPECT_FALSE(fs::exists(dir / "c.json"));
  EXPECT_FALSE(fs::exists(dir / "k.json"));
}

TEST(UnreadOptionsCli, AColourChartIsReadByItsHeaderAndRefusedWhenItIsGrey) {
  const fs::path dir = fresh_dir("colour");
  const std::string rows = "0.45,0.2,0.12,0.5,0.2,0.1\n0.1,0.45,0.2,0.1,0.5,0.2\n0.12,0.2,0.45,0.1,0.2,0.5\n0.3,0.3,0.3,0.3,0.3,0.3\n";
  const std::string probe_first = write(dir / "probe_first.csv", "probe_r,probe_g,probe_b,plate_r,plate_g,plate_b\n" + rows);
  // The same chart with the plate's columns first: the header says so (it was skipped, and the
  // inverse matrix came out).
  std::string swapped = "plate_r,plate_g,plate_b,probe_r,probe_g,probe_b\n";
  for (const std::string row : {"0.5,0.2,0.1,0.45,0.2,0.12", "0.1,0.5,0.2,0.1,0.45,0.2", "0.1,0.2,0.5,0.12,0.2,0.45",
                                "0.3,0.3,0.3,0.3,0.3,0.3"})
    swapped += row + "\n";
  const std::string plate_first = write(dir / "plate_first.csv", swapped);
  const CliRun a = lightprobe("--json calib colour " + probe_first + " -o " + (dir / "a.json").string());
  const CliRun b = lightprobe("--json calib colour " + plate_first + " -o " + (dir / "b.json").string());
  ASSERT_EQ(a.code, 0) << a.err;
  ASSERT_EQ(b.code, 0) << b.err;
  const auto ma = nlohmann::json::parse(a.out)["matrix"], mb = nlohmann::json::parse(b.out)["matrix"];
  for (size_t i = 0; i < 9; ++i) EXPECT_NEAR(ma[i].get<double>(), mb[i].get<double>(), 1e-12) << i;
  EXPECT_NEAR(ma[0].get<double>(), 1.12, 0.01);  // the plate is 12 % redder than the probe
  expect_one_line_error(lightprobe("calib colour " + write(dir / "pct.csv", "0.45,0.2,0.12,0.5,0.2,40%\n") + " -o x.json"),
                        "'40%' is not a number");
  expect_one_line_error(lightprobe("calib colour " + write(dir / "names.csv", "r,g,b,R,G,B\n" + rows) + " -o x.json"),
                        "header column 'r' is not one of");
  const std::string grey = write(dir / "grey.csv", "0.05,0.0501,0.05,0.05,0.05,0.05\n0.18,0.18,0.1801,0.18,0.18,0.18\n"
                                                   "0.5001,0.5,0.5,0.5,0.5,0.5\n0.9,0.9,0.9,0.9,0.9,0.9\n");
  expect_one_line_error(lightprobe("calib colour " + grey + " -o x.json"), "the probe colours barely span RGB");
}

TEST(UnreadOptionsCli, CalibCompareRefusesATransposedMatrixAndStepsItCannotUse) {
  const fs::path dir = fresh_dir("compare");
  const std::string a = shared("calib-opencv-stereo-9x6/reference/opencv_left_intrinsics.yml");
  std::string text = slurp(a);
  const std::string k = "data: [ 5.3591573396163199e+02, 0., 3.4228315473308373e+02, 0.,\n       5.3591573396163199e+02, "
                        "2.3557082909788173e+02, 0., 0., 1. ]";
  const size_t at = text.find(k);
  ASSERT_NE(at, std::string::npos);
  const std::string transposed = write(
      dir / "transposed.yml",
      text.substr(0, at) + "data: [ 5.3591573396163199e+02, 0., 0., 0., 5.3591573396163199e+02, 0., 3.4228315473308373e+02, "
                           "2.3557082909788173e+02, 1. ]" + text.substr(at + k.size()));
  expect_one_line_error(lightprobe("calib compare " + a + " " + transposed), "transposed, as MATLAB stores it?");
  const std::string k22 = write(dir / "k22.yml", text.substr(0, at) + k.substr(0, k.size() - 4) + "2. ]" + text.substr(at + k.size()));
  expect_one_line_error(lightprobe("calib compare " + a + " " + k22), "k22.yml: camera_matrix is not [fx 0 cx; 0 fy cy; 0 0 1]");
  expect_one_line_error(lightprobe("calib compare " + a + " " + a + " --step 0"), "--step must be 1..160 px");
  expect_one_line_error(lightprobe("calib compare " + a + " " + a + " --step 400"), "--step must be 1..160 px");
  EXPECT_EQ(lightprobe("calib compare " + a + " " + a + " --step 8").code, 0);
}

// Map outputs that would read back otherwise, and options the input or output never reads.
TEST(UnreadOptionsCli, MapsProbesAndTablesRefuseWhatTheirOutputCannotHoldOrTheirInputNeverReads) {
  const fs::path dir = fresh_dir("maps");
  const std::string map = (dir / "map.exr").string();
  ASSERT_EQ(lightprobe("synth scene --size 128x64 -o " + map).code, 0);
  // .pfm records no layout: a 2:1 hemisphere map came back as latlong.
  expect_one_line_error(lightprobe("convert " + map + " " + (dir / "h.pfm").string() + " --layout hemisphere --size 128x64"),
                        "h.pfm: cannot write: .pfm records no layout, and this hemisphere map of 128x64 would read back as latlong");
  EXPECT_EQ(lightprobe("convert " + map + " " + (dir / "l.pfm").string()).code, 0);
  EXPECT_EQ(lightprobe("convert " + map + " " + (dir / "h4.pfm").string() + " --layout hemisphere --size 256x64").code, 0);
  expect_one_line_error(lightprobe("convert " + map + " " + (dir / "o.hdr").string() + " --half"), "--half writes EXR half floats");
  expect_one_line_error(lightprobe("convert " + shared("probes-threejs-spot-and-cube/pisa_cube") + " " +
                                   (dir / "c.exr").string() + " --in-layout healpix"),
                        "--in-layout reads a map file");
  expect_one_line_error(lightprobe("sh " + map + " -o " + (dir / "sh.exr").string()), "name the output .json");
  expect_one_line_error(lightprobe("sh scene --layout hemisphere -o " + (dir / "sh.json").string()), "--layout reads a map file");
  expect_one_line_error(lightprobe("sh " + map + " --exposure 1100 -o " + (dir / "sh.json").string()), "not a finite positive factor");
  expect_one_line_error(lightprobe("tables " + map + " --n 16 -o " + (dir / "t.exr").string()), "not an image file");
  expect_one_line_error(lightprobe("prefilter " + map + " --size 16 --lut " + (dir / "d.hdr").string() + " -o " +
                                   (dir / "p.exr").string()),
                        "name it .exr");
  expect_one_line_error(lightprobe("prefilter " + map + " --size 16 --lut-size 16 -o " + (dir / "p.exr").string()), "give --lut");
  for (const char* name : {"h.pfm", "o.hdr", "c.exr", "sh.exr", "sh.json", "t.exr", "d.hdr", "p.exr"})
    EXPECT_FALSE(fs::exists(dir / name)) << name;
}

TEST(UnreadOptionsCli, ProbeOptionsForASequenceOrAFoundBallNeedThem) {
  const fs::path dir = fresh_dir("probe");
  const std::string ball = (dir / "ball.exr").string(), seq = (dir / "seq").string();
  ASSERT_EQ(lightprobe("synth probe scene --size 256x256 -o " + ball).code, 0);
  ASSERT_EQ(lightprobe("synth probe scene --frames 2 --size 256x256 -o " + seq).code, 0);
  const std::string out = " --size 64x32 -o " + (dir / "u.exr").string();
  expect_one_line_error(lightprobe("probe unwrap " + ball + " --smooth-track" + out), "--smooth-track acts on a sequence's track");
  expect_one_line_error(lightprobe("probe unwrap " + ball + " --fixed-ball" + out), "--fixed-ball acts on a sequence's track");
  expect_one_line_error(lightprobe("probe unwrap " + seq + " --ball 128,128,100 --smooth-track --size 64x32 -o " +
                                   (dir / "s").string()),
                        "--ball gives one for every frame");
  expect_one_line_error(lightprobe("probe unwrap " + seq + " --size 64x32 -o " + (dir / "s.hdr").string()),
                        "s.hdr: 2 frames are written as a folder");
  expect_one_line_error(lightprobe("probe unwrap " + ball + " --reflectivity 1e-30" + out), "--reflectivity must be in [0.01, 1]");
  EXPECT_FALSE(fs::exists(dir / "u.exr"));
  EXPECT_EQ(lightprobe("probe unwrap " + seq + " --smooth-track --size 64x32 -o " + (dir / "s").string()).code, 0);
}

TEST(UnreadOptionsCli, ProbeRegisterRefusesTwoPhotosOfOneNameAndSaysWhatLayOutsideThePhoto) {
  const fs::path dir = fresh_dir("register");
  const std::string k = shared("hdr-mirrorball-kartik/");
  fs::create_directories(dir / "a");
  fs::create_directories(dir / "b");
  fs::copy_file(k + "ball_1-10s.jpg", dir / "a" / "ball.jpg");
  fs::copy_file(k + "ball_1-160s.jpg", dir / "b" / "ball.jpg");
  expect_one_line_error(lightprobe("probe register " + (dir / "a" / "ball.jpg").string() + " " +
                                   (dir / "b" / "ball.jpg").string() + " -o " + (dir / "reg").string()),
                        "would both be written as ball.png");
  // Kartik's 1/10 s ball runs a few pixels past the top of the photo.
  const CliRun r = lightprobe("probe register " + k + "ball_1-10s.jpg " + k + "ball_1-160s.jpg -o " + (dir / "reg").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("ball_1-10s.jpg: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("lay outside the photo: transparent (no data) in ball_1-10s.png"), std::string::npos) << r.err;
  // Marked as no data in the PNG (alpha 0), not written as black.
  const lp::CameraImage png = lp::read_camera_image((dir / "reg" / "ball_1-10s.png").string());
  ASSERT_FALSE(png.valid.empty());
  EXPECT_GT(std::count(png.valid.begin(), png.valid.end(), uint8_t(0)), 0);
}

// calib geometric: the corners of eight stereo views, detected once (corners.vnl rows: name x y level).
const fs::path& stereo_corners() {
  static const fs::path vnl = [] {
    const fs::path dir = scratch() / "stereo_corners";
    fs::create_directories(dir);
    std::string images;
    for (int i = 1; i <= 8; ++i) images += ' ' + shared("calib-opencv-stereo-9x6/left0" + std::to_string(i) + ".jpg");
    const CliRun r = lightprobe("calib geometric" + images + " --board 9x6 --square 25 --model plumb_bob --corners-out " +
                                (dir / "corners.vnl").string() + " -o " + (dir / "camera.yaml").string());
    EXPECT_EQ(r.code, 0) << r.err;
    return dir / "corners.vnl";
  }();
  return vnl;
}

// The first `views` views of stereo_corners(), the first `transposed` of them with their
// corners in column-major order (no 9x6 board: the outlier stage leaves them out).
std::string corners_subset(const std::string& name, int views, int transposed) {
  std::istringstream in(slurp(stereo_corners()));
  std::vector<std::string> order;
  std::map<std::string, std::vector<std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    const std::string file = line.substr(0, line.find(' '));
    if (!rows.count(file)) order.push_back(file);
    rows[file].push_back(line);
  }
  std::string text = "# filename x y level\n";
  for (int v = 0; v < views && v < int(order.size()); ++v) {
    const std::vector<std::string>& r = rows[order[size_t(v)]];
    for (int k = 0; k < 54; ++k) text += r[size_t(v < transposed ? (k % 6) * 9 + k / 6 : k)] + "\n";
  }
  const fs::path path = stereo_corners().parent_path() / name;
  std::ofstream(path) << text;
  return path.string();
}

TEST(UnreadOptionsCli, CalibGeometricSaysWhatItLeavesOutAndRefusesWhatItWouldOverwrite) {
  const std::string solve = " --board 9x6 --square 25 -o " + (scratch() / "cam.yaml").string();
  const std::string eight = stereo_corners().string();
  // A board of another size in some views: they were left out without a word.
  std::string images;
  for (int i = 1; i <= 8; ++i) images += ' ' + shared("calib-opencv-stereo-9x6/left0" + std::to_string(i) + ".jpg");
  const CliRun wrong = lightprobe("calib geometric" + images + " --board 8x6 --square 25 --model plumb_bob -o " +
                                  (scratch() / "w.yaml").string());
  ASSERT_EQ(wrong.code, 0) << wrong.err;
  EXPECT_NE(wrong.out.find("show a 9x6 board (inner corners), not the 8x6 of --board: those views are left out"),
            std::string::npos) << wrong.out;
  // Views the outlier stage drops are named in the text, not only in --json.
  const CliRun out = lightprobe("calib geometric --corners-in " + corners_subset("t.vnl", 8, 2) + solve + " --model plumb_bob");
  ASSERT_EQ(out.code, 0) << out.err;
  EXPECT_NE(out.out.find("view left out: "), std::string::npos) << out.out;
  // --drop-influential is capped so that five views stay: said.
  const CliRun capped = lightprobe("calib geometric --corners-in " + corners_subset("five.vnl", 5, 0) + solve +
                                   " --model plumb_bob --drop-influential 3");
  ASSERT_EQ(capped.code, 0) << capped.err;
  EXPECT_NE(capped.out.find("influential view:"), std::string::npos) << capped.out;  // left02 (0.68 px)
  EXPECT_NE(capped.out.find("--drop-influential 3: 0 of the 1 influential views dropped; at least 5 views stay"),
            std::string::npos) << capped.out;
  // Asked to drop and nothing flagged: said (the run was the same as without the option).
  const CliRun none = lightprobe("calib geometric --corners-in " + eight + solve + " --model plumb_bob --drop-influential 1");
  ASSERT_EQ(none.code, 0) << none.err;
  EXPECT_NE(none.out.find("--drop-influential 1: no view is flagged influential"), std::string::npos) << none.out;
  expect_one_line_error(lightprobe("calib geometric" + images + " --imagersize 1280,960" + solve),
                        "--imagersize is for --corners-in without the images");
  expect_one_line_error(lightprobe("calib geometric --corners-in " + eight + " --corners-out " + eight + solve),
                        "is the --corners-in file");
  expect_one_line_error(lightprobe("calib geometric --corners-in " + eight + " --corners-out " +
                                   (scratch() / "left01.jpg").string() + solve),
                        "the corners are text (mrcal's corners.vnl), not an image");
  std::ofstream(scratch() / "report.txt") << "x";
  expect_one_line_error(lightprobe("calib geometric --corners-in " + eight + " --report " + (scratch() / "report.txt").string() + solve),
                        "a file is there");
  expect_one_line_error(lightprobe("calib geometric --corners-in " + eight + " --board 2x2 --square 25 -o x.yaml"),
                        "needs at least 3x3");
}

double valid_fraction(const std::string& map) {
  const CliRun r = lightprobe("--json info " + map);
  EXPECT_EQ(r.code, 0) << r.err;
  return r.code == 0 ? nlohmann::json::parse(r.out)["valid_fraction"].get<double>() : -1;
}

std::string opencv_yaml(const fs::path& path, int w, int h, double f, double cx, double cy, const std::string& model,
                        const std::string& coefficients, int count) {
  std::ofstream(path) << "%YAML:1.0\n---\nimage_width: " << w << "\nimage_height: " << h
                      << "\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ " << f << ", 0., "
                      << cx << ", 0., " << f << ", " << cy << ", 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n"
                      << "   rows: 1\n   cols: " << count << "\n   dt: d\n   data: [ " << coefficients
                      << " ]\ndistortion_model: " << model << "\n";
  return path.string();
}

// Through a calibrated lens (--camera): the black around a fisheye's image circle was mapped
// as valid dark sky, and a polynomial fit used past its fold wrote rings of the zenith at
// 45-50 deg. Both are invalid now.
TEST(UnreadOptionsCli, ACalibratedLensMapsNeitherTheBlackAroundItsCircleNorItsFold) {
  const fs::path dir = fresh_dir("lens");
  const std::string fish = (dir / "fish.exr").string();
  ASSERT_EQ(lightprobe("synth probe scene --type fisheye --fov 190 --size 512x512 -o " + fish).code, 0);
  // The render's own lens: equidistant, its 190 deg circle inscribed (f = 256 / 95 deg).
  const std::string ideal = opencv_yaml(dir / "ideal.yaml", 512, 512, 256 / (95 * M_PI / 180), 255.5, 255.5, "fisheye",
                                        "0., 0., 0., 0.", 4);
  const std::string by_fov = (dir / "fov.exr").string(), by_camera = (dir / "camera.exr").string();
  ASSERT_EQ(lightprobe("probe unwrap " + fish + " --type fisheye --fov 190 --size 256x128 -o " + by_fov).code, 0);
  ASSERT_EQ(lightprobe("probe unwrap " + fish + " --type fisheye --camera " + ideal + " --size 256x128 -o " + by_camera).code, 0);
  EXPECT_NEAR(valid_fraction(by_camera), valid_fraction(by_fov), 0.01);  // was 0.59 against 0.53
  // The shared stereo camera's plumb_bob fit (k1 0.296, k2 -1.035) peaks at 36.1 deg off axis
  // and folds back: nothing beyond 36.1 deg, 20.1 % of a latlong's rows, may be valid.
  const std::string wide = (dir / "wide.exr").string();
  ASSERT_EQ(lightprobe("synth probe scene --type fisheye --fov 190 --size 640x480 -o " + wide).code, 0);
  const std::string folds = opencv_yaml(dir / "plumb.yaml", 640, 480, 534.80326845051309, 335.68643204394891,
                                        240.66183054066337, "plumb_bob",
                                        "2.9589439552724328e-01, -1.0354662043042675e+00, 0., 0., 0.", 5);
  const std::string folded = (dir / "folded.exr").string();
  ASSERT_EQ(lightprobe("probe unwrap " + wide + " --type fisheye --camera " + folds + " --size 256x128 -o " + folded).code, 0);
  const double v = valid_fraction(folded);
  EXPECT_LE(v, 36.1 / 180 + 0.005);
  EXPECT_GT(v, 0.05);
}

// What a light-list format cannot carry, and a --format against the file's extension.
TEST(UnreadOptionsCli, SampleRefusesWhatItsFormatCannotCarry) {
  const fs::path dir = fresh_dir("sample");
  const std::string map = (dir / "map.exr").string();
  ASSERT_EQ(lightprobe("synth scene --size 64x32 -o " + map).code, 0);
  const std::string sample = "sample " + map + " --method pharr --n 3 ";
  // --residual sh9 to pbrt lost a third of the power and reported the error of lights + SH9.
  for (const char* name : {"rs.pbrt", "rs.xml", "rs.csv"})
    expect_one_line_error(lightprobe(sample + "--residual sh9 -o " + (dir / name).string()), "cannot carry the SH9 of --residual sh9");
  expect_one_line_error(lightprobe(sample + "--sh9 -o " + (dir / "s.pbrt").string()), "cannot carry the SH9 of --sh9");
  expect_one_line_error(lightprobe(sample + "--format csv -o " + (dir / "c.gltf").string()),
                        "--format csv contradicts the extension .gltf (gltf)");
  EXPECT_EQ(lightprobe(sample + "--format ndjson -o " + (dir / "n.json").string()).code, 0);
  EXPECT_EQ(lightprobe(sample + "--format gltf -o " + (dir / "g.txt").string()).code, 0);
  EXPECT_EQ(lightprobe(sample + "--residual sh9 -o " + (dir / "rs.gltf").string()).code, 0);
  // A csv has no frame column: a sequence's frames ran together.
  const fs::path seq = dir / "seq";
  fs::create_directories(seq);
  fs::copy_file(map, seq / "a.exr");
  fs::copy_file(map, seq / "b.exr");
  expect_one_line_error(lightprobe("sample " + seq.string() + " --n 3 -o " + (dir / "seq.csv").string()),
                        "form a sequence: write NDJSON");
  // A relative csv is said, as a relative pbrt is: the csv records no units.
  const CliRun csv = lightprobe(sample + "-o " + (dir / "r.csv").string());
  ASSERT_EQ(csv.code, 0) << csv.err;
  EXPECT_NE(csv.err.find("relative units written as they are"), std::string::npos) << csv.err;
  for (const char* name : {"rs.pbrt", "rs.xml", "rs.csv", "s.pbrt", "c.gltf"}) EXPECT_FALSE(fs::exists(dir / name)) << name;
}

TEST(UnreadOptionsCli, SynthRefusesValuesItCannotRenderAndOptionsItNeverReads) {
  const std::string out = " -o " + (scratch() / "s.exr").string();
  expect_one_line_error(lightprobe("synth scene --size 64x32 --sun-scale inf" + out), "--sun-scale must be a finite number");
  expect_one_line_error(lightprobe("synth scene --size 64x32 --sun-scale 5 --no-sun" + out), "--sun-scale and --no-sun");
  expect_one_line_error(lightprobe("synth bracket scene --no-noise --seed 5 -o " + (scratch() / "b").string()),
                        "--no-noise has none");
  expect_one_line_error(lightprobe("synth probe scene --type fisheye --radius 30 --size 64x64" + out),
                        "--radius applies to --type mirrorball");
  EXPECT_FALSE(fs::exists(scratch() / "s.exr"));
}

TEST(UnreadOptionsCli, EvalRefusesOptionsItsRunNeverReadsAndListsWithHoles) {
  expect_one_line_error(lightprobe("eval calib --sweep --board 7x5 --square 20 -o " + (scratch() / "ec").string()),
                        "the sweep alone uses its own 10x7, 40 mm board");
  const fs::path walk = scratch() / "walk";
  ASSERT_EQ(lightprobe("synth walkthrough --probe-size 32 --samples 2 --rays 4 -o " + walk.string()).code, 0);
  const std::string eval = "eval metadata " + walk.string() + " -o " + (scratch() / "em").string() + " ";
  expect_one_line_error(lightprobe(eval + "--root-size -5"), "--root-size must be 0 (automatic)");
  expect_one_line_error(lightprobe(eval + "--fractions 1,1"), "--fractions: 1 is given twice");
  expect_one_line_error(lightprobe(eval + "--fractions 0.5,"), "--fractions: '' is not a number");
  expect_one_line_error(lightprobe(eval + "--fractions 0.5,,1"), "--fractions: '' is not a number");
  EXPECT_FALSE(fs::exists(scratch() / "em"));
}

// stream and merge options that the mode, the source or the transport never reads, and
// inputs that made every bracket or round fail while the command ran on with exit 0.
TEST(UnreadOptionsCli, StreamAndMergeRefuseOptionsTheirModeOrSourceNeverReads) {
  const std::string fake = "stream --source aravis:Fake_1 --listen 127.0.0.1:0 --duration 0.5 ";
  expect_one_line_error(lightprobe(fake + "--fov nan"), "--fov must be a field of view in (0, 360]");
  expect_one_line_error(lightprobe(fake + "--metadata-model " + (scratch() / "m.json").string() + " --method q2tree"),
                        "--method belongs to the probe chain, which --metadata-model replaces");
  expect_one_line_error(lightprobe(fake + "--position 3,4"), "--position applies only with --metadata-model");
  expect_one_line_error(lightprobe(fake + "--mqtt-qos 0"), "--mqtt-qos applies only with --publish");
  expect_one_line_error(lightprobe(fake + "--publish mqtt://127.0.0.1:1/x --mqtt-cafile ca.pem"), "--mqtt-cafile is for TLS");
  expect_one_line_error(lightprobe(fake + "--loop"), "--loop replays a recording");
  expect_one_line_error(lightprobe(fake + "--cluster 500"), "--cluster 500 keeps every one of --n 300 lights");
  expect_one_line_error(lightprobe("stream --source aravis:Fake_1 --listen 127.0.0.1:0junk --metadata-model m.json"),
                        "--listen: '0junk' is not a port");
  const fs::path dir = fresh_dir("stream");
  const std::string seq = (dir / "maps").string();
  ASSERT_EQ(lightprobe("synth probe scene --frames 2 --size 64x64 -o " + seq).code, 0);
  const std::string replay = "stream --source replay:" + seq + " --listen 127.0.0.1:0 --duration 0.5 ";
  expect_one_line_error(lightprobe(replay + "--maps --rotation 90,0,0"), "--rotation applies to camera frames");
  expect_one_line_error(lightprobe(replay + "--response srgb"), "holds float frames");
  expect_one_line_error(lightprobe(replay + "--bracketing sequencer --exposures 0.1,0.2"), "--bracketing chooses how an Aravis");

  const std::string merge = "merge --listen 127.0.0.1:0 --duration 0.5 ";
  expect_one_line_error(lightprobe(merge + "http://127.0.0.1:21001 --timeout -1"), "--timeout must be a positive number");
  expect_one_line_error(lightprobe(merge + "http://127.0.0.1:21001 --weights 0"), "--weights must be positive");
  expect_one_line_error(lightprobe(merge + "http://127.0.0.1:21001 --mqtt-qos 0"), "--mqtt-qos applies only with --subscribe");
  expect_one_line_error(lightprobe(merge + "--subscribe mqtt://127.0.0.1:1/s/+/lights --upstream-token t"),
                        "--upstream-token is for the cameras' HTTP servers");
  const CliRun stream_url = lightprobe(merge + "http://127.0.0.1:21001/lights/stream");
  EXPECT_EQ(stream_url.code, 2);
  EXPECT_NE(stream_url.err.find("not /lights/stream"), std::string::npos) << stream_url.err;
  const CliRun twice = lightprobe(merge + "http://127.0.0.1:21001 http://localhost:21001/lights");
  EXPECT_EQ(twice.code, 2);
  EXPECT_NE(twice.err.find("are the same server"), std::string::npos) << twice.err;
  // An empty token read as "no token": on localhost the server then answered everyone.
  expect_one_line_error(lightprobe(fake + "--token ''"), "--token: must not be empty");
  expect_one_line_error(lightprobe(merge + "http://127.0.0.1:21001 --token ''"), "--token: must not be empty");
  expect_one_line_error(lightprobe(merge + "http://127.0.0.1:21001 --upstream-token ''"),
                        "--upstream-token: must not be empty");
  const CliRun nobody = lightprobe(merge + "http://127.0.0.1:21001");
  EXPECT_EQ(nobody.code, 0) << nobody.err;  // a camera may come later: said, not refused
  EXPECT_NE(nobody.out.find("no input ever gave a light list"), std::string::npos) << nobody.out;
}

// Bad input from the start made every bracket fail, and the stream served nothing with exit 0:
// a camera model for another sensor size, a replay without the times of its --exposures.
TEST(UnreadOptionsCli, AStreamWhoseEveryBracketFailsFromTheStartEndsAsBadInput) {
  const fs::path dir = fresh_dir("fails");
  ASSERT_EQ(lightprobe("synth boards --views 1 -o " + (dir / "boards").string()).code, 0);
  const CliRun model = lightprobe("stream --source aravis:Fake_1 --listen 127.0.0.1:0 --duration 5 --camera " +
                                  (dir / "boards" / "true_camera.yaml").string());
  EXPECT_EQ(model.code, 2) << model.err;
  EXPECT_NE(model.err.find("camera model is for 1280x960, frames are 512x512"), std::string::npos) << model.err;
  const std::string fish = (dir / "fish").string();
  fs::create_directories(fish);
  for (const char* name : {"a.exr", "b.exr", "c.exr"})
    ASSERT_EQ(lightprobe("synth probe scene --type fisheye --fov 190 --size 64x64 -o " + (dir / "fish" / name).string()).code, 0);
  // Two frames through a camera model of another sensor size, the replay over before three
  // failures: bad input all the same (it ended with exit 0 having served nothing).
  const std::string two = (dir / "two").string();
  fs::create_directories(two);
  for (const char* name : {"a.exr", "b.exr"}) fs::copy_file(dir / "fish" / name, dir / "two" / name);
  const CliRun short_replay = lightprobe("stream --source replay:" + two + " --fps 50 --listen 127.0.0.1:0 --camera " +
                                         (dir / "boards" / "true_camera.yaml").string());
  EXPECT_EQ(short_replay.code, 2) << short_replay.err;
  EXPECT_NE(short_replay.err.find("camera model is for 1280x960, frames are 64x64"), std::string::npos) << short_replay.err;
  // Without --loop and --duration, a replay that ends ends the stream (it served until killed).
  const CliRun once = lightprobe("--json stream --source replay:" + fish + " --fps 50 --listen 127.0.0.1:0");
  ASSERT_EQ(once.code, 0) << once.err;
  EXPECT_EQ(nlohmann::json::parse(once.out)["brackets_processed"], 3) << once.out;
  const CliRun replay = lightprobe("stream --source replay:" + fish +
                                   " --exposures 0.01,0.1,1 --fps 50 --loop --listen 127.0.0.1:0 --duration 5");
  EXPECT_EQ(replay.code, 2) << replay.err;
  EXPECT_NE(replay.err.find("none at an exposure time of the cycle 0.01,0.1,1"), std::string::npos) << replay.err;
}

}  // namespace
}  // namespace lp::cli_test
