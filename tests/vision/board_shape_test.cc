// The board's shape (board_shape.h) on corners of a board that is not flat:
// each tag's corners lifted off the plane in 3-D and projected exactly
// through the lens, with noise; the camera calibrated as if the board were
// flat, as calibrate-camera does. The estimator is a linearisation about the
// flat board's poses; the data are not.
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "odocal/test_util/options_checks.h"
#include "odocal/vision/board_shape.h"
#include "odocal/vision/camera_calibration.h"
#include "odocal/vision/camera_model.h"
#include "vision_fixtures.h"

namespace odocal::vision {
namespace {

using testing::KalibrBoard;

// `views` views of the board, its tag i lifted by lift_m(i) along +z, 0.7 to
// 1.3 m away, tilted up to 35 degrees, corners with noise `noise_px` per
// axis; only tags wholly in the image.
std::vector<BoardDetection> Views(const CalibrationBoard& board, const Intrinsics& in,
                                  const std::map<int, double>& lift_m, int views, double noise_px,
                                  unsigned seed) {
  const CameraModel camera(in, CameraMount{});
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> tilt(-35.0, 35.0), dist(0.7, 1.3), shift(-0.08, 0.08);
  std::normal_distribution<double> noise(0.0, noise_px);
  const double side = board.cols * board.square_m * (1.0 + board.spacing) - board.spacing * board.square_m;
  std::vector<BoardDetection> out;
  while (static_cast<int>(out.size()) < views) {
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(tilt(rng) * M_PI / 180.0, Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(tilt(rng) * M_PI / 180.0, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(M_PI + tilt(rng) * M_PI / 180.0, Eigen::Vector3d::UnitZ()))
                                  .toRotationMatrix();
    // The board's centre on the optical axis (give or take), `dist` away.
    const Eigen::Vector3d centre(0.5 * side, 0.5 * side, 0.0);
    const Eigen::Vector3d t = Eigen::Vector3d(shift(rng), shift(rng), dist(rng)) - R * centre;
    BoardDetection d;
    for (int id = 0; id < board.cols * board.rows; ++id) {
      std::vector<cv::Point2f> image;
      std::vector<cv::Point3f> object;
      for (int k = 0; k < 4; ++k) {
        const cv::Point3f p = *board.AprilgridCorner(id, k);
        const Eigen::Vector3d lifted(p.x, p.y, lift_m.count(id) ? lift_m.at(id) : 0.0);
        const auto px = camera.ProjectCamera(R * lifted + t);
        if (!px || px->x() < 5 || px->y() < 5 || px->x() > in.width - 6 || px->y() > in.height - 6) break;
        image.emplace_back(static_cast<float>(px->x() + noise(rng)), static_cast<float>(px->y() + noise(rng)));
        object.push_back(p);  // the layout as printed: flat
      }
      if (image.size() < 4) continue;
      d.tag_ids.push_back(id);
      d.image_points.insert(d.image_points.end(), image.begin(), image.end());
      d.object_points.insert(d.object_points.end(), object.begin(), object.end());
      for (int k = 0; k < 4; ++k) d.point_sigma_px.push_back(noise_px);
    }
    d.found = d.tag_ids.size() >= 12;
    if (d.found) out.push_back(std::move(d));
  }
  return out;
}

const Intrinsics kCamera{640, 480, 610.0, 608.0, 321.0, 242.0, {-0.08, 0.05, 0.0, 0.0, 0.0}};

// What a pose can absorb (a plane over the board) removed from the truth,
// unweighted: the lifts the estimator reports are relative to it.
std::map<int, double> WithoutPlane(const CalibrationBoard& board, const std::map<int, double>& lift_m) {
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& [id, h] : lift_m) {
    const cv::Point3f c0 = *board.AprilgridCorner(id, 0), c2 = *board.AprilgridCorner(id, 2);
    const Eigen::Vector3d row(1.0, 0.5 * (c0.x + c2.x), 0.5 * (c0.y + c2.y));
    A += row * row.transpose();
    b += row * h;
  }
  const Eigen::Vector3d plane = A.ldlt().solve(b);
  std::map<int, double> out;
  for (const auto& [id, h] : lift_m) {
    const cv::Point3f c0 = *board.AprilgridCorner(id, 0), c2 = *board.AprilgridCorner(id, 2);
    out[id] = h - plane.dot(Eigen::Vector3d(1.0, 0.5 * (c0.x + c2.x), 0.5 * (c0.y + c2.y)));
  }
  return out;
}

// Up to +-1 mm per tag, with no plane in it a pose could take: what the
// real D435i board shows (docs/vision.md).
std::map<int, double> RandomLifts(const CalibrationBoard& board) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> mm(-1.0, 1.0);
  std::map<int, double> lift_m;
  for (int id = 0; id < board.cols * board.rows; ++id) lift_m[id] = 1e-3 * mm(rng);
  return WithoutPlane(board, lift_m);
}

TEST(BoardShape, AFlatBoardIsFlat) {
  const CalibrationBoard board = KalibrBoard();
  const std::vector<BoardDetection> views = Views(board, kCamera, {}, 20, 0.05, 3);
  const CameraCalibrationResult cal = CalibrateCamera(views, cv::Size(640, 480));
  ASSERT_TRUE(cal.ok()) << cal.message;
  const BoardShape shape = MeasureBoardShape(views, board, cal.intrinsics);
  ASSERT_TRUE(shape.ok()) << shape.message;
  std::printf("flat board: %zu tags, lifts RMS %.4f mm (sigma ~%.4f), chi2/dof %.2f over %d\n", shape.tags.size(),
              shape.rms_lift_mm, shape.tags.front().sigma_mm, shape.chi2_per_dof, shape.dof);
  EXPECT_EQ(shape.tags.size(), 36u);
  EXPECT_TRUE(shape.flat);
  // chi2 / dof of 33 lifts: 1 +- 0.25; its sigmas are the noise's.
  EXPECT_GT(shape.chi2_per_dof, 0.4);
  EXPECT_LT(shape.chi2_per_dof, 1.8);
}

TEST(BoardShape, EachTagsLiftIsFoundWhereTheBoardIsNotFlat) {
  const CalibrationBoard board = KalibrBoard();
  const std::map<int, double> lift_m = RandomLifts(board);
  const std::vector<BoardDetection> views = Views(board, kCamera, lift_m, 20, 0.05, 5);
  const CameraCalibrationResult cal = CalibrateCamera(views, cv::Size(640, 480));
  ASSERT_TRUE(cal.ok()) << cal.message;
  const BoardShape shape = MeasureBoardShape(views, board, cal.intrinsics);
  ASSERT_TRUE(shape.ok()) << shape.message;
  EXPECT_FALSE(shape.flat);
  ASSERT_EQ(shape.tags.size(), 36u);
  const std::map<int, double> truth = WithoutPlane(board, lift_m);
  double sq = 0.0, z2 = 0.0, truth_sq = 0.0;
  for (const TagLift& t : shape.tags) {
    const double e = t.lift_mm - 1e3 * truth.at(t.id);
    sq += e * e;
    z2 += std::pow(e / t.sigma_mm, 2);
    truth_sq += std::pow(1e3 * truth.at(t.id), 2);
  }
  const double rms = std::sqrt(sq / shape.tags.size()), z_rms = std::sqrt(z2 / shape.tags.size());
  std::printf("lifted board: lifts RMS %.3f mm (truth %.3f), error RMS %.4f mm = %.2f sigma; chi2/dof %.1f; the "
              "lifts explain %.0f %% of the residual; calibration RMS %.3f px\n",
              shape.rms_lift_mm, std::sqrt(truth_sq / shape.tags.size()), rms, z_rms, shape.chi2_per_dof,
              100.0 * shape.explained_fraction, cal.rms_reprojection_error_px);
  // Each lift to a tenth of the lifts. The stated sigmas are the image
  // noise's; the camera, calibrated on the board as if flat, took a little
  // of the shape into its intrinsics, which they do not hold: 0.035-0.047 mm
  // (1.8-2.5 sigma RMS) over four seeds, 0.029 mm still at a fifth of the
  // noise (docs/vision.md).
  EXPECT_LT(rms, 0.1 * std::sqrt(truth_sq / shape.tags.size()));
  EXPECT_LT(z_rms, 3.0);
  EXPECT_NEAR(shape.rms_lift_mm, std::sqrt(truth_sq / shape.tags.size()), 0.1);
}

// The lifts back into the calibration (CameraCalibrationOptions::
// board_lift_m): the intrinsics' error from taking a lifted board as flat
// against the same views' calibration with the measured lifts, and the same
// poses' views of a flat board (the noise alone), over four seeds.
TEST(BoardShape, CalibratingWithTheLiftsTakesTheShapeOutOfTheIntrinsics) {
  const CalibrationBoard board = KalibrBoard();
  const std::map<int, double> lift_m = RandomLifts(board);
  auto worst = [](const Intrinsics& in) {
    return std::max({std::abs(in.fx - kCamera.fx), std::abs(in.fy - kCamera.fy), std::abs(in.cx - kCamera.cx),
                     std::abs(in.cy - kCamera.cy)});
  };
  double flat_sq = 0.0, fitted_sq = 0.0, noise_sq = 0.0;
  for (unsigned seed : {5u, 6u, 11u, 19u}) {
    const std::vector<BoardDetection> views = Views(board, kCamera, lift_m, 20, 0.05, seed);
    const CameraCalibrationResult flat = CalibrateCamera(views, cv::Size(640, 480));
    ASSERT_TRUE(flat.ok()) << flat.message;
    const BoardShape shape = MeasureBoardShape(views, board, flat.intrinsics);
    ASSERT_TRUE(shape.ok()) << shape.message;
    CameraCalibrationOptions options;
    for (const TagLift& t : shape.tags) options.board_lift_m[t.id] = 1e-3 * t.lift_mm;
    options.initial = flat.intrinsics;
    const CameraCalibrationResult fitted = CalibrateCamera(views, cv::Size(640, 480), options);
    ASSERT_TRUE(fitted.ok()) << fitted.message;
    const CameraCalibrationResult noise = CalibrateCamera(Views(board, kCamera, {}, 20, 0.05, seed), cv::Size(640, 480));
    ASSERT_TRUE(noise.ok()) << noise.message;
    std::printf("seed %2u: worst of fx, fy, cx, cy - truth: as flat %.3f px (RMS %.3f px), with the lifts %.3f px "
                "(RMS %.3f px), a flat board %.3f px\n",
                seed, worst(flat.intrinsics), flat.rms_reprojection_error_px, worst(fitted.intrinsics),
                fitted.rms_reprojection_error_px, worst(noise.intrinsics));
    flat_sq += std::pow(worst(flat.intrinsics), 2);
    fitted_sq += std::pow(worst(fitted.intrinsics), 2);
    noise_sq += std::pow(worst(noise.intrinsics), 2);
  }
  EXPECT_LT(fitted_sq, 0.25 * flat_sq);
  EXPECT_LT(fitted_sq, 4.0 * noise_sq);
}

TEST(BoardShape, OtherBoardsAndBadOptionsAreRefusedByName) {
  CalibrationBoard chess;
  chess.type = CalibrationBoard::Type::kChessboard;
  const BoardShape shape = MeasureBoardShape({}, chess, kCamera);
  EXPECT_FALSE(shape.ok());
  EXPECT_NE(shape.message.find("aprilgrid"), std::string::npos) << shape.message;
  const BoardShape none = MeasureBoardShape({}, KalibrBoard(), kCamera);
  EXPECT_FALSE(none.ok());
  EXPECT_NE(none.message.find("fewer than 4 tags"), std::string::npos) << none.message;
  test_util::ExpectValidAndEachEditRejected<BoardShapeOptions>(
      BoardShapeOptions{}, {{[](BoardShapeOptions* o) { o->min_sightings = 3; }, "min_sightings"},
                            {[](BoardShapeOptions* o) { o->flat_mm = -1.0; }, "flat_mm"}});
}

}  // namespace
}  // namespace odocal::vision
