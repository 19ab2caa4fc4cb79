// Registration of mirror-ball photos: resample each frame so that its ball is centred
// with the same radius in a square image, so that differently cropped brackets (e.g. the
// kartik set: 480x472, 484x468, 490x480) can be fused pixel by pixel.
#pragma once

#include <vector>

#include "core/image_io.h"
#include "probe/mirror_ball.h"

namespace lp {

// The ball in a registered image: centre (output_size / 2, output_size / 2), radius
// output_size / (2 margin). Throws InputError on output_size < 2 or margin <= 0.
BallInImage registered_ball(int output_size, double margin = 1.02);

// Each frame resampled (bilinear on pixel centres, values copied as they are: code values
// stay code values for HDR fusion) so that balls[i] maps onto registered_ball(output_size,
// margin). Output pixels whose source point lies outside the frame [0, W] x [0, H], or
// whose bilinear taps touch an invalid source pixel, are invalid (RgbImage::valid, value 0).
// Units are copied. Throws InputError on mismatched counts, empty frames or a bad ball.
std::vector<RgbImage> register_balls(const std::vector<RgbImage>& frames, const std::vector<BallInImage>& balls,
                                     int output_size, double margin = 1.02);

}  // namespace lp
