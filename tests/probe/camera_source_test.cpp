#include "probe/camera_source.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "core/error.h"
#include "core/image_io.h"
#include "core/warnings.h"
#include "tests/cli/cli_run.h"

namespace fs = std::filesystem;
using lp::CameraFrame;
using lp::InputError;
using lp::SourceOptions;

namespace {

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("camera_source_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

double mean(const CameraFrame& f) {
  double s = 0;
  for (float v : f.image.rgb) s += v;
  return f.image.rgb.empty() ? 0 : s / double(f.image.rgb.size());
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("not an InputError: ") + e.what();
  }
  return "no exception";
}

}  // namespace

TEST(CameraSourceReplay, FramesInNameOrderWithSidecarExposuresAndTimestamps) {
  TempDir dir;
  // Written out of order; grey level tells which file a frame came from.
  const std::vector<std::string> names = {"frame_002.png", "frame_000.png", "frame_001.png"};
  for (const auto& name : names) {
    const int k = name[8] - '0';
    cv::imwrite((dir.path / name).string(), cv::Mat(6, 8, CV_8UC3, cv::Scalar::all(40 + 80 * k)));
  }
  std::ofstream(dir.path / "exposures.csv") << "file,exposure_s\nframe_001.png,0.004\nframe_000.png,0.001\nframe_002.png,0.016\n";
  std::ofstream(dir.path / "timestamps.txt") << "10.0\n10.5\n11.0\n";
  SourceOptions options;
  options.exposure_cycle = {0.001, 0.004, 0.016};
  auto source = lp::open_source("replay:" + dir.path.string(), options);
  EXPECT_NE(source->describe().find("3 images"), std::string::npos) << source->describe();
  const double exposures[] = {0.001, 0.004, 0.016};
  for (int k = 0; k < 3; ++k) {
    auto frame = source->next(1.0);
    ASSERT_TRUE(frame) << k;
    EXPECT_EQ(frame->image.width, 8);
    EXPECT_EQ(frame->image.height, 6);
    EXPECT_NEAR(frame->image.rgb[0], (40 + 80 * k) / 255.0, 1e-6) << k;
    EXPECT_DOUBLE_EQ(frame->exposure_s, exposures[k]);
    EXPECT_DOUBLE_EQ(frame->timestamp_s, 10.0 + 0.5 * k);
    EXPECT_EQ(frame->sequence, k);
    EXPECT_EQ(frame->bracket_index, k);
    EXPECT_EQ(frame->pixel_format, "RGB8");
  }
  EXPECT_FALSE(source->next(0.1));
  EXPECT_TRUE(source->finished());
}

TEST(CameraSourceReplay, FramesNumberedWithoutPaddingComeInTheirNumbersOrder) {
  TempDir dir;
  for (const int k : {1, 2, 10, 11}) {
    cv::imwrite((dir.path / ("frame_" + std::to_string(k) + ".png")).string(),
                cv::Mat(6, 8, CV_8UC3, cv::Scalar::all(10 * k)));
  }
  auto source = lp::open_source("replay:" + dir.path.string(), {});
  for (const int k : {1, 2, 10, 11}) {
    auto frame = source->next(1.0);
    ASSERT_TRUE(frame) << k;
    EXPECT_NEAR(frame->image.rgb[0], 10 * k / 255.0, 1e-6) << "frame_" << k << " (frame_10 came before frame_2)";
  }
}

// The stream unwraps a fisheye in its sensor's frame: a replayed frame tagged upside down
// (a camera pointing up records an arbitrary EXIF Orientation) is replayed as stored, said
// once, as probe unwrap reads fisheyes. Turned, it was unwrapped 180 degrees off in azimuth.
TEST(CameraSourceReplay, AFrameTaggedUpsideDownIsReplayedAsStoredAndSaidOnce) {
  TempDir dir;
  cv::Mat gradient(6, 8, CV_8UC3);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x) gradient.at<cv::Vec3b>(y, x) = cv::Vec3b(uchar(20 * x), uchar(30 * y), 100);
  cv::imwrite((dir.path / "a.jpg").string(), gradient);
  const std::string plain = lp::cli_test::slurp(dir.path / "a.jpg");
  std::ofstream(dir.path / "b.jpg", std::ios::binary) << lp::cli_test::with_exif_orientation(plain, 3);
  std::ofstream(dir.path / "c.jpg", std::ios::binary) << lp::cli_test::with_exif_orientation(plain, 3);
  std::vector<std::string> warnings;
  const lp::WarningSink before = lp::set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  auto source = lp::open_source("replay:" + dir.path.string(), {});
  const auto a = source->next(1.0), b = source->next(1.0), c = source->next(1.0);
  lp::set_warning_sink(before);
  ASSERT_TRUE(a && b && c);
  EXPECT_EQ(a->image.rgb, b->image.rgb);
  EXPECT_EQ(a->image.rgb, c->image.rgb);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("b.jpg: its EXIF Orientation (3) is not applied"), std::string::npos) << warnings[0];
}

// A replayed fused probe that records the EXIF turn its bracket was shown by (hdr fuse) is
// turned back to the sensor's frame, said once.
TEST(CameraSourceReplay, AFusedProbeShownTurnedIsReplayedInItsSensorsFrame) {
  TempDir dir;
  lp::RgbImage stored;
  stored.width = 4, stored.height = 3;
  for (int i = 0; i < 12 * 3; ++i) stored.rgb.push_back(float(i));
  lp::write_rgb_image((dir.path / "a.exr").string(), stored);
  lp::RgbImage shown = stored;  // half a turn: pixel i at 11 - i
  for (int i = 0; i < 12; ++i)
    for (int c = 0; c < 3; ++c) shown.rgb[size_t(3 * (11 - i) + c)] = stored.rgb[size_t(3 * i + c)];
  shown.orientation = 3;
  lp::write_rgb_image((dir.path / "b.exr").string(), shown);
  std::vector<std::string> warnings;
  const lp::WarningSink before = lp::set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  auto source = lp::open_source("replay:" + dir.path.string(), {});
  const auto a = source->next(1.0), b = source->next(1.0);
  lp::set_warning_sink(before);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(b->image.rgb, stored.rgb);
  EXPECT_EQ(a->image.rgb, stored.rgb);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("b.exr: fused turned by its frames' EXIF Orientation (3); turned back"), std::string::npos);
}

// A recorded Mono12 camera saved as 16-bit PNGs: the first frame's lamp piles up at 4095, so
// both frames replay as 12-bit codes (the second, which clips nowhere, at the same scale),
// and a frame with codes above that white level is refused.
TEST(CameraSourceReplay, SixteenBitFramesOfATwelveBitSensorReplayAtItsWhiteLevel) {
  TempDir dir;
  cv::Mat lamp(20, 20, CV_16UC3, cv::Scalar::all(1000));
  lamp(cv::Rect(8, 8, 4, 4)).setTo(cv::Scalar::all(4095));
  cv::imwrite((dir.path / "frame_0.png").string(), lamp);
  cv::imwrite((dir.path / "frame_1.png").string(), cv::Mat(20, 20, CV_16UC3, cv::Scalar::all(2000)));
  cv::imwrite((dir.path / "frame_2.png").string(), cv::Mat(20, 20, CV_16UC3, cv::Scalar::all(5000)));
  auto source = lp::open_source("replay:" + dir.path.string(), {});
  auto first = source->next(1.0), second = source->next(1.0);
  ASSERT_TRUE(first && second);
  EXPECT_EQ(first->pixel_format, "RGB12");
  EXPECT_NEAR(first->image.rgb[0], 1000.0 / 4095, 1e-6);  // was 1000 / 65535
  EXPECT_EQ(first->image.rgb[3 * (9 * 20 + 9)], 1.0f);    // the lamp: clipped, at the top
  EXPECT_EQ(second->pixel_format, "RGB12");
  EXPECT_NEAR(second->image.rgb[0], 2000.0 / 4095, 1e-6);
  EXPECT_NE(message_of([&] { source->next(1.0); }).find("16-bit codes up to 5000 above the white level 4095"),
            std::string::npos);
}

TEST(CameraSourceReplay, LoopsPacedWithOrderedExposures) {
  TempDir dir;
  for (int k = 0; k < 2; ++k) cv::imwrite((dir.path / ("a" + std::to_string(k) + ".png")).string(), cv::Mat(4, 4, CV_16UC3, cv::Scalar::all(1000 * (k + 1))));
  std::ofstream(dir.path / "exposures.csv") << "0.01\n0.02\n";
  SourceOptions options;
  options.loop = true;
  options.frame_rate = 200;
  auto source = lp::open_source("replay:" + dir.path.string(), options);
  for (int k = 0; k < 5; ++k) {
    auto frame = source->next(1.0);
    ASSERT_TRUE(frame);
    EXPECT_EQ(frame->sequence, k);
    EXPECT_DOUBLE_EQ(frame->exposure_s, k % 2 ? 0.02 : 0.01);
    EXPECT_NEAR(frame->image.rgb[0], 1000.0 * (k % 2 + 1) / 65535, 1e-6);
    EXPECT_EQ(frame->pixel_format, "RGB16");
    EXPECT_NEAR(frame->timestamp_s, k / 200.0, 1e-9);
    EXPECT_EQ(frame->bracket_index, -1);
  }
  EXPECT_FALSE(source->finished());
}

TEST(CameraSourceReplay, PacesByTheRecordedTimestampsAndRefusesBadOnes) {
  TempDir dir;
  for (int k = 0; k < 3; ++k) cv::imwrite((dir.path / ("f" + std::to_string(k) + ".png")).string(), cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(50)));
  std::ofstream(dir.path / "timestamps.txt") << "100.0\n100.3\n100.6\n";
  auto source = lp::open_source("replay:" + dir.path.string());
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < 3; ++k) ASSERT_TRUE(source->next(2.0)) << k;
  // Frame 2 is due 0.6 s after frame 0 (not a timed assertion on speed: a lower bound).
  EXPECT_GE(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 0.59);
  // Backwards, hex and two numbers per line are refused with the line; named times must
  // cover every image and rise in the images' order.
  const std::pair<const char*, const char*> bad[] = {{"1\n3\n2\n", "timestamps.txt:3"},
                                                     {"1\n0x10\n20\n", "timestamps.txt:2"},
                                                     {"0.1 0.2\n0.3 0.4\n0.5 0.6\n", "no time for f0.png"},
                                                     {"f0.png 2\nf1.png 1\nf2.png 3\n", "f1.png is not after"}};
  for (const auto& [text, where] : bad) {
    std::ofstream(dir.path / "timestamps.txt") << text;
    EXPECT_NE(message_of([&] { lp::open_source("replay:" + dir.path.string()); }).find(where), std::string::npos) << text;
  }
}

TEST(CameraSourceReplay, AFrameThatCannotBeReadIsAnInputErrorNotALostCamera) {
  TempDir dir;
  cv::imwrite((dir.path / "a.png").string(), cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(9)));
  std::ofstream(dir.path / "b.png") << "garbage";
  auto source = lp::open_source("replay:" + dir.path.string());
  ASSERT_TRUE(source->next(1.0));
  EXPECT_NE(message_of([&] { source->next(1.0); }).find("b.png"), std::string::npos);
}

TEST(CameraSourceReplay, BadDirectoriesAndSidecars) {
  TempDir dir;
  EXPECT_NE(message_of([&] { lp::open_source("replay:" + (dir.path / "missing").string()); }).find("not a directory"), std::string::npos);
  EXPECT_NE(message_of([&] { lp::open_source("replay:" + dir.path.string()); }).find("no images"), std::string::npos);
  cv::imwrite((dir.path / "a.png").string(), cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(9)));
  std::ofstream(dir.path / "exposures.csv") << "0.01\n-1\n";
  EXPECT_NE(message_of([&] { lp::open_source("replay:" + dir.path.string()); }).find("exposures.csv:2"), std::string::npos);
}

TEST(CameraSourceVideo, WritesAndReadsBackAnMjpgAvi) {
  TempDir dir;
  const fs::path file = dir.path / "clip.avi";
  {
    cv::VideoWriter writer(file.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10, cv::Size(64, 48));
    ASSERT_TRUE(writer.isOpened());
    for (int k = 0; k < 6; ++k) writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(30 + 40 * k)));
  }
  std::ofstream(dir.path / "clip.exposures.csv") << "0.001\n0.002\n0.004\n0.001\n0.002\n0.004\n";
  auto source = lp::open_source("video:" + file.string());
  double previous = -1;
  for (int k = 0; k < 6; ++k) {
    auto frame = source->next(1.0);
    ASSERT_TRUE(frame) << k;
    EXPECT_EQ(frame->image.width, 64);
    EXPECT_EQ(frame->image.height, 48);
    EXPECT_NEAR(mean(*frame), (30 + 40 * k) / 255.0, 0.03) << k;
    EXPECT_GT(mean(*frame), previous);
    previous = mean(*frame);
    EXPECT_DOUBLE_EQ(frame->exposure_s, 0.001 * (1 << (k % 3)));
    EXPECT_NEAR(frame->timestamp_s, k * 0.1, 1e-6);
  }
  EXPECT_FALSE(source->next(0.1));
  EXPECT_TRUE(source->finished());
  EXPECT_NE(message_of([&] { lp::open_source("video:" + (dir.path / "none.avi").string()); }).find("no such file"), std::string::npos);
}

TEST(CameraSourceAravis, FakeCameraCyclesExposuresAndBrightnessFollows) {
  SourceOptions options;
  options.pixel_format = "Mono16";
  options.frame_rate = 200;
  auto source = lp::open_source("aravis:Fake_1", options);
  EXPECT_NE(source->describe().find("Mono16"), std::string::npos) << source->describe();
  auto first = source->next(2.0);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->image.width, 512);
  EXPECT_EQ(first->bracket_index, -1);

  const std::vector<double> cycle = {0.001, 0.004, 0.016};
  source->set_exposure_cycle(cycle);
  std::vector<CameraFrame> frames;
  for (int k = 0; k < 9; ++k) {
    auto frame = source->next(2.0);
    ASSERT_TRUE(frame) << k;
    frames.push_back(std::move(*frame));
  }
  int64_t last_sequence = -1;
  for (size_t k = 0; k < frames.size(); ++k) {
    const CameraFrame& f = frames[k];
    EXPECT_EQ(f.bracket_index, int(k % 3)) << k;
    ASSERT_GE(f.bracket_index, 0);
    EXPECT_NEAR(f.exposure_s, cycle[size_t(f.bracket_index)], 1e-9) << k;  // read back, not assumed
    EXPECT_GT(f.sequence, last_sequence);
    last_sequence = f.sequence;
    EXPECT_EQ(f.pixel_format, "Mono16");
  }
  EXPECT_LT(frames[0].timestamp_s, frames[8].timestamp_s);
  // Brightness scales with exposure where neither frame clips nor is black.
  for (size_t k = 0; k + 1 < 3; ++k) {
    const CameraFrame &a = frames[k], &b = frames[k + 1];
    const double expected = b.exposure_s / a.exposure_s;
    double sum_a = 0, sum_b = 0;
    size_t n = 0;
    for (size_t i = 0; i < a.image.rgb.size(); i += 3) {
      const float va = a.image.rgb[i], vb = b.image.rgb[i];
      if (va > 0.005f && vb < 0.95f) {
        sum_a += va, sum_b += vb, ++n;
        ASSERT_NEAR(vb / va, expected, 0.05 * expected) << "pixel " << i / 3;
      }
    }
    EXPECT_GT(n, 10000u);
    EXPECT_NEAR(sum_b / sum_a, expected, 0.05 * expected);
  }
  // Black outside the image circle, the sun clipped at the longest exposure.
  EXPECT_EQ(frames[2].image.rgb[0], 0.0f);
  EXPECT_EQ(*std::max_element(frames[2].image.rgb.begin(), frames[2].image.rgb.end()), 1.0f);

  // Back to a fixed exposure.
  source->set_exposure_cycle({});
  auto fixed = source->next(2.0);
  ASSERT_TRUE(fixed);
  EXPECT_EQ(fixed->bracket_index, -1);
}

TEST(CameraSourceAravis, FakeBayerIsDemosaicedAndSceneCanChange) {
  SourceOptions options;
  options.pixel_format = "BayerRG8";
  options.exposure_s = 0.005;
  options.frame_rate = 200;
  options.roi = SourceOptions::Roi{0, 0, 256, 192};
  auto source = lp::open_source("aravis:Fake_1", options);
  auto frame = source->next(2.0);
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->image.width, 256);
  EXPECT_EQ(frame->image.height, 192);
  EXPECT_NEAR(frame->exposure_s, 0.005, 1e-9);
  EXPECT_EQ(frame->pixel_format, "BayerRG8");
  // The zenith (image centre) is blue sky: B > G > R, as painted.
  const size_t centre = (size_t(96) * 256 + 128) * 3;
  const float* px = &frame->image.rgb[centre];
  EXPECT_GT(px[2], px[1]);
  EXPECT_GT(px[1], px[0]);
  EXPECT_NEAR(px[2], 60 * 0.005, 0.03);

  lp::FakeScene brighter;
  for (int c = 0; c < 3; ++c) brighter.sky_zenith[c] = brighter.sky_horizon[c] = 120;
  ASSERT_TRUE(lp::set_fake_scene(*source, brighter));
  bool changed = false;
  for (int k = 0; k < 20 && !changed; ++k) {
    auto f = source->next(2.0);
    ASSERT_TRUE(f);
    changed = std::abs(f->image.rgb[centre + 2] - 0.6f) < 0.02f && std::abs(f->image.rgb[centre] - 0.6f) < 0.02f;
  }
  EXPECT_TRUE(changed);
}

TEST(CameraSourceAravis, UnknownCameraAndPixelFormat) {
  SourceOptions options;
  options.pixel_format = "NoSuchFormat";
  EXPECT_NE(message_of([&] { lp::open_source("aravis:Fake_1", options); }).find("aravis:Fake_1"), std::string::npos);
  TempDir dir;
  cv::imwrite((dir.path / "a.png").string(), cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(9)));
  auto replay = lp::open_source("replay:" + dir.path.string());
  EXPECT_FALSE(lp::set_fake_scene(*replay, {}));
}

TEST(CameraSourceAravis, RequiringASequencerOnACameraWithoutOneIsAClearError) {
  SourceOptions options;
  options.exposure_cycle = {0.001, 0.004};
  options.bracketing = "sequencer";
  const std::string message = message_of([&] { lp::open_source("aravis:Fake_1", options); });
  EXPECT_NE(message.find("aravis:Fake_1"), std::string::npos) << message;
  EXPECT_NE(message.find("no sequencer"), std::string::npos) << message;
  options.bracketing = "auto";  // falls back to per-frame writes
  auto source = lp::open_source("aravis:Fake_1", options);
  std::optional<CameraFrame> frame;
  for (int i = 0; i < 50 && !frame; ++i) frame = source->next(0.5);
  ASSERT_TRUE(frame);
  EXPECT_GE(frame->bracket_index, 0);
}

TEST(CameraSourceLibcamera, NoCameraIsAClearInputError) {
  EXPECT_EQ(message_of([] { lp::open_source("libcamera"); }), "libcamera: no libcamera camera found");
  EXPECT_NE(message_of([] { lp::open_source("libcamera:/base/soc/i2c0/imx477"); }).find("no libcamera camera"), std::string::npos);
}

TEST(CameraSourceSpecs, UnknownSpecsAndMissingDevices) {
  const std::string unknown = message_of([] { lp::open_source("firewire:3"); });
  EXPECT_NE(unknown.find("'firewire:3'"), std::string::npos) << unknown;
  EXPECT_EQ(unknown.find('\n'), std::string::npos);
  EXPECT_NE(message_of([] { lp::open_source("v4l2:0"); }).find("/dev/video0"), std::string::npos);
  EXPECT_NE(message_of([] { lp::open_source("v4l2:x"); }).find("device number"), std::string::npos);
  EXPECT_NE(message_of([] { lp::open_source("replay:"); }).find("directory"), std::string::npos);
}

TEST(CameraSourceAravis, ReconnectKeepsSettingsAndCycle) {
  SourceOptions options;
  options.pixel_format = "Mono8";
  options.frame_rate = 200;
  options.exposure_cycle = {0.002, 0.008};
  auto source = lp::open_source("aravis:Fake_1", options);
  auto before = source->next(2.0);
  ASSERT_TRUE(before);
  EXPECT_EQ(before->bracket_index, 0);
  ASSERT_TRUE(source->reconnect());
  for (int k = 0; k < 4; ++k) {
    auto frame = source->next(2.0);
    ASSERT_TRUE(frame) << k;
    ASSERT_GE(frame->bracket_index, 0);
    EXPECT_NEAR(frame->exposure_s, options.exposure_cycle[size_t(frame->bracket_index)], 1e-9);
    EXPECT_EQ(frame->pixel_format, "Mono8");
  }
}
