// Raw frames: Bayer mosaics and mono buffers from machine-vision cameras (8/12/16 bit,
// one sample per uint16_t, as Aravis/GenICam deliver Mono12/BayerRG12 unpacked), and
// camera RAW files through LibRaw. Every result is an RgbImage of linear code values in
// [0, 1] (value / (2^bit_depth - 1)), the same domain as read_camera_image.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/image_io.h"

namespace lp {

// Colour of the top-left 2x2 cell, read row by row: RGGB is R G / G B.
// (OpenCV names patterns by the second row's second and third pixels instead, so its
// COLOR_BayerBG* is RGGB; demosaic_bayer does that translation.)
enum class BayerPattern { RGGB, BGGR, GRBG, GBRG };

// Demosaics a width x height mosaic (row-major, samples in [0, 2^bit_depth - 1]) with
// OpenCV's edge-aware demosaicing (cv::demosaicing, COLOR_Bayer*2BGR_EA).
// bit_depth in [8, 16]; width and height even and at least 2. Throws InputError on a size
// mismatch, a bad depth, or a sample above 2^bit_depth - 1 (usually the wrong depth).
RgbImage demosaic_bayer(const std::vector<uint16_t>& data, int width, int height, int bit_depth,
                        BayerPattern pattern);

// A mono buffer (same conventions) as a grey RgbImage (R = G = B).
RgbImage mono_to_rgb(const std::vector<uint16_t>& data, int width, int height, int bit_depth);

// Whether `path` names a camera RAW file, by its extension (CR2, CR3, NEF, ARW, DNG, RAF, ORF,
// RW2, PEF, SRW; any case).
bool is_camera_raw_file(const std::string& path);

// A camera RAW file (CR2, NEF, ARW, DNG, ...) developed by LibRaw to linear 16-bit sRGB
// primaries: camera white balance, no gamma, no auto-brightening, values / 65535.
// What a RAW file records of its exposure; 0 where it records nothing.
struct RawExposure {
  double seconds = 0, iso = 0, f_number = 0;
  int orientation = 1;  // the file's, as EXIF's 1-8: the pixels are as stored, not turned by it
};
// `exposure_out` (may be null) receives the shutter time, ISO, f-number and orientation
// recorded in the file. The pixels are as the sensor stored them (RgbImage::orientation says
// the file's orientation; turned_as_shown shows them). Throws InputError naming the file when
// LibRaw cannot open, unpack or develop it.
RgbImage read_camera_raw(const std::string& path, RawExposure* exposure_out = nullptr);

}  // namespace lp
