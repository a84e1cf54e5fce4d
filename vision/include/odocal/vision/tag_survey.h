// What odocal sees of the tags in one image, for `odocal detect` (the tool a
// user reaches for when a tag is not found): every tag of a family with its
// refined corners and each corner's sigma, the candidate quads libapriltag
// found but could not decode (a wrong border, a wrong family, a blurred or
// clipped tag), and, with intrinsics, a planar object's pose in the camera
// frame with its covariance.
//
// Pixels: OpenCV's convention (pixel centres at integers), lens distortion
// still in them. Corner order: libapriltag's p[0..3] = TagCornersInTag()
// (tag.h): from the printed bitmap's bottom-left corner, counter-clockwise
// as seen looking at the printed face.
// Frames: camera = OpenCV optical (x right, y down, z forward); object =
// the tag frame of tag.h (centre, x along the bitmap's columns, y up it,
// z out of the face) or a board's frame (camera_calibration.h).
// Units: metres and radians inside.
#ifndef ODOCAL_VISION_TAG_SURVEY_H_
#define ODOCAL_VISION_TAG_SURVEY_H_

#include <array>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "odocal/base/status.h"
#include "odocal/vision/camera_model.h"

namespace odocal::vision {

struct TagSurveyOptions {
  std::string family = "tag36h11";  // tag.h's IsKnownTagFamily, e.g. tag36h11b2
  // A debugging tool looks at every pixel: no decimation by default.
  float quad_decimate = 1.0f;
  int max_hamming = 1;
  // The exact edge model (RefineTagCornersByEdgeModel) with each corner's
  // sigma; off: libapriltag's corners, no sigma.
  bool refine = true;
  // Tags (by id) left as libapriltag found them, not refined: e.g. a
  // board's, which DetectBoard refines its own way.
  std::set<int> not_refined;
  // libapriltag's candidate quads (apriltag_quad_thresh, the library's own
  // first stage) that no tag was decoded from.
  bool collect_rejected = true;
  // ... of those not decoded, only quads darker inside than outside by at
  // least this many grey levels (median of samples just inside and just
  // outside the edges): texture and noise make faint quads by the dozen.
  double min_rejected_contrast = 25.0;

  bool IsValid(std::string* why) const;
};

struct SurveyedTag {
  int id = -1;
  int hamming = 0;
  double decision_margin = 0.0;
  std::array<cv::Point2d, 4> corners_px{};
  // 1-sigma per axis, sqrt(trace / 2) of the corner's covariance from the
  // two edge fits through it (the fits' own residual as the noise); 0 when
  // not refined.
  std::array<double, 4> corner_sigma_px{};
  bool refined = false;
  std::string refine_message;  // why not, when not refined
  // When refined: the tag's edge shift (edge_shift.h; how far its black
  // looks larger (+) than printed), already taken out of corners_px; NaN when
  // it could not be measured (cells under 2 px, too little contrast).
  double edge_shift_px = std::numeric_limits<double>::quiet_NaN();
  double edge_shift_sigma_px = std::numeric_limits<double>::quiet_NaN();
};

struct RejectedQuad {
  std::array<cv::Point2d, 4> corners_px{};  // as libapriltag found them (no edge refinement)
  // "no tag decoded" for a candidate quad, or why a decoded tag was refused
  // (DetectResult::refused: a border of the wrong width).
  std::string reason;
  int decoded_id = -1;  // the id it decoded to, when it did
  double contrast = 0.0;  // grey levels, outside minus inside along the edges
};

struct TagSurvey {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;  // when !ok(): bad options or image
  std::vector<SurveyedTag> tags;
  std::vector<RejectedQuad> rejected;
};

// `grey`: CV_8UC1. `camera` may be null; given, the edges are fitted on
// undistorted lines (its mount is not used).
TagSurvey SurveyTags(const cv::Mat& grey, const CameraModel* camera, const TagSurveyOptions& options);

// A planar object's pose from its points' pixels: IPPE (OpenCV's planar
// solver) refined by Levenberg-Marquardt, weighted by each point's sigma.
struct ObjectPose {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;
  Eigen::Isometry3d T_camera_object = Eigen::Isometry3d::Identity();
  // Of (rotation vector [rad], translation [m]) — OpenCV's rvec, tvec — from
  // the points' sigmas, times covariance_scale.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  std::vector<cv::Point2d> residuals_px;  // measured - reprojected, per point
  double rms_residual_px = 0.0;
  // sum((residual / sigma)^2) over the 2n - 6 degrees of freedom: 1 when the
  // sigmas are right. With 8 points or more (10 degrees of freedom) the
  // covariance is scaled by it where it is above 1: the points' sigmas hold
  // the image noise only, and on real frames the board's residual is 5-18
  // times that (the lens model, the print; docs/formats.md, detect). With
  // fewer (one tag: 2) it is reported, and the covariance left as it is.
  double chi2_per_dof = 0.0;
  double covariance_scale = 1.0;
};

// `object_points` on the plane z = 0 (>= 4, not collinear); `sigma_px` one
// per point (> 0), or empty for 1 px each.
ObjectPose EstimateObjectPose(const Intrinsics& intrinsics, const std::vector<cv::Point3d>& object_points,
                              const std::vector<cv::Point2d>& image_points, const std::vector<double>& sigma_px);

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_TAG_SURVEY_H_
