// Kalibr's target.yaml (and yac's calib_target block) read into an aprilgrid board.
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/config/calib_target.h"
#include "odocal/test_util/test_util.h"

namespace odocal::config {
namespace {

using ::testing::HasSubstr;

TEST(CalibTarget, KalibrAprilgrid) {
  std::string error;
  const auto board = ParseCalibrationTarget(
      "target_type: 'aprilgrid' #gridtype\ntagCols: 6\ntagRows: 5\ntagSize: 0.088\ntagSpacing: 0.3\n", "t.yaml");
  ASSERT_TRUE(board) << board.message;
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
      "yac.yaml");
  ASSERT_TRUE(board) << board.message;
  EXPECT_EQ(board->cols * board->rows, 36);
}

TEST(CalibTarget, OtherTargetsAndBadKeysNameTheLine) {
  std::string error;
  error =
      test_util::ErrorOf(ParseCalibrationTarget("target_type: 'checkerboard'\ntargetCols: 6\ntargetRows: 7\n"
                                                "rowSpacingMeters: 0.06\ncolSpacingMeters: 0.06\n",
                                                "c.yaml"));
  EXPECT_THAT(error, HasSubstr("c.yaml:1: target_type: 'checkerboard': only aprilgrid targets"));
  error = test_util::ErrorOf(
      ParseCalibrationTarget("target_type: aprilgrid\ntagCols: 6\ntagRows: 6\ntagSize: 0.088\n", "m.yaml"));
  EXPECT_THAT(error, HasSubstr("m.yaml:")) << error;
  EXPECT_THAT(error, HasSubstr("tagSpacing")) << error;
  error = test_util::ErrorOf(ParseCalibrationTarget(
      "target_type: aprilgrid\ntagCols: 6\ntagRows: 6\ntagSize: -1\ntagSpacing: 0.3\n", "n.yaml"));
  EXPECT_THAT(error, HasSubstr("n.yaml:4: tagSize")) << error;
  error = test_util::ErrorOf(
      ParseCalibrationTarget("target_type: aprilgrid\ntagCols: 6\ntagRows: 6\ntagSize: 0.1\ntagSpacing: 0.3\n"
                             "tagFamily: t36h11\n",
                             "k.yaml"));
  EXPECT_THAT(error, HasSubstr("tagFamily")) << error;
  EXPECT_FALSE(ReadCalibrationTarget("/nonexistent/target.yaml"));
}

// yac's per-frame detections: the corners read in order, header and blank
// lines skipped, CRLF tolerated; a short line or a corner index out of range
// named by file and line.
TEST(YacAprilgridCsv, ReadsTheCornersAndNamesABadLine) {
  const std::string dir = test_util::MakeTempDir("odocal_yac_csv_");
  const std::string good = dir + "/1403709385487836928.csv";
  std::ofstream(good) << "#ts,tag_rows,tag_cols,tag_size,tag_spacing,kp_x,kp_y,p_x,p_y,p_z,tag_id,corner_idx\r\n"
                      << "1403709385487836928,6,6,0.088,0.3,274.66,57.44,0.0,0.1144,0.0,6,0\r\n"
                      << "\n"
                      << "1403709385487836928,6,6,0.088,0.3,235.92,51.60,0.088,0.1144,0.0,6,1\n";
  const auto read = ReadYacAprilgridCsv(good);
  ASSERT_TRUE(read) << read.message;
  ASSERT_EQ(read->size(), 2u);
  EXPECT_EQ((*read)[1].tag_id, 6);
  EXPECT_EQ((*read)[1].corner, 1);
  EXPECT_NEAR((*read)[1].x_px, 235.92, 1e-12);
  EXPECT_NEAR((*read)[1].board_x_m, 0.088, 1e-12);

  const std::string short_line = dir + "/short.csv";
  std::ofstream(short_line) << "#header\n1,6,6,0.088,0.3,274.66,57.44,0.0,0.1144,0.0,6\n";
  auto bad = ReadYacAprilgridCsv(short_line);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.status, StatusCode::kBadFile);
  EXPECT_THAT(bad.message, ::testing::HasSubstr(short_line + ":2: expected 12 numbers"));
  const std::string corner = dir + "/corner.csv";
  std::ofstream(corner) << "1,6,6,0.088,0.3,274.66,57.44,0.0,0.1144,0.0,6,4\n";
  bad = ReadYacAprilgridCsv(corner);
  ASSERT_FALSE(bad);
  EXPECT_THAT(bad.message, ::testing::HasSubstr(corner + ":1: corner_idx 4 is not 0..3"));
  bad = ReadYacAprilgridCsv(dir + "/missing.csv");
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.status, StatusCode::kNotFound);
}

}  // namespace
}  // namespace odocal::config
