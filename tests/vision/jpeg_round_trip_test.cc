// The camera simulator's MJPEG stage (JpegRoundTrip, vision/image_formation.h)
// against OpenCV's cv::imencode / cv::imdecode, which it replaced: the same
// frames, bit for bit, at every quality the presets and scenarios use.
#include "odocal/vision/image_formation.h"

#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

namespace odocal::vision {
namespace {

cv::Mat OpenCvRoundTrip(const cv::Mat& grey, int quality) {
  std::vector<uchar> bytes;
  cv::imencode(".jpg", grey, bytes, {cv::IMWRITE_JPEG_QUALITY, quality});
  return cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
}

// A frame with what JPEG finds hard: sensor noise, hard edges, smooth shading,
// and a size that is not a multiple of the 8 x 8 blocks.
cv::Mat TestFrame(int width, int height, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 3.0);
  cv::Mat grey(height, width, CV_8UC1);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const bool black = ((u / 11) + (v / 7)) % 3 == 0;
      const double level = (black ? 40.0 : 200.0) + 30.0 * u / width + noise(rng);
      grey.at<uchar>(v, u) = cv::saturate_cast<uchar>(level);
    }
  return grey;
}

TEST(JpegRoundTrip, IsOpenCvsImencodeAndImdecode) {
  unsigned seed = 1;
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(333, 97), cv::Size(8, 8), cv::Size(1, 1)}) {
    for (const int quality : {1, 23, 50, 75, 80, 90, 95, 100}) {
      SCOPED_TRACE(std::to_string(size.width) + "x" + std::to_string(size.height) + " q" + std::to_string(quality));
      const cv::Mat frame = TestFrame(size.width, size.height, seed++);
      const cv::Mat ours = JpegRoundTrip(frame, quality);
      const cv::Mat theirs = OpenCvRoundTrip(frame, quality);
      ASSERT_EQ(ours.size(), frame.size());
      ASSERT_EQ(ours.type(), CV_8UC1);
      EXPECT_EQ(cv::norm(ours, theirs, cv::NORM_INF), 0.0);
      // And it is lossy: a round trip that returned its input would pass the
      // line above only if OpenCV's did too.
      if (quality < 95 && size.area() > 64) {
        EXPECT_GT(cv::norm(ours, frame, cv::NORM_L1), 0.0);
      }
    }
  }
}

}  // namespace
}  // namespace odocal::vision
