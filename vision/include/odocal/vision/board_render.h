// Board renderer: images of a planar calibration board (chessboard, or any
// pattern of black and white cells such as a ChArUco board) seen by a camera
// with lens distortion, with the exact pixels of its corners — the golden
// data the camera-calibration tests run on.
//
// Frames:
//   board   x along the pattern's columns, y along its rows, z = x cross y
//           (away from a camera that sees the printed face); origin at the
//           outer corner of cell (0, 0); the board is the plane z = 0.
//   camera  OpenCV optical frame (x right, y down, z forward).
// T_camera_board maps board points into the camera frame.
// Pixels: OpenCV convention (pixel centres at integers).
// Units: metres inside.
//
// Image formation, as in the tag renderer (they share raster.h): every pixel
// corner undistorted to a ray, the ray meets the board plane, area-correct
// anti-aliasing (uniform pixels looked up once, pixels on an edge integrated
// with supersample^2 stratified samples), Gaussian optical blur, seeded
// additive Gaussian noise, rounding to 8 bits.
#ifndef ODOCAL_VISION_BOARD_RENDER_H_
#define ODOCAL_VISION_BOARD_RENDER_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "odocal/base/status.h"
#include "odocal/vision/camera_calibration.h"
#include "odocal/vision/camera_model.h"

namespace odocal::vision {

// The printed pattern: a grid of square cells, black (0) or white (non-zero),
// surrounded by a white quiet zone.
struct BoardPattern {
  cv::Mat cells;          // CV_8U; row r, column c covers [c, c+1] x [r, r+1] cells
  double cell_m = 0.0;    // cell side
  double margin_m = 0.0;  // white border beyond the cells

  bool IsValid(std::string* why) const;
  // A chessboard with inner_cols x inner_rows inner corners, i.e.
  // (inner_cols + 1) x (inner_rows + 1) squares, cell (0, 0) black; a quiet
  // zone of one square (findChessboardCorners needs a white border).
  static BoardPattern Chessboard(int inner_cols, int inner_rows, double square_m);
};

// Kalibr's aprilgrid as cells: the tags' bitmaps (libapriltag's, of
// board.tag_family, without their white ring), and a black corner square of
// spacing x tag side at every crossing of the gaps, as Kalibr prints it. The
// gap must be a whole number of cells (spacing x width_at_border, e.g.
// 0.3 x 10 = 3); kInvalidArgument saying why otherwise. No margin: the outer corner
// squares are the pattern's edge (a white quiet zone is `margin_m`, added
// here as one gap).
Result<BoardPattern> AprilgridPattern(const CalibrationBoard& board);
// A point of the aprilgrid's own (Kalibr) frame, e.g. AprilgridCorner(),
// in the frame of AprilgridPattern(): the same plane turned 180 degrees about
// x (Kalibr's y runs up the print, the pattern's rows down it).
Eigen::Vector3d AprilgridPointInPattern(const CalibrationBoard& board, const cv::Point3f& kalibr_point);

// The inner corners of a chessboard in the board frame (z = 0), row by row:
// corner (r, c) at ((c + 1) * square, (r + 1) * square).
std::vector<Eigen::Vector3d> ChessboardCorners(int inner_cols, int inner_rows, double square_m);

struct BoardRenderOptions {
  double noise_sigma = 2.0;     // grey levels, additive Gaussian; 0 = none
  double blur_sigma_px = 0.7;   // optical blur; 0 = none
  uint64_t seed = 1;            // noise
  int supersample = 16;         // samples per axis in edge pixels
  double black = 30.0;          // grey levels before noise
  double white = 220.0;
  double background = 110.0;    // beyond the board, and behind the camera

  bool IsValid(std::string* why) const;
};

struct RenderedBoard {
  cv::Mat image;                      // CV_8UC1, width x height of the intrinsics
  std::vector<cv::Point2d> points_px; // the requested board points, distorted, OpenCV convention
  // Every requested point in front of the camera and at least `margin_px`
  // inside the image.
  bool all_visible = false;
};

struct BoardRenderResult {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;
  RenderedBoard frame;
};

// Renders `pattern` at T_camera_board; `points_board` (e.g. ChessboardCorners)
// are projected for the ground truth.
BoardRenderResult RenderBoard(const Intrinsics& intrinsics, const BoardPattern& pattern,
                              const Eigen::Isometry3d& T_camera_board,
                              const std::vector<Eigen::Vector3d>& points_board,
                              const BoardRenderOptions& options, double margin_px = 2.0);

// Views a calibration wants (Zhang: tilted boards, spread over the image so
// that the distortion is seen at the edges): seeded random poses of a board
// whose points `points_board` all land inside the image.
struct BoardPoseSampling {
  int count = 12;
  uint64_t seed = 1;
  double min_tilt_deg = 10.0;   // about the board's x and y axes, each, random sign
  double max_tilt_deg = 40.0;
  double max_turn_deg = 30.0;   // about the view axis
  double min_fill = 0.45;       // board extent / image width
  double max_fill = 0.75;
  double margin_px = 10.0;      // every point at least this far inside
};

// nullopt when no pose satisfying the margins turns up (board too large).
std::optional<std::vector<Eigen::Isometry3d>> SampleBoardPoses(
    const Intrinsics& intrinsics, const std::vector<Eigen::Vector3d>& points_board,
    const BoardPoseSampling& sampling);

// Views a wide lens sees (a fisheye's rim, a board partly out of the
// image): the board's centre on a ray min_off_axis_deg..max_off_axis_deg
// off the optical axis at near_m..far_m, facing the camera within max_tilt_deg about each of
// its axes, turned freely in its plane; kept when at least
// min_points_in_view of `points_board` land margin_px inside the image.
struct FieldPoseSampling {
  int count = 8;
  uint64_t seed = 1;
  double min_off_axis_deg = 0.0;
  double max_off_axis_deg = 60.0;
  double near_m = 0.4;
  double far_m = 1.0;
  double max_tilt_deg = 40.0;
  int min_points_in_view = 32;
  double margin_px = 3.0;
};
// nullopt when 1000 x count attempts do not give `count` views.
std::optional<std::vector<Eigen::Isometry3d>> SampleFieldBoardPoses(
    const Intrinsics& intrinsics, const std::vector<Eigen::Vector3d>& points_board,
    const FieldPoseSampling& sampling);

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_BOARD_RENDER_H_
