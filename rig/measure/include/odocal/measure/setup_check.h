// Before a session: can this camera, where it hangs, measure the plan?
// (`odocal setup-check`, issue 13 §5.)
//
// From a few seconds of the robot standing still under the camera:
//   - is the tag found, how large is it in pixels, are the images good enough
//     (contrast, blur, clipping: vision/edge_quality.h's quality gate);
//   - the per-frame noise of the tag's pose at rest, and the error the
//     frames share (the corners' closure: vision::EstimateRestCornerError,
//     its expectation with each corner erring on its own, not the bound
//     batch states) -- what averaging a rest cannot remove. Even a clean
//     camera needs it: through any codec a still scene's frames are nearly
//     one image (on the rendered 640x360 clip of the tests the frames'
//     spread over sqrt(n) is 20-50x below a rest's error);
//   - from them, the predicted sigma of a session's rest of `rest_s` (what
//     a codec adds to rests next to motion allowed for: session factors in
//     the options) and of a return error (the difference of two rests:
//     sqrt(2) x);
//   - the floor area the camera sees at the tag's height, and whether the
//     planned UMBMark squares (cw and ccw from where the robot stands) fit in
//     it with the whole tag in view;
//   - the predicted sigma of UMBMark's Ed and Eb for the plan: the estimator
//     itself on return errors drawn with the predicted sigma (Monte Carlo,
//     seeded).
// The camera's pose starts from the operator's mount guess, or (without one)
// a level camera at the height the tag's apparent size implies; its tilt and
// height are then fitted to the still tag's perspective (the camera-plane
// bundle adjustment), so that a wrong tilt is not counted as image error.
//
// Units: SI inside; the command prints and writes mm and degrees.
#ifndef ODOCAL_MEASURE_SETUP_CHECK_H_
#define ODOCAL_MEASURE_SETUP_CHECK_H_

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "odocal/base/status.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/edge_quality.h"
#include "odocal/vision/edge_shift.h"
#include "odocal/vision/planar_pose.h"
#include "odocal/vision/tag.h"

namespace odocal::measure {

struct SetupFrame {
  cv::Mat grey;
  double t_s = 0.0;
};

struct SetupCheckOptions {
  vision::Intrinsics intrinsics;
  vision::TagSpec tag;
  std::optional<vision::CameraMount> mount_guess;
  double rest_s = 1.0;         // how long each rest of the plan is
  double square_side_m = 1.0;  // the planned UMBMark squares
  int runs_per_direction = 3;
  double track_m = 0.3;        // the robot's (nominal) track, for Ed/Eb
  double border_margin_px = 10.0;  // the tag must stay this far inside the image
  int monte_carlo_draws = 400;
  uint64_t seed = 1;
  // A session's rests are not this still second. Through a video codec the
  // rests next to motion, and the first one before it, carry more of the
  // whole-tag error no closure can see (a shift or turn of all four edges
  // alike). On rendered sessions (renderer 640x360 and 720p,
  // machine-vision, webcam aligned with and turned to the pixel grid;
  // bench/setup_check/setup_check_sweep.py, docs/vision.md) batch's return
  // errors were 0.85-1.54x (position) and 1.3-1.5x (heading; 2.3x with the
  // webcam's edges along the pixel rows, warned about instead) what the
  // still second's closure expects; these are the geometric means. They
  // scale the frames' shared error only (1 = none).
  double session_position_factor = 1.15;
  double session_heading_factor = 1.4;
};

struct SetupCheckResult {
  StatusCode status = StatusCode::kFailed;
  // A number could be given (the tag was found and refined).
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;  // why not, when !ok()
  int frames = 0, frames_found = 0, frames_refined = 0;
  double fps = 0.0;
  vision::TagImageQuality quality;  // median over the refined frames
  // How far the tag's edges turn from the pixel rows and columns (0-45 deg).
  // A square plan's rests keep this angle (quarter turns); near 0 a video
  // codec turns such edges toward the rows, all four alike (a heading error
  // no closure shows: 1.8x the predicted on the webcam preset within 3 deg,
  // docs/vision.md), and a warning says so.
  double grid_angle_deg = 0.0;
  std::vector<vision::ObservationFlag> quality_flags;
  std::vector<std::string> warnings;  // in words, for the operator

  vision::CameraMount mount;  // used for the floor geometry
  bool mount_from_tag_size = false;
  bool plane_from_tag = false;  // roll, pitch and height fitted to the still tag's views
  // The tag's edge shift (vision/edge_shift.h) in every (n / 8)-th of the n refined frames, removed
  // before the height and the tilt were found; not ok when not measured.
  vision::EdgeShiftEstimate edge_shift;
  // Per frame (spread about the mean) and shared by every frame (the
  // closure's expectation, this still second's).
  double frame_sigma_position_m = 0.0, frame_sigma_heading_rad = 0.0;
  double shared_sigma_position_m = 0.0, shared_sigma_heading_rad = 0.0;
  // Predicted 1-sigma of a session's rest (x or y; heading: the frames'
  // spread over sqrt(frames in a rest) and the shared error times the
  // session factors) and of a return error's x (or y) and heading.
  double rest_sigma_position_m = 0.0, rest_sigma_heading_rad = 0.0;
  double return_sigma_position_m = 0.0, return_sigma_heading_rad = 0.0;
  // Floor geometry at the tag's height, world frame (m): the area the
  // camera sees with the whole tag in view, and the squares from the tag's
  // pose (cw, ccw: the axle midpoint's corners).
  std::vector<Eigen::Vector2d> view_polygon;
  std::array<std::vector<Eigen::Vector2d>, 2> squares;
  bool squares_fit = false;
  double view_width_m = 0.0, view_depth_m = 0.0;  // of the polygon's bounding box
  // The tag's shortest side in the image (px) at the squares' corners, as
  // the robot arrives and leaves, and where (world, m, the axle): a wide
  // lens shrinks a tag towards the rim of its view (a 190-degree fisheye to
  // half its centre's size at 55 degrees off the axis). With cells under
  // kSmallTagCellPx a warning; under kTooSmallTagCellPx the rests there are
  // not measured and the plan cannot be (`squares_tag_too_small`).
  double squares_min_tag_side_px = 0.0;
  Eigen::Vector2d squares_min_tag_side_at = Eigen::Vector2d::Zero();
  bool squares_tag_too_small = false;
  // Predicted 1-sigma of UMBMark's coupled Ed and Eb for the plan.
  double sigma_Ed = 0.0, sigma_Eb = 0.0;
  // The last refined frame and its corners (for the annotated image).
  cv::Mat last_frame;
  std::optional<vision::TagCorners> last_corners;
};

// A tag whose cells (its side over the family's width at the border) are
// this narrow carries several times the corner error of a 60 px tag36h11
// (docs/vision.md, "Small tags"); one with narrower cells is not measured
// (vision::CornerRefineOptions::min_cell_px). A tag36h11 (8 cells): 32 and
// 16 px; Kalibr's tag36h11b2 (10): 40 and 20 px.
inline constexpr double kSmallTagCellPx = 4.0;
inline constexpr double kTooSmallTagCellPx = 2.0;

SetupCheckResult CheckSetup(const std::vector<SetupFrame>& frames, const SetupCheckOptions& options);

}  // namespace odocal::measure

#endif  // ODOCAL_MEASURE_SETUP_CHECK_H_
