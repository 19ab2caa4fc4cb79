#include "eval/ball_eval.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>

#include "core/error.h"
#include "core/image_io.h"
#include "core/image_view.h"
#include "core/tonemap.h"
#include "probe/cube_map.h"
#include "probe/synthetic_probe.h"

namespace lp {

namespace {

namespace fs = std::filesystem;

constexpr double kDeg = M_PI / 180;

double mean_luminance(const EnvMap& m) {
  double s = 0;
  for (size_t i = 0; i < m.pixel_count(); ++i) s += luminance(m.pixel(i)[0], m.pixel(i)[1], m.pixel(i)[2]);
  return m.pixel_count() ? s / double(m.pixel_count()) : 0;
}

// The map as the case sees it: a sun near the blind spot (Sun), the lower hemisphere
// beyond 120 deg from the view direction blacked out (Dark).
EnvMap case_world(const EnvMap& world, BallBackground bg) {
  EnvMap w = world;
  if (bg == BallBackground::Sun) {
    const Vec3 sun{std::cos(8 * kDeg), 0, std::sin(8 * kDeg)};  // 172 deg from -X
    const float value = float(1e4 * std::max(1e-6, mean_luminance(world)));
    for (size_t i = 0; i < w.pixel_count(); ++i)
      if (dot(pixel_direction(w, i), sun) > std::cos(1.5 * kDeg))
        for (int c = 0; c < 3; ++c) w.rgb[3 * i + c] = value;
  } else if (bg == BallBackground::Dark) {
    for (size_t i = 0; i < w.pixel_count(); ++i) {
      const Vec3 d = pixel_direction(w, i);
      if (d.z < 0 && -d.x < std::cos(150 * kDeg))
        for (int c = 0; c < 3; ++c) w.rgb[3 * i + c] = 0;
    }
  }
  return w;
}

// Share of pixel (x, y) inside the disc, on the renderer's 4 x 4 sub-sample grid.
double coverage(const BallInImage& b, int x, int y) {
  int in = 0;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) {
      const double dx = x + (i + 0.5) / 4 - b.cx, dy = y + (j + 0.5) / 4 - b.cy;
      if (dx * dx + dy * dy <= b.radius_px * b.radius_px) ++in;
    }
  return in / 16.0;
}

// The photo resampled to w x h (bilinear), as a float RGB matrix.
cv::Mat photo_at(const RgbImage& photo, int w, int h) {
  cv::Mat src(photo.height, photo.width, CV_32FC3, const_cast<float*>(photo.rgb.data())), out;
  cv::resize(src, out, cv::Size(w, h), 0, 0, cv::INTER_LINEAR);
  return out;
}

void add_noise(RgbImage& img, uint64_t seed) {
  double mean = 0;
  for (size_t i = 0; i < img.rgb.size(); i += 3) mean += luminance(img.rgb[i], img.rgb[i + 1], img.rgb[i + 2]);
  mean /= double(img.rgb.size() / 3);
  std::mt19937_64 rng(seed ^ 0x9e3779b97f4a7c15ull);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (float& v : img.rgb) v = float(std::max(0.0, v * (1 + 0.02 * normal(rng)) + 0.05 * mean * normal(rng)));
}

}  // namespace

const char* background_name(BallBackground b) {
  switch (b) {
    case BallBackground::Black: return "black";
    case BallBackground::Photo: return "photo";
    case BallBackground::Sun: return "sun";
    case BallBackground::Dark: return "dark";
    case BallBackground::Night: return "night";
  }
  return "?";
}

std::vector<BallBackground> all_ball_backgrounds() {
  return {BallBackground::Black, BallBackground::Photo, BallBackground::Sun, BallBackground::Dark,
          BallBackground::Night};
}

BallCase render_ball_case(const EnvMap& world, BallBackground background, double radius_px, const RgbImage& photo,
                          uint64_t seed, double frame) {
  if (!(radius_px >= 8)) throw InputError("eval ball: the radius must be at least 8 px");
  if (background != BallBackground::Black && photo.rgb.empty())
    throw InputError(fmt::format("eval ball: the {} background needs a photo", background_name(background)));
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  if (!(frame >= 1)) throw InputError("eval ball: the frame must be at least 1 (the crop around the ball)");
  const int w = int(std::ceil(2.9 * frame * radius_px)), h = int(std::ceil(2.5 * frame * radius_px));
  BallCase c;
  c.truth = {1.1 * radius_px + u(rng) * (w - 2.2 * radius_px), 1.1 * radius_px + u(rng) * (h - 2.2 * radius_px),
             radius_px + u(rng) - 0.5};
  c.image = render_mirror_ball(case_world(world, background), c.truth, {}, w, h, 4);
  if (background == BallBackground::Black) return c;
  // Photo behind the ball, at the ball's mean luminance (darkened for Dark).
  const cv::Mat ph = photo_at(photo, w, h);
  double ball_sum = 0, photo_sum = 0;
  size_t n = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float* p = &c.image.rgb[3 * (size_t(y) * w + x)];
      const cv::Vec3f q = ph.at<cv::Vec3f>(y, x);
      photo_sum += luminance(q[0], q[1], q[2]);
      if (coverage(c.truth, x, y) == 1) ball_sum += luminance(p[0], p[1], p[2]), ++n;
    }
  double scale = photo_sum > 0 ? (ball_sum / std::max<size_t>(n, 1)) / (photo_sum / (double(w) * h)) : 0;
  if (background == BallBackground::Dark) scale *= 0.01;
  if (!(scale > 0)) scale = 1;  // a black ball (the spot map): the photo as it is
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double out = 1 - coverage(c.truth, x, y);
      if (out == 0) continue;
      const cv::Vec3f q = ph.at<cv::Vec3f>(y, x);
      for (int ch = 0; ch < 3; ++ch) c.image.rgb[3 * (size_t(y) * w + x) + ch] += float(out * scale * q[ch]);
    }
  if (background == BallBackground::Night) {
    for (float& v : c.image.rgb) v *= 1e-3f;
    add_noise(c.image, seed);
  }
  return c;
}

namespace {

EnvMap read_world(const std::string& path) {
  if (fs::is_directory(path)) return read_cube_map(path, Layout::LatLong, 1024, 512);
  return map_or_scene(path, 1024);
}

// Share of the disc's pixels that are not black: below 1 % there is nothing to find on black.
double lit_share(const BallCase& c) {
  size_t lit = 0, all = 0;
  const BallInImage& b = c.truth;
  for (int y = 0; y < c.image.height; ++y)
    for (int x = 0; x < c.image.width; ++x) {
      if (std::hypot(x + 0.5 - b.cx, y + 0.5 - b.cy) > b.radius_px - 1) continue;
      ++all;
      const float* p = &c.image.rgb[3 * (size_t(y) * c.image.width + x)];
      if (luminance(p[0], p[1], p[2]) > 0) ++lit;
    }
  return all ? double(lit) / all : 0;
}

// The render around the ball, tone-mapped, the true rim green and the found one red, so
// that a miss can be looked at: crop of 1.6 radii around the truth, scaled up to at least
// 480 px (nearest, so that the rims' pixels show).
void write_case_picture(const std::string& path, const BallCase& c, const std::optional<BallInImage>& found) {
  const double r = c.truth.radius_px;
  const int x0 = std::max(0, int(std::floor(c.truth.cx - 1.6 * r))), y0 = std::max(0, int(std::floor(c.truth.cy - 1.6 * r)));
  const int x1 = std::min(c.image.width, int(std::ceil(c.truth.cx + 1.6 * r))),
            y1 = std::min(c.image.height, int(std::ceil(c.truth.cy + 1.6 * r)));
  const int scale = std::max(1, int(std::ceil(480.0 / std::max(1, x1 - x0))));
  const std::vector<float> shown = tone_map(image_view(c.image), {});
  const int w = (x1 - x0) * scale, h = (y1 - y0) * scale;
  std::vector<float> out(3 * size_t(w) * size_t(h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t src = 3 * (size_t(y0 + y / scale) * size_t(c.image.width) + size_t(x0 + x / scale));
      std::copy_n(&shown[src], 3, &out[3 * (size_t(y) * size_t(w) + size_t(x))]);
    }
  auto rim = [&](const BallInImage& b, std::array<float, 3> colour) {
    const int steps = int(8 * M_PI * b.radius_px * scale);
    for (int k = 0; k < steps; ++k) {
      const double a = 2 * M_PI * k / steps;
      // Pixel centres are at integer + 0.5 in the ball's coordinates.
      const int x = int(std::floor((b.cx + b.radius_px * std::cos(a) - x0) * scale)),
                y = int(std::floor((b.cy + b.radius_px * std::sin(a) - y0) * scale));
      if (x >= 0 && y >= 0 && x < w && y < h) std::copy(colour.begin(), colour.end(), &out[3 * (size_t(y) * size_t(w) + size_t(x))]);
    }
  };
  rim(c.truth, {0.0f, 1.0f, 0.0f});
  if (found) rim(*found, {1.0f, 0.0f, 0.0f});
  write_display_image(path, w, h, out);
}

BallRow measure(const std::string& label, const BallCase& c, BallBackground bg, const EvalBallOptions& options) {
  BallRow row;
  row.map = label, row.background = background_name(bg), row.radius_px = c.truth.radius_px;
  if (bg == BallBackground::Black && lit_share(c) < 0.01) {
    row.error = "nothing to see";
    return row;
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::optional<BallInImage> found;
  try {
    found = find_ball(c.image, {}, &row.report);
    row.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    row.found = true;
    row.centre_error_px = std::hypot(found->cx - c.truth.cx, found->cy - c.truth.cy);
    row.radius_error_px = found->radius_px - c.truth.radius_px;
  } catch (const InputError& e) {
    row.error = e.what();
  }
  if (!options.output_dir.empty() && options.picture_beyond_px >= 0 &&
      (!row.found || std::max(row.centre_error_px, std::fabs(row.radius_error_px)) > options.picture_beyond_px)) {
    make_output_directory(options.output_dir);
    write_case_picture((fs::path(options.output_dir) /
                        fmt::format("ball_{}_{}_R{:.0f}.png", label, row.background, c.truth.radius_px))
                           .string(),
                       c, found);
  }
  // What detection is weighed against: unwrapping the same photo (latlong 1024 x 512).
  const auto t1 = std::chrono::steady_clock::now();
  unwrap_mirror_ball(c.image, c.truth, {}, Layout::LatLong, 1024, 512);
  row.unwrap_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
  return row;
}

}  // namespace

EvalBallReport evaluate_ball_detection(const EvalBallOptions& options, const EvalProgress& progress) {
  EvalBallReport report;
  const RgbImage photo = options.photo.empty() ? RgbImage{} : read_rgb_image(options.photo);
  ProgressSteps steps(progress, options.maps.size());
  uint64_t seed = 1;
  for (const std::string& path : options.maps) {
    const std::string label = map_label(fs::path(path).has_filename() ? path : fs::path(path).parent_path().string());
    bool any = !options.include;
    for (double r : options.radii)
      for (BallBackground bg : options.backgrounds) any = any || options.include(label, r, bg);
    if (!any) {
      seed += options.radii.size() * options.backgrounds.size();
      steps.advance();
      continue;
    }
    const EnvMap world = read_world(path);
    for (double r : options.radii)
      for (BallBackground bg : options.backgrounds) {
        const uint64_t case_seed = seed++;
        if (!options.include || options.include(label, r, bg))
          report.rows.push_back(measure(label, render_ball_case(world, bg, r, photo, case_seed, options.frame), bg, options));
      }
    steps.advance();
  }
  if (options.output_dir.empty()) return report;
  make_output_directory(options.output_dir);
  std::string csv =
      "map,background,radius_px,found,centre_error_px,radius_error_px,sigma_centre_px,sigma_radius_px,"
      "noise_sigma_centre_px,noise_sigma_radius_px,confidence,subpixel,rim_agreement,inner_rim_dropped,ms,unwrap_ms,error\n";
  for (const BallRow& r : report.rows)
    csv += fmt::format("{},{},{:.2f},{},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.3f},{},{:.3f},{},{:.2f},{:.2f},\"{}\"\n", r.map,
                       r.background, r.radius_px, r.found ? 1 : 0, r.centre_error_px, r.radius_error_px,
                       r.report.sigma_centre_px, r.report.sigma_radius_px, r.report.noise_sigma_centre_px,
                       r.report.noise_sigma_radius_px, r.report.confidence,
                       r.report.subpixel ? 1 : 0, r.report.rim_agreement, r.report.inner_rim_dropped ? 1 : 0, r.ms,
                       r.unwrap_ms, r.error);
  report.csv_path = (fs::path(options.output_dir) / "ball.csv").string();
  write_file_atomically(report.csv_path, csv);
  return report;
}

std::string EvalBallReport::summary() const {
  std::string s = fmt::format("{:<12} {:<6} {:>6} {:>10} {:>10} {:>9} {:>9} {:>8}\n", "map", "bg", "R px",
                              "centre px", "radius px", "sigma c", "sigma r", "ms");
  for (const BallRow& r : rows) {
    if (!r.found) {
      s += fmt::format("{:<12} {:<6} {:>6.1f}  not found: {}\n", r.map, r.background, r.radius_px, r.error);
      continue;
    }
    s += fmt::format("{:<12} {:<6} {:>6.1f} {:>10.3f} {:>+10.3f} {:>9.3f} {:>9.3f} {:>8.1f}\n", r.map, r.background,
                     r.radius_px, r.centre_error_px, r.radius_error_px, r.report.sigma_centre_px,
                     r.report.sigma_radius_px, r.ms);
  }
  for (BallBackground bg : all_ball_backgrounds()) {
    double wc = 0, wr = 0, ms = 0;
    int n = 0, missed = 0;
    for (const BallRow& r : rows)
      if (r.background == background_name(bg)) {
        if (!r.found) {
          missed += r.error != "nothing to see";
          continue;
        }
        wc = std::max(wc, r.centre_error_px), wr = std::max(wr, std::abs(r.radius_error_px)), ms += r.ms, ++n;
      }
    if (n || missed)
      s += fmt::format("{:<6}: {} found, {} missed; worst centre {:.3f} px, worst |radius| {:.3f} px, mean {:.1f} ms\n",
                       background_name(bg), n, missed, wc, wr, n ? ms / n : 0.0);
  }
  if (!csv_path.empty()) s += fmt::format("-> {}\n", csv_path);
  return s;
}

nlohmann::json EvalBallReport::to_json() const {
  nlohmann::json jr = nlohmann::json::array();
  for (const BallRow& r : rows)
    jr.push_back({{"map", r.map}, {"background", r.background}, {"radius_px", r.radius_px}, {"found", r.found},
                  {"error", r.error}, {"centre_error_px", r.centre_error_px}, {"radius_error_px", r.radius_error_px},
                  {"sigma_centre_px", r.report.sigma_centre_px}, {"sigma_radius_px", r.report.sigma_radius_px},
                  {"ms", r.ms}, {"unwrap_ms", r.unwrap_ms}});
  return {{"csv", csv_path}, {"rows", jr}};
}

}  // namespace lp
