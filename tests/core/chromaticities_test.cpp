#include "core/chromaticities.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"
#include "tests/core/icc_blob.h"

namespace lp {
namespace {

// ACES2065-1 (AP0 primaries, ACES white x 0.32168 y 0.33767): the ACES specification S-2014-004.
const Chromaticities kAp0{{0.7347, 0.2653}, {0.0, 1.0}, {0.0001, -0.0770}, {0.32168, 0.33767}};

TEST(Chromaticities, Rec709IsTheIdentity) {
  const auto m = to_rec709_matrix(kRec709, "test");
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(m[size_t(i)], i % 4 == 0 ? 1.0 : 0.0, 1e-12) << i;
}

// The peer: ACES2065-1 to linear Rec. 709 with Bradford adaptation from the ACES white to
// D65 (the ACES CTL's calculate_cat_matrix default), as printed by colour-science and
// OpenColorIO's ACES configs: its first row and green-to-green entry, to 8 digits. The rest
// of the matrix is held by the white staying neutral and by the ACES specification's own
// RGB -> XYZ matrix (TB-2014-004), whose Y row is AP0's luminance weights.
TEST(Chromaticities, Ap0ToRec709MatchesThePublishedBradfordMatrix) {
  const auto m = to_rec709_matrix(kAp0, "test");
  EXPECT_NEAR(m[0], 2.52168619, 1e-7);
  EXPECT_NEAR(m[1], -1.13413099, 1e-7);
  EXPECT_NEAR(m[2], -0.38755520, 1e-7);
  EXPECT_NEAR(m[4], 1.37271909, 1e-7);
  // The file's white stays neutral: each row sums to 1.
  for (int r = 0; r < 3; ++r) EXPECT_NEAR(m[size_t(3 * r)] + m[size_t(3 * r + 1)] + m[size_t(3 * r + 2)], 1.0, 1e-9);
  // Luminance is kept: Rec. 709's Y of the converted primaries is AP0's Y row (0.3439664498,
  // 0.7281660966, -0.0721325464), since Bradford keeps Y of a colour only up to the white's
  // change; held to 1 % as a check of the primaries' matrix, not of the adaptation.
  const double ap0_y[3] = {0.3439664498, 0.7281660966, -0.0721325464};
  for (int c = 0; c < 3; ++c) {
    const double y709 = 0.2126 * m[size_t(c)] + 0.7152 * m[size_t(3 + c)] + 0.0722 * m[size_t(6 + c)];
    EXPECT_NEAR(y709, ap0_y[c], 0.01) << c;
  }
}

TEST(Chromaticities, DegeneratePrimariesAreRefusedNamingTheSource) {
  Chromaticities flat = kRec709;
  flat.green = {0.395, 0.195};  // on the line from red to blue
  EXPECT_THROW(to_rec709_matrix(flat, "x.exr"), InputError);
  Chromaticities zero_y = kRec709;
  zero_y.white = {0.3, 0.0};
  try {
    to_rec709_matrix(zero_y, "x.exr");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("x.exr: ", 0), 0u) << e.what();
  }
  EXPECT_TRUE(same_chromaticities(kRec709, Chromaticities{}));
  EXPECT_FALSE(same_chromaticities(kRec709, kAp0));
}

}  // namespace
}  // namespace lp

namespace lp {
namespace {

TEST(IccProfile, SrgbIsToldFromWideGamutByColorantsOrByName) {
  const auto srgb = summarize_icc_profile(icc_blob("IEC 61966-2.1 Default RGB", &kSrgbColorants));
  ASSERT_TRUE(srgb);
  EXPECT_TRUE(srgb->srgb);
  EXPECT_TRUE(srgb->has_colorants);
  EXPECT_EQ(srgb->description, "IEC 61966-2.1 Default RGB");
  const auto p3 = summarize_icc_profile(icc_blob("Display P3", &kP3Colorants, true));
  ASSERT_TRUE(p3);
  EXPECT_FALSE(p3->srgb);
  EXPECT_EQ(p3->description, "Display P3");
  // Without colorants (a LUT profile) the name decides.
  EXPECT_TRUE(summarize_icc_profile(icc_blob("sRGB v4 ICC preference perceptual intent beta", nullptr))->srgb);
  EXPECT_FALSE(summarize_icc_profile(icc_blob("Apple Wide Color Sharing Profile", nullptr))->srgb);
}

TEST(IccProfile, BytesThatAreNotAProfileOrPointOutsideItAreSafe) {
  EXPECT_FALSE(summarize_icc_profile(""));
  EXPECT_FALSE(summarize_icc_profile(std::string(200, 'x')));
  std::string cut = icc_blob("Display P3", &kP3Colorants);
  cut.resize(cut.size() - 20);  // the last colorant runs off the end: read as absent
  const auto s = summarize_icc_profile(cut);
  ASSERT_TRUE(s);
  EXPECT_FALSE(s->has_colorants);
  std::string lying = icc_blob("x", nullptr);
  lying[128] = '\x7f';  // a tag count far beyond the table
  EXPECT_TRUE(summarize_icc_profile(lying));
}

}  // namespace
}  // namespace lp
