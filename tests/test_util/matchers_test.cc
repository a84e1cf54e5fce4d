// The test_util matchers themselves: each must accept what is near, reject
// what is far, and say by how much.
#include <cmath>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/test_util/test_util.h"

namespace odocal::test_util {
namespace {

using calibration::Pose2;
using calibration::ReturnError;
using calibration::WheelParams;

// The explanation a matcher gives for `value`, and whether it matched.
template <typename M, typename T>
std::string Explain(const M& matcher, const T& value, bool* matched) {
  ::testing::StringMatchResultListener listener;
  *matched = ::testing::Matcher<const T&>(matcher).MatchAndExplain(value, &listener);
  return listener.str();
}

TEST(IsNearReturnError, AcceptsNearAndRejectsFarOnEachAxis) {
  const ReturnError expected = ReturnError::FromMmDeg(10.0, -5.0, 1.0);
  EXPECT_THAT(expected, IsNearReturnError(expected, 0.0, 0.0));
  EXPECT_THAT(ReturnError::FromMmDeg(10.09, -5.09, 1.009), IsNearReturnError(expected, 0.1, 0.01));
  // x, y and heading each on their own.
  EXPECT_THAT(ReturnError::FromMmDeg(10.2, -5.0, 1.0), ::testing::Not(IsNearReturnError(expected, 0.1, 0.01)));
  EXPECT_THAT(ReturnError::FromMmDeg(10.0, -5.2, 1.0), ::testing::Not(IsNearReturnError(expected, 0.1, 0.01)));
  EXPECT_THAT(ReturnError::FromMmDeg(10.0, -5.0, 1.02), ::testing::Not(IsNearReturnError(expected, 0.1, 0.01)));
  // Per axis, not by distance: 0.09 mm in x and in y is 0.127 mm away, still near.
  EXPECT_THAT(ReturnError::FromMmDeg(10.09, -4.91, 1.0), IsNearReturnError(expected, 0.1, 0.01));
  // A NaN is never near.
  ReturnError nan = expected;
  nan.x_m = std::nan("");
  EXPECT_THAT(nan, ::testing::Not(IsNearReturnError(expected, 1e9, 1e9)));
}

TEST(IsNearReturnError, HeadingsWrapAndMustBePresentOnBothSidesOrNeither) {
  EXPECT_THAT(ReturnError::FromMmDeg(0, 0, 179.995),
              IsNearReturnError(ReturnError::FromMmDeg(0, 0, -179.995), 0.0, 0.011));
  EXPECT_THAT(ReturnError::FromMmDeg(3, 4), IsNearReturnError(ReturnError::FromMmDeg(3, 4), 0.0, 0.0));
  EXPECT_THAT(ReturnError::FromMmDeg(3, 4),
              ::testing::Not(IsNearReturnError(ReturnError::FromMmDeg(3, 4, 0.0), 1.0, 1.0)));
  EXPECT_THAT(ReturnError::FromMmDeg(3, 4, 0.0),
              ::testing::Not(IsNearReturnError(ReturnError::FromMmDeg(3, 4), 1.0, 1.0)));
}

TEST(IsNearReturnError, TakesPosesAndSaysHowFarOff) {
  const Pose2 expected = Pose2::FromXYHeading(0.010, -0.005, 1.0 * M_PI / 180.0);
  EXPECT_THAT(Pose2::FromXYHeading(0.010, -0.005, 1.0 * M_PI / 180.0),
              IsNearReturnError(expected, 1e-9, 1e-9));
  EXPECT_THAT(ReturnError::FromMmDeg(10.0, -5.0, 1.0), IsNearReturnError(expected, 1e-9, 1e-9));
  bool matched = true;
  const std::string why = Explain(IsNearReturnError(expected, 0.1, 0.01),
                                  Pose2::FromXYHeading(0.0105, -0.005, 1.5 * M_PI / 180.0), &matched);
  EXPECT_FALSE(matched);
  EXPECT_THAT(why, ::testing::HasSubstr("off by (0.5"));
  EXPECT_THAT(why, ::testing::HasSubstr("0.5 deg"));
  const std::string missing =
      Explain(IsNearReturnError(ReturnError::FromMmDeg(0, 0, 0), 1.0, 1.0), ReturnError::FromMmDeg(0, 0), &matched);
  EXPECT_FALSE(matched);
  EXPECT_THAT(missing, ::testing::HasSubstr("heading missing"));
}

WheelParams Params(double left_mm, double right_mm, double track_mm) {
  WheelParams p;
  p.left_wheel_diameter_m = left_mm * 1e-3;
  p.right_wheel_diameter_m = right_mm * 1e-3;
  p.track_m = track_mm * 1e-3;
  p.ticks_per_rev = 2048;
  return p;
}

TEST(IsNearWheelParams, AcceptsNearAndRejectsFarInEachField) {
  const WheelParams expected = Params(69.95, 70.06, 303.0);
  EXPECT_THAT(expected, IsNearWheelParams(expected, 0.0));
  EXPECT_THAT(Params(69.959, 70.051, 303.009), IsNearWheelParams(expected, 0.01));
  EXPECT_THAT(Params(69.97, 70.06, 303.0), ::testing::Not(IsNearWheelParams(expected, 0.01)));
  EXPECT_THAT(Params(69.95, 70.04, 303.0), ::testing::Not(IsNearWheelParams(expected, 0.01)));
  EXPECT_THAT(Params(69.95, 70.06, 303.5), ::testing::Not(IsNearWheelParams(expected, 0.01)));
  EXPECT_THAT(Params(std::nan(""), 70.06, 303.0), ::testing::Not(IsNearWheelParams(expected, 1e9)));
  bool matched = true;
  const std::string why = Explain(IsNearWheelParams(expected, 0.01), Params(69.95, 70.06, 303.5), &matched);
  EXPECT_FALSE(matched);
  EXPECT_THAT(why, ::testing::HasSubstr("0.5 mm (track)"));
}

}  // namespace
}  // namespace odocal::test_util
