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

// What the frames gave of one floor tag: the undistorted (normalised) centres
// and the qualities of the usable frames, why the others were refused, and in
// how many frames its id was seen more than once.
struct FloorTagEvidence {
  std::vector<cv::Point2d> centres;
  std::vector<TagImageQuality> qualities;
  std::map<ObservationFlag, int> reasons;
  int duplicates = 0;
};

// Refines a floor tag's detection and keeps its centre when it passes the gate.
struct SightingRefiner {
  const CameraModel& lens;
  const CornerRefineOptions& refine;
  const QualityGate& gate;

  // Adds one frame's single detection of the tag to its evidence.
  void Add(const cv::Mat& frame, const TagDetection& hit, FloorTagEvidence* evidence) const {
    const ModelFreeRefineResult r = RefineTagCornersModelFree(frame, hit.corners_px, &lens, refine);
    const std::vector<ObservationFlag> flags =
        r.ok() ? QualityFlags(r.quality, gate) : std::vector<ObservationFlag>{ObservationFlag::kEdgesNotFitted};
    for (const ObservationFlag f : flags) ++evidence->reasons[f];
    if (!flags.empty()) return;
    const std::vector<cv::Point2d> undistorted = lens.UndistortToNormalized({r.corners_px.begin(), r.corners_px.end()});
    const std::optional<cv::Point2d> c = DiagonalCrossing(undistorted);
    if (!c) return;
    evidence->centres.push_back(*c);
    evidence->qualities.push_back(r.quality);
  }
};

// The median quality of a tag's usable frames (the worst saturation and residual).
TagImageQuality MedianQuality(const std::vector<TagImageQuality>& qualities) {
  std::vector<double> side, contrast, blur, sat, resid;
  for (const TagImageQuality& q : qualities) {
    side.push_back(q.side_px);
    contrast.push_back(q.contrast_grey);
    blur.push_back(q.blur_sigma_px);
    sat.push_back(q.saturated_fraction);
    resid.push_back(q.rms_residual_grey);
  }
  TagImageQuality median = qualities.front();
  median.side_px = calibration::Median(side);
  median.contrast_grey = calibration::Median(contrast);
  median.blur_sigma_px = calibration::Median(blur);
  median.saturated_fraction = *std::max_element(sat.begin(), sat.end());
  median.rms_residual_grey = *std::max_element(resid.begin(), resid.end());
  return median;
}

// A tag's sighting from its evidence: a flag when it cannot be used, else
// the mean centre (a distorted pixel), its sigma and the median quality.
void SummariseSighting(const FloorTagEvidence& evidence, const Intrinsics& intrinsics, const CameraModel& lens,
                       FloorTagSighting* sighting) {
  FloorTagSighting& s = *sighting;
  s.frames_used = static_cast<int>(evidence.centres.size());
  if (s.frames_seen == 0) {
    s.flags.push_back(ObservationFlag::kNotSeen);
    return;
  }
  if (evidence.duplicates > 0) {
    s.flags.push_back(ObservationFlag::kDuplicateId);
    return;
  }
  if (2 * s.frames_used < s.frames_seen || s.frames_used < 2) {
    // The commonest reason the frames were refused.
    ObservationFlag reason = ObservationFlag::kEdgesNotFitted;
    int most = 0;
    for (const auto& [name, count] : evidence.reasons)
      if (count > most) most = count, reason = name;
    s.flags.push_back(reason);
    return;
  }
  const double n = s.frames_used;
  cv::Point2d mean(0, 0);
  for (const cv::Point2d& c : evidence.centres) mean += c;
  mean *= 1.0 / n;
  double ss = 0.0;
  for (const cv::Point2d& c : evidence.centres) ss += (c - mean).dot(c - mean);
  // Per-axis spread in pixels (normalised coordinates times the focal length).
  const double f = 0.5 * (intrinsics.fx + intrinsics.fy);
  const double spread_px = std::sqrt(ss / (2.0 * std::max(1.0, n - 1.0))) * f;
  s.sigma_centre_px = std::hypot(spread_px / std::sqrt(n), kCentreFloorPx);
  // Back to a distorted pixel (what the camera model unprojects).
  const auto px = lens.ProjectCamera(Eigen::Vector3d(mean.x, mean.y, 1.0));
  s.centre_px = cv::Point2d(px->x(), px->y());
  s.median_quality = MedianQuality(evidence.qualities);
}

// The distance between two tags' floor points as `cam` sees them (mm).
std::optional<double> SeenDistanceMm(const CameraModel& cam, const cv::Point2d& a, const cv::Point2d& b) {
  const auto pa = OnFloor(cam, a), pb = OnFloor(cam, b);
  if (!pa || !pb) return std::nullopt;
  return (*pa - *pb).norm() * kMToMm;
}

// A taped distance whose two tags were both seen: the camera height it
// implies and that height's variance from the tape and from the centres.
struct UsedPair {
  FloorScaleResult::Pair pair;
  double var_tape = 0.0, var_centres = 0.0;  // of this pair's height, mm^2
  cv::Point2d a, b;
};

// The camera height one taped distance implies (nullopt when the camera
// does not see the two centres apart on the floor).
std::optional<UsedPair> MeasurePair(const CameraModel& camera, const FloorReference::Distance& d,
                                    const FloorTagSighting& A, const FloorTagSighting& B) {
  const double h0_mm = camera.mount().height_mm;
  const std::optional<double> d0 = SeenDistanceMm(camera, A.centre_px, B.centre_px);
  if (!d0 || !(*d0 > 0.0)) return std::nullopt;
  UsedPair u;
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
      if (const auto moved = SeenDistanceMm(camera, a, b)) var_seen += std::pow(*moved - *d0, 2);
    }
  }
  u.pair.sigma_seen_mm = std::sqrt(var_seen);
  const double rel_tape = d.sigma_mm / d.mm, rel_seen = u.pair.sigma_seen_mm / *d0;
  u.var_tape = std::pow(u.pair.height_mm * rel_tape, 2);
  u.var_centres = std::pow(u.pair.height_mm * rel_seen, 2);
  return u;
}

// The pairs' heights pooled, and the pooled height's variance from the tape
// and from the centres (mm, mm^2).
struct PooledHeight {
  double height_mm = 0.0;
  double var_tape = 0.0, var_centres = 0.0;
};

// Inverse-variance mean of the pairs' heights.
PooledHeight PoolHeights(const std::vector<UsedPair>& used) {
  double sw = 0.0, swh = 0.0;
  for (const UsedPair& u : used) {
    const double w = 1.0 / (u.var_tape + u.var_centres);
    sw += w;
    swh += w * u.pair.height_mm;
  }
  PooledHeight pooled;
  pooled.height_mm = swh / sw;
  for (const UsedPair& u : used) {
    const double w = 1.0 / (u.var_tape + u.var_centres) / sw;
    pooled.var_tape += w * w * u.var_tape;
    pooled.var_centres += w * w * u.var_centres;
  }
  return pooled;
}

// The pooled height as `cam` sees the pairs' centres; `fallback` when it
// sees none of them.
double HeightSeenBy(const CameraModel& cam, const std::vector<UsedPair>& used, double fallback) {
  double s = 0.0, sh = 0.0;
  for (const UsedPair& u : used) {
    const auto d = SeenDistanceMm(cam, u.a, u.b);
    if (!d) continue;
    const double w = 1.0 / (u.var_tape + u.var_centres);
    s += w;
    sh += w * cam.mount().height_mm * u.pair.tape_mm / *d;
  }
  return s > 0.0 ? sh / s : fallback;
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
  if (!created.ok() || !family) {
    for (FloorTagSighting& s : out) s.flags.push_back(ObservationFlag::kDetectorUnavailable);
    return out;
  }
  CornerRefineOptions refine;
  refine.width_at_border = family->width_at_border;
  const CameraModel lens(intrinsics, CameraMount{});
  const SightingRefiner refiner{lens, refine, gate};
  std::vector<FloorTagEvidence> evidence(out.size());
  for (const cv::Mat& frame : frames) {
    const DetectResult detected = created.detector->Detect(frame);
    for (size_t k = 0; k < out.size(); ++k) {
      std::vector<const TagDetection*> hits;
      for (const TagDetection& d : detected.detections)
        if (d.id == out[k].id) hits.push_back(&d);
      if (hits.empty()) continue;
      ++out[k].frames_seen;
      if (hits.size() > 1) {
        ++evidence[k].duplicates;
        continue;
      }
      refiner.Add(frame, *hits[0], &evidence[k]);
    }
  }
  for (size_t k = 0; k < out.size(); ++k) SummariseSighting(evidence[k], intrinsics, lens, &out[k]);
  return out;
}

FloorScaleResult EstimateFloorScale(const CameraModel& camera,
                                    const std::vector<FloorTagSighting>& sightings,
                                    const FloorReference& reference, double sigma_roll_deg,
                                    double sigma_pitch_deg) {
  FloorScaleResult result;
  std::string why;
  if (!reference.IsValid(&why)) {
    result.status = StatusCode::kInvalidArgument;
    result.message = why;
    return result;
  }
  std::map<int, const FloorTagSighting*> by_id;
  for (const FloorTagSighting& s : sightings) by_id[s.id] = &s;
  std::vector<UsedPair> used;
  std::vector<std::string> missing;
  for (const FloorReference::Distance& d : reference.distances) {
    const auto ia = by_id.find(d.id_a), ib = by_id.find(d.id_b);
    const std::string name = std::to_string(d.id_a) + "-" + std::to_string(d.id_b);
    if (ia == by_id.end() || ib == by_id.end() || !ia->second->usable() || !ib->second->usable()) {
      missing.push_back(name);
      continue;
    }
    const std::optional<UsedPair> u = MeasurePair(camera, d, *ia->second, *ib->second);
    if (!u) {
      missing.push_back(name);
      continue;
    }
    used.push_back(*u);
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
  const PooledHeight pooled = PoolHeights(used);
  const double height = pooled.height_mm;
  // Tilt: the same estimate with roll (pitch) moved by its sigma.
  const double base = HeightSeenBy(camera, used, height);
  const double var_tilt = std::pow(HeightSeenBy(Tilted(camera, sigma_roll_deg, 0.0), used, height) - base, 2) +
                          std::pow(HeightSeenBy(Tilted(camera, 0.0, sigma_pitch_deg), used, height) - base, 2);
  const double var = pooled.var_tape + pooled.var_centres + var_tilt;
  result.status = StatusCode::kOk;
  result.camera_height_mm = height;
  result.sigma_camera_height_mm = std::sqrt(var);
  if (var > 0.0) {
    result.variance_share_tape = pooled.var_tape / var;
    result.variance_share_centres = pooled.var_centres / var;
    result.variance_share_tilt = var_tilt / var;
  }
  for (UsedPair& u : used) {
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
