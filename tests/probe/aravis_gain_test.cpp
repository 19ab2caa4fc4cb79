// Which GenICam gain features are in dB (probe/plugin/aravis_gain.h): frames are divided by
// exposure time x gain, so a gain read in the wrong unit scales every light.
#include "probe/plugin/aravis_gain.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lp {
namespace {

TEST(AravisGain, SfncGainIsInDecibelsUnlessItsNodeSaysOtherwise) {
  EXPECT_EQ(gain_feature_db("Gain", "", 6.0), 6.0);
  EXPECT_EQ(gain_feature_db("Gain", "dB", 12.5), 12.5);
  EXPECT_EQ(gain_feature_db("GainAbs", " DB ", 3.0), 3.0);
  // A linear factor: x2 is 6.02 dB, and --gain-db 6.02 writes x2 back.
  ASSERT_TRUE(gain_feature_db("Gain", "x", 2.0));
  EXPECT_NEAR(*gain_feature_db("Gain", "x", 2.0), 6.0206, 1e-4);
  EXPECT_NEAR(*gain_feature_value("Gain", "times", 20.0 * std::log10(2.0)), 2.0, 1e-12);
  EXPECT_FALSE(gain_feature_db("Gain", "x", 0.0));
  EXPECT_EQ(gain_feature_value("Gain", "dB", 9.0), 9.0);
}

TEST(AravisGain, RawStepsAndUnknownUnitsAreNotTakenForDecibels) {
  // GainRaw 120 read as dB divided every frame by 10^6.
  EXPECT_FALSE(gain_feature_db("GainRaw", "", 120.0));
  EXPECT_FALSE(gain_feature_value("GainRaw", "", 6.0));
  EXPECT_FALSE(gain_feature_db("Gain", "percent", 50.0));
  EXPECT_FALSE(gain_feature_db("Gain", "", NAN));
  EXPECT_FALSE(gain_feature_db("DigitalGain", "dB", 3.0));
}

}  // namespace
}  // namespace lp
