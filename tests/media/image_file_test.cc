// ReadGreyImage (rig/media/image_file.h): files written here by OpenCV at 8 and 16 bits, in
// colour and in floating point, read back as the 8-bit grey the detectors take, each pixel
// against the level the header's scaling rule gives for what was written.
#include "odocal/media/image_file.h"

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "media_test.h"
#include "odocal/test_util/test_util.h"

namespace odocal::media {
namespace {

using ::testing::HasSubstr;

class ImageFile : public odocal::testing::MediaTest {};

// A one-row image holding `values` at depth T.
template <typename T>
cv::Mat Row(const std::vector<double>& values, int type) {
  cv::Mat row(1, static_cast<int>(values.size()), type);
  for (size_t i = 0; i < values.size(); ++i) row.at<T>(0, static_cast<int>(i)) = static_cast<T>(values[i]);
  return row;
}

// Each pixel of `grey` is the nearest 8-bit level to value * scale.
void ExpectLevels(const cv::Mat& grey, const std::vector<double>& values, double scale) {
  ASSERT_EQ(grey.type(), CV_8UC1);
  ASSERT_EQ(grey.total(), values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    EXPECT_NEAR(grey.at<std::uint8_t>(0, static_cast<int>(i)), values[i] * scale, 0.5 + 1e-9)
        << "pixel " << i << " written as " << values[i];
  }
}

TEST_F(ImageFile, EightBitGreyReadsBackItsLevelsUnchanged) {
  cv::Mat ramp(16, 16, CV_8UC1);
  for (int i = 0; i < 256; ++i) ramp.at<std::uint8_t>(i / 16, i % 16) = static_cast<std::uint8_t>(i);
  for (const char* ext : {".png", ".tiff", ".pgm"}) {
    const std::string path = Path(std::string("ramp") + ext);
    ASSERT_TRUE(cv::imwrite(path, ramp)) << path;
    const GreyImage read = ReadGreyImage(path);
    ASSERT_EQ(read.grey.type(), CV_8UC1) << path;
    ASSERT_EQ(read.grey.size(), ramp.size()) << path;
    EXPECT_EQ(cv::countNonZero(read.grey != ramp), 0) << path << ": every level as written";
    EXPECT_TRUE(read.conversion.empty()) << path << ": " << read.conversion;
  }
}

TEST_F(ImageFile, SixteenBitFullRangeIsScaledBy255Over65535) {
  const std::vector<double> values = {0, 1, 128, 257, 1000, 30000, 40000, 65534, 65535};
  const std::string path = Path("full.png");
  ASSERT_TRUE(cv::imwrite(path, Row<std::uint16_t>(values, CV_16UC1)));
  const GreyImage read = ReadGreyImage(path);
  ExpectLevels(read.grey, values, 255.0 / 65535.0);
  EXPECT_THAT(read.conversion, HasSubstr("values up to 65535"));
  EXPECT_THAT(read.conversion, HasSubstr("16-bit sensor"));
}

// The case the header exists for: a 12-bit sensor in a 16-bit file is read by its own full scale
// (4095 -> 255), not by OpenCV's top byte (4095 -> 15). The bits are the fewest that hold the
// largest value, so a 12-bit frame that never reaches 4095 is still read as 12 bits.
TEST_F(ImageFile, TenAndTwelveBitSensorsInSixteenBitFilesReachFullScale) {
  struct Case {
    std::string name;
    std::vector<double> values;
    double full_scale;
    std::string says;
  };
  const std::vector<Case> cases = {
      {"twelve_bit_full.png", {0, 1, 16, 100, 2048, 3000, 4000, 4095}, 4095.0, "read as a 12-bit sensor"},
      {"twelve_bit_dim.png", {0, 500, 2047, 2048, 3000}, 4095.0, "values up to 3000: read as a 12-bit sensor"},
      {"ten_bit.png", {0, 4, 511, 512, 1000, 1023}, 1023.0, "read as a 10-bit sensor"},
      {"twelve_bit.tiff", {0, 700, 1400, 4095}, 4095.0, "read as a 12-bit sensor"},
      // At most 255: read as 8 bits, each value its own level.
      {"eight_bit_in_sixteen.png", {0, 17, 200, 255}, 255.0, "read as an 8-bit sensor"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = Path(c.name);
    ASSERT_TRUE(cv::imwrite(path, Row<std::uint16_t>(c.values, CV_16UC1)));
    const GreyImage read = ReadGreyImage(path);
    ExpectLevels(read.grey, c.values, 255.0 / c.full_scale);
    EXPECT_THAT(read.conversion, HasSubstr(c.says));
  }
}

// OpenCV's weights: Y = 0.299 R + 0.587 G + 0.114 B (a codec's fixed-point arithmetic may round
// the other way: within a level).
TEST_F(ImageFile, ColourIsConvertedToGreyWithOpenCvsWeights) {
  const std::vector<cv::Vec3b> bgr = {{0, 0, 0},   {255, 255, 255}, {255, 0, 0},   {0, 255, 0},
                                      {0, 0, 255}, {30, 120, 210},  {200, 10, 90}, {64, 128, 192}};
  cv::Mat colour(1, static_cast<int>(bgr.size()), CV_8UC3);
  for (size_t i = 0; i < bgr.size(); ++i) colour.at<cv::Vec3b>(0, static_cast<int>(i)) = bgr[i];
  for (const char* ext : {".png", ".bmp"}) {
    const std::string path = Path(std::string("colour") + ext);
    ASSERT_TRUE(cv::imwrite(path, colour));
    const GreyImage read = ReadGreyImage(path);
    ASSERT_EQ(read.grey.type(), CV_8UC1) << path;
    ASSERT_EQ(read.grey.total(), bgr.size()) << path;
    for (size_t i = 0; i < bgr.size(); ++i) {
      const double y = 0.114 * bgr[i][0] + 0.587 * bgr[i][1] + 0.299 * bgr[i][2];
      EXPECT_NEAR(read.grey.at<std::uint8_t>(0, static_cast<int>(i)), y, 1.0) << path << ", pixel " << i;
    }
    EXPECT_TRUE(read.conversion.empty()) << read.conversion;
  }
  // A 16-bit colour file: grey first, then the 16-bit rule (here the full 16 bits).
  cv::Mat deep(1, 2, CV_16UC3);
  deep.at<cv::Vec3w>(0, 0) = {65535, 65535, 65535};
  deep.at<cv::Vec3w>(0, 1) = {0, 0, 32768};  // red only
  const std::string path = Path("colour16.png");
  ASSERT_TRUE(cv::imwrite(path, deep));
  const GreyImage read = ReadGreyImage(path);
  ASSERT_EQ(read.grey.type(), CV_8UC1);
  EXPECT_NEAR(read.grey.at<std::uint8_t>(0, 0), 255.0, 1.0);
  EXPECT_NEAR(read.grey.at<std::uint8_t>(0, 1), 0.299 * 32768 * 255.0 / 65535.0, 1.0);
  EXPECT_THAT(read.conversion, HasSubstr("16-bit"));
}

TEST_F(ImageFile, FloatingPointIsScaledBy255InTheUnitRangeElseByItsLargestValue) {
  const std::vector<double> unit = {0.0, 0.25, 0.5, 0.999, 1.0};
  std::string path = Path("unit.tiff");
  ASSERT_TRUE(cv::imwrite(path, Row<float>(unit, CV_32FC1)));
  GreyImage read = ReadGreyImage(path);
  ExpectLevels(read.grey, unit, 255.0);
  EXPECT_THAT(read.conversion, HasSubstr("floating-point"));

  const std::vector<double> radiance = {0.0, 3.0, 10.0, 40.0};
  path = Path("radiance.tiff");
  ASSERT_TRUE(cv::imwrite(path, Row<float>(radiance, CV_32FC1)));
  read = ReadGreyImage(path);
  ExpectLevels(read.grey, radiance, 255.0 / 40.0);
  EXPECT_THAT(read.conversion, HasSubstr("values up to 40"));
}

// The documented failure: an empty image (the caller names the file in its message).
TEST_F(ImageFile, WhatIsNotAnImageReadsAsEmpty) {
  std::ofstream(Path("notes.png")) << "not an image, whatever the name says\n";
  std::ofstream(Path("empty.png"));
  std::filesystem::create_directory(Path("empty_dir"));
  for (const char* name : {"missing.png", "notes.png", "empty.png", "empty_dir"}) {
    const GreyImage read = ReadGreyImage(Path(name));
    EXPECT_TRUE(read.grey.empty()) << name;
    EXPECT_TRUE(read.conversion.empty()) << name << ": " << read.conversion;
  }
}

}  // namespace
}  // namespace odocal::media
