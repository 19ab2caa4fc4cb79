// What a camera image file's header says, read without decoding it: the format, the size,
// and the fewest bytes any file of that size can have. OpenCV 4.6 allocates what a header
// claims before it finds out the data is missing (a 30 KB JPEG claiming 16384x16384 pixels
// decodes to 7 GB of grey), so read_camera_image checks this first (core/limits.h).
//
// Formats: PNG (IHDR), JPEG (the first SOFn frame header), TIFF (the first IFD's
// ImageWidth and ImageLength; classic TIFF, not BigTIFF), binary and ASCII PNM (P1-P6)
// and BMP. Also the EXIF Orientation a JPEG (APP1 "Exif"), a PNG (eXIf) or a TIFF (its first
// IFD) states.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace lp {

enum class ImageFormat { Png, Jpeg, Tiff, Pnm, Bmp };
std::string_view to_string(ImageFormat format);

struct ImageHeader {
  ImageFormat format = ImageFormat::Png;
  long long width = 0, height = 0;
  // No valid file of this size is smaller (0: the encoding allows no safe bound). PNG:
  // deflate packs at most 1032 bytes into one (a 258-byte match in two bits); Huffman
  // JPEG: every 8x8 block of the full-resolution component costs at least one bit;
  // binary PNM: every sample is stored. Arithmetic-coded JPEG, TIFF and BMP get none.
  uint64_t min_file_bytes = 0;
  // EXIF Orientation (TIFF tag 274): how viewers turn the stored pixels for display, 1-8 as
  // in the EXIF 2.3 specification (1 as stored, 6 rotated 90 degrees clockwise, ...). 1
  // when the file states none, or a value outside 1-8 or in a damaged EXIF block (viewers
  // then show the pixels as stored too). `width` and `height` are the stored size.
  int orientation = 1;
  // TIFF: its samples decode to floating point, radiance rather than camera codes: IEEE
  // floats (SampleFormat 3), or Greg Ward's LogLuv (compression SGILOG or SGILOG24, what
  // OpenCV writes for 3-channel float images).
  bool float_samples = false;
};

// nullopt when `bytes` is none of the formats above. Throws InputError naming `path` when
// the header is one of them but damaged or invalid (a PNG bit depth its colour type does
// not allow, a JPEG without a frame header), in one line.
std::optional<ImageHeader> read_image_header(const std::string& path, std::string_view bytes);

}  // namespace lp
