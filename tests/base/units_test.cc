// Unit conversions (base/units.h): the named helpers compute exactly what the
// inline expressions they replaced did, so swapping one for the other changes
// no result.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "odocal/base/units.h"

namespace odocal {
namespace {

TEST(Units, AngleHelpersAreTheInlineExpressionsBitForBit) {
  std::mt19937 rng(25);
  std::uniform_real_distribution<double> angle(-1e4, 1e4);
  for (int i = 0; i < 100000; ++i) {
    const double x = angle(rng);
    EXPECT_EQ(RadToDeg(x), x * 180.0 / M_PI) << x;
    EXPECT_EQ(DegToRad(x), x * M_PI / 180.0) << x;
  }
  static_assert(DegToRad(180.0) == M_PI);
  static_assert(RadToDeg(M_PI) == 180.0);
}

TEST(Units, LengthConstantsAreTheLiterals) {
  static_assert(kMToMm == 1e3 && kMmToM == 1e-3);
  EXPECT_EQ(0.25 * kMToMm, 250.0);
}

}  // namespace
}  // namespace odocal
