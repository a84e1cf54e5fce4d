// Camera calibration: intrinsics (pinhole + k1 k2 p1 p2 k3) from images of a
// planar board, with OpenCV (Zhang's method as cv::calibrateCamera implements
// it; Zhang, "A flexible new technique for camera calibration", PAMI 2000).
// A pure function of the images: loading them and writing the result are in
// rig/ (odocal calibrate-camera).
//
// Boards:
//   chessboard  COLS x ROWS inner corners, square side; cv::findChessboardCorners
//               (cv::findChessboardCornersSB as the fallback) then cv::cornerSubPix.
//   ChArUco     COLS x ROWS squares, square and marker sides, ArUco dictionary;
//               cv::aruco marker detection and corner interpolation (needs
//               OpenCV's contrib aruco module; CharucoAvailable() says whether
//               this build has it).
// Frames: the board frame is OpenCV's object-point frame of each board type
// (z = 0 on the board); pixels are OpenCV's (centres at integers).
// Units: metres inside; the reprojection errors are in pixels.
#ifndef ODOCAL_VISION_CAMERA_CALIBRATION_H_
#define ODOCAL_VISION_CAMERA_CALIBRATION_H_

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/vision/camera_model.h"

namespace odocal::vision {

struct CalibrationBoard {
  enum class Type { kChessboard, kCharuco };
  Type type = Type::kChessboard;
  int cols = 0;            // chessboard: inner corners across; ChArUco: squares across
  int rows = 0;            // the same down
  double square_m = 0.0;
  double marker_m = 0.0;   // ChArUco only
  std::string dictionary;  // ChArUco only, OpenCV's name, e.g. "DICT_5X5_100"

  bool IsValid(std::string* why) const;
  // Corners a view can show at most.
  int MaxCorners() const;
};

// Whether this build can detect ChArUco boards (OpenCV's aruco module).
bool CharucoAvailable();

// One image's board corners, matched to their positions on the board.
struct BoardDetection {
  bool found = false;
  std::string message;                  // why not, when not found
  std::vector<cv::Point2f> image_points;
  std::vector<cv::Point3f> object_points;
};

struct BoardDetectionOptions {
  // cornerSubPix half window [px]; it is also capped at 40 % of the smallest
  // corner spacing seen, so that it never reaches into the next square.
  int subpix_half_window_px = 5;
  // ChArUco views with fewer interpolated corners are rejected: below ~6
  // the view adds little and may be nearly collinear.
  int min_charuco_corners = 6;
  // Chessboards: when cv::findChessboardCorners fails, try
  // cv::findChessboardCornersSB (finds steeper views; slower on images
  // without a board).
  bool sector_fallback = true;

  // A half window of at least 1 px, and at least 4 ChArUco corners (a view's
  // homography needs 4 points).
  bool IsValid(std::string* why) const;
};

// `image`: 8-bit grey, or BGR / BGRA (converted to grey). Not found (with
// the reason in `message`) rather than an exception when OpenCV objects.
BoardDetection DetectBoard(const cv::Mat& image, const CalibrationBoard& board,
                           const BoardDetectionOptions& options = {});

struct CameraCalibrationOptions {
  int min_views = 3;     // fewer usable views: kTooFewViews
  // Estimate k3 too (OpenCV's default). For lenses with a modest field of view
  // k3 is poorly observed and trades off against k1, k2; fix it (to 0) there.
  bool fix_k3 = false;
  bool fix_tangential = false;  // p1 = p2 = 0

  bool IsValid(std::string* why) const;
};

struct CameraCalibrationResult {
  enum class Status { kOk, kInvalidInput, kTooFewViews, kFailed };
  Status status = Status::kFailed;
  std::string message;
  Intrinsics intrinsics;
  // Over all corners of all views, and per view (input order) [px].
  double rms_reprojection_error_px = 0.0;
  std::vector<double> per_view_rms_px;
  // One-sigma of fx, fy, cx, cy, k1, k2, p1, p2, k3 from OpenCV's covariance
  // (assumes the corner errors are independent with the observed RMS).
  std::array<double, 9> sigma{};
  int views = 0;
  int corners = 0;

  bool ok() const { return status == Status::kOk; }
};

// Views without a detection (found = false) must be filtered out by the caller.
CameraCalibrationResult CalibrateCamera(const std::vector<BoardDetection>& views,
                                        const cv::Size& image_size,
                                        const CameraCalibrationOptions& options = {});

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_CAMERA_CALIBRATION_H_
