#include "calib/corners_vnl.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <sstream>
#include <tuple>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/limits.h"

namespace lp {
namespace {

namespace fs = std::filesystem;

// One data row: x, y and level, each NaN for '-'.
struct Row {
  std::string file;
  double x = NAN, y = NAN, level = 0;
  int line = 0;
};

double field(const std::string& path, int line, const std::string& text) {
  if (text == "-") return NAN;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(v))
    throw InputError(fmt::format("{}:{}: '{}' is neither a number nor '-' (rows are 'filename x y [level]')", path,
                                 line, text));
  return v;
}

std::vector<Row> read_rows(const std::string& path) {
  std::istringstream in(read_text_file(path, "corners file"));
  std::vector<Row> rows;
  std::string text;
  // vnlog's legend ('# filename x y level', the first '#' line that is not a '##' or '#!'
  // comment) names every row's columns: a row with fewer is cut short, as the last row of a
  // truncated file is (its level, or its y's last digits, lost), not a row without a level.
  size_t columns = 0;
  int legend_line = 0;
  for (int line = 1; std::getline(in, text); ++line) {
    std::istringstream words(text);
    std::vector<std::string> f;
    for (std::string w; words >> w;) f.push_back(w);
    if (f.empty()) continue;
    if (f[0][0] == '#') {  // the legend, vnlog comments
      const bool comment = f[0].rfind("##", 0) == 0 || f[0].rfind("#!", 0) == 0;
      if (!comment && columns == 0 && rows.empty()) {
        columns = f.size() - (f[0] == "#" ? 1 : 0);
        legend_line = line;
      }
      continue;
    }
    if (f.size() != 3 && f.size() != 4)
      throw InputError(fmt::format("{}:{}: {} fields, rows are 'filename x y [level]'", path, line, f.size()));
    if ((columns == 3 || columns == 4) && f.size() != columns)
      throw InputError(fmt::format("{}:{}: {} fields where the legend (line {}) names {}: a row cut short (a "
                                   "truncated file?)",
                                   path, line, f.size(), legend_line, columns));
    Row r{f[0], field(path, line, f[1]), field(path, line, f[2]), f.size() == 4 ? field(path, line, f[3]) : 0.0, line};
    rows.push_back(std::move(r));
  }
  if (rows.empty()) throw InputError(path + ": no corner rows (expected 'filename x y [level]')");
  return rows;
}

// The image as mrcal finds it: as written when absolute or present from here, else beside
// the corners file.
std::string locate(const std::string& vnl, const std::string& image) {
  std::error_code ec;
  if (fs::path(image).is_absolute() || fs::exists(image, ec)) return image;
  return (fs::path(vnl).parent_path() / image).string();
}

double median_of(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// A view's corners run in rows of the board's width, each row's last corner followed by the
// next row's first: a step across the board. The median of the steps that, with rows of
// `width`, would be those, over the median of the others: about width - 1 for the rows the
// corners really run in, about 1 for another width.
double row_jump_ratio(const std::vector<std::array<double, 2>>& c, int width) {
  std::vector<double> within, across;
  for (size_t k = 0; k + 1 < c.size(); ++k) {
    const double step = std::hypot(c[k + 1][0] - c[k][0], c[k + 1][1] - c[k][1]);
    (int(k % size_t(width)) == width - 1 ? across : within).push_back(step);
  }
  if (within.empty() || across.empty()) return NAN;
  return median_of(across) / median_of(within);
}

}  // namespace

void write_corners_vnl(const std::string& path, const BoardDetections& d) {
  std::string t = "# filename x y level\n";
  for (size_t i = 0; i < d.images.size(); ++i) {
    const std::string& name = d.images[i];
    if (name.empty() || name[0] == '#' || name.find_first_of(" \t\r\n\v\f") != std::string::npos)
      throw InputError(fmt::format("{}: cannot write '{}' to corners.vnl: a file name there has no whitespace and "
                                   "does not start with '#'",
                                   path, name));
    if (d.corners[i].empty()) t += name + " - - -\n";
    // In each image's own frame as shown, as OpenCV and mrgingham read it (a view turned into
    // the frame of the others is turned back): read_corners_vnl turns it again.
    for (const auto& c : corners_as_image_shows_them(d, i)) t += fmt::format("{} {:.17g} {:.17g} 0\n", name, c[0], c[1]);
  }
  write_file_atomically(path, t);
}

CornersFile read_corners_vnl(const std::string& path, const BoardSpec& board, double given_width, double given_height) {
  const std::vector<Row> rows = read_rows(path);
  const size_t per_board = size_t(board.cols) * size_t(board.rows);
  CornersFile out;
  BoardDetections& d = out.detections;
  std::set<std::string> seen;
  int weighed_below_one = 0;
  for (size_t begin = 0; begin < rows.size();) {
    size_t end = begin;
    while (end < rows.size() && rows[end].file == rows[begin].file) ++end;
    const Row& first = rows[begin];
    if (!seen.insert(first.file).second)
      throw InputError(fmt::format("{}:{}: {} again: the rows of one view must be consecutive", path, first.line,
                                   first.file));
    const size_t n = end - begin;
    BoardDetection det;
    std::vector<std::array<double, 2>> corners;
    if (n == 1 && (std::isnan(first.x) || std::isnan(first.y))) {
      det.reason = "no board (corners.vnl)";
    } else if (n != per_board) {
      throw InputError(fmt::format("{}:{}: {} has {} corner rows; a {}x{} board has {}", path, first.line, first.file,
                                   n, board.cols, board.rows, per_board));
    } else {
      int missing = 0;
      for (size_t k = begin; k < end; ++k) {
        const Row& r = rows[k];
        if (std::isnan(r.x) || std::isnan(r.y) || std::isnan(r.level) || r.level < 0) ++missing;
        else if (r.level > 0) ++weighed_below_one;
        corners.push_back({r.x, r.y});
      }
      if (missing > 0) {
        corners.clear();
        det.reason = fmt::format("incomplete board in corners.vnl ({} of {} corners not detected)", missing, per_board);
        out.notes.push_back(fmt::format("{}: {}: {} of {} corners not detected; lightprobe solves whole boards only, "
                                        "the view is left out",
                                        path, first.file, missing, per_board));
      } else {
        canonicalize_corner_order(corners, board.cols, board.rows);  // the detector's order (see the header)
        det.found = true;
        det.method = "corners.vnl";
        det.corners = corners;
        ++d.found;
      }
    }
    d.images.push_back(first.file);
    d.per_image.push_back(std::move(det));
    d.corners.push_back(std::move(corners));
    begin = end;
  }
  // A W x H board's corners and an H x W board's are as many, so a file written for the board
  // turned reads without complaint, and every model then misses by thousands of pixels
  // (Fisheye190deg's 6x7 corners read as 7x6: 1.3e5 px RMS, exit 0 but for a warning).
  if (board.cols != board.rows && std::min(board.cols, board.rows) >= 3) {
    int views = 0, turned = 0;
    for (const auto& c : d.corners)
      if (c.size() == per_board) {
        ++views;
        turned += row_jump_ratio(c, board.cols) < 1.5 && row_jump_ratio(c, board.rows) > 2;
      }
    if (views > 0 && 2 * turned > views)
      throw InputError(fmt::format("{}: the corners of {} of its {} views run in rows of {}, not {}: written for a "
                                   "{}x{} board (--board {}x{}?)",
                                   path, turned, views, board.rows, board.cols, board.rows, board.cols, board.rows,
                                   board.cols));
  }
  if (weighed_below_one > 0)
    out.notes.push_back(fmt::format("{}: {} corners have a level above 0 (mrcal weighs them 2^-level); lightprobe "
                                    "weighs every corner 1",
                                    path, weighed_below_one));
  // Every image the file names that is here (headers only, no decode): one size, the
  // size, or a check of the one given. One camera, one resolution: views of a half-size
  // copy among them solved to a model 3.3 px off, most of them then dropped as outliers.
  // Images shown turned by their EXIF Orientation (one camera held upright for some shots):
  // their views turned into the frame of the others, as detect_boards turns them.
  std::vector<std::array<int, 2>> shown(d.images.size(), {0, 0});
  std::vector<int> orientation(d.images.size(), 1);
  for (size_t i = 0; i < d.images.size(); ++i) {
    const std::string file = locate(path, d.images[i]);
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) continue;
    const auto [w, h] = camera_image_size(file, &orientation[i]);
    shown[i] = {w, h};
  }
  turn_views_into_one_frame(d, shown, orientation, board);
  int width = 0, height = 0;
  std::string here;
  for (size_t i = 0; i < d.images.size(); ++i) {
    if (shown[i][0] == 0) continue;
    const std::string file = locate(path, d.images[i]);
    const int w = shown[i][0], h = shown[i][1];
    if (here.empty()) {
      width = w, height = h, here = file;
    } else if (w != width || h != height) {
      throw InputError(fmt::format("{}: {} is {}x{}, {} is {}x{} (one camera, one resolution){}", path, file, w, h, here,
                                   width, height, turned_size_hint(w, h, width, height)));
    }
  }
  if (given_width != 0 || given_height != 0) {
    for (double v : {given_width, given_height})
      if (!(v >= 1 && v <= 1e9) || v != std::floor(v))
        throw InputError(fmt::format("--imagersize {},{}: not two positive whole numbers of pixels", given_width,
                                     given_height));
    const int w = int(given_width), h = int(given_height);
    check_image_size("--imagersize", w, h, "image size");
    // A model written for another size than its images is wrong wherever it is used on them.
    if (!here.empty() && (w != width || h != height))
      throw InputError(fmt::format("--imagersize {},{}: {} (named in {}) is {}x{}{}", w, h, here, path, width, height,
                                   turned_size_hint(w, h, width, height)));
    width = w;
    height = h;
  } else if (width <= 0) {
    throw InputError(path + ": the image size is unknown: none of the images it names is here (" +
                     locate(path, d.images.front()) + ", ...); give it (--imagersize W,H)");
  }
  d.width = width;
  d.height = height;
  return out;
}

}  // namespace lp
