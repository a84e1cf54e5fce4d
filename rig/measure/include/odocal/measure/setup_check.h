// Before a session: can this camera, where it hangs, measure the plan?
// (`odocal setup-check`, issue 13 §5.)
//
// From a few seconds of the robot standing still under the camera:
//   - is the tag found, how large is it in pixels, are the images good enough
//     (contrast, blur, clipping: vision/edge_quality.h's quality gate);
//   - the per-frame noise of the tag's pose at rest, and the error the
//     frames share (the corners' closure: vision::EstimateRestCornerError) --
//     what averaging a rest cannot remove;
//   - from them, the predicted sigma of a rest of `rest_s` and of a return
//     error (the difference of two rests: sqrt(2) x);
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

#include "odocal/vision/camera_model.h"
#include "odocal/vision/edge_quality.h"
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
};

struct SetupCheckResult {
  bool ok = false;      // a number could be given (the tag was found and refined)
  std::string message;  // why not, when !ok
  int frames = 0, frames_found = 0, frames_refined = 0;
  double fps = 0.0;
  vision::TagImageQuality quality;  // median over the refined frames
  std::vector<std::string> quality_flags;
  std::vector<std::string> warnings;  // in words, for the operator

  vision::CameraMount mount;  // used for the floor geometry
  bool mount_from_tag_size = false;
  bool plane_from_tag = false;  // roll, pitch and height fitted to the still tag's views
  // Per frame (spread about the mean) and shared by every frame (closure).
  double frame_sigma_position_m = 0.0, frame_sigma_heading_rad = 0.0;
  double shared_sigma_position_m = 0.0, shared_sigma_heading_rad = 0.0;
  // Predicted 1-sigma of a rest's mean (x or y; heading) and of a return
  // error's x (or y) and heading.
  double rest_sigma_position_m = 0.0, rest_sigma_heading_rad = 0.0;
  double return_sigma_position_m = 0.0, return_sigma_heading_rad = 0.0;
  // Floor geometry at the tag's height, world frame (m): the area the
  // camera sees with the whole tag in view, and the squares from the tag's
  // pose (cw, ccw: the axle midpoint's corners).
  std::vector<Eigen::Vector2d> view_polygon;
  std::array<std::vector<Eigen::Vector2d>, 2> squares;
  bool squares_fit = false;
  double view_width_m = 0.0, view_depth_m = 0.0;  // of the polygon's bounding box
  // Predicted 1-sigma of UMBMark's coupled Ed and Eb for the plan.
  double sigma_Ed = 0.0, sigma_Eb = 0.0;
  // The last refined frame and its corners (for the annotated image).
  cv::Mat last_frame;
  std::optional<vision::TagCorners> last_corners;
};

SetupCheckResult CheckSetup(const std::vector<SetupFrame>& frames, const SetupCheckOptions& options);

}  // namespace odocal::measure

#endif  // ODOCAL_MEASURE_SETUP_CHECK_H_
