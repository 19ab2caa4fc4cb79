// A log sensor through the commands (issue 20 item 3): `calib photometric --model log` and
// `hdr fuse` give the same cd/m2 as a linear camera calibrated and fused the same way, and
// what cannot be decoded (a bracket under a log curve, offline or live) is refused with one
// line and exit 2.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <sstream>
#include <vector>

#include "cli_run.h"
#include "core/envmap.h"
#include "core/image_io.h"

namespace lp::cli_test {
namespace {

constexpr double kScale = 2.78, kCurveA = 0.25, kCurveB = 0.05;
// One row of patches, per-channel luminance-like values in cd/m2: three coloured ones (the
// scene), then four grey ones a meter measured (the linear camera's calibration regions).
const std::vector<std::array<double, 3>> kScene = {{40, 60, 80},    {100, 100, 100}, {300, 250, 200}, {50, 50, 50},
                                                   {100, 100, 100}, {200, 200, 200}, {300, 300, 300}};
constexpr int kFirstGrey = 3;

// One 16-bit frame of kScene: linear at exposure t, or by the log curve.
fs::path write_frame(const std::string& name, bool log, double t) {
  RgbImage frame;
  frame.width = int(kScene.size());
  frame.height = 1;
  for (const auto& px : kScene)
    for (double l : px) frame.rgb.push_back(float(log ? kCurveA + kCurveB * std::log(l) : l * t / kScale));
  const fs::path path = scratch() / name;
  write_code_image(path.string(), frame, 16);
  return path;
}

void expect_candelas(const fs::path& exr, double tolerance) {
  const RgbImage im = read_rgb_image(exr.string());
  ASSERT_EQ(im.rgb.size(), 3 * kScene.size());
  for (size_t p = 0; p < kScene.size(); ++p)
    EXPECT_NEAR(683.0 * luminance(im.rgb[3 * p], im.rgb[3 * p + 1], im.rgb[3 * p + 2]) / luminance(kScene[p].data()), 1.0,
                tolerance)
        << exr << " patch " << p;
}

// The log camera is calibrated as Havran et al. 2005 did: six grey patches, the raw code
// of each against the meter.
fs::path calibrate_log_camera() {
  const fs::path csv = scratch() / "log_readings.csv", cal = scratch() / "log_cal.json";
  std::ofstream f(csv);
  f << "region,camera_value,measured,unit\n";
  for (double l : {3.1, 12.0, 48.5, 160.0, 720.0, 2950.0})
    f << "patch" << l << "," << kCurveA + kCurveB * std::log(l) << "," << l << ",cd/m2\n";
  f.close();
  EXPECT_EQ(lightprobe("calib photometric --model log " + csv.string() + " -o " + cal.string()).code, 0);
  return cal;
}

TEST(LogSensorCli, HdrFuseGivesALogCameraAndALinearCameraTheSameCandelas) {
  const fs::path log_exr = scratch() / "log.exr";
  const CliRun log = lightprobe("hdr fuse --json " + write_frame("log.png", true, 0).string() + " --photometric " +
                                calibrate_log_camera().string() + " -o " + log_exr.string());
  ASSERT_EQ(log.code, 0) << log.err;
  EXPECT_EQ(nlohmann::json::parse(log.out)["mode"], "log-sensor");

  // The linear camera as a user calibrates it: fuse a bracket (hdr fuse refuses one frame;
  // codes 0.4 and 0.8 at most), read the grey patches' relative values off the fused map
  // (regions), fit k, fuse again with it.
  const double t1 = 0.4 * kScale / 300, t2 = 2 * t1;
  std::ostringstream times;
  times.precision(17);
  times << t1 << "," << t2;
  const std::string fuse = "hdr fuse --linear " + write_frame("lin1.png", false, t1).string() + " " +
                           write_frame("lin2.png", false, t2).string() + " --exposure-times " + times.str();
  const fs::path relative = scratch() / "lin_rel.exr", csv = scratch() / "lin_readings.csv";
  ASSERT_EQ(lightprobe(fuse + " -o " + relative.string()).code, 0);
  std::ofstream f(csv);
  f << "region,camera_value,measured,unit\n";
  for (size_t p = kFirstGrey; p < kScene.size(); ++p)
    f << "\"lin_rel.exr:" << p << ",0,1,1\",," << kScene[p][0] << ",cd/m2\n";
  f.close();
  const fs::path lin_cal = scratch() / "lin_cal.json", lin_exr = scratch() / "lin.exr";
  const CliRun fit = lightprobe("calib photometric " + csv.string() + " -o " + lin_cal.string());
  ASSERT_EQ(fit.code, 0) << fit.err;
  const CliRun lin = lightprobe(fuse + " --photometric " + lin_cal.string() + " -o " + lin_exr.string());
  ASSERT_EQ(lin.code, 0) << lin.err;
  // The log camera: 16-bit codes resolve ln L to 1/65535/2/b = 1.5e-4. The linear one:
  // hdr fuse reads 16-bit codes at its linear response's 1024 levels, so a patch at code
  // 0.13 (the dimmest, 40 cd/m2 in red at the long exposure) is off by up to 0.4 %.
  expect_candelas(log_exr, 1e-3);
  expect_candelas(lin_exr, 6e-3);
}

TEST(LogSensorCli, ABracketUnderALogCurveIsRefusedOfflineAndLive) {
  const fs::path cal = calibrate_log_camera();
  const fs::path a = write_frame("a.png", true, 0), b = write_frame("b.png", true, 0);
  const fs::path out = scratch() / "refused.exr";
  expect_one_line_error(lightprobe("hdr fuse " + a.string() + " " + b.string() + " --exposure-times 0.01,0.02 --photometric " +
                                   cal.string() + " -o " + out.string()),
                        "log_cal.json: a log-sensor calibration decodes one frame, not a bracket");
  EXPECT_FALSE(fs::exists(out));
  const fs::path replay = scratch() / "replay";
  fs::create_directories(replay);
  fs::copy_file(a, replay / "a.png", fs::copy_options::overwrite_existing);
  expect_one_line_error(lightprobe("stream --source replay:" + replay.string() + " --listen 127.0.0.1:0 --photometric " +
                                   cal.string() + " --exposures 0.001,0.01"),
                        "log_cal.json: a log-sensor calibration decodes single frames");
}

}  // namespace
}  // namespace lp::cli_test
