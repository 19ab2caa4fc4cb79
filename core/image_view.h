// Non-owning views of float images: what algorithms take when they only read (or fill) the
// pixels of an image someone else owns. The owning types (EnvMap, RgbImage, CameraImage)
// hand one out with image_view(); a view is two pointers and four numbers, passed by
// value, and is valid only while its owner lives and is not resized.
//
// Layout: rows top first, `channels` interleaved floats per pixel, `stride` floats from the
// start of one row to the next (width * channels when the rows are packed). The optional
// validity mask has one byte per pixel (0 invalid), its rows stride / channels bytes apart.
#pragma once

#include <cstddef>
#include <cstdint>

namespace lp {

struct ImageView {
  const float* data = nullptr;
  int width = 0, height = 0;
  int channels = 3;
  size_t stride = 0;               // floats between row starts
  const uint8_t* valid = nullptr;  // null: every pixel valid

  bool empty() const { return data == nullptr || width <= 0 || height <= 0; }
  bool packed() const { return stride == size_t(width) * size_t(channels); }
  size_t pixel_count() const { return size_t(width) * size_t(height); }
  const float* row(int y) const { return data + size_t(y) * stride; }
  const float* pixel(int x, int y) const { return row(y) + size_t(x) * size_t(channels); }
  bool is_valid(int x, int y) const { return !valid || valid[size_t(y) * (stride / size_t(channels)) + size_t(x)] != 0; }
};

// The writable twin, for algorithms that fill an image the caller owns.
struct MutableImageView {
  float* data = nullptr;
  int width = 0, height = 0;
  int channels = 3;
  size_t stride = 0;

  float* row(int y) const { return data + size_t(y) * stride; }
  float* pixel(int x, int y) const { return row(y) + size_t(x) * size_t(channels); }
  operator ImageView() const { return {data, width, height, channels, stride, nullptr}; }
};

// A packed view of `width` x `height` pixels of `channels` floats at `data`.
inline ImageView packed_view(const float* data, int width, int height, int channels = 3,
                             const uint8_t* valid = nullptr) {
  return {data, width, height, channels, size_t(width) * size_t(channels), valid};
}
inline MutableImageView packed_view(float* data, int width, int height, int channels = 3) {
  return {data, width, height, channels, size_t(width) * size_t(channels)};
}

struct EnvMap;       // core/envmap.h
struct RgbImage;     // core/image_io.h
struct CameraImage;  // core/image_io.h
// Packed views of the owning types, with their validity masks when they have one.
ImageView image_view(const EnvMap& map);
ImageView image_view(const RgbImage& image);
ImageView image_view(const CameraImage& image);

}  // namespace lp
