// What a command loads at start (issue 23, "a fast start"): the heavy libraries (OpenCV's
// codecs and video I/O, ccalib, mrgingham and what they pull: GDAL, FFmpeg, GStreamer, Qt)
// are loaded only by a command that needs them, through core/lazy_libs.h's plugin. The
// dynamic loader itself reports what it loads (LD_DEBUG=files).
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_run.h"

namespace lp::cli_test {
namespace {

CliRun traced(const std::string& args) {
  const fs::path out = scratch() / "trace_out.txt", err = scratch() / "trace_err.txt";
  const std::string cmd =
      "LD_DEBUG=files " + std::string(LIGHTPROBE_CLI) + " " + args + " >" + out.string() + " 2>" + err.string();
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

// Whether the loader opened `library` (a file name's start: "libceres" matches
// libceres.so.3), named bare or by a path (the plugins are opened by path).
bool loaded(const CliRun& r, const std::string& library) {
  for (size_t at = r.err.find("file="); at != std::string::npos; at = r.err.find("file=", at + 5)) {
    const size_t end = r.err.find_first_of(" \t\n", at);
    const std::string file = r.err.substr(at + 5, end == std::string::npos ? std::string::npos : end - at - 5);
    const size_t slash = file.rfind('/');
    if (file.compare(slash == std::string::npos ? 0 : slash + 1, library.size(), library) == 0) return true;
  }
  return false;
}

TEST(Startup, VersionLoadsNoCodecVideoOrGuiLibrary) {
  const CliRun r = traced("--version");
  ASSERT_EQ(r.code, 0) << r.err.substr(0, 2000);
  ASSERT_TRUE(loaded(r, "libopencv_core")) << "LD_DEBUG reported nothing: " << r.err.substr(0, 500);
  for (const char* heavy : {"libopencv_imgcodecs", "libopencv_videoio", "libopencv_ccalib", "libopencv_highgui",
                            "libmrgingham", "libgdal", "libavcodec", "libgstreamer", "libQt5Core", "liblightprobe_lazy_libs",
                            // the camera drivers (probe/camera_plugin.h) and chealpix's FITS chain (core/healpix.h)
                            "libaravis", "libcamera", "liblttng-ust", "libglib", "libusb", "liblightprobe_cameras",
                            "libchealpix", "libcfitsio", "libcurl", "libgnutls",
                            // mrcal and its FreeImage chain (calib/mrcal_loader.cpp)
                            "libmrcal", "libfreeimage", "libjxrglue", "libopenjp2",
                            // OpenCV's video module (ECC alignment) and its DNN module
                            "libopencv_video", "libopencv_dnn", "libprotobuf",
                            // Ceres (static in Debian, in the plugin of calib/ceres_plugin.h) and its solver chain
                            "liblightprobe_ceres", "libglog", "libgflags", "libspqr", "libcholmod",
                            // cv::omnidir (calib/omnidir_plugin.h)
                            "liblightprobe_omnidir",
                            "libcxsparse", "libmetis",
                            // LibRaw and Exiv2 (hdr/camera_files_plugin.h)
                            "liblightprobe_camera_files", "libraw_r", "libexiv2", "liblcms2", "libexpat",
                            // libmosquitto (live/mosquitto_loader.cpp), cpp-httplib's client
                            // (live/http_client_plugin.h) and what they pull
                            "libmosquitto", "liblightprobe_http_client", "libcpp-httplib", "libssl", "libcrypto",
                            "libbrotli",
                            // Highway, whose library calibrates its timer at load (cli/process/highway_loader.cpp)
                            "libhwy"})
    EXPECT_FALSE(loaded(r, heavy)) << heavy << " is loaded by `lightprobe --version`";
}

// A PNG is written with libpng in-process: a preview or an overlay does not load OpenCV's
// codecs plugin (265 libraries, ~0.35 s). A JPEG still goes through it.
TEST(Startup, WritingAPngLoadsNoCodecPlugin) {
  const std::string map = shared("probes-blender-studiolights") + "/studio.exr";
  const fs::path png = scratch() / "preview.png", jpg = scratch() / "preview.jpg";
  const CliRun r = traced("preview " + map + " -o " + png.string());
  ASSERT_EQ(r.code, 0) << r.err.substr(r.err.size() > 2000 ? r.err.size() - 2000 : 0);
  EXPECT_FALSE(loaded(r, "libopencv_imgcodecs"));
  EXPECT_GT(fs::file_size(png), 100000u);
  const CliRun j = traced("preview " + map + " -o " + jpg.string());
  ASSERT_EQ(j.code, 0);
  EXPECT_TRUE(loaded(j, "libopencv_imgcodecs"));
}

// PNG and JPEG frames are decoded in-process (libpng, libjpeg-turbo): a bracket of either
// loads no codecs plugin (a JPEG preview still does: WritingAPngLoadsNoCodecPlugin).
TEST(Startup, ReadingPngAndJpegBracketsLoadsNoCodecPlugin) {
  const std::string dir = shared("hdr-memorial-debevec") + "/";
  const fs::path out = scratch() / "fused.exr";
  const CliRun r = traced("hdr fuse " + dir + "memorial0066.png " + dir + "memorial0068.png --exposure-times 1,0.25 -o " +
                          out.string());
  ASSERT_EQ(r.code, 0) << r.err.substr(r.err.size() > 2000 ? r.err.size() - 2000 : 0);
  EXPECT_FALSE(loaded(r, "libopencv_imgcodecs"));
  EXPECT_EQ(r.err.find("liblightprobe_lazy_libs.so [0];  dynamically loaded"), std::string::npos);
  EXPECT_FALSE(loaded(r, "libexiv2"));  // the exposure times are given: no EXIF read
  EXPECT_GT(fs::file_size(out), 100000u);
  const std::string k = shared("hdr-mirrorball-kartik") + "/ball_1-10s.jpg";
  // Its longer frame: a brighter JPEG of it, made by another command (the same file twice is
  // not a bracket).
  const std::string bright = (scratch() / "bright.jpg").string();
  ASSERT_EQ(lightprobe("preview " + k + " --percentile 0.3 -o " + bright).code, 0);
  const CliRun j = traced("hdr fuse " + k + " " + bright + " --exposure-times 0.025,0.1 -o " + (scratch() / "j.exr").string());
  ASSERT_EQ(j.code, 0) << j.err.substr(j.err.size() > 2000 ? j.err.size() - 2000 : 0);
  EXPECT_FALSE(loaded(j, "libopencv_imgcodecs"));
  EXPECT_TRUE(loaded(j, "libexiv2"));  // its ICC profile is read (and warned about)
}

// The shared mirror-ball crops differ in size, so fusing them is refused, but only after the
// first frame's EXIF exposure time was read: through the plugin, with Exiv2.
TEST(Startup, ReadingExifLoadsTheCameraFilesPlugin) {
  const std::string k = shared("hdr-mirrorball-kartik") + "/";
  const CliRun r = traced("hdr fuse " + k + "ball_1-10s.jpg " + k + "ball_1-40s.jpg -o " + (scratch() / "k.exr").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("ball_1-40s.jpg: size 484x468 differs"), std::string::npos) << r.err.substr(r.err.size() > 2000 ? r.err.size() - 2000 : 0);
  EXPECT_TRUE(loaded(r, "liblightprobe_camera_files.so"));
  EXPECT_TRUE(loaded(r, "libexiv2"));
}

// Unwrapping runs the vector remap kernel. On x86 its dispatch needs no libhwy (whose
// loading timed its timer, 3.4 ms: cli/process/highway_loader.cpp); elsewhere the first
// dispatch loads it.
TEST(Startup, TheFirstVectorKernelDispatchesWithoutLibhwyOnX86) {
  const fs::path ball = scratch() / "startup_ball.exr", map = scratch() / "startup_map.exr";
  ASSERT_EQ(std::system((std::string(LIGHTPROBE_CLI) + " synth probe scene --type mirrorball --size 200x200 -o " +
                         ball.string() + " >/dev/null 2>&1")
                            .c_str()),
            0);
  const CliRun r = traced("probe unwrap " + ball.string() + " --type mirrorball --layout latlong --size 128x64 -o " +
                          map.string());
  ASSERT_EQ(r.code, 0) << r.err.substr(r.err.size() > 2000 ? r.err.size() - 2000 : 0);
#if defined(__x86_64__) || defined(__i386__)
  EXPECT_FALSE(loaded(r, "libhwy"));
#else
  EXPECT_NE(r.err.find("file=libhwy.so.1 [0];  dynamically loaded"), std::string::npos);
#endif
  EXPECT_GT(fs::file_size(map), 1000u);
}

TEST(Startup, APhotometricFitLoadsCeresThroughItsPlugin) {
  const fs::path csv = scratch() / "startup_readings.csv", cal = scratch() / "startup_photometric.json";
  std::ofstream(csv) << "region,camera_value,measured,unit\npatch1,0.5,100,cd/m2\npatch2,1.0,200,cd/m2\n"
                        "patch3,2.0,400,cd/m2\n";
  const CliRun r = traced("calib photometric --json " + csv.string() + " -o " + cal.string());
  ASSERT_EQ(r.code, 0) << r.err.substr(r.err.size() > 2000 ? r.err.size() - 2000 : 0);
  EXPECT_TRUE(loaded(r, "liblightprobe_ceres.so"));
  EXPECT_TRUE(loaded(r, "libglog"));  // Debian's Ceres is a static library: glog and SuiteSparse show it
  EXPECT_NEAR(nlohmann::json::parse(r.out)["scale_luminance"].get<double>(), 200.0, 200.0 * 1e-6);
}

TEST(Startup, OpeningACameraLoadsTheCameraPlugin) {
  const CliRun r = traced("stream --source aravis:Fake_1 --listen 127.0.0.1:0 --duration 1 --n 8 --method pharr");
  ASSERT_EQ(r.code, 0) << r.err.substr(r.err.size() > 2000 ? r.err.size() - 2000 : 0);
  EXPECT_NE(r.err.find("liblightprobe_cameras.so [0];  dynamically loaded"), std::string::npos);
  EXPECT_TRUE(loaded(r, "libaravis"));
}

// Mei's seed needs no cv::omnidir (calibration_seed.h: mei_unit_xi_seed): a Mei calibration
// loads neither its plugin nor ccalib (with highgui's chain, imgcodecs and GDAL among it),
// nor the video libraries of the codecs plugin. (cv::omnidir is still loaded, in its own
// plugin, for `eval calib`'s peer and where the unit-xi seed cannot pose every view.)
TEST(Startup, AMeiCalibrationLoadsNoOmnidirPlugin) {
  const fs::path dir = scratch() / "startup_omnidir";
  fs::create_directories(dir);
  const std::string images = six_board_images(dir);
  ASSERT_FALSE(images.empty());
  const std::string vnl = (dir / "corners.vnl").string();
  const std::string common = " --board 9x6 --square 30 --no-progress --model LENSMODEL_OMNIDIR_MEI";
  ASSERT_EQ(lightprobe("calib geometric" + images + common + " --corners-out " + vnl + " -o " +
                       (dir / "a.yaml").string()).code, 0);
  const CliRun r = traced("calib geometric --corners-in " + vnl + " --imagersize 1280,960" + common + " --json -o " +
                          (dir / "b.yaml").string());
  ASSERT_EQ(r.code, 0) << r.err.substr(r.err.size() > 2000 ? r.err.size() - 2000 : 0);
  EXPECT_NE(r.out.find("unit-xi search"), std::string::npos) << r.out.substr(0, 2000);
  for (const char* other : {"liblightprobe_omnidir.so", "libopencv_ccalib", "libopencv_highgui", "liblightprobe_lazy_libs",
                            "libopencv_videoio", "libavcodec", "libgstreamer", "libmrgingham"})
    EXPECT_FALSE(loaded(r, other)) << other;
}

}  // namespace
}  // namespace lp::cli_test
