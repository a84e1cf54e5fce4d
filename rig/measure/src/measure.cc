#include "odocal/measure/measure.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>

#include "odocal/base/format.h"
#include "odocal/base/parallel.h"
#include "odocal/base/units.h"
#include "odocal/measure/segment_runs.h"
#include "odocal/media/video.h"
#include "odocal/vision/edge_shift.h"

namespace odocal::measure {

using calibration::RunFlag;
using calibration::RunFlagKind;

namespace {

// The telemetry reader shared with pose-log runs (pose_log.h); for a video
// run a bad file is a flag, not an error.
std::vector<calibration::TelemetryRecord> ReadTelemetry(const std::string& path,
                                                        const calibration::WheelParams& nominal,
                                                        std::vector<RunFlag>* flags) {
  if (path.empty()) return {};
  auto records = ReadTelemetryCsv(path, nominal);
  if (records) return std::move(*records);
  flags->push_back(RunFlag::Of(
      records.status == StatusCode::kNotFound ? RunFlagKind::kTelemetryUnreadable : RunFlagKind::kTelemetryMalformed,
      records.message));
  return {};
}

// Whether the tag and its quiet zone (one cell of 10 beyond the black
// square's 8: an eighth of its side) lie `margin_px` inside the image.
bool AwayFromBorder(const vision::CameraModel& camera, const vision::TagCorners& c,
                    double margin_px) {
  const cv::Point2d centre = (c[0] + c[1] + c[2] + c[3]) * 0.25;
  for (const cv::Point2d& p : c) {
    // The quiet zone's corner: 1/8 of the side beyond the black corner, i.e.
    // 1.25 times as far from the centre.
    const cv::Point2d q = centre + (p - centre) * 1.25;
    if (!camera.InImage(Eigen::Vector2d(q.x, q.y), margin_px)) return false;
  }
  return true;
}

// A frame's robot pose: nullopt without corners, too near the border, or
// when the pose cannot be measured.
std::optional<calibration::Pose2> FramePose(const vision::CameraModel& camera, const vision::TagSpec& tag,
                                            const vision::FrameObservation& f, double margin_px) {
  if (!f.corners_px || !AwayFromBorder(camera, *f.corners_px, margin_px)) return std::nullopt;
  const vision::PlanarPoseResult pose = vision::MeasureTagPose(camera, tag, *f.corners_px);
  if (!pose.ok()) return std::nullopt;
  return pose.T_world_robot;
}

// The views for the plane estimate. With `exact`, each picked view is
// refined by the exact edge model from its kept crop (the per-frame corners
// make a 30 px tag look 0.025 px too large: the camera's height came out
// 1.5 mm low at 1.85 m, 15 sigma, and every distance 8e-4 long). Each view's
// corner velocities (px/s, from the frames either side of it in its run;
// zero without both) go to `velocities`, for the rolling shutter.
std::vector<vision::TagCorners> PickViews(const std::vector<RunMeasurement>& runs,
                                          double separation_px, int max_views,
                                          const vision::CameraModel& lens, double margin_px,
                                          bool exact, std::vector<vision::CornerVelocities>* velocities,
                                          const vision::TagSpec& tag, int shift_views,
                                          vision::EdgeShiftEstimate* shift) {
  std::vector<vision::TagCorners> candidates;
  std::vector<std::pair<const std::vector<vision::FrameObservation>*, size_t>> frames;
  for (const RunMeasurement& run : runs)
    for (size_t i = 0; i < run.track.frames.size(); ++i) {
      const vision::FrameObservation& f = run.track.frames[i];
      if (f.corners_px && AwayFromBorder(lens, *f.corners_px, margin_px)) {
        candidates.push_back(*f.corners_px);
        frames.emplace_back(&run.track.frames, i);
      }
    }
  std::vector<vision::TagCorners> views = PickPlaneViews(candidates, separation_px, max_views);
  velocities->assign(views.size(), vision::CornerVelocities{});
  // PickPlaneViews keeps candidates in order: find each view's frame.
  size_t k = 0;
  std::vector<size_t> view_frame;  // views[v]'s index in `frames`
  for (size_t v = 0; v < views.size(); ++v) {
    while (k < candidates.size() && candidates[k] != views[v]) ++k;
    if (k == candidates.size()) break;
    view_frame.push_back(k);
    const auto& [run_frames, i] = frames[k];
    if (i > 0 && i + 1 < run_frames->size()) {
      const vision::FrameObservation& a = (*run_frames)[i - 1];
      const vision::FrameObservation& b = (*run_frames)[i + 1];
      const double dt = b.t_s - a.t_s;
      // Neighbours seen, and no frame dropped between them.
      if (a.corners_px && b.corners_px && dt > 0.0 &&
          dt < 2.5 * std::max((*run_frames)[i].t_s - a.t_s, b.t_s - (*run_frames)[i].t_s))
        for (int c = 0; c < 4; ++c) (*velocities)[v][c] = ((*b.corners_px)[c] - (*a.corners_px)[c]) * (1.0 / dt);
    }
    if (exact)
      if (auto refined = vision::RefineObservationExactly((*run_frames)[i], lens)) views[v] = *refined;
  }
  // The edge shift (tone curve, blur, ink) in evenly spaced views, then out
  // of every view: the plane's height is the tag's apparent size.
  if (shift_views > 0 && !view_frame.empty()) {
    std::vector<const vision::FrameObservation*> observed;
    for (size_t k2 : view_frame) observed.push_back(&(*frames[k2].first)[frames[k2].second]);
    *shift = MeasureTagEdgeShift(observed, tag, lens, shift_views);
    if (shift->ok())
      for (vision::TagCorners& view : views) view = vision::RemoveEdgeShift(view, shift->shift_px, &lens);
  }
  return views;
}

void MeasureRestsAndReturnError(const MeasureOptions& options, const vision::CameraModel& camera,
                                const vision::TagSpec& tag, RunMeasurement* rm) {
  calibration::MeasuredRun& m = rm->measured;
  std::vector<calibration::PoseSample> samples;
  for (const calibration::CameraRecord& c : m.camera) {
    if (c.t_s < rm->run.start_s - 1e-6 || c.t_s > rm->run.end_s + 1e-6) continue;
    samples.push_back({c.t_s, c.T_world_robot, c.valid});
  }
  const calibration::RestSummary rests = calibration::FindRests(samples, options.rest);
  const double span = std::min(rm->run.end_s, samples.empty() ? 0.0 : samples.back().t_s) -
                      std::max(rm->run.start_s, samples.empty() ? 0.0 : samples.front().t_s);
  const double t0 = samples.empty() ? rm->run.start_s : samples.front().t_s;
  const double t1 = samples.empty() ? rm->run.end_s : samples.back().t_s;
  if (!rests.rests.empty() && rests.rests.front().t_begin_s <= t0 + options.rest_search_fraction * span)
    m.start_rest = rests.rests.front();
  if (!rests.rests.empty() && rests.rests.back().t_end_s >= t1 - options.rest_search_fraction * span &&
      (!m.start_rest || rests.rests.size() >= 2))
    m.end_rest = rests.rests.back();
  if (!m.start_rest) m.flags.push_back(RunFlag::Of(RunFlagKind::kNoStartRest));
  if (!m.end_rest) m.flags.push_back(RunFlag::Of(RunFlagKind::kNoEndRest));
  // The averaged frames, refined exactly (the per-frame refinement is biased
  // by up to 0.02 px on edges parallel to the pixel grid: docs/vision.md).
  if (options.exact_rest_refinement) {
    for (std::optional<calibration::RestWindow>* rest : {&m.start_rest, &m.end_rest}) {
      if (!*rest) continue;
      const bool start = rest == &m.start_rest;
      RestQuality quality;
      RestQuality* q = options.model_free_rest_refinement ? &quality : nullptr;
      if (auto exact = MeasureRestExactly(rm->track.frames, (*rest)->t_begin_s, (*rest)->t_end_s,
                                          camera, tag, q, options.quality_gate)) {
        **rest = *exact;
      } else if (q && !quality.flags.empty()) {
        // The images cannot support the number: no value, say why.
        for (const vision::ObservationFlag f : quality.flags)
          m.flags.push_back(RunFlag::Of(RunFlagKind::kImageQuality,
                                        std::string(start ? "start_rest:" : "end_rest:") + vision::ToString(f)));
      } else {
        m.flags.push_back(RunFlag::Of(RunFlagKind::kExactRefinementFailed));
      }
      if (q) (start ? rm->start_quality : rm->end_quality) = std::move(quality);
    }
  }
  if (m.start_rest && m.start_rest->n < 10) m.flags.push_back(RunFlag::Of(RunFlagKind::kShortStartRest));
  if (m.end_rest && m.end_rest->n < 10) m.flags.push_back(RunFlag::Of(RunFlagKind::kShortEndRest));
  // Gaps while moving: between the rests, longer than flag_gap_s.
  if (m.start_rest && m.end_rest) {
    double last_seen = m.start_rest->t_end_s, longest = 0.0;
    for (const calibration::PoseSample& s : samples) {
      if (s.t_s <= m.start_rest->t_end_s || s.t_s >= m.end_rest->t_begin_s || !s.valid) continue;
      longest = std::max(longest, s.t_s - last_seen);
      last_seen = s.t_s;
    }
    longest = std::max(longest, m.end_rest->t_begin_s - last_seen);
    if (longest > options.flag_gap_s) {
      char gap[32];
      std::snprintf(gap, sizeof(gap), "%.1fs", longest);
      m.flags.push_back(RunFlag::Of(RunFlagKind::kTagOutOfViewMidRun, gap));
    }
    const calibration::RelativePose r =
        calibration::Between(*m.start_rest, *m.end_rest, options.systematic_floor);
    // true - odometry: the odometry's relative pose over the run (it does not
    // change during the rests, whatever the offset of the clocks).
    const calibration::Pose2 odometry =
        m.telemetry.size() < 2 ? calibration::Pose2::Identity()
                               : m.telemetry.front().odometry.inverse() * m.telemetry.back().odometry;
    m.return_error = calibration::TrueMinusOdometry(r, odometry);
  }
}

// The first frames of the session's videos, for the floor tags.
std::vector<cv::Mat> FloorFrames(const SessionMeasurement& sm, const MeasureOptions& options) {
  std::vector<cv::Mat> frames;
  std::vector<std::string> videos;
  for (const RunMeasurement& rm : sm.runs)
    if (!rm.run.video.empty() && std::find(videos.begin(), videos.end(), rm.run.video) == videos.end())
      videos.push_back(rm.run.video);
  if (static_cast<int>(videos.size()) > options.floor_max_videos) videos.resize(options.floor_max_videos);
  for (const std::string& video : videos) {
    media::VideoReader reader;
    if (!reader.Open(video).ok()) continue;
    cv::Mat frame;
    for (int k = 0; k < options.floor_frames_per_video && reader.Read(&frame); ++k) frames.push_back(frame.clone());
  }
  return frames;
}

std::string Percent(double fraction, int decimals) { return Fixed(100.0 * fraction, decimals) + " %"; }

// The scale from a usable floor reference: the camera's height above the
// reference's tags (to `mount`), and what the robot tag's print then measures.
void ScaleFromFloorReference(const vision::FloorReference& reference, double tag_mm, double apparent_sigma,
                             vision::CameraMount* mount, std::vector<SessionFlag>* flags, CameraScale& scale) {
  const vision::FloorScaleResult& f = *scale.floor;
  const double above_ref = f.camera_height_mm - tag_mm;
  const double above_tag = mount->height_mm - tag_mm;
  const double sigma_above_ref = std::hypot(f.sigma_camera_height_mm, reference.tag_height_sigma_mm);
  scale.source = CameraScale::Source::kFloorReference;
  scale.relative_sigma = sigma_above_ref / above_ref;
  scale.camera_height_mm = f.camera_height_mm;
  scale.sigma_camera_height_mm = f.sigma_camera_height_mm;
  // A tag printed s times its stated size looks s times nearer.
  scale.tag_print_scale = above_ref / above_tag;
  scale.tag_print_scale_sigma = *scale.tag_print_scale * std::hypot(scale.relative_sigma, apparent_sigma);
  const double off = *scale.tag_print_scale - 1.0;
  scale.explanation = "from the floor reference (" + std::to_string(f.pairs.size()) +
                      (f.pairs.size() == 1 ? " distance" : " distances") + "): ±" + Percent(scale.relative_sigma, 3) +
                      "; the robot tag prints " + Percent(std::abs(off), 2) + " ± " +
                      Percent(*scale.tag_print_scale_sigma, 2) + (off >= 0.0 ? " large" : " small") +
                      " (or looks it: tone curve, blur)";
  if (f.inconsistent) {
    if (flags) flags->push_back(SessionFlag::kFloorReferenceInconsistent);
    scale.explanation += "; the measured distances disagree beyond their sigmas (a tag moved? a misread tape?)";
  }
  mount->height_mm = f.camera_height_mm;
}

// The edge shift found and removed, as the explanation says it.
std::string EdgeShiftText(const vision::EdgeShiftEstimate& shift) {
  std::string shift_text = "; the tag's edges lie ";
  shift_text += Fixed(std::abs(shift.shift_px), 3);
  shift_text += " ± ";
  shift_text += Fixed(shift.sigma_px, 3);
  shift_text += shift.shift_px >= 0.0 ? " px outside" : " px inside";
  shift_text += " the print (tone curve, blur, ink: ";
  shift_text += Percent(std::abs(shift.RelativeScaleError()), 2);
  shift_text += " of the scale, removed)";
  return shift_text;
}

}  // namespace

const char* ToString(SessionFlag flag) {
  switch (flag) {
    case SessionFlag::kCameraPlaneNotEstimated:
      return "camera_plane_not_estimated:using_operator_guess";
    case SessionFlag::kFloorReferenceUnusable:
      return "floor_reference_unusable";
    case SessionFlag::kFloorReferenceInconsistent:
      return "floor_reference_inconsistent";
  }
  return "unknown";
}

CameraScale EstimateCameraScale(const vision::Intrinsics& intrinsics, const vision::TagSpec& tag,
                                std::optional<double> tag_size_sigma_mm, const vision::CameraPlaneResult* plane,
                                const vision::FloorReference* reference, const std::vector<cv::Mat>& floor_frames,
                                const CameraScaleOptions& options, vision::CameraMount* mount,
                                std::vector<SessionFlag>* flags, const vision::EdgeShiftEstimate* edge_shift) {
  CameraScale scale;
  scale.with_floor_reference = reference != nullptr;
  if (edge_shift) scale.edge_shift = *edge_shift;
  const double tag_mm = tag.height_mm;
  const double print_sigma = tag_size_sigma_mm ? *tag_size_sigma_mm / tag.size_mm : options.tag_print_sigma;
  const double plane_sigma =
      plane && mount->height_mm > tag_mm ? plane->sigma_height_mm / (mount->height_mm - tag_mm) : 0.0;
  // The edge shift removed from the plane's views leaves its own sigma.
  const double shift_sigma = edge_shift ? edge_shift->RelativeScaleSigma() : 0.0;
  const double apparent_sigma = std::hypot(std::hypot(plane_sigma, options.systematic_scale_sigma), shift_sigma);
  const double tag_sigma = std::hypot(apparent_sigma, print_sigma);
  std::string fallback_reason;
  if (reference) {
    scale.floor_tags = vision::ObserveFloorTags(floor_frames, intrinsics, *reference, options.quality_gate);
    if (!plane) {
      fallback_reason = "the camera's tilt was not estimated";
    } else {
      scale.floor = vision::EstimateFloorScale(vision::CameraModel(intrinsics, *mount), scale.floor_tags,
                                               *reference, plane->sigma_roll_deg, plane->sigma_pitch_deg);
      if (!scale.floor->ok()) fallback_reason = scale.floor->message;
    }
    if (scale.floor && scale.floor->ok()) {
      ScaleFromFloorReference(*reference, tag_mm, apparent_sigma, mount, flags, scale);
      return scale;
    }
    if (flags) flags->push_back(SessionFlag::kFloorReferenceUnusable);
  }
  const std::string shift_text = edge_shift ? EdgeShiftText(*edge_shift) : std::string();
  scale.source = CameraScale::Source::kTagSize;
  scale.relative_sigma = tag_sigma;
  scale.camera_height_mm = mount->height_mm;
  scale.sigma_camera_height_mm = plane ? plane->sigma_height_mm : 0.0;
  scale.explanation =
      "from the robot tag's printed size: ±" + Percent(tag_sigma, 2) + " (print size ±" +
      Percent(print_sigma, 2) +
      (tag_size_sigma_mm ? " as measured" : " assumed; state tag.size_sigma_mm if you measured it") +
      ", apparent size ±" + Percent(apparent_sigma, 3) +
      shift_text +
      ")" +
      (reference ? "; the floor reference could not be used: " + fallback_reason
                 : "; a floor reference (two floor tags at a taped distance) pins it");
  return scale;
}

std::string_view ToString(CameraScale::Source source) {
  switch (source) {
    case CameraScale::Source::kNone: return "none";
    case CameraScale::Source::kTagSize: return "tag_size";
    case CameraScale::Source::kFloorReference: return "floor_reference";
  }
  return "none";
}

vision::EdgeShiftEstimate MeasureTagEdgeShift(const std::vector<const vision::FrameObservation*>& frames,
                                              const vision::TagSpec& tag, const vision::CameraModel& lens,
                                              int max_frames) {
  vision::EdgeShiftEstimate none;
  const Result<vision::TagCells> cells = vision::TagCells::Of(tag.family, tag.id);
  if (!cells) {
    none.message = cells.message;
    return none;
  }
  std::vector<vision::EdgeShiftResult> measured;
  if (max_frames > 0 && !frames.empty()) {
    const size_t stride = std::max<size_t>(1, frames.size() / static_cast<size_t>(max_frames));
    for (size_t i = 0; i < frames.size(); i += stride) {
      const vision::FrameObservation& f = *frames[i];
      if (f.crop.empty()) continue;
      const auto refined = vision::RefineObservationExactly(f, lens);
      if (refined) measured.push_back(vision::MeasureEdgeShift(f.crop, *refined, *cells, &lens, {}, f.crop_origin));
    }
  }
  if (measured.empty()) {
    none.message = "no frame with a kept crop to measure the edge shift in";
    return none;
  }
  return vision::PoolEdgeShifts(measured);
}

std::vector<vision::TagCorners> PickPlaneViews(const std::vector<vision::TagCorners>& candidates,
                                               double separation_px, int max_views) {
  std::vector<vision::TagCorners> views;
  cv::Point2d last(-1e9, -1e9);
  for (const vision::TagCorners& c : candidates) {
    const cv::Point2d centre = (c[0] + c[1] + c[2] + c[3]) * 0.25;
    if (cv::norm(centre - last) < separation_px) continue;
    last = centre;
    views.push_back(c);
  }
  if (static_cast<int>(views.size()) <= max_views) return views;
  std::vector<vision::TagCorners> thinned;
  for (int i = 0; i < max_views; ++i)
    thinned.push_back(views[static_cast<size_t>(i) * views.size() / max_views]);
  return thinned;
}

CameraPlaneOrGuess EstimateCameraPlaneOrGuess(const vision::Intrinsics& intrinsics, const vision::TagSpec& tag,
                                              const std::vector<vision::TagCorners>& views,
                                              const vision::CameraMount& guess,
                                              const vision::CameraPlaneOptions& options,
                                              const std::vector<vision::CornerVelocities>* velocities) {
  CameraPlaneOrGuess fit;
  fit.mount = guess;
  if (static_cast<int>(views.size()) < options.min_views) {
    fit.plane.message = Format("need at least %d views of the tag, got %zu", options.min_views, views.size());
    return fit;
  }
  fit.plane = vision::EstimateCameraOverTagPlane(intrinsics, tag, views, guess, options, velocities);
  if (fit.plane.ok()) fit.mount = fit.plane.mount;
  return fit;
}

vision::CameraMount LevelMountFromTagSize(const vision::Intrinsics& intrinsics, const vision::TagSpec& tag,
                                          double side_px) {
  const double f = 0.5 * (intrinsics.fx + intrinsics.fy);
  vision::CameraMount level;
  level.height_mm = tag.height_mm + f * tag.size_mm / side_px;
  return level;
}

// Whether two observations give a refinement the same input: the same crop
// pixels at the same place, the same starting corners and cell count.
bool SameRefinementInput(const vision::FrameObservation& a, const vision::FrameObservation& b) {
  if (a.crop_origin != b.crop_origin || a.width_at_border != b.width_at_border || !a.corners_px ||
      !b.corners_px || *a.corners_px != *b.corners_px || a.crop.size() != b.crop.size() ||
      a.crop.type() != b.crop.type())
    return false;
  const size_t row_bytes = a.crop.cols * a.crop.elemSize();
  for (int y = 0; y < a.crop.rows; ++y)
    if (std::memcmp(a.crop.ptr(y), b.crop.ptr(y), row_bytes) != 0) return false;
  return true;
}

namespace {

// A refined frame's quality, to quality.per_frame (its flags counted in
// `reasons`): its corners when the gate raises no flag.
std::optional<vision::TagCorners> GateFrame(const vision::ModelFreeRefineResult& r, double t_s,
                                            const vision::QualityGate& gate,
                                            std::map<vision::ObservationFlag, int>& reasons, RestQuality& quality) {
  FrameQuality fq;
  fq.t_s = t_s;
  fq.fitted = r.ok();
  fq.quality = r.quality;
  fq.flags = r.ok() ? vision::QualityFlags(r.quality, gate)
                    : std::vector<vision::ObservationFlag>{vision::ObservationFlag::kEdgesNotFitted};
  for (const vision::ObservationFlag reason : fq.flags) ++reasons[reason];
  std::optional<vision::TagCorners> corners;
  if (fq.flags.empty()) corners = r.corners_px;
  quality.per_frame.push_back(std::move(fq));
  return corners;
}

// The rest's quality: frames tried and usable, the median fitted frame, and
// the frames' reasons when most were unusable.
void SummariseRestQuality(int tried, int usable, const std::map<vision::ObservationFlag, int>& reasons,
                          RestQuality& quality) {
  quality.frames = tried;
  quality.usable = usable;
  std::vector<vision::TagImageQuality> fitted;
  for (const FrameQuality& fq : quality.per_frame)
    if (fq.fitted) fitted.push_back(fq.quality);
  if (!fitted.empty()) {
    auto median = [&](auto member) {
      std::vector<double> v;
      for (const auto& q : fitted) v.push_back(q.*member);
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      return v[v.size() / 2];
    };
    vision::TagImageQuality& m = quality.median;
    m.side_px = median(&vision::TagImageQuality::side_px);
    m.cell_px = median(&vision::TagImageQuality::cell_px);
    m.contrast_grey = median(&vision::TagImageQuality::contrast_grey);
    m.blur_sigma_px = median(&vision::TagImageQuality::blur_sigma_px);
    m.gamma = median(&vision::TagImageQuality::gamma);
    for (const auto& q : fitted) {
      m.saturated_fraction = std::max(m.saturated_fraction, q.saturated_fraction);
      m.rms_residual_grey = std::max(m.rms_residual_grey, q.rms_residual_grey);
      m.relative_residual = std::max(m.relative_residual, q.relative_residual);
    }
  }
  if (tried > 0 && 2 * quality.usable < tried)
    for (const auto& [reason, count] : reasons) quality.flags.push_back(reason);
}

}  // namespace

std::optional<calibration::RestWindow> MeasureRestExactly(
    const std::vector<vision::FrameObservation>& frames, double t_begin_s, double t_end_s,
    const vision::CameraModel& camera, const vision::TagSpec& tag, RestQuality* quality,
    const vision::QualityGate& gate) {
  std::vector<calibration::PoseSample> samples;
  std::vector<std::array<Eigen::Vector2d, 4>> closures;
  int tried = 0;
  std::map<vision::ObservationFlag, int> reasons;
  // A still scene through a codec often decodes to the same image frame
  // after frame, and the same input gives the same fit: the previous
  // frame's, when its crop, place and starting corners are this frame's to
  // the bit.
  const vision::FrameObservation* previous = nullptr;
  vision::ModelFreeRefineResult previous_fit;
  std::optional<vision::TagCorners> previous_corners;
  for (const vision::FrameObservation& f : frames) {
    if (f.t_s < t_begin_s - 1e-9 || f.t_s > t_end_s + 1e-9 || !f.corners_px) continue;
    ++tried;
    std::optional<vision::TagCorners> corners;
    const bool repeated = previous != nullptr && SameRefinementInput(*previous, f);
    if (!repeated) previous = &f;
    if (quality) {
      if (f.crop.empty()) continue;
      if (!repeated)
        previous_fit = vision::RefineTagCornersModelFree(f.crop, *f.corners_px, &camera,
                                                         vision::RefineOptionsFor(f), f.crop_origin);
      corners = GateFrame(previous_fit, f.t_s, gate, reasons, *quality);
    } else {
      if (!repeated) previous_corners = vision::RefineObservationExactly(f, camera);
      corners = previous_corners;
    }
    if (!corners) continue;
    const vision::PlanarPoseResult pose = vision::MeasureTagPose(camera, tag, *corners);
    if (!pose.ok()) continue;
    samples.push_back({f.t_s, pose.T_world_robot, true});
    closures.push_back(pose.closure_mm);
  }
  if (quality) SummariseRestQuality(tried, static_cast<int>(samples.size()), reasons, *quality);
  if (tried == 0 || 2 * static_cast<int>(samples.size()) < tried) return std::nullopt;
  std::optional<calibration::RestWindow> rest = calibration::SummarizeRest(samples);
  if (!rest) return rest;
  // What the frames share, their spread cannot show: add it (a codec's
  // repeated image is otherwise stated at the systematic floor, 10-50x too
  // small; docs/vision.md).
  const vision::RestCornerError shared = vision::EstimateRestCornerError(closures, tag, rest->mean.heading());
  rest->covariance += shared.shared_covariance;
  if (quality) {
    quality->shared_error_mm = shared.sigma_shared_mm;
    quality->independent_error_mm = shared.sigma_independent_mm;
  }
  return rest;
}

bool MeasureOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!track.IsValid(why) || !plane.IsValid(why) || !rest.IsValid(why) || !pose_log.IsValid(why) ||
      !quality_gate.IsValid(why))
    return false;
  if (max_plane_views < 1) return fail("max_plane_views must be at least 1");
  if (!(min_view_separation_px >= 0.0)) return fail("min_view_separation_px must not be negative");
  if (!(border_margin_px >= 0.0)) return fail("border_margin_px must not be negative");
  if (!(systematic_floor.position_m >= 0.0) || !(systematic_floor.heading_rad >= 0.0))
    return fail("systematic_floor must not be negative");
  if (!(systematic_scale_sigma >= 0.0)) return fail("systematic_scale_sigma must not be negative");
  if (!(tag_print_sigma >= 0.0)) return fail("tag_print_sigma must not be negative");
  if (floor_frames_per_video < 1) return fail("floor_frames_per_video must be at least 1");
  if (floor_max_videos < 1) return fail("floor_max_videos must be at least 1");
  if (!(rest_search_fraction > 0.0 && rest_search_fraction <= 1.0))
    return fail("rest_search_fraction must be in (0, 1]");
  if (!(flag_gap_s > 0.0)) return fail("flag_gap_s must be positive");
  return true;
}

bool IsFatalFlag(const std::string& flag) {
  const std::optional<calibration::RunFlag> parsed = calibration::ParseRunFlag(flag);
  return parsed && parsed->fatal();
}

const calibration::RelativePose* UsableReturnError(const calibration::MeasuredRun& run) {
  if (!run.return_error || calibration::AnyFatal(run.flags)) return nullptr;
  return &*run.return_error;
}

std::optional<calibration::FloorCamera> FloorCameraOf(const SessionMeasurement& sm) {
  const config::Session& session = sm.session;
  if (!session.has_camera) return std::nullopt;  // pose logs alone
  // The lens candidate perturbs plumb_bob's k1; a fisheye's theta polynomial
  // is another model, so its sessions are explained without that candidate.
  if (session.intrinsics.lens != vision::LensModel::kPlumbBob) return std::nullopt;
  const vision::CameraMount mount = sm.plane_estimated ? sm.plane.mount : session.camera_mount_guess;
  const vision::CameraModel camera(session.intrinsics, mount);
  calibration::FloorCamera floor;
  floor.centre_m = camera.T_world_camera().translation() -
                   Eigen::Vector3d(0.0, 0.0, session.tag.height_m());
  floor.R_camera_world = camera.T_camera_world().rotation();
  floor.distortion = session.intrinsics.distortion;
  if (!floor.IsValid()) return std::nullopt;
  return floor;
}

calibration::MeasuredSession SessionMeasurement::ToMeasuredSession() const {
  calibration::MeasuredSession s;
  s.believed = session.nominal;
  for (const RunMeasurement& r : runs) s.runs.push_back(r.measured);
  s.camera_scale_sigma = camera_scale_sigma;
  // One frame's noise, from the frames at rest about their window's mean
  // (a pose log's tracker states its own noise: pose_log.h).
  std::vector<const calibration::MeasuredRun*> video_runs;
  for (size_t i = 0; i < s.runs.size(); ++i)
    if (!runs[i].pose_log) video_runs.push_back(&s.runs[i]);
  const calibration::RestScatter scatter = calibration::PooledRestScatter(video_runs);
  if (scatter.dof > 0) {
    const double sigma_p = scatter.sigma_position_m, sigma_h = scatter.sigma_heading_rad;
    for (size_t i = 0; i < s.runs.size(); ++i)
      for (calibration::CameraRecord& c : s.runs[i].camera)
        if (c.valid && !runs[i].pose_log) {
          c.sigma_position_m = sigma_p;
          c.sigma_heading_rad = sigma_h;
        }
  }
  return s;
}

namespace {

// MeasureSessions' steps. The runs whose video is decoded, one job each;
// runs sharing one video share its track.
struct Job {
  size_t session;
  size_t run;
};
struct TrackingPlan {
  std::vector<Job> jobs;
  std::vector<std::pair<Job, Job>> shared_tracks;  // (run, the run whose track it shares)
  long expected_frames = 0;
};

// Every session's runs laid out in `out`, pose-log runs sharing one log
// found in it (segment_runs.h), and the videos to decode.
Status PlanTracking(const std::vector<config::Session>& sessions, const MeasureOptions& options,
                    std::vector<SessionMeasurement>* measurements, TrackingPlan* plan) {
  std::vector<SessionMeasurement>& out = *measurements;
  std::vector<Job>& jobs = plan->jobs;
  std::vector<std::pair<Job, Job>>& shared_tracks = plan->shared_tracks;
  long& expected_frames = plan->expected_frames;
  for (size_t s = 0; s < sessions.size(); ++s) {
    out[s].session = sessions[s];
    // Pose-log runs sharing one log: found in it (segment_runs.h).
    if (const Status spans = AssignPoseLogSpans(&out[s].session, options.pose_log.rest, &out[s].segments); !spans)
      return spans;
    out[s].runs.resize(out[s].session.runs.size());
    std::map<std::pair<std::string, std::string>, size_t> tracked;  // (video, timestamps) -> run
    for (size_t r = 0; r < out[s].session.runs.size(); ++r) {
      const config::SessionRun& run = out[s].session.runs[r];
      out[s].runs[r].run = run;
      if (!run.poses.empty()) continue;  // no video to decode
      const auto key = std::make_pair(run.video, run.timestamps);
      if (const auto it = tracked.find(key); it != tracked.end()) {
        shared_tracks.push_back({{s, r}, {s, it->second}});
        continue;
      }
      tracked[key] = r;
      jobs.push_back({s, r});
      if (std::isfinite(run.end_s)) expected_frames += static_cast<long>((run.end_s - run.start_s) * 30.0) + 1;
    }
  }
  return Status::Ok();
}

// Every video decoded and its tag tracked, in parallel (phase 1).
void TrackVideos(const std::vector<config::Session>& sessions, const TrackingPlan& plan, const MeasureOptions& options,
                 const ProgressFn& progress, std::vector<SessionMeasurement>* measurements) {
  std::vector<SessionMeasurement>& out = *measurements;
  const std::vector<Job>& jobs = plan.jobs;
  const long expected_frames = plan.expected_frames;
  std::atomic<long> frames_done{0};
  ParallelFor(jobs.size(), static_cast<unsigned>(std::max(0, options.threads)), [&](size_t j) {
    const config::Session& session = sessions[jobs[j].session];
    RunMeasurement& rm = out[jobs[j].session].runs[jobs[j].run];
    std::vector<double> stamps;
    if (!rm.run.timestamps.empty()) {
      const auto read = media::ReadTimestamps(rm.run.timestamps);
      if (read) {
        stamps = *read;
      } else {
        rm.measured.flags.push_back(RunFlag::Of(RunFlagKind::kTimestampsUnreadable));
      }
    }
    rm.track = TrackTagInVideo(rm.run.video, stamps, session.tag, session.intrinsics, options.track,
                               [&](int) {
                                 const long done = ++frames_done;
                                 if (progress && done % 10 == 0) progress(done, expected_frames);
                               });
  });
  if (progress) progress(frames_done, frames_done);
  for (const auto& [to, from] : plan.shared_tracks)
    out[to.session].runs[to.run].track = out[from.session].runs[from.run].track;
}

// The session's pose-log runs (a bad log is an error, not a flag); whether
// it has video runs too.
Status MeasurePoseLogRuns(const MeasureOptions& options, SessionMeasurement* session_measurement, bool* any_video_run) {
  SessionMeasurement& sm = *session_measurement;
  // Pose-log runs first: a bad log is an error, not a flag.
  std::vector<calibration::MeasuredRun*> pose_runs;
  bool& any_video = *any_video_run;
  any_video = false;
  for (RunMeasurement& rm : sm.runs) {
    if (rm.run.poses.empty()) {
      any_video = true;
      continue;
    }
    rm.pose_log.emplace();
    if (const Status measured = MeasurePoseLogRun(rm.run, sm.session.tracker, sm.session.nominal, options.pose_log,
                                                  &rm.measured, &*rm.pose_log);
        !measured)
      return measured;
    pose_runs.push_back(&rm.measured);
  }
  if (!pose_runs.empty()) FinishPoseLogRuns(options.pose_log, pose_runs);
  return Status::Ok();
}

// The camera over the session's tag plane: its views' plane (or the
// operator's guess) and its scale (the tag's size, the floor reference).
vision::CameraModel SessionCamera(const MeasureOptions& options, SessionMeasurement* session_measurement) {
  SessionMeasurement& sm = *session_measurement;
  const vision::CameraModel lens_only(sm.session.intrinsics, sm.session.camera_mount_guess);
  std::vector<vision::CornerVelocities> velocities;
  const std::vector<vision::TagCorners> views =
      PickViews(sm.runs, options.min_view_separation_px, options.max_plane_views, lens_only, options.border_margin_px,
                options.exact_plane_refinement, &velocities, sm.session.tag, options.edge_shift_views, &sm.edge_shift);
  const CameraPlaneOrGuess fit = EstimateCameraPlaneOrGuess(sm.session.intrinsics, sm.session.tag, views,
                                                            sm.session.camera_mount_guess, options.plane, &velocities);
  vision::CameraMount mount = fit.mount;
  sm.plane = fit.plane;
  sm.plane_estimated = fit.estimated();
  if (!sm.plane_estimated) sm.flags.push_back(SessionFlag::kCameraPlaneNotEstimated);
  {
    const config::Session& session = sm.session;
    const std::vector<cv::Mat> floor_frames =
        session.floor_reference ? FloorFrames(sm, options) : std::vector<cv::Mat>{};
    sm.camera_scale = EstimateCameraScale(
        session.intrinsics, session.tag, session.tag_size_sigma_mm, sm.plane_estimated ? &sm.plane : nullptr,
        session.floor_reference ? &*session.floor_reference : nullptr, floor_frames,
        {options.systematic_scale_sigma, options.tag_print_sigma, options.quality_gate}, &mount, &sm.flags,
        sm.edge_shift.ok() ? &sm.edge_shift : nullptr);
  }
  sm.camera_scale_sigma = sm.camera_scale.relative_sigma;
  return vision::CameraModel(sm.session.intrinsics, mount);
}

// Video runs sharing one video with no spans of their own: found in it (a
// lone `procedure: auto` run: every run it holds).
Status FindRunsInSharedVideos(const vision::CameraModel& camera, const MeasureOptions& options,
                              SessionMeasurement* session_measurement) {
  SessionMeasurement& sm = *session_measurement;
  std::map<std::string, std::vector<size_t>> groups;
  std::vector<std::string> order;
  for (size_t i = 0; i < sm.runs.size(); ++i) {
    if (sm.runs[i].pose_log) continue;
    if (!groups.count(sm.runs[i].run.video)) order.push_back(sm.runs[i].run.video);
    groups[sm.runs[i].run.video].push_back(i);
  }
  std::map<size_t, std::vector<config::SessionRun>> expanded;  // run index -> its runs
  for (const std::string& video : order) {
    const std::vector<size_t>& group = groups[video];
    std::vector<config::SessionRun*> runs;
    for (size_t i : group) runs.push_back(&sm.runs[i].run);
    const bool lone_auto = IsLoneAutoRun(runs);
    if ((group.size() < 2 && !lone_auto) || !sm.runs[group.front()].track.ok()) continue;
    std::vector<calibration::PoseSample> samples;
    for (const vision::FrameObservation& f : sm.runs[group.front()].track.frames) {
      const auto pose = FramePose(camera, sm.session.tag, f, options.border_margin_px);
      samples.push_back({f.t_s, pose.value_or(calibration::Pose2()), pose.has_value()});
    }
    const Status assigned =
        lone_auto ? ExpandAutoRun(*runs.front(), video, samples, options.rest, &expanded[group.front()], &sm.segments)
                  : AssignSpansFromRecording(video, samples, runs, options.rest, &sm.segments);
    if (!assigned) return assigned;
  }
  if (!expanded.empty()) {
    std::vector<RunMeasurement> all;
    for (size_t i = 0; i < sm.runs.size(); ++i) {
      const auto it = expanded.find(i);
      if (it == expanded.end()) {
        all.push_back(std::move(sm.runs[i]));
        continue;
      }
      for (const config::SessionRun& run : it->second) {
        RunMeasurement copy = sm.runs[i];
        copy.run = run;
        all.push_back(std::move(copy));
      }
    }
    sm.runs = std::move(all);
    sm.session.runs.clear();
    for (const RunMeasurement& rm : sm.runs) sm.session.runs.push_back(rm.run);
  }
  return Status::Ok();
}

// One video run's frames as poses on the floor, its flags, its rests and
// return error.
void MeasureVideoRun(const vision::CameraModel& camera, const MeasureOptions& options, const config::Session& session,
                     RunMeasurement* run_measurement) {
  RunMeasurement& rm = *run_measurement;
  calibration::MeasuredRun& m = rm.measured;
  m.name = rm.run.name;
  m.spec = rm.run.spec;
  m.telemetry = ReadTelemetry(rm.run.telemetry, session.nominal, &m.flags);
  if (!rm.track.ok()) {
    m.flags.push_back(RunFlag::Of(RunFlagKind::kVideoUnreadable, rm.track.message));
    return;
  }
  if (rm.track.duplicate_frames > 0) {
    m.flags.push_back(
        RunFlag::Of(RunFlagKind::kDuplicateTagId, "id " + std::to_string(session.tag.id) + " seen twice in " +
                                                      std::to_string(rm.track.duplicate_frames) + " frames"));
  }
  if (rm.track.found == 0) {
    if (rm.track.duplicate_frames == 0) {
      m.flags.push_back(
          rm.track.wrong_id_frames > 0
              ? RunFlag::Of(RunFlagKind::kWrongTagId, "tags seen, never id " + std::to_string(session.tag.id))
              : RunFlag::Of(RunFlagKind::kTagNeverSeen));
    }
    return;
  }
  for (const vision::FrameObservation& f : rm.track.frames) {
    // The run's span of its video (a video may hold several runs).
    if (f.t_s < rm.run.start_s - 1e-6 || f.t_s > rm.run.end_s + 1e-6) continue;
    calibration::CameraRecord c;
    c.t_s = f.t_s;
    const auto pose = FramePose(camera, session.tag, f, options.border_margin_px);
    c.valid = pose.has_value();
    if (pose) {
      c.T_world_robot = *pose;
      // The tag centre's image row, v / (H - 1), for the rolling_shutter candidate.
      const vision::TagCorners& q = *f.corners_px;
      c.image_row_fraction = (q[0].y + q[1].y + q[2].y + q[3].y) / 4.0 / (session.intrinsics.height - 1);
    }
    m.camera.push_back(c);
  }
  if (rm.track.duplicate_frames > 0) return;
  MeasureRestsAndReturnError(options, camera, session.tag, &rm);
}

}  // namespace

Result<std::vector<SessionMeasurement>> MeasureSessions(const std::vector<config::Session>& sessions,
                                                        const MeasureOptions& options, const ProgressFn& progress) {
  using Measured = Result<std::vector<SessionMeasurement>>;
  std::string why;
  if (!options.IsValid(&why)) return Measured::Error(StatusCode::kInvalidArgument, "measure options: " + why);
  std::vector<SessionMeasurement> out(sessions.size());
  // Phase 1: every run of every session, in parallel.
  TrackingPlan plan;
  if (const Status planned = PlanTracking(sessions, options, &out, &plan); !planned.ok())
    return Measured::Error(planned.status, planned.message);
  TrackVideos(sessions, plan, options, progress, &out);
  // Phase 2, per session: the plane, the poses, the rests.
  for (SessionMeasurement& sm : out) {
    bool any_video = false;
    if (const Status poses = MeasurePoseLogRuns(options, &sm, &any_video); !poses.ok())
      return Measured::Error(poses.status, poses.message);
    if (!any_video) continue;
    const vision::CameraModel camera = SessionCamera(options, &sm);
    if (const Status found = FindRunsInSharedVideos(camera, options, &sm); !found.ok())
      return Measured::Error(found.status, found.message);
    for (RunMeasurement& rm : sm.runs)
      if (!rm.pose_log) MeasureVideoRun(camera, options, sm.session, &rm);
  }
  return Measured::Ok(std::move(out));
}

}  // namespace odocal::measure
