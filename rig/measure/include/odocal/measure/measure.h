// Measuring recorded sessions: videos -> the tag in every frame -> the
// camera's plane over the tag -> planar robot poses -> rests -> each run's
// return error with its uncertainty and quality flags.
//
// Return errors are the robot's end pose in its start frame (x along the
// start heading, y left, theta CCW), from the rest before the run to the rest
// after it; for closed paths this is true - odometry (docs/conventions.md).
#ifndef ODOCAL_MEASURE_MEASURE_H_
#define ODOCAL_MEASURE_MEASURE_H_

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "odocal/base/format.h"
#include "odocal/base/status.h"
#include "odocal/calibration/measured_session.h"
#include "odocal/calibration/rest.h"
#include "odocal/config/session.h"
#include "odocal/measure/pose_log.h"
#include "odocal/measure/segment_runs.h"
#include "odocal/measure/video_track.h"
#include "odocal/vision/edge_quality.h"
#include "odocal/vision/edge_shift.h"
#include "odocal/vision/floor_reference.h"
#include "odocal/vision/planar_pose.h"

namespace odocal::measure {

struct MeasureOptions {
  vision::VideoTrackOptions track;
  vision::CameraPlaneOptions plane;
  // Views used for the plane estimate: distinct positions, evenly spread.
  int max_plane_views = 300;
  double min_view_separation_px = 8.0;
  // A frame whose tag (with its white quiet zone, one cell wide) comes within
  // this many pixels of the image border is not measured: half-visible tags
  // at the border gave poses 2 mm off.
  double border_margin_px = 2.0;
  // Refine the plane's views with the exact edge model (the camera's height,
  // hence every measured distance, depends on the tag's apparent size).
  bool exact_plane_refinement = true;
  // Measure the tag's edge shift (vision/edge_shift.h: a tone curve, blur or
  // ink that makes the black look larger or smaller) in every (n / this)-th
  // of the plane's n views, ~0.1 s each, and remove it from every view;
  // 0 = off.
  int edge_shift_views = 16;
  calibration::RestOptions rest;
  // Refine the frames of each start and end rest with the exact edge model
  // before averaging them.
  bool exact_rest_refinement = true;
  // ... by the edge model that assumes neither the PSF nor a power-law tone
  // curve (vision/edge_quality.h), which also reports each frame's image
  // quality; false: the Gaussian edge model of the renderer.
  bool model_free_rest_refinement = true;
  // When a rest frame's image cannot support the stated sigma (overexposed,
  // low contrast, defocused, an edge that is not straight). A rest keeps its
  // number only when at least half its frames pass; otherwise the run gets a
  // fatal image_quality flag and no return error.
  vision::QualityGate quality_gate;
  // Floors on a return error's sigma: what the spread of rest frames cannot
  // see (compression artefacts shared by the frames of a rest, detector
  // bias), measured on rendered truth at CRF 12 (docs/vision.md).
  calibration::SystematicFloor systematic_floor;
  // The camera's length scale beyond the plane estimate's own sigma: the
  // tag's apparent size, hence the camera height and every distance, came
  // out 3.0e-4 small on the rendered 720p explain plan (a 30 px tag) with
  // the exact refinement, 8.3e-4 without. Add the tag's print tolerance for
  // a real tag.
  double systematic_scale_sigma = 4e-4;
  // A tag's printed size is known to this relative 1-sigma unless the
  // session states `tag.size_sigma_mm` (measured with a caliper): office
  // printers scale by a few tenths of a percent, "fit to page" by several.
  // It is the dominant term of Es's uncertainty without a floor reference.
  double tag_print_sigma = 3e-3;
  // With a floor reference: the first frames of each video (at most
  // floor_max_videos of them) in which the floor tags are measured.
  int floor_frames_per_video = 8;
  int floor_max_videos = 3;
  // A start (end) rest must begin (end) within this fraction of the run's
  // span from its start (end).
  double rest_search_fraction = 0.35;
  // Gaps longer than this while the robot moves are flagged.
  double flag_gap_s = 0.5;
  int threads = 0;  // 0 (or negative): one per core
  // Runs measured from a pose log instead of a video (pose_log.h).
  PoseLogOptions pose_log;

  // False with `why` naming the offending option (the nested options' own
  // checks included).
  bool IsValid(std::string* why) const;
};

// Whether a flag's text form names a kind that leaves a run without a
// return error (calibration/run_flag.h).
bool IsFatalFlag(const std::string& flag);

// The run's return error when it has one and no fatal flag (what report.json
// prints and the estimators pool); nullptr otherwise.
const calibration::RelativePose* UsableReturnError(const calibration::MeasuredRun& run);

// The image quality of one refined rest frame, and of a rest:
// what the user reads to judge the camera (report.json "quality").
struct FrameQuality {
  double t_s = 0.0;
  bool fitted = false;  // false: the edges could not be fitted at all
  vision::TagImageQuality quality;
  std::vector<vision::ObservationFlag> flags;  // QualityFlags; empty = usable
};
struct RestQuality {
  int frames = 0, usable = 0;
  // Medians over the fitted frames (saturation and residual: the worst).
  vision::TagImageQuality median;
  // The rest's image error from the corners' closure (vision::
  // EstimateRestCornerError), per corner coordinate in mm: the part its
  // frames share (a still scene through a codec repeats one image) and each
  // frame's own. The shared part is in the rest's covariance.
  double shared_error_mm = 0.0;
  double independent_error_mm = 0.0;
  std::vector<vision::ObservationFlag> flags;  // the reasons, when fewer than half are usable
  std::vector<FrameQuality> per_frame;
};

struct RunMeasurement {
  config::SessionRun run;
  VideoTrack track;  // video runs
  std::optional<PoseLogStats> pose_log;  // pose-log runs
  calibration::MeasuredRun measured;
  std::optional<RestQuality> start_quality, end_quality;  // with model_free_rest_refinement
};

// What is wrong with a session as a whole (report.json's session "flags"),
// each with a stable text (ToString); nothing matches that text.
enum class SessionFlag {
  kCameraPlaneNotEstimated,     // "camera_plane_not_estimated:using_operator_guess"
  kFloorReferenceUnusable,      // "floor_reference_unusable": the robot tag's print sets the scale
  kFloorReferenceInconsistent,  // "floor_reference_inconsistent": its distances disagree beyond their sigmas
};
const char* ToString(SessionFlag flag);
using odocal::ToStrings;  // base/format.h: each flag's ToString

// Where the camera's length scale comes from, and how well it is known:
// what Es's uncertainty rests on (report.json "camera_scale").
struct CameraScale {
  enum class Source { kNone, kTagSize, kFloorReference };
  Source source = Source::kNone;
  double relative_sigma = 0.0;  // of every measured distance
  double camera_height_mm = 0.0;  // above the floor, as used
  double sigma_camera_height_mm = 0.0;
  // The plain reason, for the report ("from the robot tag's printed size:
  // ±0.30 % print tolerance (assumed) ...").
  std::string explanation;
  // With a floor reference: its tags, its estimate, and the robot tag's
  // printed size it implies (the tag-size height over the reference's, above
  // the tag plane; 1.0042 = "prints 0.42 % large").
  std::vector<vision::FloorTagSighting> floor_tags;
  std::optional<vision::FloorScaleResult> floor;
  std::optional<double> tag_print_scale, tag_print_scale_sigma;
  bool with_floor_reference = false;  // one was given (used or not)
  // The tag's edge shift measured in the plane's views and removed from them
  // before the plane was fitted (vision/edge_shift.h); its sigma is in
  // relative_sigma. Not ok when it was not measured.
  vision::EdgeShiftEstimate edge_shift;
};
std::string_view ToString(CameraScale::Source source);

// What the camera's scale rests on besides the images (MeasureOptions' terms
// of the same names; the station's).
struct CameraScaleOptions {
  double systematic_scale_sigma = 4e-4;
  double tag_print_sigma = 3e-3;
  vision::QualityGate quality_gate;  // for the floor tags
};

// The camera's length scale, shared by batch and the station: from the floor
// reference when `reference` is given and could be measured in
// `floor_frames` (grey, CV_8UC1; `mount`'s height is then set to the
// reference's and the robot tag's print scale is reported), else from the
// robot tag's printed size (`mount` untouched; the explanation says why the
// reference could not be used). `plane` is the plane estimate `mount` came
// from, null when `mount` is the operator's guess (no tilt sigmas: the
// reference is then not used). Appends floor_reference_unusable or
// floor_reference_inconsistent to `flags` (may be null).
CameraScale EstimateCameraScale(const vision::Intrinsics& intrinsics, const vision::TagSpec& tag,
                                std::optional<double> tag_size_sigma_mm, const vision::CameraPlaneResult* plane,
                                const vision::FloorReference* reference, const std::vector<cv::Mat>& floor_frames,
                                const CameraScaleOptions& options, vision::CameraMount* mount,
                                std::vector<SessionFlag>* flags, const vision::EdgeShiftEstimate* edge_shift = nullptr);

struct SessionMeasurement {
  config::Session session;
  vision::CameraPlaneResult plane;
  bool plane_estimated = false;
  // Relative 1-sigma of every measured distance: camera_scale's.
  double camera_scale_sigma = 0.0;
  CameraScale camera_scale;
  vision::EdgeShiftEstimate edge_shift;  // in the plane's views (camera_scale.edge_shift when used)
  std::vector<RunMeasurement> runs;
  std::vector<SessionFlag> flags;  // session-wide
  // Runs found in a shared recording (segment_runs.h): what each was matched to.
  std::vector<SegmentAssignment> segments;

  // The session as estimators see it. Each valid frame states the noise of
  // one frame's pose: the scatter of the per-frame poses about their rest
  // means, pooled over every rest of the session (frames in motion are
  // blurred and scatter more; the trajectory fit scales its covariance by
  // the reduced chi-square when they do). Zero when no rest was seen.
  // Pose-log runs keep the sigma their own rests gave (pose_log.h).
  calibration::MeasuredSession ToMeasuredSession() const;
};

// The camera's geometry over the tag plane, as the lens candidate of the
// trajectory model needs it (calibration/floor_camera.h): the camera pose the
// plane estimate found in the videos (the session's mount guess without one)
// and the session's calibrated lens. nullopt when that is not a camera looking
// down at the plane, or when the lens is not plumb_bob (the candidate perturbs
// its k1). Shared by explain and check, so both model the same lens.
std::optional<calibration::FloorCamera> FloorCameraOf(const SessionMeasurement& measurement);

// Progress: called with (frames done, frames expected) from worker threads.
using ProgressFn = std::function<void(long, long)>;

// Measures every session's runs (videos in parallel across cores; pose logs
// by pose_log.h). Fails for bad options (kInvalidArgument) and for a
// malformed pose log or its telemetry (kBadFile, the message names the file);
// bad videos become flags.
Result<std::vector<SessionMeasurement>> MeasureSessions(const std::vector<config::Session>& sessions,
                                                        const MeasureOptions& options,
                                                        const ProgressFn& progress);

// Pieces of the measurement shared with the live station (station.h):
// Views for the plane estimate from candidate corners in time order: each new
// one at least `separation_px` from the last kept, then evenly thinned to
// `max_views`.
std::vector<vision::TagCorners> PickPlaneViews(const std::vector<vision::TagCorners>& candidates,
                                               double separation_px, int max_views);
// The camera's mount over the tag plane with the one fallback batch, the
// station, setup-check and watch share: the plane fitted to `views`
// (vision::EstimateCameraOverTagPlane, started from `guess`) when there are
// at least `options.min_views` of them and the fit converges; else `guess`.
struct CameraPlaneOrGuess {
  vision::CameraMount mount;  // the fitted plane's, or the guess
  // The fit; not ok: why (with too few views it was not tried, and says so).
  vision::CameraPlaneResult plane;
  bool estimated() const { return plane.ok(); }
};
CameraPlaneOrGuess EstimateCameraPlaneOrGuess(const vision::Intrinsics& intrinsics, const vision::TagSpec& tag,
                                              const std::vector<vision::TagCorners>& views,
                                              const vision::CameraMount& guess,
                                              const vision::CameraPlaneOptions& options = {},
                                              const std::vector<vision::CornerVelocities>* velocities = nullptr);
// Without an operator's guess: a level camera at the height the tag's
// apparent size implies (f x size / side, plus the tag's height).
vision::CameraMount LevelMountFromTagSize(const vision::Intrinsics& intrinsics, const vision::TagSpec& tag,
                                          double side_px);
// The frames of a rest (those with t_begin_s <= t_s <= t_end_s), each refined
// exactly from its kept crop and measured on the camera's plane, averaged;
// nullopt when fewer than half of them could be.
// With `quality`, the frames are refined by the PSF- and tone-free edge model
// instead, frames failing `gate` are left out, and `quality` says how the
// rest's images were (nullopt is then returned when fewer than half pass).
std::optional<calibration::RestWindow> MeasureRestExactly(
    const std::vector<vision::FrameObservation>& frames, double t_begin_s, double t_end_s,
    const vision::CameraModel& camera, const vision::TagSpec& tag, RestQuality* quality = nullptr,
    const vision::QualityGate& gate = {});
// The tag's edge shift (vision/edge_shift.h) in every (n / `max_frames`)-th
// of the n `frames` (all of them when n < max_frames, else max_frames to
// twice that), each refined exactly from its kept crop first, pooled; not ok
// with the reason when none could be measured. `lens`: the camera's lens
// (its mount does not matter).
vision::EdgeShiftEstimate MeasureTagEdgeShift(const std::vector<const vision::FrameObservation*>& frames,
                                              const vision::TagSpec& tag, const vision::CameraModel& lens,
                                              int max_frames);

}  // namespace odocal::measure

#endif  // ODOCAL_MEASURE_MEASURE_H_
