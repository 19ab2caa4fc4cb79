#include "core/sensor_white_level.h"

#include <gtest/gtest.h>

#include <vector>

namespace lp {
namespace {

// 10,000 values spread over codes 0 .. spread - 1, and `clipped` more at `top`.
std::vector<float> codes(long spread, long top, int clipped) {
  std::vector<float> v;
  for (int i = 0; i < 10000; ++i) v.push_back(float(double(i % spread) / 65535.0));
  for (int i = 0; i < clipped; ++i) v.push_back(float(double(top) / 65535.0));
  return v;
}

TEST(SensorWhiteLevel, APileUpAtASensorsTopCodeIsItsWhiteLevelAndNothingElseIs) {
  for (long top : {1023L, 4095L, 16383L}) {
    const auto v = codes(top, top, 50);
    const SensorWhiteLevel found = find_sensor_white_level({&v});
    EXPECT_EQ(found.code, top);
    EXPECT_EQ(found.at_top, 50u);
  }
  EXPECT_EQ(white_level_bits(4095), 12);
  // Not a clip: too few at the top (noise), the top bit used, a top that is no 2^N - 1 (an
  // 8-bit image scaled by 257 that stays dark; a flat synthetic frame).
  const auto few = codes(4095, 4095, 10), full = codes(60000, 65535, 50), scaled = codes(127 * 257, 127 * 257, 50),
             flat = std::vector<float>(1000, float(30000 / 65535.0));
  for (const auto* v : {&few, &full, &scaled, &flat}) EXPECT_EQ(find_sensor_white_level({v}).code, 0);
  // Read at the white level: the top is 1, the rest k / 4095.
  std::vector<float> read = {float(4095 / 65535.0), float(1000 / 65535.0), 0.0f};
  read_at_white_level(read, 4095);
  EXPECT_EQ(read[0], 1.0f);
  EXPECT_FLOAT_EQ(read[1], float(1000.0 / 4095.0));
  EXPECT_EQ(read[2], 0.0f);
}

}  // namespace
}  // namespace lp
