// Camera calibration on rendered boards with exact ground truth: chessboard
// and (when this build has OpenCV's aruco module) ChArUco.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
// The ChArUco case needs OpenCV's contrib aruco module (libopencv-contrib-dev),
// the same condition under which odocal::vision is built with ChArUco support.
#if __has_include(<opencv2/aruco/charuco.hpp>)
#define ODOCAL_TEST_HAVE_ARUCO 1
#include <opencv2/aruco/charuco.hpp>
#endif

#include "odocal/vision/board_render.h"
#include "odocal/vision/camera_calibration.h"

namespace odocal::vision {
namespace {

// 640x480 with clear barrel distortion and some decentring (seeded views below).
Intrinsics Truth() {
  return Intrinsics{640, 480, 610.0, 606.0, 322.5, 237.25, {-0.21, 0.09, 6e-4, -4e-4, 0.0}};
}

std::vector<cv::Mat> RenderViews(const BoardPattern& pattern, const std::vector<Eigen::Vector3d>& points,
                                 int count, uint64_t seed) {
  BoardPoseSampling sampling;
  sampling.count = count;
  sampling.seed = seed;
  const auto poses = SampleBoardPoses(Truth(), points, sampling);
  EXPECT_TRUE(poses);
  std::vector<cv::Mat> images;
  BoardRenderOptions o;  // noise 2 grey levels, blur 0.7 px
  for (size_t i = 0; poses && i < poses->size(); ++i) {
    o.seed = seed * 1000 + i;
    const auto r = RenderBoard(Truth(), pattern, (*poses)[i], points, o);
    EXPECT_TRUE(r.ok()) << r.message;
    images.push_back(r.frame.image);
  }
  return images;
}

void ExpectNearTruth(const CameraCalibrationResult& r, double rel_focal, double px_centre,
                     double k1_tol) {
  const Intrinsics t = Truth();
  const Intrinsics& e = r.intrinsics;
  EXPECT_NEAR(e.fx, t.fx, rel_focal * t.fx);
  EXPECT_NEAR(e.fy, t.fy, rel_focal * t.fy);
  EXPECT_NEAR(e.cx, t.cx, px_centre);
  EXPECT_NEAR(e.cy, t.cy, px_centre);
  EXPECT_NEAR(e.distortion[0], t.distortion[0], k1_tol);
  ::testing::Test::RecordProperty(
      "errors", "fx " + std::to_string(e.fx - t.fx) + " fy " + std::to_string(e.fy - t.fy) +
                    " cx " + std::to_string(e.cx - t.cx) + " cy " + std::to_string(e.cy - t.cy) +
                    " k1 " + std::to_string(e.distortion[0] - t.distortion[0]) + " k2 " +
                    std::to_string(e.distortion[1] - t.distortion[1]) + " k3 " +
                    std::to_string(e.distortion[4]) + " rms " +
                    std::to_string(r.rms_reprojection_error_px));
}

TEST(CameraCalibration, RecoversIntrinsicsFromRenderedChessboards) {
  CalibrationBoard board;
  board.cols = 9;
  board.rows = 6;
  board.square_m = 0.025;
  const auto images = RenderViews(BoardPattern::Chessboard(9, 6, 0.025), ChessboardCorners(9, 6, 0.025), 12, 1);
  std::vector<BoardDetection> views;
  for (const cv::Mat& image : images) {
    BoardDetection d = DetectBoard(image, board);
    ASSERT_TRUE(d.found) << d.message;
    EXPECT_EQ(d.image_points.size(), 54u);
    views.push_back(d);
  }
  const CameraCalibrationResult r = CalibrateCamera(views, cv::Size(640, 480));
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.views, 12);
  EXPECT_EQ(r.corners, 12 * 54);
  ASSERT_EQ(r.per_view_rms_px.size(), 12u);
  // Measured over 8 seeds x 12 views (this set-up, k3 free): RMS 0.035-0.042
  // px; worst errors fx 0.12 px, fy 0.12 px, cx 0.17 px, cy 0.28 px, k1
  // 0.0025, each within 1.3 sigma of OpenCV's own standard deviations
  // (fx ~0.17 px, cx ~0.3 px, k1 ~0.0015). The bounds are ~3x the worst
  // case: focal lengths 0.1 % (the issue asks 0.5 %), principal point 1 px.
  EXPECT_LT(r.rms_reprojection_error_px, 0.1);
  ExpectNearTruth(r, 0.001, 1.0, 0.006);
}

// A fisheye (equidistant, 640x480, 125 deg across the diagonal) calibrated
// from rendered chessboards with cv::fisheye (issue 24 §2): the intrinsics
// within 0.5 % and 2 px of the truth, each within 4 of its jackknife sigma.
TEST(CameraCalibration, RecoversAFisheyeLensWithJackknifeSigmas) {
  Intrinsics truth{640, 480, 300.0, 301.0, 318.5, 242.25, {-0.03, 0.006, -0.002, 0.0004, 0.0}};
  truth.lens = LensModel::kEquidistant;
  CalibrationBoard board;
  board.cols = 9;
  board.rows = 6;
  board.square_m = 0.025;
  const std::vector<Eigen::Vector3d> points = ChessboardCorners(9, 6, 0.025);
  BoardPoseSampling sampling;
  sampling.count = 15;
  sampling.seed = 5;
  const auto poses = SampleBoardPoses(truth, points, sampling);
  ASSERT_TRUE(poses);
  std::vector<BoardDetection> views;
  BoardRenderOptions o;
  for (size_t i = 0; i < poses->size(); ++i) {
    o.seed = 5000 + i;
    const auto r = RenderBoard(truth, BoardPattern::Chessboard(9, 6, 0.025), (*poses)[i], points, o);
    ASSERT_TRUE(r.ok()) << r.message;
    BoardDetection d = DetectBoard(r.frame.image, board);
    if (d.found) views.push_back(d);
  }
  ASSERT_GE(views.size(), 10u);
  CameraCalibrationOptions options;
  options.lens = LensModel::kEquidistant;
  const CameraCalibrationResult r = CalibrateCamera(views, cv::Size(640, 480), options);
  ASSERT_TRUE(r.ok()) << r.message;
  const Intrinsics& e = r.intrinsics;
  EXPECT_EQ(e.lens, LensModel::kEquidistant);
  std::printf("figures: fisheye calibration, %d views: rms %.4f px; fx %+.3f (sigma %.3f), fy %+.3f (%.3f), "
              "cx %+.3f (%.3f), cy %+.3f (%.3f) px; k1 %+.5f (%.5f)\n",
              r.views, r.rms_reprojection_error_px, e.fx - truth.fx, r.sigma[0], e.fy - truth.fy, r.sigma[1],
              e.cx - truth.cx, r.sigma[2], e.cy - truth.cy, r.sigma[3], e.distortion[0] - truth.distortion[0],
              r.sigma[4]);
  EXPECT_LT(r.rms_reprojection_error_px, 0.15);
  EXPECT_NEAR(e.fx, truth.fx, 0.005 * truth.fx);
  EXPECT_NEAR(e.fy, truth.fy, 0.005 * truth.fy);
  EXPECT_NEAR(e.cx, truth.cx, 2.0);
  EXPECT_NEAR(e.cy, truth.cy, 2.0);
  const double errors[] = {e.fx - truth.fx, e.fy - truth.fy, e.cx - truth.cx, e.cy - truth.cy,
                           e.distortion[0] - truth.distortion[0]};
  for (int k = 0; k < 5; ++k) {
    ASSERT_TRUE(std::isfinite(r.sigma[k]) && r.sigma[k] > 0.0) << k;
    EXPECT_LT(std::abs(errors[k]), 4.0 * r.sigma[k]) << "parameter " << k;
  }
  ASSERT_EQ(r.per_view_rms_px.size(), views.size());
  // One view of the 11 is ill-conditioned for cv::fisheye (which then stays
  // at its starting guess for all, 30 px RMS, or with CALIB_CHECK_COND
  // leaves it out): with the joint adjustment (fisheye_fit.h) it is in,
  // every view posed through the lens and used. Measured: 11 of 11, fx
  // +0.061 px (sigma 0.083).
  EXPECT_TRUE(r.views_left_out.empty());
  EXPECT_EQ(r.views, static_cast<int>(views.size()));
  for (double e : r.per_view_rms_px) EXPECT_TRUE(std::isfinite(e));
}

// A fisheye's rim corners are its least certain (small, dark, blurred tags)
// and the ones that pin k1..k4. Synthetic views through a 190-degree lens:
// corners more than 55 degrees off the axis 0.4 px off (and so stated),
// the rest 0.03 px. Weighed by their sigmas (min(1, median / sigma)) the
// lens comes out closer than with every corner alike.
TEST(CameraCalibration, AFisheyeWeighsItsCornersByTheirSigmas) {
  Intrinsics truth{512, 512, 190.98, 190.97, 254.93, 256.90, {0.00348, 0.000715, -0.00205, 0.000203, 0.0}};
  truth.lens = LensModel::kEquidistant;
  const cv::Matx33d K(truth.fx, 0.0, truth.cx, 0.0, truth.fy, truth.cy, 0.0, 0.0, 1.0);
  const cv::Vec4d D(truth.distortion[0], truth.distortion[1], truth.distortion[2], truth.distortion[3]);
  std::vector<cv::Point3d> board;
  for (int j = 0; j < 8; ++j)
    for (int i = 0; i < 8; ++i) board.emplace_back(0.05 * (i - 3.5), 0.05 * (j - 3.5), 0.0);
  cv::RNG rng(41);
  std::vector<BoardDetection> views;
  for (int v = 0; v < 14; ++v) {
    // Boards from the centre to 70 degrees off the axis, tilted.
    const double off = (v / 13.0) * 70.0 * M_PI / 180.0, around = v * 2.4;
    const double distance = 0.45 + 0.05 * (v % 3);
    const cv::Vec3d tvec(distance * std::sin(off) * std::cos(around), distance * std::sin(off) * std::sin(around),
                         distance * std::cos(off));
    const cv::Vec3d rvec(0.4 * std::sin(off) * std::sin(around), -0.4 * std::sin(off) * std::cos(around), 0.3 * v);
    std::vector<cv::Point2d> px;
    cv::fisheye::projectPoints(board, px, rvec, tvec, K, D);
    BoardDetection d;
    for (size_t k = 0; k < board.size(); ++k) {
      if (!(px[k].x > 3 && px[k].y > 3 && px[k].x < 508 && px[k].y < 508)) continue;
      const double theta = std::hypot((px[k].x - truth.cx) / truth.fx, (px[k].y - truth.cy) / truth.fy);
      const double sigma = theta > 55.0 * M_PI / 180.0 ? 0.4 : 0.03;
      d.object_points.emplace_back(static_cast<float>(board[k].x), static_cast<float>(board[k].y), 0.0f);
      d.image_points.emplace_back(static_cast<float>(px[k].x + rng.gaussian(sigma)),
                                  static_cast<float>(px[k].y + rng.gaussian(sigma)));
      d.point_sigma_px.push_back(sigma);
    }
    d.found = d.image_points.size() >= 16;
    if (d.found) views.push_back(d);
  }
  ASSERT_GE(views.size(), 12u);
  const auto error = [&](bool weighted) {
    CameraCalibrationOptions options;
    options.lens = LensModel::kEquidistant;
    options.weight_by_corner_sigma = weighted;
    const CameraCalibrationResult r = CalibrateCamera(views, cv::Size(512, 512), options);
    EXPECT_TRUE(r.ok()) << r.message;
    const Intrinsics& e = r.intrinsics;
    return std::abs(e.fx - truth.fx) + std::abs(e.fy - truth.fy) + std::abs(e.cx - truth.cx) +
           std::abs(e.cy - truth.cy);
  };
  const double weighted = error(true), alike = error(false);
  std::printf("figures: fisheye, rim corners 0.4 px: |fx|+|fy|+|cx|+|cy| error weighted %.4f px, alike %.4f px\n",
              weighted, alike);
  // Measured: 0.86 px weighted, 11.3 px alike (the rim's noise traded
  // against k1..k4 and the focal length).
  EXPECT_LT(weighted, 0.25 * alike);
  EXPECT_LT(weighted, 1.5);
}

TEST(CameraCalibration, NoBoardIsNamedAndTooFewViewsFail) {
  CalibrationBoard board;
  board.cols = 9;
  board.rows = 6;
  board.square_m = 0.025;
  cv::Mat blank(480, 640, CV_8U, cv::Scalar(120));
  cv::randn(blank, 120, 3);
  const BoardDetection d = DetectBoard(blank, board);
  EXPECT_FALSE(d.found);
  EXPECT_EQ(d.message, "chessboard 9x6 not found");

  const auto images = RenderViews(BoardPattern::Chessboard(9, 6, 0.025), ChessboardCorners(9, 6, 0.025), 2, 2);
  std::vector<BoardDetection> views;
  for (const cv::Mat& image : images) views.push_back(DetectBoard(image, board));
  const CameraCalibrationResult r = CalibrateCamera(views, cv::Size(640, 480));
  EXPECT_EQ(r.status, StatusCode::kInvalidArgument);
  EXPECT_EQ(r.message, "2 usable views, need at least 3");
}

TEST(CameraCalibration, RejectsInvalidBoards) {
  std::string why;
  CalibrationBoard board;
  board.cols = 1;
  board.rows = 6;
  board.square_m = 0.025;
  EXPECT_FALSE(board.IsValid(&why));
  board.type = CalibrationBoard::Type::kCharuco;
  board.cols = 5;
  board.marker_m = 0.03;  // larger than the square
  EXPECT_FALSE(board.IsValid(&why));
  EXPECT_THAT(why, ::testing::HasSubstr("marker"));
}

TEST(CameraCalibration, InvalidDetectionOptionsAreNamedNotFound) {
  std::string why;
  EXPECT_TRUE(BoardDetectionOptions{}.IsValid(&why)) << why;
  BoardDetectionOptions window;
  window.subpix_half_window_px = 0;
  EXPECT_FALSE(window.IsValid(&why));
  EXPECT_THAT(why, ::testing::HasSubstr("half window"));
  BoardDetectionOptions corners;
  corners.min_charuco_corners = 3;
  EXPECT_FALSE(corners.IsValid(&why));
  EXPECT_THAT(why, ::testing::HasSubstr("min_charuco_corners"));

  CalibrationBoard board;
  board.cols = 9;
  board.rows = 6;
  board.square_m = 0.025;
  const auto images = RenderViews(BoardPattern::Chessboard(9, 6, 0.025), ChessboardCorners(9, 6, 0.025), 1, 1);
  ASSERT_FALSE(images.empty());
  ASSERT_TRUE(DetectBoard(images.front(), board).found);
  const BoardDetection d = DetectBoard(images.front(), board, window);
  EXPECT_FALSE(d.found);
  EXPECT_THAT(d.message, ::testing::HasSubstr("board detection options"));
}

#ifdef ODOCAL_TEST_HAVE_ARUCO
// A ChArUco board at one cell per marker bit becomes the renderer's cell
// pattern: DICT_5X5_100 markers are 7 bits across (border included), the
// squares 9 bits, so 36 mm squares carry 28 mm markers. (CharucoBoard::draw
// is not bit-exact at this scale, so the cells are laid out from the board's
// own marker object points and Dictionary::drawMarker.)
TEST(CameraCalibration, RecoversIntrinsicsFromRenderedCharucoBoards) {
  ASSERT_TRUE(CharucoAvailable());
  const int cols = 8, rows = 6;
  const double bit_m = 0.004;
  const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_5X5_100);
  const auto charuco = cv::aruco::CharucoBoard::create(cols, rows, 9 * bit_m, 7 * bit_m, dict);
  BoardPattern pattern;
  pattern.cells = cv::Mat(rows * 9, cols * 9, CV_8U, cv::Scalar(0));
  for (size_t m = 0; m < charuco->ids.size(); ++m) {
    // Marker corner 0 is its top-left in the board frame (y down, as the renderer's).
    const cv::Point3f tl = charuco->objPoints[m][0];
    const int x = static_cast<int>(std::lround(tl.x / bit_m)), y = static_cast<int>(std::lround(tl.y / bit_m));
    pattern.cells(cv::Rect(x / 9 * 9, y / 9 * 9, 9, 9)).setTo(255);  // its square is white
    cv::Mat marker;
    dict->drawMarker(charuco->ids[m], 7, marker, 1);
    marker.copyTo(pattern.cells(cv::Rect(x, y, 7, 7)));
  }
  pattern.cell_m = bit_m;
  pattern.margin_m = 9 * bit_m;
  // OpenCV's object points of the corners are the renderer's board frame.
  std::vector<Eigen::Vector3d> points;
  for (const cv::Point3f& p : charuco->chessboardCorners) points.emplace_back(p.x, p.y, p.z);

  CalibrationBoard board;
  board.type = CalibrationBoard::Type::kCharuco;
  board.cols = cols;
  board.rows = rows;
  board.square_m = 9 * bit_m;
  board.marker_m = 7 * bit_m;
  board.dictionary = "DICT_5X5_100";
  ASSERT_TRUE(board.IsValid(nullptr));
  BoardPoseSampling sampling;
  sampling.seed = 4;
  sampling.max_tilt_deg = 35.0;
  const auto poses = SampleBoardPoses(Truth(), points, sampling);
  ASSERT_TRUE(poses);
  std::vector<BoardDetection> views;
  std::vector<double> errors;
  cv::Point2d mean_error(0, 0);
  for (size_t i = 0; i < poses->size(); ++i) {
    BoardRenderOptions o;
    o.seed = 40 + i;
    const auto r = RenderBoard(Truth(), pattern, (*poses)[i], points, o);
    ASSERT_TRUE(r.ok());
    BoardDetection d = DetectBoard(r.frame.image, board);
    if (!d.found) continue;
    // Each detected corner is where the renderer put the corner with its id.
    for (size_t k = 0; k < d.image_points.size(); ++k) {
      const auto& op = d.object_points[k];
      for (size_t j = 0; j < points.size(); ++j) {
        if (std::abs(points[j].x() - op.x) < 1e-6 && std::abs(points[j].y() - op.y) < 1e-6) {
          const cv::Point2d e = cv::Point2d(d.image_points[k]) - r.frame.points_px[j];
          errors.push_back(cv::norm(e));
          mean_error += e;
        }
      }
    }
    views.push_back(d);
  }
  RecordProperty("charuco_views", static_cast<int>(views.size()));
  ASSERT_FALSE(errors.empty());
  mean_error *= 1.0 / errors.size();
  RecordProperty("charuco_mean_error_px", std::to_string(mean_error.x) + "," + std::to_string(mean_error.y));
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2], p95 = errors[errors.size() * 95 / 100];
  RecordProperty("charuco_corner_error_px", "median " + std::to_string(median) + " p95 " +
                                                std::to_string(p95) + " max " + std::to_string(errors.back()) +
                                                " n " + std::to_string(errors.size()));
  EXPECT_GE(views.size(), 10u);
  // Every corner is matched by id: a wrong board frame or layout would be off
  // by whole squares (tens of px).
  EXPECT_LT(median, 0.1);
  EXPECT_LT(errors.back(), 2.0);
  const CameraCalibrationResult r = CalibrateCamera(views, cv::Size(640, 480));
  ASSERT_TRUE(r.ok()) << r.message;
  // Measured (this seed): fx +0.43 px, fy +0.41, cx +0.16, cy -0.11, k1
  // +0.0013, RMS 0.052 px; fewer corners than the chessboard (409 vs 648).
  ExpectNearTruth(r, 0.002, 1.0, 0.006);
}
#endif

}  // namespace
}  // namespace odocal::vision

namespace odocal::vision {
namespace {

// MeasureCoverage on corners placed by hand: which cells, how much, and what
// is not a corner of the image.
TEST(ImageCoverage, CountsTheCellsTheCornersReach) {
  const cv::Size size(800, 600);  // cells of 100 x 75 px on the 8 x 8 grid
  BoardDetection a, b;
  a.image_points = {{10.f, 10.f}, {150.f, 10.f}, {10.f, 100.f}};  // cells (0,0), (1,0), (0,1)
  b.image_points = {{799.f, 599.f},                               // the last pixel: cell (7,7)
                    {150.f, 10.f},                                // (1,0) again
                    {-5.f, 300.f},
                    {400.f, 700.f}};  // outside the image: not counted
  const ImageCoverage c = MeasureCoverage({a, b}, size);
  EXPECT_EQ(c.grid, 8);
  EXPECT_EQ(c.cells_covered, 4);
  EXPECT_NEAR(c.fraction, 4.0 / 64.0, 1e-12);
  EXPECT_NEAR(c.x_min, 10.5 / 800.0, 1e-9);
  EXPECT_NEAR(c.x_max, 799.5 / 800.0, 1e-9);
  EXPECT_NEAR(c.y_min, 10.5 / 600.0, 1e-9);
  EXPECT_NEAR(c.y_max, 599.5 / 600.0, 1e-9);
  EXPECT_LT(c.fraction, ImageCoverage::kWarnBelow);

  // A corner in every cell: all of it.
  BoardDetection all;
  for (int j = 0; j < 8; ++j)
    for (int i = 0; i < 8; ++i) all.image_points.emplace_back(100.f * i + 50.f, 75.f * j + 30.f);
  EXPECT_NEAR(MeasureCoverage({all}, size).fraction, 1.0, 1e-12);
  EXPECT_EQ(MeasureCoverage({}, size).cells_covered, 0);
}

}  // namespace
}  // namespace odocal::vision
