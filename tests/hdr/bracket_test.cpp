#include "hdr/bracket.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.h"
#include "tests/hdr/synthetic_bracket.h"

namespace lp {
namespace {

const std::string kData = LIGHTPROBE_SHARED_DATA;
namespace fs = std::filesystem;

struct TempDir {
  // One directory per test process: ctest runs these tests in parallel processes.
  fs::path path = fs::temp_directory_path() / ("lightprobe_hdr_bracket_test_" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() { fs::remove_all(path); }
  std::string png(const std::string& name, int w, int h) const {
    const std::string p = (path / name).string();
    write_display_image(p, w, h, std::vector<float>(3 * size_t(w) * size_t(h), 0.5f));
    return p;
  }
  std::string text(const std::string& name, const std::string& body) const {
    const std::string p = (path / name).string();
    std::ofstream(p) << body;
    return p;
  }
};

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

TEST(ReadExifExposure, GivesTheKartikMirrorBallPhotosTimesAndReadBracketRefusesTheirMixedCrops) {
  const std::string dir = kData + "/hdr-mirrorball-kartik/";
  EXPECT_DOUBLE_EQ(read_exif_exposure_seconds(dir + "ball_1-10s.jpg").value(), 0.1);
  EXPECT_DOUBLE_EQ(read_exif_exposure_seconds(dir + "ball_1-40s.jpg").value(), 1.0 / 40);
  EXPECT_DOUBLE_EQ(read_exif_exposure_seconds(dir + "ball_1-160s.jpg").value(), 1.0 / 160);
  EXPECT_EQ(read_exposure_list(dir + "exposures.csv"), (std::vector<double>{0.1, 1.0 / 40, 1.0 / 160}));
  // The three photos are hand crops of different sizes (480x472, 484x468, 490x480): not a
  // registered bracket, and the second file is the one named.
  const std::string msg = message_of([&] {
    read_bracket({dir + "ball_1-10s.jpg", dir + "ball_1-40s.jpg", dir + "ball_1-160s.jpg"});
  });
  EXPECT_EQ(msg, dir + "ball_1-40s.jpg: size 484x468 differs from the first image's 480x472");
  EXPECT_FALSE(read_exif_exposure_seconds(kData + "/hdr-memorial-debevec/memorial0061.png").has_value());
}

TEST(ReadExposureList, ReadsTheSharedCsvsDebevecsListAndPlainLines) {
  const auto memorial = read_exposure_list(kData + "/hdr-memorial-debevec/exposures.csv");
  ASSERT_EQ(memorial.size(), 16u);
  EXPECT_DOUBLE_EQ(memorial[0], 32.0);
  EXPECT_DOUBLE_EQ(memorial[15], 0.0009765625);
  EXPECT_EQ(read_exposure_list(kData + "/hdr-memorial-debevec/hdr_image_list.txt"), memorial);
  TempDir tmp;
  EXPECT_EQ(read_exposure_list(tmp.text("plain.txt", "# seconds\n0.5\n\n1/40\n2e-3\n")),
            (std::vector<double>{0.5, 1.0 / 40, 2e-3}));
  EXPECT_NE(message_of([&] { read_exposure_list(tmp.text("neg.txt", "0.5\n-1\n")); }).find("neg.txt:2"),
            std::string::npos);
  EXPECT_THROW(read_exposure_list(tmp.text("junk.csv", "a,b\nx,y\n")), InputError);
  EXPECT_THROW(read_exposure_list(tmp.text("empty.txt", "# nothing\n")), InputError);
}

TEST(ReadBracket, RefusesBadInputWithOneLineNamingTheFile) {
  TempDir tmp;
  const std::string a = tmp.png("a.png", 8, 6), b = tmp.png("b.png", 8, 6), odd = tmp.png("odd.png", 6, 8);
  // One exposure.
  EXPECT_THROW(read_bracket({a}, std::vector<double>{1.0}), InputError);
  // Different sizes: the odd file is named.
  const std::string size_msg = message_of([&] { read_bracket({a, odd}, std::vector<double>{1.0, 2.0}); });
  EXPECT_NE(size_msg.find("odd.png"), std::string::npos) << size_msg;
  // The odd size is named when it is the first frame, too.
  const std::string first_msg = message_of([&] { read_bracket({odd, a, b}, std::vector<double>{1.0, 2.0, 4.0}); });
  EXPECT_EQ(first_msg, odd + ": size 6x8 differs from the 8x6 of 2 of the 3 images");
  // Two frames at one exposure time: both named.
  const std::string same_msg = message_of([&] { read_bracket({a, b}, std::vector<double>{0.5, 0.5}); });
  EXPECT_EQ(same_msg, a + " and " + b + ": the same exposure time 0.5 s; each frame of a bracket needs its own");
  // No EXIF in a PNG and no times given.
  const std::string exif_msg = message_of([&] { read_bracket({a, b}); });
  EXPECT_EQ(exif_msg, a + ": no exposure time in EXIF; give --exposure-times");
  // Non-positive and non-finite times, wrong counts.
  EXPECT_NE(message_of([&] { read_bracket({a, b}, std::vector<double>{1.0, 0.0}); }).find("b.png"), std::string::npos);
  EXPECT_THROW(read_bracket({a, b}, std::vector<double>{1.0, -2.0}), InputError);
  EXPECT_THROW(read_bracket({a, b}, std::vector<double>{1.0, std::nan("")}), InputError);
  EXPECT_THROW(read_bracket({a, b}, std::vector<double>{1.0}), InputError);
  // A missing file.
  EXPECT_THROW(read_bracket({a, (tmp.path / "missing.png").string()}, std::vector<double>{1.0, 2.0}), InputError);
  for (const std::string& m : {size_msg, exif_msg}) EXPECT_EQ(m.find('\n'), std::string::npos);
  // A good one: times kept matched to frames.
  const Bracket ok = read_bracket({a, b}, std::vector<double>{0.5, 0.25});
  EXPECT_EQ(ok.exposure_seconds, (std::vector<double>{0.5, 0.25}));
  EXPECT_EQ(ok.width(), 8);
  EXPECT_EQ(ok.height(), 6);
}

TEST(CheckBracket, NamesInMemoryFramesByIndex) {
  Bracket b = test::photograph(test::random_radiance(4, 4, 0.1, 1.0), {1.0, 2.0}, test::gamma_curve());
  EXPECT_NO_THROW(check_bracket(b));
  b.frames[1].width = 3;
  EXPECT_NE(message_of([&] { check_bracket(b); }).find("bracket frame 1"), std::string::npos);
}

}  // namespace
}  // namespace lp
