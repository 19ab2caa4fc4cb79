#include "calib/calibration_report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/image_io.h"
#include "core/picture_io.h"

namespace lp {

namespace {

double scale_for(const CameraModel& m, const CalibrationPlotOptions& o) {
  if (m.width <= 0 || m.height <= 0) throw InputError("calibration plot: the model has no image size");
  return std::min(1.0, double(o.max_width_px) / m.width);
}

// The plots are drawn with OpenCV (BGR) and written by core's one encoder.
void write_png(const std::string& path, const cv::Mat& bgr) {
  std::vector<uint16_t> rgb(3 * size_t(bgr.cols) * size_t(bgr.rows));
  for (int y = 0; y < bgr.rows; ++y) {
    const uint8_t* row = bgr.ptr<uint8_t>(y);
    uint16_t* out = &rgb[3 * size_t(y) * size_t(bgr.cols)];
    for (int i = 0; i < 3 * bgr.cols; i += 3) out[i] = row[i + 2], out[i + 1] = row[i + 1], out[i + 2] = row[i];
  }
  write_file_atomically(path, encode_rgb_codes(path, bgr.cols, bgr.rows, 8, rgb));
}

}  // namespace

void write_residual_plot(const std::string& path, const CalibrationResult& result,
                         const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                         const CalibrationPlotOptions& options) {
  const double s = scale_for(result.model, options);
  const int w = int(std::lround(result.model.width * s)), h = int(std::lround(result.model.height * s));
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(245, 245, 245));
  double largest = 0;
  for (const CornerResidual& r : result.residuals)
    if (!r.outlier) largest = std::max(largest, std::hypot(r.dx, r.dy));
  const double k = options.arrow_scale > 0 ? options.arrow_scale : (largest > 0 ? 40.0 / largest : 1.0);
  for (const CornerResidual& r : result.residuals) {
    if (r.view < 0 || size_t(r.view) >= corners_per_view.size()) continue;
    const auto& cs = corners_per_view[size_t(r.view)];
    if (r.corner < 0 || size_t(r.corner) >= cs.size()) continue;
    const cv::Point2d p(cs[size_t(r.corner)][0] * s, cs[size_t(r.corner)][1] * s);
    const cv::Point2d q(p.x + r.dx * k, p.y + r.dy * k);
    const double m = largest > 0 ? std::min(1.0, std::hypot(r.dx, r.dy) / largest) : 0;
    const cv::Scalar colour = r.outlier ? cv::Scalar(0, 0, 220) : cv::Scalar(180 * (1 - m), 120 + 60 * m, 40 * m);
    cv::circle(img, p, 1, cv::Scalar(90, 90, 90), cv::FILLED, cv::LINE_AA);
    cv::line(img, p, q, colour, 1, cv::LINE_AA);
  }
  cv::putText(img, fmt::format("residuals x{:.0f}   RMS {:.3f} px   cross-validation {:.3f} px   {}", k,
                               result.model.rms_reprojection_px, result.cross_validation_px, result.model.lensmodel),
              cv::Point(8, 18), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(30, 30, 30), 1, cv::LINE_AA);
  write_png(path, img);
}

void write_coverage_plot(const std::string& path, const CalibrationResult& result,
                         const CalibrationPlotOptions& options) {
  const double s = scale_for(result.model, options);
  const int w = int(std::lround(result.model.width * s)), h = int(std::lround(result.model.height * s));
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(0, 0, 0));
  const int nx = result.coverage_nx, ny = result.coverage_ny;
  int most = 1;
  for (int c : result.coverage) most = std::max(most, c);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int c = result.coverage[size_t(j * nx + i)];
      const cv::Rect cell(i * w / nx, j * h / ny, (i + 1) * w / nx - i * w / nx, (j + 1) * h / ny - j * h / ny);
      // Empty: dark red; otherwise grey to green with log count.
      const double t = c > 0 ? std::log1p(c) / std::log1p(most) : 0;
      const cv::Scalar colour = c == 0 ? cv::Scalar(20, 20, 120) : cv::Scalar(60 * (1 - t), 90 + 140 * t, 60 * (1 - t));
      cv::rectangle(img, cell, colour, cv::FILLED);
      cv::rectangle(img, cell, cv::Scalar(40, 40, 40), 1);
      if (cell.width > 28)
        cv::putText(img, std::to_string(c), cv::Point(cell.x + 3, cell.y + cell.height / 2 + 4), cv::FONT_HERSHEY_SIMPLEX,
                    0.35, cv::Scalar(240, 240, 240), 1, cv::LINE_AA);
    }
  cv::putText(img,
              fmt::format("corners per cell{}", result.corners_poorly_covered ? "   WARNING: image corners poorly covered" : ""),
              cv::Point(8, 18), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  write_png(path, img);
}

void write_uncertainty_plot(const std::string& path, const CalibrationResult& result,
                            const CalibrationPlotOptions& options) {
  const UncertaintyGrid& g = result.uncertainty.headline_grid();
  if (g.nx <= 0 || g.ny <= 0 || g.worst_px.size() != size_t(g.nx) * g.ny)
    throw InputError(fmt::format("{}: the calibration has no projection uncertainty to plot", path));
  const double s = scale_for(result.model, options);
  const int w = int(std::lround(result.model.width * s)), h = int(std::lround(result.model.height * s));
  const int legend = 40;
  cv::Mat img(h + legend, w, CV_8UC3, cv::Scalar(255, 255, 255));
  // Log scale from 0.01 px to the largest value (at least 1 px), turbo colours.
  double hi = 1;
  for (double v : g.worst_px)
    if (std::isfinite(v)) hi = std::max(hi, v);
  hi = std::min(hi, 1000.0);
  const double lo = 0.01;
  // The turbo table once: applyColorMap builds its 256 colours on every call (about 0.5 ms),
  // which per cell and legend column was half of a forced-model calib command.
  cv::Mat ramp(1, 256, CV_8U), turbo;
  for (int i = 0; i < 256; ++i) ramp.at<uint8_t>(0, i) = uint8_t(i);
  cv::applyColorMap(ramp, turbo, cv::COLORMAP_TURBO);
  auto colour = [&](double v) {
    const double t = std::clamp(std::log(std::max(v, lo) / lo) / std::log(hi / lo), 0.0, 1.0);
    const auto b = turbo.at<cv::Vec3b>(0, int(std::lround(255 * t)));
    return cv::Scalar(b[0], b[1], b[2]);
  };
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      const double v = g.worst_px[size_t(j) * g.nx + i];
      const cv::Rect cell(i * w / g.nx, j * h / g.ny, (i + 1) * w / g.nx - i * w / g.nx,
                          (j + 1) * h / g.ny - j * h / g.ny);
      cv::rectangle(img, cell, std::isfinite(v) ? colour(v) : cv::Scalar(0, 0, 0), cv::FILLED);
    }
  // Legend: a colour bar with ticks at decades.
  const int bar_x0 = 8, bar_x1 = w - 8, bar_y = h + 6;
  for (int x = bar_x0; x < bar_x1; ++x) {
    const double v = lo * std::pow(hi / lo, double(x - bar_x0) / (bar_x1 - bar_x0 - 1));
    cv::line(img, {x, bar_y}, {x, bar_y + 10}, colour(v));
  }
  for (double v = lo; v <= hi * 1.0001; v *= 10) {
    const int x = bar_x0 + int(std::lround(std::log(v / lo) / std::log(hi / lo) * (bar_x1 - bar_x0 - 1)));
    cv::line(img, {x, bar_y + 10}, {x, bar_y + 14}, cv::Scalar(0, 0, 0));
    cv::putText(img, fmt::format("{:g} px", v), {std::min(x, w - 50), bar_y + 28}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  const UncertaintyReport& u = result.uncertainty;
  const std::string title =
      fmt::format("projection uncertainty ({}, 1 sigma), rays at infinity: centre {:.3f}  median {:.3f} px{}", u.headline,
                  g.centre_px, g.median_px,
                  std::isfinite(g.corner_px) ? fmt::format("  corners {:.3g} px", g.corner_px) : "");
  cv::putText(img,
              title,
              cv::Point(8, 18), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 255), 2, cv::LINE_AA);
  cv::putText(img,
              title,
              cv::Point(8, 18), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(20, 20, 20), 1, cv::LINE_AA);
  write_png(path, img);
}

}  // namespace lp
