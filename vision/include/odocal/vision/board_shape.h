// How flat the calibration board is, as the calibration's own views see it.
//
// A camera calibration takes the board's layout as exact and flat. A printed
// aprilgrid on foam board or card is neither to a millimetre: on the real
// D435i frames (docs/vision.md, "Real photographs") each tag sits up to 1 mm
// off the board's plane, the same for odocal's corners, yac's and OpenCV
// aruco's. Such a board leaves every method's corners the same error, and
// the calibration cannot tell it from the lens.
//
// The model: tag i lifted by h_i along the board's normal (+z of the board
// frame, camera_calibration.h). With each view's pose solved through the
// calibrated lens (EstimateObjectPose) and the corners' residuals r (measured
// - reprojected), a lift moves a corner's image by h J, J = d pixel / d h
// (central differences of the lens's projection, any lens model). Each tag's
// lift is the least-squares h over its corners in every view, h = sum(J.r) /
// sum(J.J), with sigma s / sqrt(sum(J.J)), s the residual per coordinate left
// once the lifts are removed. A lift that is a plane over the board (a + b x
// + c y) is what a view's pose absorbs: it is fitted (weighted by the
// sigmas) and removed, and what is reported is the shape. chi2 / dof of the
// lifts against their sigmas is ~1 for a flat board.
// Units: the board's metres inside; lifts reported in mm; residuals in px.
#ifndef ODOCAL_VISION_BOARD_SHAPE_H_
#define ODOCAL_VISION_BOARD_SHAPE_H_

#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/vision/camera_calibration.h"
#include "odocal/vision/camera_model.h"

namespace odocal::vision {

struct TagLift {
  int id = 0;
  double lift_mm = 0.0;   // along the board's +z, the plane over the board removed
  double sigma_mm = 0.0;  // 1 sigma
  int corners = 0;        // corner sightings it rests on
};

struct BoardShape {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;  // why not, when not ok
  std::vector<TagLift> tags;  // by id; tags seen in fewer than min_sightings corners left out
  double rms_lift_mm = 0.0;
  double max_abs_lift_mm = 0.0;
  int max_lift_id = -1;
  // Of the lifts against their sigmas, over tags - 3 degrees of freedom.
  double chi2_per_dof = 0.0;
  int dof = 0;
  // The part of the corners' squared residual the lifts account for.
  double explained_fraction = 0.0;
  // chi2_per_dof within what chance gives a flat board 999 times in 1000
  // (Wilson-Hilferty) or, beyond it, lifts under flat_mm RMS: flat for the
  // purpose.
  bool flat = true;
};

struct BoardShapeOptions {
  int min_sightings = 8;     // corner sightings a tag needs (two views of its 4 corners)
  double flat_mm = 0.1;      // RMS lift below which a board is flat for any purpose here
  bool IsValid(std::string* why) const;
};

// An aprilgrid's views (BoardDetection with tag_ids) and the lens calibrated
// from them. Not ok for another board type, or fewer than 4 tags seen often
// enough.
BoardShape MeasureBoardShape(const std::vector<BoardDetection>& views, const CalibrationBoard& board,
                             const Intrinsics& intrinsics, const BoardShapeOptions& options = {});

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_BOARD_SHAPE_H_
