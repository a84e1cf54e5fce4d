#include "odocal/base/units.h"
#include "odocal/vision/floor_reference.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <boost/math/distributions/chi_squared.hpp>

#include "apriltag_util.h"
#include "odocal/calibration/statistics.h"
#include "odocal/vision/detector.h"

namespace odocal::vision {
namespace {

// Intersection of the diagonals 0-2 and 1-3 of four points.
std::optional<cv::Point2d> DiagonalCrossing(const std::vector<cv::Point2d>& p) {
  const cv::Point2d d1 = p[2] - p[0], d2 = p[3] - p[1], r = p[1] - p[0];
  const double den = d1.x * d2.y - d1.y * d2.x;
  if (std::abs(den) < 1e-12) return std::nullopt;
  const double t = (r.x * d2.y - r.y * d2.x) / den;
  return p[0] + t * d1;
}

// The floor point (world, z = 0) of a distorted pixel; nullopt looking away.
std::optional<Eigen::Vector2d> OnFloor(const CameraModel& camera, const cv::Point2d& px) {
  const auto p = camera.UnprojectToWorldPlane(Eigen::Vector2d(px.x, px.y), 0.0);
  if (!p) return std::nullopt;
  return p->head<2>();
}

CameraModel Tilted(const CameraModel& camera, double droll_deg, double dpitch_deg) {
  CameraMount m = camera.mount();
  m.roll_deg += droll_deg;
  m.pitch_deg += dpitch_deg;
  return CameraModel(camera.intrinsics(), m);
}

}  // namespace

bool FloorReference::IsValid(std::string* why) const {
  auto fail = [why](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  std::set<int> ids;
  for (const Tag& t : tags) {
    if (t.id < 0) return fail("floor_reference: a tag id must not be negative");
    if (!(t.size_mm > 0.0)) return fail("floor_reference: tag " + std::to_string(t.id) + ": size_mm must be positive");
    if (!ids.insert(t.id).second) return fail("floor_reference: tag " + std::to_string(t.id) + " listed twice");
  }
  if (tags.size() < 2) return fail("floor_reference: needs at least two tags");
  if (distances.empty()) return fail("floor_reference: needs at least one measured distance");
  for (const Distance& d : distances) {
    const std::string name = std::to_string(d.id_a) + "-" + std::to_string(d.id_b);
    if (!ids.count(d.id_a) || !ids.count(d.id_b))
      return fail("floor_reference: distance " + name + " names a tag not in `tags`");
    if (d.id_a == d.id_b) return fail("floor_reference: distance " + name + " joins a tag to itself");
    if (!(d.mm > 0.0)) return fail("floor_reference: distance " + name + ": mm must be positive");
    if (!(d.sigma_mm > 0.0)) return fail("floor_reference: distance " + name + ": sigma_mm must be positive");
  }
  if (!(tag_height_sigma_mm >= 0.0)) return fail("floor_reference: tag_height_sigma_mm must not be negative");
  return true;
}

std::vector<FloorTagSighting> ObserveFloorTags(const std::vector<cv::Mat>& frames,
                                               const Intrinsics& intrinsics,
                                               const FloorReference& reference,
                                               const QualityGate& gate) {
  std::vector<FloorTagSighting> out;
  for (const FloorReference::Tag& t : reference.tags) {
    FloorTagSighting s;
    s.id = t.id;
    out.push_back(s);
  }
  DetectorOptions detector_options;
  detector_options.family = reference.family;
  detector_options.quad_decimate = 2.0f;  // the refinement makes the corners exact
  TagDetectorResult created = TagDetector::Create(detector_options);
  auto family = internal::CreateFamily(reference.family);
  if (!created.ok || !family) {
    for (FloorTagSighting& s : out) s.flags.push_back("detector_unavailable");
    return out;
  }
  CornerRefineOptions refine;
  refine.width_at_border = family->width_at_border;
  const CameraModel lens(intrinsics, CameraMount{});
  // Per tag: the undistorted (normalised) centres of the usable frames.
  std::vector<std::vector<cv::Point2d>> centres(out.size());
  std::vector<std::vector<TagImageQuality>> qualities(out.size());
  std::vector<std::map<std::string, int>> reasons(out.size());
  std::vector<int> duplicates(out.size(), 0);
  for (const cv::Mat& frame : frames) {
    const DetectResult detected = created.detector->Detect(frame);
    for (size_t k = 0; k < out.size(); ++k) {
      std::vector<const TagDetection*> hits;
      for (const TagDetection& d : detected.detections)
        if (d.id == out[k].id) hits.push_back(&d);
      if (hits.empty()) continue;
      ++out[k].frames_seen;
      if (hits.size() > 1) {
        ++duplicates[k];
        continue;
      }
      const ModelFreeRefineResult r = RefineTagCornersModelFree(frame, hits[0]->corners_px, &lens, refine);
      const std::vector<std::string> flags =
          r.ok ? QualityFlags(r.quality, gate) : std::vector<std::string>{"edges_not_fitted"};
      for (const std::string& f : flags) ++reasons[k][f];
      if (!flags.empty()) continue;
      const std::vector<cv::Point2d> undistorted =
          lens.UndistortToNormalized({r.corners_px.begin(), r.corners_px.end()});
      const std::optional<cv::Point2d> c = DiagonalCrossing(undistorted);
      if (!c) continue;
      centres[k].push_back(*c);
      qualities[k].push_back(r.quality);
    }
  }
  for (size_t k = 0; k < out.size(); ++k) {
    FloorTagSighting& s = out[k];
    s.frames_used = static_cast<int>(centres[k].size());
    if (s.frames_seen == 0) {
      s.flags.push_back("not_seen");
      continue;
    }
    if (duplicates[k] > 0) {
      s.flags.push_back("duplicate_id");
      continue;
    }
    if (2 * s.frames_used < s.frames_seen || s.frames_used < 2) {
      // The commonest reason the frames were refused.
      std::string reason = "edges_not_fitted";
      int most = 0;
      for (const auto& [name, count] : reasons[k])
        if (count > most) most = count, reason = name;
      s.flags.push_back(reason);
      continue;
    }
    const double n = s.frames_used;
    cv::Point2d mean(0, 0);
    for (const cv::Point2d& c : centres[k]) mean += c;
    mean *= 1.0 / n;
    double ss = 0.0;
    for (const cv::Point2d& c : centres[k]) ss += (c - mean).dot(c - mean);
    // Per-axis spread in pixels (normalised coordinates times the focal length).
    const double f = 0.5 * (intrinsics.fx + intrinsics.fy);
    const double spread_px = std::sqrt(ss / (2.0 * std::max(1.0, n - 1.0))) * f;
    s.sigma_centre_px = std::hypot(spread_px / std::sqrt(n), kCentreFloorPx);
    // Back to a distorted pixel (what the camera model unprojects).
    const auto px = lens.ProjectCamera(Eigen::Vector3d(mean.x, mean.y, 1.0));
    s.centre_px = cv::Point2d(px->x(), px->y());
    std::vector<double> side, contrast, blur, sat, resid;
    for (const TagImageQuality& q : qualities[k]) {
      side.push_back(q.side_px);
      contrast.push_back(q.contrast_grey);
      blur.push_back(q.blur_sigma_px);
      sat.push_back(q.saturated_fraction);
      resid.push_back(q.rms_residual_grey);
    }
    s.median_quality = qualities[k].front();
    s.median_quality.side_px = calibration::Median(side);
    s.median_quality.contrast_grey = calibration::Median(contrast);
    s.median_quality.blur_sigma_px = calibration::Median(blur);
    s.median_quality.saturated_fraction = *std::max_element(sat.begin(), sat.end());
    s.median_quality.rms_residual_grey = *std::max_element(resid.begin(), resid.end());
  }
  return out;
}

FloorScaleResult EstimateFloorScale(const CameraModel& camera,
                                    const std::vector<FloorTagSighting>& sightings,
                                    const FloorReference& reference, double sigma_roll_deg,
                                    double sigma_pitch_deg) {
  FloorScaleResult result;
  std::string why;
  if (!reference.IsValid(&why)) {
    result.message = why;
    return result;
  }
  std::map<int, const FloorTagSighting*> by_id;
  for (const FloorTagSighting& s : sightings) by_id[s.id] = &s;
  const double h0_mm = camera.mount().height_mm;
  // The distance between two tags' floor points as `cam` sees them (mm).
  auto seen = [&](const CameraModel& cam, const cv::Point2d& a, const cv::Point2d& b) -> std::optional<double> {
    const auto pa = OnFloor(cam, a), pb = OnFloor(cam, b);
    if (!pa || !pb) return std::nullopt;
    return (*pa - *pb).norm() * kMToMm;
  };
  struct Used {
    FloorScaleResult::Pair pair;
    double var_tape = 0.0, var_centres = 0.0;  // of this pair's height, mm^2
    cv::Point2d a, b;
  };
  std::vector<Used> used;
  std::vector<std::string> missing;
  for (const FloorReference::Distance& d : reference.distances) {
    const auto ia = by_id.find(d.id_a), ib = by_id.find(d.id_b);
    const std::string name = std::to_string(d.id_a) + "-" + std::to_string(d.id_b);
    if (ia == by_id.end() || ib == by_id.end() || !ia->second->usable() || !ib->second->usable()) {
      missing.push_back(name);
      continue;
    }
    const FloorTagSighting& A = *ia->second;
    const FloorTagSighting& B = *ib->second;
    const std::optional<double> d0 = seen(camera, A.centre_px, B.centre_px);
    if (!d0 || !(*d0 > 0.0)) {
      missing.push_back(name);
      continue;
    }
    Used u;
    u.a = A.centre_px;
    u.b = B.centre_px;
    u.pair.id_a = d.id_a;
    u.pair.id_b = d.id_b;
    u.pair.tape_mm = d.mm;
    u.pair.tape_sigma_mm = d.sigma_mm;
    u.pair.height_mm = h0_mm * d.mm / *d0;
    // Centre noise: move each centre by its sigma along the baseline's image
    // direction (where it changes the distance most) and across; in quadrature.
    double var_seen = 0.0;
    const cv::Point2d along = (B.centre_px - A.centre_px) * (1.0 / cv::norm(B.centre_px - A.centre_px));
    const cv::Point2d across(-along.y, along.x);
    for (const auto& [end, sigma] : {std::pair{0, A.sigma_centre_px}, std::pair{1, B.sigma_centre_px}}) {
      for (const cv::Point2d& dir : {along, across}) {
        const cv::Point2d a = end == 0 ? A.centre_px + sigma * dir : A.centre_px;
        const cv::Point2d b = end == 1 ? B.centre_px + sigma * dir : B.centre_px;
        if (const auto moved = seen(camera, a, b)) var_seen += std::pow(*moved - *d0, 2);
      }
    }
    u.pair.sigma_seen_mm = std::sqrt(var_seen);
    const double rel_tape = d.sigma_mm / d.mm, rel_seen = u.pair.sigma_seen_mm / *d0;
    u.var_tape = std::pow(u.pair.height_mm * rel_tape, 2);
    u.var_centres = std::pow(u.pair.height_mm * rel_seen, 2);
    used.push_back(u);
  }
  if (used.empty()) {
    result.message = "no measured distance has both its floor tags seen well";
    if (!missing.empty()) {
      result.message += " (";
      for (size_t i = 0; i < missing.size(); ++i) result.message += (i ? ", " : "") + missing[i];
      result.message += ")";
    }
    return result;
  }
  // Inverse-variance mean of the pairs' heights.
  double sw = 0.0, swh = 0.0;
  for (const Used& u : used) {
    const double w = 1.0 / (u.var_tape + u.var_centres);
    sw += w;
    swh += w * u.pair.height_mm;
  }
  const double height = swh / sw;
  double var_tape = 0.0, var_centres = 0.0;
  for (const Used& u : used) {
    const double w = 1.0 / (u.var_tape + u.var_centres) / sw;
    var_tape += w * w * u.var_tape;
    var_centres += w * w * u.var_centres;
  }
  // Tilt: the same estimate with roll (pitch) moved by its sigma.
  auto height_with = [&](const CameraModel& cam) {
    double s = 0.0, sh = 0.0;
    for (const Used& u : used) {
      const auto d = seen(cam, u.a, u.b);
      if (!d) continue;
      const double w = 1.0 / (u.var_tape + u.var_centres);
      s += w;
      sh += w * cam.mount().height_mm * u.pair.tape_mm / *d;
    }
    return s > 0.0 ? sh / s : height;
  };
  const double base = height_with(camera);
  const double var_tilt = std::pow(height_with(Tilted(camera, sigma_roll_deg, 0.0)) - base, 2) +
                          std::pow(height_with(Tilted(camera, 0.0, sigma_pitch_deg)) - base, 2);
  const double var = var_tape + var_centres + var_tilt;
  result.ok = true;
  result.camera_height_mm = height;
  result.sigma_camera_height_mm = std::sqrt(var);
  if (var > 0.0) {
    result.variance_share_tape = var_tape / var;
    result.variance_share_centres = var_centres / var;
    result.variance_share_tilt = var_tilt / var;
  }
  for (Used& u : used) {
    u.pair.seen_mm = u.pair.tape_mm * height / u.pair.height_mm;
    const double sigma = std::sqrt(u.var_tape + u.var_centres);
    result.chi_square += std::pow((u.pair.height_mm - height) / sigma, 2);
    result.pairs.push_back(u.pair);
  }
  if (used.size() > 1) {
    const boost::math::chi_squared chi(static_cast<double>(used.size() - 1));
    result.inconsistent = boost::math::cdf(boost::math::complement(chi, result.chi_square)) < 1e-3;
  }
  return result;
}

}  // namespace odocal::vision
