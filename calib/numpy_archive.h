// numpy's .npz container, the way mrcal's Python stores a .cameramodel's
// `optimization_inputs` (mrcal/cameramodel.py _serialize_optimization_inputs):
// np.savez_compressed of a dict (one .npy member per key, deflated in a zip), then
// base64.b85encode. Only what that dict holds: little-endian float64 and int32 arrays,
// scalars of float64 and bool, unicode strings and string arrays, and None (which mrcal
// stores as the empty string '').
//
// Written here rather than through a zip library: a handful of zip records around zlib's
// deflate (no zip writer is among the project's Debian dependencies).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace lp {

// One value of the dict: an n-dimensional array (shape {} for a scalar) of one of the kinds.
struct NpyValue {
  enum class Kind { Float64, Int32, Bool, Unicode };
  Kind kind = Kind::Float64;
  std::vector<size_t> shape;          // {} for a scalar
  std::vector<double> f64;            // Float64 (row-major)
  std::vector<int32_t> i32;           // Int32
  bool boolean = false;               // Bool (scalars only)
  std::vector<std::string> strings;   // Unicode (UTF-8 here; UCS-4 in the file), row-major

  static NpyValue array(std::vector<double> values, std::vector<size_t> shape);
  static NpyValue array(std::vector<int32_t> values, std::vector<size_t> shape);
  static NpyValue scalar(double value);
  static NpyValue scalar(bool value);
  static NpyValue text(const std::string& value);
  static NpyValue texts(std::vector<std::string> values);  // 1-D
  static NpyValue none();  // mrcal's None: the empty string
};

// The .npy bytes of one value (format version 1.0, header padded to 64 bytes as numpy does).
std::string npy_bytes(const NpyValue& value);
// A zip archive of `key.npy` members, deflated, in the order given (np.savez_compressed).
std::string npz_bytes(const std::vector<std::pair<std::string, NpyValue>>& entries);
// Python's base64.b85encode (RFC 1924 alphabet, no padding kept).
std::string base85_encode(const std::string& bytes);

}  // namespace lp
