// calib/opencv_storage_check.h: the YAML subset handed to OpenCV's parser. Everything OpenCV's
// own writer emits for camera-file content passes (the peer is the reference), the real
// files of the shared sets pass, and the inputs on which OpenCV 4.6 aborts or hangs (found
// by fuzz_opencv_yaml) are refused naming the line, with the rest of a table of malformed text.
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "calib/opencv_storage_check.h"
#include "core/error.h"
#include "core/file_io.h"

namespace lp {
namespace {

using namespace std::string_literals;  // "...\0..."s keeps the NUL bytes the findings hold

// The check's one-line error for `text` ("" when it passes), as cam.yaml or cam.xml.
std::string error_of(const std::string& text, bool xml = false) {
  try {
    xml ? check_opencv_xml_text("cam.xml", text) : check_opencv_yaml_text("cam.yaml", text);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(OpencvYamlCheck, EverythingOpenCVsWriterEmitsForACameraFilePassesAndReadsBack) {
  cv::FileStorage out(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  out << "image_width" << 1280 << "fx" << 400.25 << "tiny" << 1e-300;
  out << "not_a_number" << std::numeric_limits<double>::quiet_NaN() << "infinite" << -HUGE_VAL;
  out << "distortion_model" << "fisheye"
      << "with_colon" << "a: b # c" << "quoted" << "it's \"x\"" << "empty" << "";
  const cv::Mat K_written = (cv::Mat_<double>(3, 3) << 400, 0, 639.5, 0, 401, 479.5, 0, 0, 1);
  out << "camera_matrix" << K_written;
  out << "coefficients" << cv::Mat(cv::Mat_<float>(1, 14, 0.125f));
  out << "list" << std::vector<double>{1, -2.5, 3e10} << "no_values" << std::vector<int>{};
  out << "nested" << "{" << "rows" << 3 << "inner" << "[" << 1 << 2 << "]" << "}";
  out << "flow_map" << "{:" << "a" << 1 << "b" << "x" << "}";
  const std::string text = out.releaseAndGetString();
  EXPECT_EQ(error_of(text), "") << text;

  cv::FileStorage in(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  EXPECT_EQ(int(in["image_width"]), 1280);
  EXPECT_EQ(std::string(in["with_colon"]), "a: b # c");
  EXPECT_EQ(std::string(in["quoted"]), "it's \"x\"");
  cv::Mat K;
  in["camera_matrix"] >> K;
  EXPECT_EQ(K.at<double>(1, 2), 479.5);
  EXPECT_EQ(int(in["nested"]["inner"][1]), 2);
  EXPECT_EQ(std::string(in["flow_map"]["b"]), "x");
}

TEST(OpencvYamlCheck, TheSharedSetsRealOpenCVFilesPass) {
  const std::string dir = std::string(LIGHTPROBE_SHARED_DATA) + "/calib-opencv-stereo-9x6/reference/";
  for (const char* name : {"opencv_left_intrinsics.yml", "opencv_stereo_intrinsics.yml"}) {
    const std::string path = dir + name;
    ASSERT_TRUE(std::filesystem::exists(path)) << path;
    EXPECT_NO_THROW(check_opencv_yaml_text(path, read_text_file(path))) << path;
  }
}

TEST(OpencvYamlCheck, HandWrittenFormsPass) {
  const std::string text =
      "%YAML 1.0\n---\n# a hand-written camera\nimage_width: 640   # pixels\nimage_height: 480\n"
      "camera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n  data: [ 300., 0., 320.,\n"
      "     0., 300., 240.,  # second row\n\n     0., 0., 1. ]\n"
      "exposures:\n  - 0.001\n  - -2.5e-3\n  - [1, 2]\nname: 'studio A'\nmap: { a: 1, b: [x, y], c: {} }\n";
  EXPECT_EQ(error_of(text), "");
}

TEST(OpencvYamlCheck, TextOnWhichOpenCVAbortsHangsOrGuessesIsRefusedNamingTheLine) {
  struct Case {
    std::string text;
    const char* error;  // after "cam.yaml: "
  };
  const std::vector<Case> cases = {
      // fuzz_opencv_yaml's findings: OpenCV loops forever on the first, aborts on the next four
      {"%YAML:1.0\n---%YAML:1.0\n--\n-", "line 2: unexpected '%' after the value"},
      {"%YAML:1.{\n r:3\n :", "line 1: unexpected '{' after the value"},
      {"%YAML:1.0\nr: { a: 1, : 3}\n", "line 2: an empty key"},
      {"%YAML:1.0\n--- {\n :3\n", "line 2: unexpected '{' after the value"},
      {"%YAML:1.0\nr: {a: 1,\n  : 3}\n", "line 3: an empty key"},
      {"%YAML:1.0\n   :ols: 3\n", "line 2: an empty key"},
      // and what a user's editor can produce
      {"image_width: 3\n", "line 1: the first line must be %YAML:1.0"},
      {"{\"image_width\": 3}\n", "line 1: the first line must be %YAML:1.0"},
      {"%YAML:1.0\na: [1, 2\n", "line 3: a '[' or '{' that is never closed"},
      {"%YAML:1.0\na: [1, , 2]\n", "line 2: an empty item inside '[' or '{'"},
      {"%YAML:1.0\na: [1, 2, ]\n", "line 2: an empty item before ']'"},
      {"%YAML:1.0\na: [1, 2]]\n", "line 2: unexpected ']' after the value"},
      {"%YAML:1.0\na: 1\n  b: 2\n", "line 3: indented deeper without a 'key:' above to hold it"},
      {"%YAML:1.0\n  a: 1\nb: 2\n", "line 3: indented less than the first key"},
      {"%YAML:1.0\na:\n\tb: 2\n", "line 3: a tab in the indentation (YAML indents with spaces)"},
      {"%YAML:1.0\na: \"x\n", "line 2: a quoted string that does not end on its line"},
      {"%YAML:1.0\na: [[[[[[[[[1]]]]]]]]]\n", "line 2: '[' and '{' nested deeper than 8 levels"},
      {"%YAML:1.0\na: b: c\n", "line 2: ': ' inside a plain value (quote it)"},
      {"%YAML:1.0\n- 1\na: 2\n", "line 3: sequence items and keys mixed at one level"},
      {"%YAML:1.0\na:\n  - b: 1\n", "line 3: a mapping inside a sequence item"},
      {"%YAML:1.0\na: &x 1\n", "line 2: a value cannot start with '&'"},
      {"%YAML:1.0\na: 1\n...\n", "line 3: a document marker inside the document"},
      {"%YAML:1.0\na: 1\n%TAG ! x\n", "line 3: a directive after the first line"},
      {"%YAML:1.0\na: 1\x01\n", "line 2: a control byte 0x01"},
      {"%YAML:1.0\na: 1 # \0 in a comment\n"s, "line 2: a control byte 0x00"},
      {"%YAML:1.0\n\xee: 1\n", "line 2: a key must start with a letter or '_', not '\\xee'"},
      {"%YAML:1.0\na: {b 1}\n", "line 2: a key inside '{' must be followed directly by ':'"},
  };
  for (const Case& c : cases)
    EXPECT_EQ(error_of(c.text), std::string("cam.yaml: ") + c.error + " (not the OpenCV YAML a camera file holds)")
        << c.text;
}

TEST(OpencvXmlCheck, EverythingOpenCVsWriterEmitsForACameraFilePassesAndReadsBack) {
  cv::FileStorage out(".xml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_XML);
  out << "image_width" << 1280 << "not_a_number" << std::numeric_limits<double>::quiet_NaN();
  out << "distortion_model" << "fisheye" << "special" << "a <b> & 'c' \"d\"" << "empty" << "";
  const cv::Mat K_written = (cv::Mat_<double>(3, 3) << 400, 0, 639.5, 0, 401, 479.5, 0, 0, 1);
  out << "camera_matrix" << K_written;
  out << "list" << std::vector<double>{1, -2.5, 3e10} << "no_values" << std::vector<int>{};
  out << "nested" << "{" << "rows" << 3 << "inner" << "[" << 1 << 2 << "]" << "}";
  out << "maps" << "[" << "{" << "a" << 1 << "}" << "{" << "a" << 2 << "}" << "]";
  const std::string text = out.releaseAndGetString();
  EXPECT_EQ(error_of(text, true), "") << text;

  cv::FileStorage in(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  EXPECT_EQ(int(in["image_width"]), 1280);
  EXPECT_EQ(std::string(in["special"]), "a <b> & 'c' \"d\"");
  cv::Mat K;
  in["camera_matrix"] >> K;
  EXPECT_EQ(K.at<double>(1, 2), 479.5);
  EXPECT_EQ(int(in["maps"][1]["a"]), 2);
}

TEST(OpencvXmlCheck, TextOnWhichOpenCVCrashesOrGuessesIsRefusedNamingTheLine) {
  const std::string head = "<?xml version=\"1.0\"?>\n<opencv_storage>\n";
  struct Case {
    std::string text;
    const char* error;  // after "cam.xml: "
  };
  const std::vector<Case> cases = {
      // fuzz_opencv_xml's findings: OpenCV dereferences a null pointer on both
      {"<?xml verAion=\0\0\0\"1.0\"?>{\xff\xffpencv_storage>\n"s, "line 1: a control byte 0x00"},
      {"<?xml vers_On=\0\1\0ero<p>\neon"s, "line 1: a control byte 0x00"},
      {"<opencv_storage></opencv_storage>", "line 1: the text must start with <?xml"},
      {"<?xml version=1.0?>\n<opencv_storage/>", "line 1: an attribute must be name=\"value\""},
      {"<?xml version=\"1.0\"?>\n<storage></storage>\n", "line 2: the root element must be <opencv_storage>"},
      {head + "<a>1</b>\n</opencv_storage>\n", "line 3: </b> closes <a>"},
      {head + "<a>1\n", "line 4: <a> is never closed"},
      {head + "<a>1<b>2</b></a>\n</opencv_storage>\n", "line 3: <a> holds both text and elements"},
      {head + "<a>&nbsp;</a>\n</opencv_storage>\n", "line 3: an entity other than &lt; &gt; &amp; &quot; &apos;"},
      {head + "<1a>2</1a>\n</opencv_storage>\n", "line 3: an element name must start with a letter or '_'"},
      {head + "<!-- open\n</opencv_storage>\n", "line 3: a comment not closed by -->"},
      {head + "</opencv_storage>\n<x/>\n", "line 4: text after </opencv_storage>"},
      {head + std::string(17, '<').replace(0, 17, "<a><a><a><a><a><a><a><a><a><a><a><a><a><a><a><a><a>") + "\n</opencv_storage>\n",
       "line 3: elements nested deeper than 16 levels"},
  };
  for (const Case& c : cases)
    EXPECT_EQ(error_of(c.text, true), std::string("cam.xml: ") + c.error + " (not the OpenCV XML a camera file holds)")
        << c.text;
}

}  // namespace
}  // namespace lp
