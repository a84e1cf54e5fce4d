// A clip with known content for the media tests, written by OpenCV's own VideoWriter (not by
// media::Mp4Writer): a white square moving right on a dark grey field, H.264 in .mp4.
#ifndef ODOCAL_TESTS_MEDIA_MEDIA_FIXTURES_H_
#define ODOCAL_TESTS_MEDIA_MEDIA_FIXTURES_H_

#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

namespace odocal::testing {

inline constexpr int kClipWidth = 160;
inline constexpr int kClipHeight = 120;
inline constexpr int kClipFrames = 10;
inline constexpr double kClipFps = 10.0;
inline constexpr int kSquarePx = 16;
inline constexpr int kStepPx = 8;  // the square's move per frame
inline constexpr int kBackground = 40;

// Frame k as drawn: the square's top-left pixel at (16 + 8 k, 52).
inline cv::Mat ClipFrame(int k) {
  cv::Mat bgr(kClipHeight, kClipWidth, CV_8UC3, cv::Scalar::all(kBackground));
  bgr(cv::Rect(16 + kStepPx * k, 52, kSquarePx, kSquarePx)).setTo(cv::Scalar::all(255));
  return bgr;
}

// The square's centre in frame k, pixel centres at integers (OpenCV's convention).
inline cv::Point2d ClipSquareCentre(int k) {
  return {16 + kStepPx * k + (kSquarePx - 1) / 2.0, 52 + (kSquarePx - 1) / 2.0};
}

// Writes the clip in colour (BGR) with fourcc avc1; false when this OpenCV cannot write H.264.
inline bool WriteClipWithOpenCv(const std::string& path) {
  cv::VideoWriter writer(path, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('a', 'v', 'c', '1'), kClipFps,
                         cv::Size(kClipWidth, kClipHeight), true);
  if (!writer.isOpened()) return false;
  for (int k = 0; k < kClipFrames; ++k) writer.write(ClipFrame(k));
  writer.release();
  return true;
}

// The centroid of the pixels brighter than halfway between the field and the square.
inline cv::Point2d BrightCentroid(const cv::Mat& grey) {
  cv::Mat bright;
  cv::threshold(grey, bright, (kBackground + 255) / 2.0, 255, cv::THRESH_BINARY);
  const cv::Moments m = cv::moments(bright, true);
  if (m.m00 <= 0.0) return {-1.0, -1.0};
  return {m.m10 / m.m00, m.m01 / m.m00};
}

}  // namespace odocal::testing

#endif  // ODOCAL_TESTS_MEDIA_MEDIA_FIXTURES_H_
