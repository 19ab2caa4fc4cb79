#include "calib/numpy_archive.h"

#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace lp {
namespace {

void put16(std::string& out, uint32_t v) {
  out += char(v & 0xff);
  out += char((v >> 8) & 0xff);
}
void put32(std::string& out, uint32_t v) {
  put16(out, v & 0xffff);
  put16(out, v >> 16);
}
template <class T>
void put_raw(std::string& out, const T& v) {  // the host is little-endian (x86-64, arm64)
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

// UTF-8 to code points; a byte that starts no valid sequence stands for itself (Latin-1),
// so any file name survives as some string rather than failing the write.
std::u32string code_points(const std::string& s) {
  std::u32string out;
  for (size_t i = 0; i < s.size();) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    const int n = c < 0x80 ? 0 : (c >> 5) == 0x6 ? 1 : (c >> 4) == 0xe ? 2 : (c >> 3) == 0x1e ? 3 : -1;
    bool ok = n >= 0 && i + size_t(n) < s.size();
    char32_t cp = n <= 0 ? c : (c & (0x3f >> n));
    for (int k = 1; ok && k <= n; ++k) {
      const unsigned char t = static_cast<unsigned char>(s[i + size_t(k)]);
      ok = (t >> 6) == 0x2;
      cp = (cp << 6) | (t & 0x3f);
    }
    if (!ok || n < 0) {
      out += char32_t(c);
      ++i;
    } else {
      out += cp;
      i += size_t(n) + 1;
    }
  }
  return out;
}

std::string shape_text(const std::vector<size_t>& shape) {
  if (shape.empty()) return "()";
  std::string s = "(";
  for (size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + (shape.size() == 1 ? ",)" : ")");
}

size_t element_count(const std::vector<size_t>& shape) {
  size_t n = 1;
  for (size_t d : shape) n *= d;
  return n;
}

// Raw deflate (no zlib header), as zip's method 8 stores it.
std::string deflate_raw(const std::string& in) {
  z_stream zs{};
  if (deflateInit2(&zs, Z_DEFAULT_COMPRESSION, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("zlib: deflateInit2 failed");
  std::string out(deflateBound(&zs, uLong(in.size())), '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  zs.avail_in = uInt(in.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = uInt(out.size());
  const int rc = deflate(&zs, Z_FINISH);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  if (rc != Z_STREAM_END) throw std::runtime_error("zlib: deflate did not finish");
  return out;
}

}  // namespace

namespace {
NpyValue of_kind(NpyValue::Kind kind, std::vector<size_t> shape) {
  NpyValue v;
  v.kind = kind;
  v.shape = std::move(shape);
  return v;
}
}  // namespace

NpyValue NpyValue::array(std::vector<double> values, std::vector<size_t> shape) {
  NpyValue v = of_kind(Kind::Float64, std::move(shape));
  v.f64 = std::move(values);
  return v;
}
NpyValue NpyValue::array(std::vector<int32_t> values, std::vector<size_t> shape) {
  NpyValue v = of_kind(Kind::Int32, std::move(shape));
  v.i32 = std::move(values);
  return v;
}
NpyValue NpyValue::scalar(double value) { return array(std::vector<double>{value}, {}); }
NpyValue NpyValue::scalar(bool value) {
  NpyValue v = of_kind(Kind::Bool, {});
  v.boolean = value;
  return v;
}
NpyValue NpyValue::text(const std::string& value) {  // a scalar: shape ()
  NpyValue v = of_kind(Kind::Unicode, {});
  v.strings = {value};
  return v;
}
NpyValue NpyValue::texts(std::vector<std::string> values) {
  NpyValue v = of_kind(Kind::Unicode, {values.size()});
  v.strings = std::move(values);
  return v;
}
NpyValue NpyValue::none() { return text(""); }

std::string npy_bytes(const NpyValue& v) {
  const size_t n = element_count(v.shape);
  std::string descr, data;
  switch (v.kind) {
    case NpyValue::Kind::Float64:
      if (v.f64.size() != n) throw std::logic_error("npy_bytes: float64 values do not match the shape");
      descr = "<f8";
      for (double x : v.f64) put_raw(data, x);
      break;
    case NpyValue::Kind::Int32:
      if (v.i32.size() != n) throw std::logic_error("npy_bytes: int32 values do not match the shape");
      descr = "<i4";
      for (int32_t x : v.i32) put_raw(data, x);
      break;
    case NpyValue::Kind::Bool:
      if (!v.shape.empty()) throw std::logic_error("npy_bytes: bool arrays are not supported");
      descr = "|b1";
      data += char(v.boolean ? 1 : 0);
      break;
    case NpyValue::Kind::Unicode: {
      if (v.strings.size() != n) throw std::logic_error("npy_bytes: strings do not match the shape");
      std::vector<std::u32string> cps;
      size_t width = 1;  // numpy's smallest unicode item is one character ('' is '<U1')
      for (const std::string& s : v.strings) {
        cps.push_back(code_points(s));
        width = std::max(width, cps.back().size());
      }
      descr = "<U" + std::to_string(width);
      for (const std::u32string& s : cps)
        for (size_t k = 0; k < width; ++k) put_raw(data, uint32_t(k < s.size() ? s[k] : 0));
      break;
    }
  }
  std::string header = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + shape_text(v.shape) + ", }";
  // magic (6) + version (2) + header length (2) + header + '\n', a multiple of 64.
  const size_t total = (10 + header.size() + 1 + 63) / 64 * 64;
  header.append(total - 10 - header.size() - 1, ' ');
  header += '\n';
  std::string out = "\x93NUMPY";
  out += '\x01';
  out += '\x00';
  put16(out, uint32_t(header.size()));
  return out + header + data;
}

std::string npz_bytes(const std::vector<std::pair<std::string, NpyValue>>& entries) {
  constexpr uint32_t kDosDate = (0u << 9) | (1u << 5) | 1u;  // 1980-01-01, as numpy's members
  std::string out, central;
  for (const auto& [key, value] : entries) {
    const std::string name = key + ".npy";
    const std::string raw = npy_bytes(value);
    const std::string packed = deflate_raw(raw);
    if (raw.size() >= 0xffffffffu || out.size() >= 0xffffffffu)
      throw std::runtime_error("npz_bytes: archives of 4 GB or more are not supported");
    const uint32_t crc = uint32_t(crc32(0, reinterpret_cast<const Bytef*>(raw.data()), uInt(raw.size())));
    const uint32_t offset = uint32_t(out.size());
    auto common = [&](std::string& h) {  // the fields local and central headers share
      put16(h, 20);  // version needed: deflate
      put16(h, 0);   // flags
      put16(h, 8);   // deflated
      put16(h, 0);   // time
      put16(h, kDosDate);
      put32(h, crc);
      put32(h, uint32_t(packed.size()));
      put32(h, uint32_t(raw.size()));
      put16(h, uint32_t(name.size()));
      put16(h, 0);   // extra field length
    };
    put32(out, 0x04034b50);
    common(out);
    out += name;
    out += packed;
    put32(central, 0x02014b50);
    put16(central, (3u << 8) | 20u);  // made by: Unix, zip 2.0
    common(central);
    put16(central, 0);               // comment length
    put16(central, 0);               // disk
    put16(central, 0);               // internal attributes
    put32(central, 0644u << 16);     // external: a regular file, rw-r--r--
    put32(central, offset);
    central += name;
  }
  const uint32_t central_offset = uint32_t(out.size());
  out += central;
  put32(out, 0x06054b50);
  put16(out, 0);
  put16(out, 0);
  put16(out, uint32_t(entries.size()));
  put16(out, uint32_t(entries.size()));
  put32(out, uint32_t(central.size()));
  put32(out, central_offset);
  put16(out, 0);
  return out;
}

std::string base85_encode(const std::string& bytes) {
  static constexpr char kAlphabet[] =
      "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz!#$%&()*+-;<=>?@^_`{|}~";
  std::string out;
  out.reserve((bytes.size() + 3) / 4 * 5);
  for (size_t i = 0; i < bytes.size(); i += 4) {
    const size_t n = std::min<size_t>(4, bytes.size() - i);
    uint32_t word = 0;
    for (size_t k = 0; k < 4; ++k)
      word = (word << 8) | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
    char chunk[5];
    for (int k = 4; k >= 0; --k) {
      chunk[k] = kAlphabet[word % 85];
      word /= 85;
    }
    out.append(chunk, n + 1);  // a partial group of n bytes keeps n + 1 characters
  }
  return out;
}

}  // namespace lp
