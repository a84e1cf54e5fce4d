#include "odocal/vision/tag_survey.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "apriltag_util.h"
#include "edge_model_refine.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/edge_shift.h"
#include "odocal/vision/tag.h"

// libapriltag's first stage (apriltag_quad_thresh.c): the candidate quads of
// an image, before decoding. Exported by the shared library (it is what
// apriltag_detector_detect calls) but not declared in its public headers.
// Each quad's homographies are still null at this stage (they are computed
// when decoding), so the array alone is freed.
extern "C" zarray_t* apriltag_quad_thresh(apriltag_detector_t* td, image_u8_t* im);

namespace odocal::vision {

bool TagSurveyOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (!IsKnownTagFamily(family)) return fail("unknown tag family '" + family + "'");
  if (!(quad_decimate >= 1.0f)) return fail("quad_decimate must be >= 1");
  if (max_hamming < 0 || max_hamming > 3) return fail("max_hamming must be in [0, 3]");
  if (!(min_rejected_contrast >= 0.0)) return fail("min_rejected_contrast must be >= 0");
  return true;
}

namespace {

// The quads libapriltag finds in `grey` at full resolution (whatever the
// detector's decimation: a debugging view wants every candidate), in
// OpenCV's pixel convention (the conversion of detector.h).
std::vector<std::array<cv::Point2d, 4>> CandidateQuads(const cv::Mat& grey, const TagSurveyOptions& options) {
  std::vector<std::array<cv::Point2d, 4>> out;
  auto family = internal::CreateFamily(options.family);
  // The family sets the smallest quad worth keeping.
  internal::DetectorPtr td(apriltag_detector_create());
  apriltag_detector_add_family_bits(td.get(), family.get(), options.max_hamming);
  td->quad_decimate = 1.0f;
  td->nthreads = 1;
  {
    // apriltag_detector_detect makes the worker pool apriltag_quad_thresh
    // uses (apriltag_detector_create leaves it null in 3.3): run it once on
    // a blank patch.
    uint8_t blank[16 * 16] = {};
    image_u8_t patch{16, 16, 16, blank};
    internal::DetectionsPtr none(apriltag_detector_detect(td.get(), &patch));
  }
  const cv::Mat image = grey.isContinuous() ? grey : grey.clone();
  image_u8_t im{image.cols, image.rows, static_cast<int32_t>(image.step[0]),
                const_cast<uint8_t*>(image.ptr<uint8_t>(0))};
  zarray_t* quads = apriltag_quad_thresh(td.get(), &im);
  for (int i = 0; i < zarray_size(quads); ++i) {
    struct quad* q = nullptr;
    zarray_get_volatile(quads, i, &q);
    std::array<cv::Point2d, 4> c;
    for (int k = 0; k < 4; ++k) {
      c[k] = cv::Point2d(q->p[k][0] + kApriltagToOpenCvPx, q->p[k][1] + kApriltagToOpenCvPx);
    }
    out.push_back(c);
  }
  zarray_destroy(quads);
  // Destroy the detector before the family it references.
  td.reset();
  return out;
}

cv::Point2d Centre(const std::array<cv::Point2d, 4>& c) { return 0.25 * (c[0] + c[1] + c[2] + c[3]); }

// Outside minus inside: medians of samples an eighth of the side inside and
// outside each edge, between 20 % and 80 % of its length.
double EdgeContrast(const cv::Mat& grey, const std::array<cv::Point2d, 4>& c) {
  std::vector<cv::Point2f> unit = {{0, 0}, {1, 0}, {1, 1}, {0, 1}}, quad;
  for (const auto& p : c) quad.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  const cv::Mat H = cv::getPerspectiveTransform(unit, quad);
  std::vector<cv::Point2f> in_pts, out_pts;
  for (int e = 0; e < 4; ++e) {
    const cv::Point2f a = unit[e], b = unit[(e + 1) % 4], centre(0.5f, 0.5f);
    for (double t = 0.2; t <= 0.8 + 1e-9; t += 0.1) {
      const cv::Point2f p = a + static_cast<float>(t) * (b - a);
      const cv::Point2f inward = (centre - p) * 0.25f;  // an eighth of the side
      in_pts.push_back(p + inward);
      out_pts.push_back(p - inward);
    }
  }
  std::vector<cv::Point2f> in_px, out_px;
  cv::perspectiveTransform(in_pts, in_px, H);
  cv::perspectiveTransform(out_pts, out_px, H);
  const auto median = [&](const std::vector<cv::Point2f>& pts) {
    std::vector<double> v;
    for (const auto& p : pts) {
      const int x = cvRound(p.x), y = cvRound(p.y);
      if (x >= 0 && y >= 0 && x < grey.cols && y < grey.rows) v.push_back(grey.at<uint8_t>(y, x));
    }
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  return median(out_px) - median(in_px);
}

// Refines a detected tag's corners by the edge model, with their sigmas, and
// takes the edge shift out of them; a message in the tag when that fails.
void RefineSurveyedTag(const cv::Mat& grey, const CameraModel* camera, const std::string& family,
                       const CornerRefineOptions& refine, SurveyedTag* tag) {
  SurveyedTag& t = *tag;
  std::array<cv::Matx22d, 4> cov;
  const CornerRefineResult r =
      internal::RefineTagCornersByEdgeModelWithCovariance(grey, t.corners_px, camera, refine, {0, 0}, &cov);
  t.refined = r.ok();
  if (!r.ok()) {
    t.refine_message = r.message;
    return;
  }
  t.corners_px = r.corners_px;
  for (int k = 0; k < 4; ++k) t.corner_sigma_px[k] = std::sqrt(0.5 * (cov[k](0, 0) + cov[k](1, 1)));
  // The edge shift (edge_shift.h), measured in the tag and taken out of
  // its corners: they are then the print's, and a pose from them has
  // the print's distance.
  if (const auto cells = TagCells::Of(family, t.id)) {
    const EdgeShiftResult shift = MeasureEdgeShift(grey, t.corners_px, *cells, camera);
    if (shift.ok()) {
      t.edge_shift_px = shift.shift_px;
      t.edge_shift_sigma_px = shift.sigma_px;
      t.corners_px = RemoveEdgeShift(t.corners_px, shift.shift_px, camera);
    }
  }
}

// Whether a candidate quad's centre `c` is explained by a known tag: within
// a quarter of its side of the tag's centre, or inside it.
bool ExplainedByKnownTag(const cv::Point2d& c, const std::vector<std::array<cv::Point2d, 4>>& known) {
  for (const auto& corners : known) {
    const double side = 0.25 * (cv::norm(corners[0] - corners[1]) + cv::norm(corners[1] - corners[2]) +
                                cv::norm(corners[2] - corners[3]) + cv::norm(corners[3] - corners[0]));
    std::vector<cv::Point2f> poly;
    for (const auto& p : corners) poly.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
    if (cv::norm(c - Centre(corners)) < 0.25 * side ||
        cv::pointPolygonTest(poly, cv::Point2f(static_cast<float>(c.x), static_cast<float>(c.y)), false) >= 0) {
      return true;
    }
  }
  return false;
}

// Adds to the survey's rejections the candidate quads no tag explains that
// have contrast enough to look like a tag nobody decoded.
void AddUndecodedQuads(const cv::Mat& grey, const TagSurveyOptions& options,
                       const std::vector<RefusedDetection>& refused, TagSurvey* survey) {
  // A candidate is "the tag" when its centre lies within a quarter of the
  // tag's side of a detection's centre (the tag's outer border quad);
  // the tag's data bits also make small quads inside it, which are not
  // rejections either.
  for (const auto& q : CandidateQuads(grey, options)) {
    const cv::Point2d c = Centre(q);
    std::vector<std::array<cv::Point2d, 4>> known;
    for (const SurveyedTag& t : survey->tags) known.push_back(t.corners_px);
    for (const RefusedDetection& r : refused) known.push_back(r.detection.corners_px);
    if (ExplainedByKnownTag(c, known)) continue;
    const double contrast = EdgeContrast(grey, q);
    if (contrast >= options.min_rejected_contrast)
      survey->rejected.push_back(RejectedQuad{q, "no tag decoded", -1, contrast});
  }
}

// The points' pixels and their Jacobian in (rvec, tvec) through the lens:
// cv::projectPoints for plumb_bob (its Jacobian's first 6 columns),
// cv::fisheye::projectPoints for the equidistant lens (columns 8..13 of
// its 2N x 15: f, c, k1..k4, then om and T).
struct PoseProjector {
  const std::vector<cv::Point3d>& object_points;
  cv::Mat K, D;
  bool fisheye = false;

  void operator()(const cv::Mat& r, const cv::Mat& t, std::vector<cv::Point2d>* px, cv::Mat* J6) const {
    cv::Mat J;
    if (fisheye) {
      cv::fisheye::projectPoints(object_points, *px, r, t, K, D, 0.0, J);
      *J6 = J.colRange(8, 14).clone();
    } else {
      cv::projectPoints(object_points, r, t, K, D, *px, J);
      *J6 = J.colRange(0, 6).clone();
    }
  }
};

// IPPE's planar pose of the points (for the fisheye lens on the points
// undistorted to the normalised plane); false with `why` when none.
bool SolvePlanarPose(const Intrinsics& intrinsics, const std::vector<cv::Point3d>& object_points,
                     const std::vector<cv::Point2d>& image_points, cv::Mat* rvec, cv::Mat* tvec, std::string* why) {
  bool solved = false;
  if (intrinsics.lens == LensModel::kEquidistant) {
    // IPPE on the points undistorted to the normalised plane (K = I).
    const CameraModel camera(intrinsics, CameraMount{});
    const std::vector<cv::Point2d> normalised = camera.UndistortToNormalized(image_points);
    for (const cv::Point2d& q : normalised) {
      if (!std::isfinite(q.x) || !std::isfinite(q.y)) {
        *why = "a point lies where the lens has no pinhole image (90 degrees or more off the axis)";
        return false;
      }
    }
    solved = cv::solvePnP(object_points, normalised, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), *rvec, *tvec, false,
                          cv::SOLVEPNP_IPPE);
  } else {
    solved = cv::solvePnP(object_points, image_points, intrinsics.CameraMatrix(), intrinsics.DistortionCoeffs(), *rvec,
                          *tvec, false, cv::SOLVEPNP_IPPE);
  }
  if (!solved) *why = "no planar pose fits these points";
  return solved;
}

// Gauss-Newton on the reprojection errors weighted by `w` (1 / sigma), at
// most 10 steps.
void RefineWeighted(const PoseProjector& project, const std::vector<cv::Point2d>& image_points,
                    const std::vector<double>& w, cv::Mat* rvec, cv::Mat* tvec) {
  const size_t n = image_points.size();
  cv::Mat J_w;
  for (int iteration = 0; iteration < 10; ++iteration) {
    std::vector<cv::Point2d> projected;
    cv::Mat J;
    project(*rvec, *tvec, &projected, &J);
    J_w = cv::Mat(static_cast<int>(2 * n), 6, CV_64F);
    cv::Mat r_w(static_cast<int>(2 * n), 1, CV_64F);
    for (size_t i = 0; i < n; ++i) {
      for (int a = 0; a < 2; ++a) {
        const int row = static_cast<int>(2 * i) + a;
        for (int c = 0; c < 6; ++c) J_w.at<double>(row, c) = w[i] * J.at<double>(row, c);
        const cv::Point2d e = image_points[i] - projected[i];
        r_w.at<double>(row) = w[i] * (a == 0 ? e.x : e.y);
      }
    }
    cv::Mat step;
    cv::solve(J_w, r_w, step, cv::DECOMP_SVD);
    *rvec += step.rowRange(0, 3);
    *tvec += step.rowRange(3, 6);
    if (cv::norm(step) < 1e-12) break;
  }
}

// The fit's residuals, rms, chi^2 per degree of freedom and the pose's
// covariance (scaled by that chi^2 when there are points enough) into `pose`.
void FitStatistics(const PoseProjector& project, const std::vector<cv::Point2d>& image_points,
                   const std::vector<double>& w, const cv::Mat& rvec, const cv::Mat& tvec, ObjectPose* pose) {
  const size_t n = image_points.size();
  std::vector<cv::Point2d> projected;
  cv::Mat J;
  project(rvec, tvec, &projected, &J);
  cv::Mat JtJ = cv::Mat::zeros(6, 6, CV_64F);
  double sq = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const cv::Mat Ji = J.rowRange(static_cast<int>(2 * i), static_cast<int>(2 * i + 2)).colRange(0, 6);
    JtJ += Ji.t() * Ji * (w[i] * w[i]);
    const cv::Point2d e = image_points[i] - projected[i];
    pose->residuals_px.push_back(e);
    sq += e.dot(e);
  }
  pose->rms_residual_px = std::sqrt(sq / n);
  double chi2 = 0.0;
  for (size_t i = 0; i < n; ++i) chi2 += pose->residuals_px[i].dot(pose->residuals_px[i]) * w[i] * w[i];
  const int dof = static_cast<int>(2 * n) - 6;
  pose->chi2_per_dof = dof > 0 ? chi2 / dof : 0.0;
  pose->covariance_scale = dof >= 10 ? std::max(1.0, pose->chi2_per_dof) : 1.0;
  const cv::Mat cov = JtJ.inv(cv::DECOMP_SVD) * pose->covariance_scale;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) pose->covariance(r, c) = cov.at<double>(r, c);
}

}  // namespace

TagSurvey SurveyTags(const cv::Mat& grey, const CameraModel* camera, const TagSurveyOptions& options) {
  TagSurvey survey;
  if (!options.IsValid(&survey.message)) {
    survey.status = StatusCode::kInvalidArgument;
    return survey;
  }
  if (grey.empty() || grey.type() != CV_8UC1) {
    survey.status = StatusCode::kInvalidArgument;
    survey.message = "needs a non-empty 8-bit grey image";
    return survey;
  }
  DetectorOptions detector_options;
  detector_options.family = options.family;
  detector_options.quad_decimate = options.quad_decimate;
  detector_options.max_hamming = options.max_hamming;
  auto created = TagDetector::Create(detector_options);
  if (!created.ok()) {
    survey.message = created.message;
    return survey;
  }
  const DetectResult found = created.detector->Detect(grey);
  CornerRefineOptions refine;
  refine.width_at_border = TagWidthAtBorder(options.family);
  for (const TagDetection& d : found.detections) {
    SurveyedTag t;
    t.id = d.id;
    t.hamming = d.hamming;
    t.decision_margin = d.decision_margin;
    t.corners_px = d.corners_px;
    if (options.not_refined.count(d.id)) {
      t.refine_message = "left to the board's refinement";
    } else if (options.refine) {
      RefineSurveyedTag(grey, camera, options.family, refine, &t);
    }
    survey.tags.push_back(t);
  }
  std::sort(survey.tags.begin(), survey.tags.end(), [](const SurveyedTag& a, const SurveyedTag& b) {
    return a.id != b.id ? a.id < b.id : Centre(a.corners_px).x < Centre(b.corners_px).x;
  });
  for (const RefusedDetection& r : found.refused)
    survey.rejected.push_back(
        RejectedQuad{r.detection.corners_px, r.reason, r.detection.id, EdgeContrast(grey, r.detection.corners_px)});
  if (options.collect_rejected) AddUndecodedQuads(grey, options, found.refused, &survey);
  survey.status = StatusCode::kOk;
  return survey;
}

ObjectPose EstimateObjectPose(const Intrinsics& intrinsics, const std::vector<cv::Point3d>& object_points,
                              const std::vector<cv::Point2d>& image_points, const std::vector<double>& sigma_px) {
  ObjectPose pose;
  const size_t n = object_points.size();
  if (n < 4 || image_points.size() != n || (!sigma_px.empty() && sigma_px.size() != n)) {
    pose.message = "a pose needs at least 4 points, each with its pixel (and sigma)";
    return pose;
  }
  for (double s : sigma_px) {
    if (!(s > 0.0) || !std::isfinite(s)) {
      pose.message = "every point's sigma must be positive";
      return pose;
    }
  }
  const PoseProjector project{object_points, intrinsics.CameraMatrix(), intrinsics.DistortionCoeffs(),
                              intrinsics.lens == LensModel::kEquidistant};
  cv::Mat rvec, tvec;
  try {
    if (!SolvePlanarPose(intrinsics, object_points, image_points, &rvec, &tvec, &pose.message)) return pose;
    // Weighted Gauss-Newton from IPPE's answer: OpenCV's LM refinement is
    // unweighted, so iterate here with each point's sigma.
    std::vector<double> w(n, 1.0);
    for (size_t i = 0; i < n && !sigma_px.empty(); ++i) w[i] = 1.0 / sigma_px[i];
    RefineWeighted(project, image_points, w, &rvec, &tvec);
    FitStatistics(project, image_points, w, rvec, tvec, &pose);
  } catch (const cv::Exception& e) {
    pose.message = "OpenCV: " + e.err;
    return pose;
  }
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Re(r, c) = R.at<double>(r, c);
  pose.T_camera_object.linear() = Re;
  pose.T_camera_object.translation() = Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  pose.status = StatusCode::kOk;
  return pose;
}

}  // namespace odocal::vision
