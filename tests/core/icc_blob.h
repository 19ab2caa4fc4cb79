// Hand-built ICC profiles for tests: the 128-byte header ("acsp" at 36), a tag table, a
// description and, when given, the three colorants (s15Fixed16 XYZ).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace lp {

// A minimal ICC profile with a 'desc' tag (v2 text, or v4 mluc) and, when given, rXYZ, gXYZ
// and bXYZ.
inline std::string icc_blob(const std::string& description, const std::array<std::array<double, 3>, 3>* colorants,
                     bool v4_description = false) {
  auto be32 = [](uint32_t v) {
    return std::string{char(v >> 24), char((v >> 16) & 0xff), char((v >> 8) & 0xff), char(v & 0xff)};
  };
  std::vector<std::pair<std::string, std::string>> tags;
  if (v4_description) {
    std::string utf16;
    for (char c : description) utf16 += '\0', utf16 += c;
    tags.push_back({"desc", "mluc" + be32(0) + be32(1) + be32(12) + "enUS" + be32(uint32_t(utf16.size())) + be32(28) + utf16});
  } else {
    tags.push_back({"desc", "desc" + be32(0) + be32(uint32_t(description.size() + 1)) + description + '\0'});
  }
  if (colorants)
    for (int i = 0; i < 3; ++i) {
      std::string t = "XYZ " + be32(0);
      for (double v : (*colorants)[size_t(i)]) t += be32(uint32_t(int32_t(std::lround(v * 65536))));
      tags.push_back({std::string(1, "rgb"[i]) + "XYZ", t});
    }
  std::string header(128, '\0');
  header.replace(36, 4, "acsp");
  std::string table = be32(uint32_t(tags.size())), data;
  size_t offset = 128 + 4 + 12 * tags.size();
  for (const auto& [sig, body] : tags) {
    table += sig + be32(uint32_t(offset + data.size())) + be32(uint32_t(body.size()));
    data += body;
    while (data.size() % 4) data += '\0';
  }
  std::string icc = header + table + data;
  icc.replace(0, 4, be32(uint32_t(icc.size())));  // the profile's size, which readers check
  return icc;
}

inline const std::array<std::array<double, 3>, 3> kSrgbColorants{{{0.4361, 0.2225, 0.0139}, {0.3851, 0.7169, 0.0971},
                                                          {0.1431, 0.0606, 0.7141}}};
// Display P3's, as Apple's matrix profiles store them (adapted to D50).
inline const std::array<std::array<double, 3>, 3> kP3Colorants{{{0.5151, 0.2412, -0.0011}, {0.2920, 0.6922, 0.0419},
                                                        {0.1571, 0.0666, 0.7841}}};

}  // namespace lp
