// OpenCV's HDR pipeline (cv::CalibrateDebevec/Robertson, cv::MergeDebevec/Robertson) run
// on a Bracket: the peer our own response recovery and merging are measured against in
// tests and benchmarks. Never used for lightprobe's own answers. (It lives in the library
// because test and bench targets do not see OpenCV's headers.)
#pragma once

#include "core/image_io.h"
#include "hdr/bracket.h"
#include "hdr/response.h"

namespace lp {

enum class OpenCvHdrMethod { Debevec, Robertson };

// The bracket as 8-bit frames (lround(z · 255)), as OpenCV's HDR functions require.
// Conversion happens inside each call below; its time is not counted in `seconds`.
// cv::CalibrateDebevec(samples, lambda, random = false) or cv::CalibrateRobertson()
// with OpenCV's defaults, converted to our log convention (g(128) = 0).
CameraResponse opencv_recover_response(const Bracket& bracket, OpenCvHdrMethod method, int samples = 70,
                                       float lambda = 10.0f);
// cv::MergeDebevec / cv::MergeRobertson with the given response (levels must be 256), or
// with OpenCV's built-in linear response when `response` is null. `seconds` (if non-null)
// receives the time of the merge call alone.
RgbImage opencv_merge(const Bracket& bracket, OpenCvHdrMethod method, const CameraResponse* response = nullptr,
                      double* seconds = nullptr);

}  // namespace lp
