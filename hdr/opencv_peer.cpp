#include "hdr/opencv_peer.h"

#include <chrono>
#include <cmath>

#include <opencv2/photo.hpp>

#include "core/error.h"

namespace lp {
namespace {

std::vector<cv::Mat> to_8bit(const Bracket& b) {
  check_bracket(b);
  std::vector<cv::Mat> mats;
  for (const RgbImage& f : b.frames) {
    cv::Mat m(f.height, f.width, CV_8UC3);  // channel order kept as R, G, B throughout
    uint8_t* d = m.ptr<uint8_t>(0);
    for (size_t i = 0; i < f.rgb.size(); ++i)
      d[i] = uint8_t(std::clamp(std::lround(double(f.rgb[i]) * 255.0), 0L, 255L));
    mats.push_back(m);
  }
  return mats;
}

std::vector<float> times_of(const Bracket& b) {
  return std::vector<float>(b.exposure_seconds.begin(), b.exposure_seconds.end());
}

cv::Mat linear_domain(const CameraResponse& r) {
  if (r.levels != 256) throw InputError("OpenCV's merge needs a 256-level response");
  cv::Mat m(256, 1, CV_32FC3);
  for (int z = 0; z < 256; ++z)
    for (int c = 0; c < 3; ++c) m.at<cv::Vec3f>(z)[c] = std::exp(r.log_exposure[size_t(c)][size_t(z)]);
  return m;
}

}  // namespace

CameraResponse opencv_recover_response(const Bracket& b, OpenCvHdrMethod method, int samples, float lambda) {
  const std::vector<cv::Mat> mats = to_8bit(b);
  cv::Mat resp;
  if (method == OpenCvHdrMethod::Debevec)
    cv::createCalibrateDebevec(samples, lambda, false)->process(mats, resp, times_of(b));
  else
    cv::createCalibrateRobertson()->process(mats, resp, times_of(b));
  CameraResponse r;
  r.levels = 256;
  for (int c = 0; c < 3; ++c) {
    auto& g = r.log_exposure[size_t(c)];
    g.resize(256);
    const double mid = std::log(std::max(double(resp.at<cv::Vec3f>(128)[c]), 1e-30));
    for (int z = 0; z < 256; ++z) g[size_t(z)] = float(std::log(std::max(double(resp.at<cv::Vec3f>(z)[c]), 1e-30)) - mid);
  }
  return r;
}

RgbImage opencv_merge(const Bracket& b, OpenCvHdrMethod method, const CameraResponse* response, double* seconds) {
  const std::vector<cv::Mat> mats = to_8bit(b);
  const std::vector<float> times = times_of(b);
  cv::Mat resp = response ? linear_domain(*response) : cv::Mat();
  cv::Mat hdr;
  const auto start = std::chrono::steady_clock::now();
  if (method == OpenCvHdrMethod::Debevec)
    cv::createMergeDebevec()->process(mats, hdr, times, resp);
  else
    cv::createMergeRobertson()->process(mats, hdr, times, resp);
  if (seconds) *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  RgbImage out;
  out.width = hdr.cols;
  out.height = hdr.rows;
  out.rgb.assign(hdr.ptr<float>(0), hdr.ptr<float>(0) + 3 * size_t(hdr.cols) * size_t(hdr.rows));
  return out;
}

}  // namespace lp
