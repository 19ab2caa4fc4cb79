// Running the `lightprobe` binary from a test as a user or a script would: its exit code,
// stdout and stderr, and the project's rule for bad input (exit 2, one line naming it).
// Shared by every tests/cli/*_test.cpp; LIGHTPROBE_CLI and LIGHTPROBE_SHARED_DATA come
// from tests/CMakeLists.txt.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

namespace lp::cli_test {

namespace fs = std::filesystem;

struct CliRun {
  int code = -1;
  std::string out, err;
};

inline std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// A scratch directory per test process (ctest runs tests in parallel processes) and, inside
// it, one per test: a whole binary run must not find another test's "lights.json" where a
// test checks that nothing was written.
inline fs::path scratch() {
  static const fs::path process_dir = [] {
    fs::path d = fs::path(::testing::TempDir()) / ("lightprobe_cli_" + std::to_string(::getpid()));
    fs::create_directories(d);
    return d;
  }();
  const ::testing::TestInfo* test = ::testing::UnitTest::GetInstance()->current_test_info();
  if (!test) return process_dir;
  const fs::path dir = process_dir / (std::string(test->test_suite_name()) + "." + test->name());
  fs::create_directories(dir);
  return dir;
}

// An empty directory `name` in this test's scratch directory (emptied if a run left it).
inline fs::path fresh_dir(const std::string& name) {
  const fs::path d = scratch() / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

inline CliRun lightprobe(const std::string& args) {
  const fs::path out = scratch() / "stdout.txt", err = scratch() / "stderr.txt";
  const std::string cmd = std::string(LIGHTPROBE_CLI) + " --no-progress " + args + " >" + out.string() + " 2>" + err.string();
  const int status = std::system(cmd.c_str());
  CliRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

inline std::string shared(const std::string& rel) { return std::string(LIGHTPROBE_SHARED_DATA) + "/" + rel; }

// A JPEG's bytes with an APP1 Exif segment spliced in after its SOI marker whose one entry is
// Orientation (1-8): the pixels stay as stored, as a camera turned for the shot writes them.
inline std::string with_exif_orientation(const std::string& jpeg, char orientation) {
  const std::string exif = std::string("Exif\0\0MM\0*\0\0\0\x08\0\x01", 16) +
                           std::string("\x01\x12\0\x03\0\0\0\x01\0", 9) + orientation + std::string("\0\0", 2) +
                           std::string(4, '\0');
  const std::string app1 = std::string("\xFF\xE1", 2) + char((exif.size() + 2) >> 8) + char((exif.size() + 2) & 0xff) + exif;
  return jpeg.substr(0, 2) + app1 + jpeg.substr(2);
}

inline int line_count(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

// Six synthetic views of a 9x6 board of 30 mm squares (`synth boards`) in dir/boards: the
// images as arguments (" a.png b.png ..."); an empty string when synth boards failed.
inline std::string six_board_images(const fs::path& dir) {
  if (lightprobe("synth boards --views 6 --board 9x6 --square 30 -o " + (dir / "boards").string()).code != 0) return "";
  std::string images;
  for (int i = 0; i < 6; ++i) {  // appended in two steps: GCC 12 warns (-Wrestrict) on " " + a temporary
    images += ' ';
    images += (dir / "boards" / ("board_0" + std::to_string(i) + ".png")).string();
  }
  return images;
}

// A bad input: exit 2, exactly one line on stderr, naming `needle` (the file or option).
inline void expect_one_line_error(const CliRun& r, const std::string& needle) {
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_EQ(line_count(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
}

}  // namespace lp::cli_test
