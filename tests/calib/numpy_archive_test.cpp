// numpy's .npz as mrcal stores optimization_inputs (calib/numpy_archive.h). Python's base64
// and numpy are the references: the vectors below are base64.b85encode's output, and
// tests/calib/consumers/mrcal_consumer.sh has numpy and mrcal load a whole archive.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>
#include <string>

#include "calib/numpy_archive.h"

namespace lp {
namespace {

TEST(NumpyArchive, Base85IsPythonsB85encode) {
  // Python 3.11: base64.b85encode(x) for each x.
  EXPECT_EQ(base85_encode(""), "");
  EXPECT_EQ(base85_encode("a"), "VE");
  EXPECT_EQ(base85_encode("hello"), "Xk~0{Zv");
  EXPECT_EQ(base85_encode(std::string(4, '\0')), "00000");
  EXPECT_EQ(base85_encode(std::string(5, '\xff')), "|NsC0{{");
  EXPECT_EQ(base85_encode(std::string("\x00\x01\x02\x03\x04\x05\x06", 7)), "009C61O)~");
}

// The header text of an .npy and where its data starts.
std::pair<std::string, size_t> npy_header(const std::string& npy) {
  EXPECT_EQ(npy.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  const size_t len = static_cast<unsigned char>(npy[8]) | (static_cast<unsigned char>(npy[9]) << 8);
  return {npy.substr(10, len), 10 + len};
}

TEST(NumpyArchive, NpyHeadersAndDataAreNumpysLayout) {
  const std::string f = npy_bytes(NpyValue::array(std::vector<double>{1.5, -2, 3, 4, 5, 6}, {2, 3}));
  const auto [fh, fdata] = npy_header(f);
  EXPECT_EQ(fdata % 64, 0u);  // numpy aligns the data to 64 bytes
  EXPECT_EQ(fh.rfind("{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }", 0), 0u) << fh;
  EXPECT_EQ(fh.back(), '\n');
  ASSERT_EQ(f.size(), fdata + 48);
  double first;
  std::memcpy(&first, f.data() + fdata, 8);
  EXPECT_EQ(first, 1.5);

  const auto [ih, idata] = npy_header(npy_bytes(NpyValue::array(std::vector<int32_t>{7, 0, -1}, {1, 3})));
  EXPECT_EQ(ih.rfind("{'descr': '<i4', 'fortran_order': False, 'shape': (1, 3), }", 0), 0u) << ih;
  const std::string b = npy_bytes(NpyValue::scalar(true));
  EXPECT_EQ(npy_header(b).first.rfind("{'descr': '|b1', 'fortran_order': False, 'shape': (), }", 0), 0u);
  EXPECT_EQ(b.back(), '\x01');
  // Strings are UCS-4, padded to the longest; None is mrcal's '' ('<U1', one zero code).
  const std::string s = npy_bytes(NpyValue::texts({"ab", "\xc3\xa9"}));  // "ab", "é"
  const auto [sh, sdata] = npy_header(s);
  EXPECT_EQ(sh.rfind("{'descr': '<U2', 'fortran_order': False, 'shape': (2,), }", 0), 0u) << sh;
  EXPECT_EQ(s.substr(sdata), std::string("a\0\0\0b\0\0\0\xe9\0\0\0\0\0\0\0", 16));
  const std::string none = npy_bytes(NpyValue::none());
  EXPECT_EQ(npy_header(none).first.rfind("{'descr': '<U1', 'fortran_order': False, 'shape': (), }", 0), 0u);
  EXPECT_EQ(none.substr(npy_header(none).second), std::string(4, '\0'));
}

uint32_t le32(const std::string& s, size_t at) {
  uint32_t v = 0;
  for (int k = 3; k >= 0; --k) v = (v << 8) | static_cast<unsigned char>(s[at + size_t(k)]);
  return v;
}
uint32_t le16(const std::string& s, size_t at) { return le32(s + std::string(2, '\0'), at) & 0xffff; }

// A zip reader of the records npz_bytes writes, through zlib's inflate.
TEST(NumpyArchive, NpzIsAZipOfDeflatedNpyMembers) {
  const NpyValue a = NpyValue::array(std::vector<double>(1000, 0.25), {1000});
  const NpyValue t = NpyValue::text("LENSMODEL_OPENCV8");
  const std::string zip = npz_bytes({{"intrinsics", a}, {"lensmodel", t}});
  // End of central directory: 2 entries, the central directory where it says.
  ASSERT_GE(zip.size(), 22u);
  const size_t eocd = zip.size() - 22;
  ASSERT_EQ(le32(zip, eocd), 0x06054b50u);
  EXPECT_EQ(le16(zip, eocd + 10), 2u);
  size_t central = le32(zip, eocd + 16);
  EXPECT_EQ(central + le32(zip, eocd + 12), eocd);
  const std::pair<std::string, const NpyValue*> want[] = {{"intrinsics.npy", &a}, {"lensmodel.npy", &t}};
  for (const auto& [name, value] : want) {
    ASSERT_EQ(le32(zip, central), 0x02014b50u);
    const uint32_t crc = le32(zip, central + 16), packed = le32(zip, central + 20), raw = le32(zip, central + 24);
    const size_t name_len = le16(zip, central + 28);
    EXPECT_EQ(zip.substr(central + 46, name_len), name);
    const size_t local = le32(zip, central + 42);
    ASSERT_EQ(le32(zip, local), 0x04034b50u);
    EXPECT_EQ(le16(zip, local + 8), 8u);  // deflated
    const size_t data = local + 30 + le16(zip, local + 26) + le16(zip, local + 28);
    std::string out(raw, '\0');
    z_stream zs{};
    ASSERT_EQ(inflateInit2(&zs, -15), Z_OK);
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(zip.data() + data));
    zs.avail_in = packed;
    zs.next_out = reinterpret_cast<Bytef*>(out.data());
    zs.avail_out = raw;
    EXPECT_EQ(inflate(&zs, Z_FINISH), Z_STREAM_END);
    inflateEnd(&zs);
    EXPECT_EQ(out, npy_bytes(*value));
    EXPECT_EQ(crc, uint32_t(crc32(0, reinterpret_cast<const Bytef*>(out.data()), uInt(out.size()))));
    central += 46 + name_len;
  }
  EXPECT_LT(le32(zip, eocd + 12), zip.size());
  EXPECT_LT(zip.size(), 200u + 8000u / 10);  // 1000 equal doubles deflate to little
}

}  // namespace
}  // namespace lp
