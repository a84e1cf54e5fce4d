// Kalibr's target.yaml (and yac's calib_target block) read into an aprilgrid board.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/config/calib_target.h"

namespace odocal::config {
namespace {

using ::testing::HasSubstr;

TEST(CalibTarget, KalibrAprilgrid) {
  std::string error;
  const auto board = ParseCalibrationTarget(
      "target_type: 'aprilgrid' #gridtype\ntagCols: 6\ntagRows: 5\ntagSize: 0.088\ntagSpacing: 0.3\n", "t.yaml", &error);
  ASSERT_TRUE(board) << error;
  EXPECT_EQ(board->type, vision::CalibrationBoard::Type::kAprilgrid);
  EXPECT_EQ(board->cols, 6);
  EXPECT_EQ(board->rows, 5);
  EXPECT_NEAR(board->square_m, 0.088, 1e-12);
  EXPECT_NEAR(board->spacing, 0.3, 1e-12);
  EXPECT_EQ(board->first_id, 0);
  EXPECT_EQ(board->tag_family, "tag36h11b2");
  // Kalibr's layout: tag 7 = column 1, row 1; corner 2 its top-right.
  const auto p = board->AprilgridCorner(7, 2);
  ASSERT_TRUE(p);
  EXPECT_NEAR(p->x, 1.3 * 0.088 + 0.088, 1e-6);
  EXPECT_NEAR(p->y, 1.3 * 0.088 + 0.088, 1e-6);
  EXPECT_FALSE(board->AprilgridCorner(30, 0));
}

TEST(CalibTarget, YacCalibTargetBlockWithOtherSections) {
  std::string error;
  const auto board = ParseCalibrationTarget(
      "settings:\n  fix_intrinsics: true\ncalib_target:\n  target_type: 'aprilgrid'\n  tag_rows: 6\n"
      "  tag_cols: 6\n  tag_size: 0.088\n  tag_spacing: 0.3\ncam0:\n  resolution: [640, 480]\n",
      "yac.yaml", &error);
  ASSERT_TRUE(board) << error;
  EXPECT_EQ(board->cols * board->rows, 36);
}

TEST(CalibTarget, OtherTargetsAndBadKeysNameTheLine) {
  std::string error;
  EXPECT_FALSE(ParseCalibrationTarget("target_type: 'checkerboard'\ntargetCols: 6\ntargetRows: 7\n"
                                      "rowSpacingMeters: 0.06\ncolSpacingMeters: 0.06\n",
                                      "c.yaml", &error));
  EXPECT_THAT(error, HasSubstr("c.yaml:1: target_type: 'checkerboard': only aprilgrid targets"));
  EXPECT_FALSE(ParseCalibrationTarget("target_type: aprilgrid\ntagCols: 6\ntagRows: 6\ntagSize: 0.088\n", "m.yaml",
                                      &error));
  EXPECT_THAT(error, HasSubstr("m.yaml:")) << error;
  EXPECT_THAT(error, HasSubstr("tagSpacing")) << error;
  EXPECT_FALSE(ParseCalibrationTarget("target_type: aprilgrid\ntagCols: 6\ntagRows: 6\ntagSize: -1\ntagSpacing: 0.3\n",
                                      "n.yaml", &error));
  EXPECT_THAT(error, HasSubstr("n.yaml:4: tagSize")) << error;
  EXPECT_FALSE(ParseCalibrationTarget("target_type: aprilgrid\ntagCols: 6\ntagRows: 6\ntagSize: 0.1\ntagSpacing: 0.3\n"
                                      "tagFamily: t36h11\n",
                                      "k.yaml", &error));
  EXPECT_THAT(error, HasSubstr("tagFamily")) << error;
  EXPECT_FALSE(ReadCalibrationTarget("/nonexistent/target.yaml"));
}

}  // namespace
}  // namespace odocal::config
