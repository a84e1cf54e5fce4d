// Planar tag pose and the camera's pose over the tag plane.
//
// The tag moves in one horizontal plane, z = tag height above the floor, so a
// measurement needs only (x, y, heading) of the tag in that plane, not a 6-DoF
// pose per frame: a free 6-DoF fit of a small tag seen face-on is ambiguous in
// tilt, and that tilt leaks into x and y (IPPE's two-fold ambiguity, Collins &
// Bartoli 2014). We instead intersect the rays through the undistorted corners
// with the known plane and fit a planar rigid transform to the four plane
// points (2-D Procrustes / Umeyama 1991 without scale). It weighs the four
// corners equally in the plane rather than in the image; for a tag this
// small (< 5 deg of view) the difference is negligible: rendered static tags
// come out within 0.003 mm (tests/vision/planar_pose_test.cc).
//
// The plane (the camera's height above it and its tilt) is itself estimated
// from many views of the tag at once: every view shares one plane, so one
// bundle adjustment (Ceres) over roll, pitch, height and each view's (x, y,
// heading) minimises the reprojection error of all corners. The camera's x, y
// and yaw over the floor are a gauge — moving them moves every tag pose the
// same way and changes no image — so they stay at the operator's nominal
// values; return errors, measured relative to a run's start pose, do not
// depend on them.
//
// Frames: world REP-103 (x forward, y left, z up, floor z = 0); poses returned
// are planar world poses (metres, radians) of the tag; corners are distorted
// pixels in OpenCV's convention (as TagDetector returns them).
#ifndef ODOCAL_VISION_PLANAR_POSE_H_
#define ODOCAL_VISION_PLANAR_POSE_H_

#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/base/solver_settings.h"
#include "odocal/base/status.h"
#include "odocal/calibration/pose2.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/tag.h"

namespace odocal::vision {

using TagCorners = std::array<cv::Point2d, 4>;

struct PlanarPoseResult {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;
  calibration::Pose2 T_world_tag;
  calibration::Pose2 T_world_robot;  // T_world_tag * T_robot_tag^-1
  // RMS distance between the four plane points and the fitted model (mm):
  // a few hundredths of a mm for a clean detection, more for a bad one.
  double rms_fit_mm = 0.0;
  // How far the four plane points are from *any* square: the residual of
  // the best similarity fit (rotation, translation and a free scale), in
  // the fitted tag's frame, mm. A tone curve or a print scale changes the
  // tag's apparent size and leaves this zero; an edge moved by a codec, a
  // noisy pixel or a wrong lens model does not. 8 numbers, 4 degrees of
  // freedom (8 coordinates less the similarity's 4).
  std::array<Eigen::Vector2d, 4> closure_mm{};
};

// The tag's planar pose from its detected corners, with the camera at
// `camera.mount()` over the floor and the tag at tag.height_mm.
PlanarPoseResult MeasureTagPose(const CameraModel& camera, const TagSpec& tag,
                                const TagCorners& corners_px);

// The error of a rest's mean pose that its frames' spread cannot show.
//
// A still scene through a video codec is one image repeated: x264 copies
// a still macroblock from frame to frame, so a rest's n frames share one
// image error and their spread (hence spread / sqrt(n)) is ~0 while the
// mean is off by that image's error (docs/vision.md: 0.1-0.28 deg of
// heading on a webcam preset, stated as 0.005 deg before this). The
// corners' closure (PlanarPoseResult::closure_mm) sees that error in every
// frame whether or not the frames repeat it. With each frame's corner error
// = s + u_i (s shared by the rest's frames, u_i its own; both isotropic,
// per coordinate sigma_s, sigma_u) and the closure r_i its projection on
// the 4 dimensions a similarity cannot absorb:
//   E[sum |r_i - mean r|^2 / (n - 1)] = 4 sigma_u^2,
//   E[|mean r|^2]                     = 4 sigma_s^2 + 4 sigma_u^2 / n,
// which gives both. One frame (or a repeated one) puts everything in s.
// The corners are intersections of four fitted edge lines, so their errors
// are the edges' errors: each edge moved along its normal (delta_e) and
// turned about its middle (phi_e). The 4 closure dimensions hold one offset
// mode (the square becoming a rectangle: E[|r|^2] = 2 sigma_delta^2) and
// three angle modes (E[|r|^2] = 1.5 L^2 sigma_phi^2, L the side), while the
// centre moves by var sigma_delta^2 / 2 per axis and the heading by
// sigma_phi^2 / 4. With sigma^2 = |r|^2 / 4 per coordinate: all offsets
// give centre variance exactly sigma^2, all angles give heading variance
// exactly sigma^2 / (1.5 L^2), and a mixture less of each; both are used
// (bounds under this edge model). The rest's mean carries sigma_s^2 +
// sigma_u^2 / n; the robot's centre, at an offset o from the tag's, adds
// |o| times the heading. Errors that are themselves a similarity (the whole
// tag shifted or turned alike) do not show: the systematic floor stays for
// those. Checked: the derivation by Monte Carlo on random edges
// (tests/vision/planar_pose_test.cc, RestCornerError); the coverage against
// rendered truth through each camera preset (bench/camera_profiles_bench,
// bench/presets/presets.py; docs/vision.md).
//
// Those bounds state a sigma that covers; they are not what to expect. On
// rendered still rests through every camera preset (bench/rest_error_bench,
// docs/vision.md "What a rest's error is made of") the closure's energy sits
// mostly in its angle modes, yet the tag's centre is off by about what its
// four corners' own errors give: each of the corner error's 8 modes
// (translation x, y, rotation, scale and the closure's four) carries about
// the same energy, as if every corner erred on its own. Then the centre has
// sigma^2 / 4 per axis and the heading sigma^2 / (2 L^2): that expectation
// is `expected_shared_covariance`, for a prediction (odocal setup-check).
// Measured: RMS error / expected 0.68-1.35 (position), 0.58-1.24 (heading)
// over the presets at 640x360; the bounds state 1.5-2.9x the position error.
// What neither sees: a whole-tag shift or turn (a codec pulling edges near
// the pixel grid toward it: 1.8-2x the expectation on the webcam preset).
struct RestCornerError {
  int frames = 0;
  double sigma_shared_mm = 0.0;       // per corner coordinate, common to the rest
  double sigma_independent_mm = 0.0;  // per corner coordinate, each frame its own
  // Of the rest's mean robot pose (x, y in metres, heading in radians, world
  // frame) from the shared part only: the independent part is what the
  // frames' spread already measures. The edge model's bounds (a stated
  // sigma that covers).
  Eigen::Matrix3d shared_covariance = Eigen::Matrix3d::Zero();
  // The same, expected: every corner its own error (above).
  Eigen::Matrix3d expected_shared_covariance = Eigen::Matrix3d::Zero();
};

// `closures` are the rest's frames' PlanarPoseResult::closure_mm, `heading_rad`
// the rest's mean robot heading. Empty input gives frames = 0 and zeros.
// `fitted_dof`: closure dimensions a camera fitted to these same frames has
// already taken up (0..3). A camera plane fitted to one still tag's views
// (setup-check) turns its roll and pitch to make that tag as square as it
// can: 2 of the mean closure's 4 dimensions, which would otherwise read the
// image error 2x too small in variance.
RestCornerError EstimateRestCornerError(const std::vector<std::array<Eigen::Vector2d, 4>>& closures,
                                        const TagSpec& tag, double heading_rad, int fitted_dof = 0);

struct CameraPlaneOptions {
  // The bundle adjustment of the camera and the views (Ceres, dense Schur).
  SolverSettings solver{.max_iterations = 100, .function_tolerance = 1e-12,
                        .parameter_tolerance = 1e-12};
  // Huber loss scale on corner residuals (px); 0 = plain least squares.
  double huber_px = 1.0;
  int min_views = 3;
  // The rolling shutter's readout time is fitted with the plane when the
  // views' motion can tell it: a readout of this long would move the
  // corners by more than `rolling_shutter_min_shear_px` RMS. Otherwise it
  // stays 0 (a still or slow plan cannot tell it, and does not need to).
  double rolling_shutter_probe_s = 0.02;
  double rolling_shutter_min_shear_px = 0.05;
  bool IsValid(std::string* why) const;
};

// How each view's corners were moving in the image (px/s, distorted
// pixels, same order as the corners), for the rolling shutter: a sensor read
// row by row over T exposes row v at (v / (H - 1) - 1/2) T after the frame's
// middle, so a moving tag is sheared; fitted with the plane, T takes the
// shear out (without it, the shear tilts the plane: 1.9 deg of roll on a
// webcam with a 20 ms readout, docs/vision.md). Zero velocity: a still view.
using CornerVelocities = std::array<cv::Point2d, 4>;

struct CameraPlaneResult {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;
  // The estimate: roll, pitch and height from the data; x, y, yaw copied from
  // the nominal mount (the gauge).
  CameraMount mount;
  int views_used = 0;
  double rms_reprojection_px = 0.0;
  // One standard deviation from the solver's covariance (0 when unavailable).
  double sigma_roll_deg = 0.0;
  double sigma_pitch_deg = 0.0;
  double sigma_height_mm = 0.0;
  // Each view's tag pose from the same adjustment.
  std::vector<calibration::Pose2> world_Ts_tag;
  // The rolling shutter's readout time (top row to bottom row, ms), when the
  // views' velocities were given and their motion could tell it.
  bool rolling_shutter_fitted = false;
  double rolling_shutter_ms = 0.0;
  double sigma_rolling_shutter_ms = 0.0;

  std::string BriefReport() const;
};

// Joint estimate of the camera's tilt and height over the tag plane from many
// views of the same tag (e.g. a whole calibration run; views should spread
// over the image — a single view position leaves tilt and position coupled).
// `views_velocities`, when given, has one entry per view (CornerVelocities).
CameraPlaneResult EstimateCameraOverTagPlane(const Intrinsics& intrinsics, const TagSpec& tag,
                                             const std::vector<TagCorners>& views_corners_px,
                                             const CameraMount& nominal_mount,
                                             const CameraPlaneOptions& options = {},
                                             const std::vector<CornerVelocities>* views_velocities = nullptr);

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_PLANAR_POSE_H_
