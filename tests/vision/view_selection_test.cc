// SelectViews: a calibration video is mostly one pose again; the views chosen
// must be the ones that differ, and calibrate as well as every view does.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "odocal/vision/camera_calibration.h"

namespace odocal::vision {
namespace {

const cv::Size kSize(640, 480);
const cv::Matx33d kK(600.0, 0.0, 322.0, 0.0, 601.0, 238.0, 0.0, 0.0, 1.0);
const std::vector<double> kDistortion = {-0.21, 0.05, 0.0004, -0.0003, 0.0};

// A 7 x 7 grid of points 60 mm apart, seen from `distance_m` with the board
// turned by (rx, ry, rz) deg and shifted by (tx, ty) m; the points inside
// the image kept, with seeded noise of 0.1 px.
BoardDetection View(double rx, double ry, double rz, double tx, double ty, double distance_m, std::mt19937& rng) {
  std::vector<cv::Point3f> board;
  for (int j = 0; j < 7; ++j)
    for (int i = 0; i < 7; ++i) board.emplace_back(0.06f * (i - 3), 0.06f * (j - 3), 0.0f);
  const cv::Vec3d rvec = cv::Vec3d(rx, ry, rz) * (M_PI / 180.0);
  const cv::Vec3d tvec(tx, ty, distance_m);
  std::vector<cv::Point2f> px;
  cv::projectPoints(board, rvec, tvec, kK, kDistortion, px);
  std::normal_distribution<float> noise(0.0f, 0.1f);
  BoardDetection d;
  for (size_t k = 0; k < board.size(); ++k) {
    if (px[k].x < 2 || px[k].y < 2 || px[k].x > kSize.width - 3 || px[k].y > kSize.height - 3) continue;
    d.object_points.push_back(board[k]);
    d.image_points.emplace_back(px[k].x + noise(rng), px[k].y + noise(rng));
  }
  d.found = d.image_points.size() >= 16;
  return d;
}

// 270 frames of a camera hovering over the board's centre (jitter of a
// degree and a centimetre), 30 spread over the field and tilted.
std::vector<BoardDetection> Video(std::vector<bool>* distinct) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<BoardDetection> views;
  for (int i = 0; i < 300; ++i) {
    const bool spread = i % 10 == 3;
    if (spread) {
      views.push_back(View(35.0 * u(rng), 35.0 * u(rng), 90.0 * u(rng), 0.25 * u(rng), 0.18 * u(rng),
                           0.55 + 0.35 * (u(rng) + 1.0), rng));
    } else {
      views.push_back(View(u(rng), u(rng), u(rng), 0.01 * u(rng), 0.01 * u(rng), 0.7 + 0.01 * u(rng), rng));
    }
    distinct->push_back(spread);
  }
  return views;
}

double FxError(const std::vector<BoardDetection>& all, const std::vector<size_t>& which) {
  std::vector<BoardDetection> views;
  for (size_t i : which) views.push_back(all[i]);
  const CameraCalibrationResult r = CalibrateCamera(views, kSize);
  EXPECT_TRUE(r.ok()) << r.message;
  return std::abs(r.intrinsics.fx - kK(0, 0)) + std::abs(r.intrinsics.cx - kK(0, 2)) + std::abs(r.intrinsics.cy - kK(1, 2));
}

TEST(SelectViews, ChoosesTheViewsThatDifferAndCalibratesFromThem) {
  std::vector<bool> distinct;
  const std::vector<BoardDetection> views = Video(&distinct);
  const std::vector<size_t> chosen = SelectViews(views, kSize, 30);
  ASSERT_EQ(chosen.size(), 30u);
  EXPECT_TRUE(std::is_sorted(chosen.begin(), chosen.end()));
  int spread = 0;
  for (size_t i : chosen) spread += distinct[i] ? 1 : 0;
  EXPECT_GE(spread, 27) << "of the 30 views that differ";

  // (Every view is not calibrated here: OpenCV's dense adjustment of 300
  // views takes minutes, one reason to choose. It was 0.76 px.)
  const double chosen_error = FxError(views, chosen);
  // Thirty views in the order recorded (every tenth frame, as one would
  // subsample a video by hand): 3 that differ, the rest the same pose.
  std::vector<size_t> every_tenth;
  for (size_t i = 0; i < views.size(); i += 10) every_tenth.push_back(i);
  const double tenth_error = FxError(views, every_tenth);
  EXPECT_LT(chosen_error, 1.5) << "|fx - truth| + |cx - truth| + |cy - truth| [px]";
  EXPECT_LT(chosen_error, 0.5 * tenth_error);
  std::printf("intrinsics error [px]: chosen 30 %.3f, every tenth frame %.3f\n", chosen_error, tenth_error);
}

TEST(SelectViews, KeepsEveryFoundViewWhenThereAreNoMoreThanAsked) {
  std::mt19937 rng(5);
  std::vector<BoardDetection> views = {View(0, 0, 0, 0, 0, 0.7, rng), View(10, 0, 0, 0.1, 0, 0.7, rng),
                                       BoardDetection{}, View(0, 20, 0, 0, 0.1, 0.8, rng)};
  EXPECT_EQ(SelectViews(views, kSize, 3), (std::vector<size_t>{0, 1, 3}));
  EXPECT_EQ(SelectViews(views, kSize, 0), (std::vector<size_t>{0, 1, 3}));
  const std::vector<size_t> two = SelectViews(views, kSize, 2);
  ASSERT_EQ(two.size(), 2u);
  for (size_t i : two) EXPECT_NE(i, 2u) << "a view without the board";
}

}  // namespace
}  // namespace odocal::vision
