// What a command loads at start (issue 23, "a fast start"): the heavy libraries (OpenCV's
// codecs and video I/O, ccalib, mrgingham and what they pull: GDAL, FFmpeg, GStreamer, Qt)
// are loaded only by a command that needs them, through core/lazy_libs.h's plugin. The
// dynamic loader itself reports what it loads (LD_DEBUG=files).
#include <gtest/gtest.h>

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

bool loaded(const CliRun& r, const std::string& library) {
  return r.err.find("file=" + library) != std::string::npos;
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
                            "libopencv_video", "libopencv_dnn", "libprotobuf"})
    EXPECT_FALSE(loaded(r, heavy)) << heavy << " is loaded by `lightprobe --version`";
}

TEST(Startup, ReadingACameraImageLoadsThePluginAndDecodes) {
  const std::string dir = shared("hdr-memorial-debevec") + "/";
  const fs::path out = scratch() / "fused.exr";
  const CliRun r = traced("hdr fuse " + dir + "memorial0066.png " + dir + "memorial0068.png --exposure-times 1,0.25 -o " +
                          out.string());
  ASSERT_EQ(r.code, 0) << r.err.substr(r.err.size() > 2000 ? r.err.size() - 2000 : 0);
  EXPECT_TRUE(loaded(r, "libopencv_imgcodecs"));
  EXPECT_NE(r.err.find("liblightprobe_lazy_libs.so [0];  dynamically loaded"), std::string::npos);
  EXPECT_GT(fs::file_size(out), 100000u);
}

TEST(Startup, OpeningACameraLoadsTheCameraPlugin) {
  const CliRun r = traced("stream --source aravis:Fake_1 --listen 127.0.0.1:0 --duration 1 --n 8 --method pharr");
  ASSERT_EQ(r.code, 0) << r.err.substr(r.err.size() > 2000 ? r.err.size() - 2000 : 0);
  EXPECT_NE(r.err.find("liblightprobe_cameras.so [0];  dynamically loaded"), std::string::npos);
  EXPECT_TRUE(loaded(r, "libaravis"));
}

}  // namespace
}  // namespace lp::cli_test
