#include "odocal/station/station.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <sstream>
#include <thread>

#include <opencv2/imgproc.hpp>

#include "odocal/base/format.h"
#include "odocal/base/units.h"
#include "odocal/calibration/corrections.h"
#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/seen_turning.h"
#include "odocal/calibration/segment.h"
#include "odocal/config/scenario.h"
#include "odocal/live/live_state.h"
#include "odocal/measure/measure.h"

namespace odocal::station {
namespace {

using Clock = std::chrono::steady_clock;
using robot_link::ParamSet;
using robot_link::ToParamSet;
using robot_link::ToWheelParams;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// The station's cause of a driver's error (driver.h): the line's codes are the robot
// link's; any other is the cause of the call that failed (`otherwise`).
StationStatus CauseOf(const Status& error, StationStatus otherwise) {
  return IsLinkFailure(error.status) ? StationStatus::kRobotLink : otherwise;
}

// The corners' centre and the farthest any corner is from `reference`.
double MaxCornerDistance(const vision::TagCorners& a, const vision::TagCorners& b) {
  double d = 0.0;
  for (int k = 0; k < 4; ++k) d = std::max(d, std::hypot(a[k].x - b[k].x, a[k].y - b[k].y));
  return d;
}

// The largest deviation from 1 of a CVRA factor, in standard errors that
// include those of `pushed_from` (the round whose estimate the robot now
// runs): the correction it pushed was off by about that much, so a factor
// left that far from 1 is what the push predicts, not an error a further
// push could remove.
std::optional<double> CvraMaxZ(const measure::SessionEstimate& e, const measure::SessionEstimate& pushed_from) {
  std::optional<double> max_z;
  for (auto f : {&measure::SessionEstimate::ratio, &measure::SessionEstimate::scale, &measure::SessionEstimate::track}) {
    const std::optional<measure::PooledCvra>& now = e.*f;
    if (!now || !now->standard_error) continue;
    // The camera's length scale is one error common to both rounds: counted once.
    double se = std::hypot(*now->standard_error, now->camera_scale_sigma);
    if (const std::optional<measure::PooledCvra>& before = pushed_from.*f; before && before->standard_error)
      se = std::hypot(se, *before->standard_error);
    if (se > 0.0) max_z = std::max(max_z.value_or(0.0), std::abs(now->mean - 1.0) / se);
  }
  return max_z;
}

// Camera clock - robot clock for telemetry without arrival times (a
// command's CSV): when the wheels first and last turned, against when the
// camera first saw the tag leave its start and last saw it short of its end
// (each threshold crossing late at the start and early at the end by the
// time the robot takes to move a few pixels: the mean of the two cancels
// that for a symmetric ramp). nullopt when either is missing.
std::optional<double> MotionClockOffset(const std::vector<DriverTelemetry>& tel,
                                        const vision::FrameObservation& start, const vision::FrameObservation& end,
                                        const std::vector<vision::FrameObservation>& moving, double threshold_px = 3.0) {
  std::optional<double> wheels_start, wheels_end;
  for (size_t k = 1; k < tel.size(); ++k) {
    if (tel[k].left_ticks != tel[k - 1].left_ticks || tel[k].right_ticks != tel[k - 1].right_ticks) {
      if (!wheels_start) wheels_start = tel[k - 1].robot_t_s;
      wheels_end = tel[k].robot_t_s;
    }
  }
  std::optional<double> camera_start, camera_end;
  for (const vision::FrameObservation& f : moving) {
    if (!f.corners_px) continue;
    if (!camera_start && MaxCornerDistance(*f.corners_px, *start.corners_px) > threshold_px) camera_start = f.t_s;
    if (MaxCornerDistance(*f.corners_px, *end.corners_px) > threshold_px) camera_end = f.t_s;
  }
  if (!wheels_start || !wheels_end || !camera_start || !camera_end) return std::nullopt;
  return 0.5 * ((*camera_start - *wheels_start) + (*camera_end - *wheels_end));
}

// A line through (steady s since origin, camera s): (intercept, slope), nullopt
// with fewer than two points or all at one time.
std::optional<std::pair<double, double>> FitCameraClock(const std::vector<std::pair<Clock::time_point, double>>& clock,
                                                        Clock::time_point origin) {
  if (clock.size() < 2) return std::nullopt;
  double mx = 0.0, my = 0.0;
  for (const auto& [steady, t] : clock) mx += Seconds(steady - origin), my += t;
  mx /= clock.size(), my /= clock.size();
  double sxx = 0.0, sxy = 0.0;
  for (const auto& [steady, t] : clock) {
    const double x = Seconds(steady - origin) - mx;
    sxx += x * x, sxy += x * (t - my);
  }
  if (!(sxx > 0.0)) return std::nullopt;
  return std::pair{my - sxy / sxx * mx, sxy / sxx};
}

// Each frame's noise: the rests' scatter, pooled (as batch states it);
// without it (no rest of 3 frames), 0.1 mm and 0.06 deg, the order of a
// 40 px tag's per-frame noise (docs/vision.md).
void SetFrameNoise(calibration::MeasuredSession& session) {
  std::vector<const calibration::MeasuredRun*> runs;
  for (const calibration::MeasuredRun& m : session.runs) runs.push_back(&m);
  const calibration::RestScatter scatter = calibration::PooledRestScatter(runs);
  for (calibration::MeasuredRun& m : session.runs)
    for (calibration::CameraRecord& c : m.camera) {
      c.sigma_position_m = scatter.dof > 0 ? scatter.sigma_position_m : 1e-4;
      c.sigma_heading_rad = scatter.dof > 0 ? scatter.sigma_heading_rad : 1e-3;
    }
}

// One pass of the loop. Members hold what the failure handling needs.
class Station {
 public:
  Station(const StationSetup& setup, const StationOptions& options) : setup_(setup), options_(options) {
    if (setup.driver) {
      driver_ = setup.driver;
    } else if (setup.transport) {
      owned_driver_ = MakeLinkDriver(*setup.transport, setup.client);
      driver_ = owned_driver_.get();
    }
  }

  StationResult Run();

 private:
  struct Failure {
    StationStatus status;
    std::string message;
  };
  struct RestFrames {
    std::vector<vision::FrameObservation> found;
    int grabbed = 0;
    int wrong_id = 0;
  };

  // Run's steps, in order (each a failure or nothing).
  std::optional<Failure> CheckInputs(StationResult* result);
  std::optional<Failure> ConnectAndPlan(StationResult* result, RestFrames* rest);
  std::optional<Failure> RunRounds(StationResult* result, RestFrames* rest);
  void LogRound(int round, const StationIteration& iteration) const;
  void Decide(const StationIteration& previous, StationIteration* iteration) const;
  std::optional<Failure> ApplyCorrected(int round, StationIteration* iteration);
  void ExplainFirstRound(StationResult* result);
  std::optional<Failure> ReadFinalParams(StationResult* result);
  StationResult Finish(std::optional<Failure> failure, Clock::time_point t0, StationResult result);

  void Log(const std::string& line) const {
    if (setup_.progress) setup_.progress(line);
  }
  bool StopRequested() const { return setup_.stop_requested && setup_.stop_requested->load(); }

  // With `keep_grey`, the first options_.floor_frames full frames are kept
  // there too (for the floor reference).
  std::optional<Failure> CaptureRest(RestFrames* rest, std::vector<cv::Mat>* keep_grey = nullptr);
  void EstimateScale(vision::CameraMount* mount, const vision::EdgeShiftEstimate* edge_shift);
  // The camera for the heading check and the default plan: the plane's
  // once known, the operator's guess before.
  const vision::CameraModel& WatchCamera() const { return camera_ ? *camera_ : *guess_camera_; }
  std::optional<double> HeadingOf(const vision::TagCorners& corners) const;
  // The live view's share of a frame: the image, the outline, the pose.
  void ShowLive(const media::CameraFrame& frame, const vision::FrameObservation& obs) const;
  void ShowEstimates(const StationIteration& iteration) const;
  std::vector<calibration::RunSpec> MakeDefaultPlan(const RestFrames& rest, std::string* why);
  // Drives one run; its end rest (the next run's start rest) goes to `rest`.
  std::optional<Failure> DriveRun(const calibration::RunSpec& spec, int index, int total, StationRun* run,
                                  RestFrames* rest);
  // DriveRun's steps, and what the camera saw between them.
  struct Recording;
  struct RunWatch {
    std::string what;                  // "run 2/6 (...)"
    vision::TagCorners start_corners;  // where the tag stood: the start rest's last corners
    Recording* recording = nullptr;    // the first round's, for explain
    Clock::time_point t0;
    bool moved = false;
    // Stillness (operator): the frame stillness started at, and its corners.
    std::optional<std::pair<double, vision::TagCorners>> still_since;
    std::vector<calibration::HeadingSighting> sightings;  // judged against the plan at the end
    // Frames the camera should have delivered but the station did not get
    // (a busy machine): gaps between frames beyond its frame interval.
    std::optional<double> fps;
    std::optional<double> last_frame_t;
    // Whether the tag was out of sight for at least three frames in a row and
    // half a second (camera clock): a robot that leaves the view has moved; a
    // frame or two missed tells nothing.
    double last_found_t = 0.0;
    int lost_streak = 0;
    bool out_of_view = false;
  };
  std::optional<Failure> StartRun(const calibration::RunSpec& spec, int index, int total, const RestFrames& rest,
                                  StationRun* run, RunWatch* watch);
  bool SeeMovingFrame(const media::CameraFrame& frame, StationRun* run, RunWatch* watch);
  std::optional<Failure> WatchRun(StationRun* run, RunWatch* watch);
  std::optional<Failure> FinishRun(const calibration::RunSpec& spec, StationRun* run, RunWatch* watch,
                                   RestFrames* rest);
  std::optional<Failure> MeasureRound(StationIteration* iteration,
                                      const std::vector<std::pair<RestFrames, RestFrames>>& rests);
  // MeasureRound's steps.
  void FitCamera(const std::vector<std::pair<RestFrames, RestFrames>>& rests);
  std::optional<Failure> MeasureRests(const std::vector<std::pair<RestFrames, RestFrames>>& rests,
                                      StationIteration* iteration, measure::SessionMeasurement* session) const;
  void Cleanup(StationResult* result);

  const StationSetup& setup_;
  const StationOptions& options_;
  std::unique_ptr<RobotDriver> owned_driver_;
  RobotDriver* driver_ = nullptr;
  std::vector<calibration::RunSpec> plan_;
  int round_ = 0;
  // The first round's frames and telemetry, for explain.
  struct Recording {
    std::vector<vision::FrameObservation> frames;  // corners and times (crops dropped)
    std::vector<DriverTelemetry> telemetry;
    std::vector<std::pair<Clock::time_point, double>> clock;  // (steady, camera t_s) at grabs
  };
  std::vector<Recording> recording_;
  std::optional<calibration::MeasuredSession> recorded_;
  void BuildRecordedSession(const StationIteration& iteration,
                            const std::vector<std::pair<RestFrames, RestFrames>>& rests);
  // BuildRecordedSession's steps, for one run.
  calibration::MeasuredRun RecordedRun(const StationRun& run, const Recording& recording,
                                       const std::pair<RestFrames, RestFrames>& rest, Clock::time_point origin) const;
  std::optional<double> TelemetryClockOffset(const Recording& recording, const std::pair<RestFrames, RestFrames>& rest,
                                             Clock::time_point origin) const;
  std::unique_ptr<vision::TagObserver> observer_;
  std::vector<vision::TagCorners> view_candidates_;
  std::optional<vision::CameraModel> guess_camera_;
  std::optional<vision::CameraModel> camera_;
  bool run_in_progress_ = false;
  ParamSet initial_;
  ParamSet current_;
  bool applied_since_start_ = false;
  vision::CameraPlaneResult plane_;
  bool plane_estimated_ = false;
  std::vector<cv::Mat> floor_frames_;
  std::optional<measure::CameraScale> camera_scale_;
  std::vector<measure::SessionFlag> flags_;
  std::string plan_summary_;
};

// Frames of the robot standing still: the tag's corners, kept with their crops
// for the exact refinement once the camera plane is known.
std::optional<Station::Failure> Station::CaptureRest(RestFrames* rest, std::vector<cv::Mat>* keep_grey) {
  if (options_.settle_s > 0.0)
    std::this_thread::sleep_for(std::chrono::duration<double>(options_.settle_s));
  for (int i = 0; i < options_.rest_flush_frames; ++i) {
    const Result<media::CameraFrame> flushed = setup_.camera->Grab();
    if (!flushed) return Failure{StationStatus::kCameraLost, setup_.camera->Describe() + ": " + flushed.message};
  }
  // Search the first rest frame in full: while the robot was out of view the
  // tracker searches only every few frames.
  observer_->Reset();
  for (int i = 0; i < options_.rest_frames; ++i) {
    const Result<media::CameraFrame> frame = setup_.camera->Grab();
    if (!frame) return Failure{StationStatus::kCameraLost, setup_.camera->Describe() + ": " + frame.message};
    if (frame->grey.cols != setup_.intrinsics.width || frame->grey.rows != setup_.intrinsics.height) {
      return Failure{StationStatus::kInvalidInput,
                     Format("%s delivers %dx%d frames, its calibration is for %dx%d",
                            setup_.camera->Describe().c_str(), frame->grey.cols, frame->grey.rows,
                            setup_.intrinsics.width, setup_.intrinsics.height)};
    }
    ++rest->grabbed;
    if (keep_grey && static_cast<int>(keep_grey->size()) < options_.floor_frames)
      keep_grey->push_back(frame->grey.clone());
    vision::FrameObservation obs = observer_->Observe(frame->grey, frame->t_s);
    ShowLive(*frame, obs);
    rest->wrong_id += obs.status == vision::DetectStatus::kWrongId ? 1 : 0;
    if (obs.corners_px) {
      view_candidates_.push_back(*obs.corners_px);
      rest->found.push_back(std::move(obs));
    }
  }
  return std::nullopt;
}

void Station::ShowLive(const media::CameraFrame& frame, const vision::FrameObservation& obs) const {
  if (!setup_.live) return;
  std::optional<live::LivePose> pose;
  if (obs.corners_px) {
    const vision::PlanarPoseResult p = vision::MeasureTagPose(WatchCamera(), setup_.tag, *obs.corners_px);
    if (p.ok()) {
      pose = live::LivePose{};
      pose->x_mm = p.T_world_robot.x() * kMToMm;
      pose->y_mm = p.T_world_robot.y() * kMToMm;
      pose->heading_deg = RadToDeg(p.T_world_robot.heading());
    }
  }
  setup_.live->OnFrame(frame.grey, frame.t_s, obs.corners_px, pose);
}

void Station::ShowEstimates(const StationIteration& it) const {
  if (!setup_.live) return;
  const calibration::UmbmarkSummary& s = it.estimate;
  if (s.ok()) {
    setup_.live->SetEstimate("E_max,syst", s.emax_syst_m * kMToMm, it.emax_sigma_m.value_or(0.0) * kMToMm, "mm");
    setup_.live->SetEstimate("Ed (UMBMark)", s.coupled.Ed, s.coupled.sigma_Ed.value_or(0.0), "");
    setup_.live->SetEstimate("Eb (UMBMark)", s.coupled.Eb, s.coupled.sigma_Eb.value_or(0.0), "");
  }
  const measure::SessionEstimate& e = it.session_estimate;
  if (e.ratio) setup_.live->SetEstimate("Ed (CVRA)", e.ratio->mean, e.ratio->standard_error.value_or(0.0), "");
  if (e.scale)
    setup_.live->SetEstimate("Es", e.scale->mean,
                             std::hypot(e.scale->standard_error.value_or(0.0), e.scale->camera_scale_sigma), "");
  if (e.track) setup_.live->SetEstimate("track factor", e.track->mean, e.track->standard_error.value_or(0.0), "");
  if (it.turn_slip.slip_per_rad_s)
    setup_.live->SetEstimate("turn slip at 1 rad/s", *it.turn_slip.slip_per_rad_s * 100.0,
                             it.turn_slip.slip_sigma.value_or(0.0) * 100.0, "%");
}

std::optional<double> Station::HeadingOf(const vision::TagCorners& corners) const {
  const vision::PlanarPoseResult pose = vision::MeasureTagPose(WatchCamera(), setup_.tag, corners);
  if (!pose.ok()) return std::nullopt;
  return pose.T_world_robot.heading();
}

std::vector<calibration::RunSpec> Station::MakeDefaultPlan(const RestFrames& rest, std::string* why) {
  const vision::CameraModel& camera = WatchCamera();
  const vision::PlanarPoseResult pose = vision::MeasureTagPose(camera, setup_.tag, *rest.found.back().corners_px);
  if (!pose.ok()) {
    *why = "the default plan: the robot's pose at the start could not be measured (" + pose.message + ")";
    return {};
  }
  const vision::TagCorners& c = *rest.found.back().corners_px;
  const double side_px = std::hypot(c[1].x - c[0].x, c[1].y - c[0].y);
  const double margin = 10.0 + side_px / std::sqrt(2.0);
  auto in_view = [&](const Eigen::Vector2d& p) {
    const auto px = camera.ProjectWorld(Eigen::Vector3d(p.x(), p.y(), setup_.tag.height_m()));
    return px && camera.InImage(*px, margin);
  };
  const calibration::Pose2 T_robot_tag = calibration::Pose2::FromXYHeading(
      setup_.tag.offset_x_mm * kMmToM, setup_.tag.offset_y_mm * kMmToM, 0.0);
  return DefaultPlan(in_view, pose.T_world_robot, T_robot_tag, *setup_.default_plan, why);
}

// DriveRun's steps: the run started, each frame while it drives seen, the
// run finished and judged against the plan.
std::optional<Station::Failure> Station::StartRun(const calibration::RunSpec& spec, int index, int total,
                                                  const RestFrames& rest, StationRun* run, RunWatch* watch) {
  run->spec = spec;
  run->name = config::RunName(index - 1, spec);
  run->run_id = static_cast<uint16_t>(index);
  watch->what = Format("run %d/%d (%s)", index, total, calibration::Describe(spec).c_str());
  RunRequest request{spec, index, total, run->name, "", ""};
  if (!setup_.run_log_dir.empty()) {
    const std::string dir = setup_.run_log_dir + "/round" + std::to_string(round_);
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    request.log_path = dir + "/" + run->name + ".log";
    request.telemetry_path = dir + "/" + run->name + ".telemetry.csv";
    run->log_path = request.log_path;
  }
  // Where the tag stood: the start rest's last corners.
  watch->start_corners = *rest.found.back().corners_px;
  if (const Status started = driver_->Start(request); !started)
    return Failure{CauseOf(started, StationStatus::kRunNotCompleted), watch->what + ": " + started.message};
  run_in_progress_ = true;
  if (setup_.live) {
    if (index == 1) setup_.live->ClearTrajectory();  // the round's path
    setup_.live->SetProgress(index, total, calibration::Describe(spec),
                             Format("round %d; %s", round_, driver_->Describe().c_str()));
  }
  if (round_ == 1) watch->recording = &recording_.emplace_back();
  Log(watch->what + ": started (" + driver_->Describe() + ")");
  watch->t0 = Clock::now();
  // The headings seen (seen_turning.h judges them against the plan at
  // the end), from the start rest's last frame on.
  if (const auto h = HeadingOf(watch->start_corners)) watch->sightings.push_back({rest.found.back().t_s, *h});
  watch->fps = setup_.camera->NominalFps();
  watch->last_found_t = rest.found.back().t_s;
  return std::nullopt;
}

// A frame while the robot moves: keeps the track, adds views for the
// plane, watches the motion. True when the camera saw the robot stop (a run
// the camera ends).
bool Station::SeeMovingFrame(const media::CameraFrame& frame, StationRun* run, RunWatch* watch) {
  if (watch->recording) watch->recording->clock.emplace_back(Clock::now(), frame.t_s);
  if (watch->fps && watch->last_frame_t)
    run->frames_dropped += std::max(0L, std::lround((frame.t_s - *watch->last_frame_t) * *watch->fps) - 1);
  watch->last_frame_t = frame.t_s;
  vision::FrameObservation obs = observer_->Observe(frame.grey, frame.t_s);
  ShowLive(frame, obs);
  if (watch->recording && obs.corners_px) {
    vision::FrameObservation kept;
    kept.t_s = obs.t_s;
    kept.corners_px = obs.corners_px;
    watch->recording->frames.push_back(std::move(kept));
  }
  ++run->moving_frames;
  watch->lost_streak = obs.corners_px ? 0 : watch->lost_streak + 1;
  watch->out_of_view = watch->out_of_view || (watch->lost_streak >= 3 && frame.t_s - watch->last_found_t >= 0.5);
  if (obs.corners_px) {
    watch->last_found_t = frame.t_s;
    ++run->moving_found;
    view_candidates_.push_back(*obs.corners_px);
    const double d = MaxCornerDistance(*obs.corners_px, watch->start_corners);
    run->max_motion_px = std::max(run->max_motion_px, d);
    watch->moved = watch->moved || d > options_.motion_threshold_px;
    if (const auto h = HeadingOf(*obs.corners_px)) watch->sightings.push_back({frame.t_s, *h});
    if (driver_->EndsByCamera() && (watch->moved || watch->out_of_view)) {
      if (!watch->still_since || MaxCornerDistance(*obs.corners_px, watch->still_since->second) > options_.still_px) {
        watch->still_since.emplace(frame.t_s, *obs.corners_px);
      } else if (frame.t_s - watch->still_since->first >= options_.still_s) {
        return true;  // the robot stopped
      }
    }
  } else {
    watch->still_since.reset();
  }
  return false;
}

// Frames while the run drives, until the driver reports it done or the
// camera sees the robot stop; a failure when it takes too long, shows no
// motion, or the camera or the link is lost.
std::optional<Station::Failure> Station::WatchRun(StationRun* run, RunWatch* watch) {
  for (;;) {
    if (StopRequested()) return Failure{StationStatus::kInterrupted, watch->what + ": interrupted"};
    if (!driver_->EndsByCamera()) {
      const auto progress = driver_->Poll();
      if (!progress) {
        run_in_progress_ = false;
        return Failure{CauseOf(Status::From(progress), StationStatus::kRunNotCompleted),
                       watch->what + ": " + progress.message};
      }
      if (*progress == RunProgress::kDone) return std::nullopt;
    }
    const Clock::duration elapsed = Clock::now() - watch->t0;
    if (elapsed > options_.run_timeout) {
      return Failure{StationStatus::kRunNotCompleted,
                     watch->what + Format(": not completed within %.0f s", Seconds(options_.run_timeout))};
    }
    if (!watch->moved && !watch->out_of_view && driver_->EndsByCamera() && elapsed > options_.start_timeout) {
      return Failure{StationStatus::kRunNotCompleted,
                     watch->what + Format(": the camera saw no motion within %.0f s", Seconds(options_.start_timeout))};
    }
    const Result<media::CameraFrame> frame = setup_.camera->Grab();
    if (!frame) return Failure{StationStatus::kCameraLost, setup_.camera->Describe() + ": " + frame.message};
    if (SeeMovingFrame(*frame, run, watch)) return std::nullopt;
    std::this_thread::sleep_for(options_.poll_interval);
  }
}

// The run's end: its telemetry taken, its end rest found (the next run's
// start rest, to `rest`), and the turning seen judged against the plan.
std::optional<Station::Failure> Station::FinishRun(const calibration::RunSpec& spec, StationRun* run, RunWatch* watch,
                                                   RestFrames* rest) {
  run_in_progress_ = false;
  if (watch->recording) {
    std::string note;
    watch->recording->telemetry = driver_->TakeTelemetry(&note);
    if (!note.empty()) Log(watch->what + ": " + note);
  }
  // No motion: the tag seen, in place, in every frame while the run lasted.
  // (A tag lost in a frame may have moved: a square larger than the view
  // leaves it.)
  if (!watch->moved && run->moving_found == run->moving_frames) {
    return Failure{
        StationStatus::kRunNotCompleted,
        watch->what + Format(": %s, but the camera saw the tag move at most %.1f px (tag in %d of %d frames "
                             "while it ran): the robot did not move",
                             driver_->EndsByCamera() ? "the operator finished" : "the driver reports the run done",
                             run->max_motion_px, run->moving_found, run->moving_frames)};
  }
  RestFrames end_rest;
  if (auto f = CaptureRest(&end_rest)) return f;
  const int need = static_cast<int>(std::ceil(options_.min_rest_found_fraction * end_rest.grabbed));
  if (static_cast<int>(end_rest.found.size()) < std::max(1, need)) {
    return Failure{StationStatus::kCameraLost,
                   Format("camera lost the tag: id %d seen in %zu of %d frames after %s "
                          "(robot out of view, or the camera blocked or moved)",
                          setup_.tag.id, end_rest.found.size(), end_rest.grabbed, watch->what.c_str())};
  }
  // The heading change, closed on the end rest's first frame, judged
  // against the plan as far as the sightings tell it: the total only when
  // no gap was too long to unwrap (at the robot's fastest turn), always
  // the end heading modulo a turn and the turning seen in view.
  const vision::FrameObservation& end_first = end_rest.found.front();
  if (const auto h = HeadingOf(*end_first.corners_px)) watch->sightings.push_back({end_first.t_s, *h});
  calibration::SeenTurningOptions turning;
  turning.max_turn_rate_rad_s = spec.turn_rate_rad_s ? 1.25 * *spec.turn_rate_rad_s : options_.max_turn_rate_rad_s;
  const calibration::SeenTurning seen = calibration::TrackSeenTurning(watch->sightings, turning);
  run->turned_rad = seen.total_rad();
  run->unseen_s = seen.unseen_s;
  if (watch->sightings.size() >= 2) {
    const std::vector<calibration::Primitive> plan = calibration::PlanPrimitives(spec);
    if (const auto why = calibration::ContradictsPlan(seen, plan, options_.heading_check_rad))
      return Failure{
          StationStatus::kRunNotCompleted,
          watch->what + ": " + *why + ": was another run driven (the wrong direction, the wrong number of turns)?"};
  }
  if (!run->turned_rad)
    Log(watch->what +
        Format(": total heading change not checked (no sighting for %.1f s of the run: the tag out of view, "
               "or frames too far apart to unwrap at %.0f deg/s); the end heading and the turning in view agree "
               "with the plan",
               seen.unseen_s, RadToDeg(turning.max_turn_rate_rad_s)));
  if (run->frames_dropped > 0)
    Log(watch->what + Format(": %d frames dropped while it ran (the machine busy, or the camera slower than %.0f fps)",
                             run->frames_dropped, watch->fps.value_or(0.0)));
  Log(Format("%s: completed in %.1f s, tag in %d/%d frames while moving (%.0f px), %zu/%d rest frames%s",
             watch->what.c_str(), Seconds(Clock::now() - watch->t0), run->moving_found, run->moving_frames,
             run->max_motion_px, end_rest.found.size(), end_rest.grabbed,
             run->turned_rad ? Format(", turned %+.1f deg", RadToDeg(*run->turned_rad)).c_str() : ""));
  *rest = std::move(end_rest);
  return std::nullopt;
}

std::optional<Station::Failure> Station::DriveRun(const calibration::RunSpec& spec, int index, int total,
                                                  StationRun* run, RestFrames* rest) {
  RunWatch watch;
  if (auto f = StartRun(spec, index, total, *rest, run, &watch)) return f;
  if (auto f = WatchRun(run, &watch)) return f;
  return FinishRun(spec, run, &watch, rest);
}

// The camera's model, once: its plane fitted to the views the rounds gave (the
// operator's guess when they are too few), then its length scale.
void Station::FitCamera(const std::vector<std::pair<RestFrames, RestFrames>>& rests) {
  std::vector<vision::TagCorners> views =
      measure::PickPlaneViews(view_candidates_, options_.min_view_separation_px, options_.max_plane_views);
  // The tag's edge shift (tone curve, blur, ink), measured in the rests'
  // frames and taken out of the views, as batch does: the plane's height is
  // the tag's apparent size.
  std::vector<const vision::FrameObservation*> rest_frames;
  for (const auto& [start, end] : rests)
    for (const RestFrames* r : {&start, &end})
      for (const vision::FrameObservation& f : r->found) rest_frames.push_back(&f);
  const vision::CameraModel lens(setup_.intrinsics, setup_.mount_guess);
  const vision::EdgeShiftEstimate shift =
      measure::MeasureTagEdgeShift(rest_frames, setup_.tag, lens, options_.edge_shift_frames);
  if (shift.ok())
    for (vision::TagCorners& view : views) view = vision::RemoveEdgeShift(view, shift.shift_px, &lens);
  const measure::CameraPlaneOrGuess fit =
      measure::EstimateCameraPlaneOrGuess(setup_.intrinsics, setup_.tag, views, setup_.mount_guess, options_.plane);
  vision::CameraMount mount = fit.mount;
  plane_ = fit.plane;
  plane_estimated_ = fit.estimated();
  if (plane_estimated_)
    Log(
        Format("camera plane from %d views: roll %.3f deg, pitch %.3f deg, height %.1f mm "
               "(rms %.3f px)",
               plane_.views_used, mount.roll_deg, mount.pitch_deg, mount.height_mm, plane_.rms_reprojection_px));
  else
    Log(Format("camera plane: %zu distinct views, using the operator's mount guess", views.size()));
  EstimateScale(&mount, shift.ok() ? &shift : nullptr);
  camera_.emplace(setup_.intrinsics, mount);
}

// Each run's start and end rest measured on the camera's model, and their
// relative pose: the run's measurement, to `iteration` and to `session`.
std::optional<Station::Failure> Station::MeasureRests(const std::vector<std::pair<RestFrames, RestFrames>>& rests,
                                                      StationIteration* iteration,
                                                      measure::SessionMeasurement* session) const {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < iteration->runs.size(); ++i) {
    StationRun& run = iteration->runs[i];
    const auto start = measure::MeasureRestExactly(rests[i].first.found, -kInf, kInf, *camera_, setup_.tag);
    const auto end = measure::MeasureRestExactly(rests[i].second.found, -kInf, kInf, *camera_, setup_.tag);
    if (!start || !end) {
      return Failure{StationStatus::kCameraLost,
                     Format("run %zu: the exact refinement failed on most frames of its %s rest", i + 1,
                            start ? "end" : "start")};
    }
    run.start_rest = *start;
    run.end_rest = *end;
    // The rests' relative pose: for a closed path the return error (true -
    // odometry, which believes it came back), for a straight the driven
    // displacement (as batch's runs without telemetry).
    const calibration::RelativePose r = calibration::Between(*start, *end, options_.systematic_floor);
    measure::RunMeasurement m;
    m.measured.name = run.name;
    m.measured.spec = run.spec;
    m.measured.start_rest = *start;
    m.measured.end_rest = *end;
    run.return_error = r;
    m.measured.return_error = r;
    session->runs.push_back(std::move(m));
  }
  return std::nullopt;
}

std::optional<Station::Failure> Station::MeasureRound(StationIteration* iteration,
                                                      const std::vector<std::pair<RestFrames, RestFrames>>& rests) {
  if (!camera_) FitCamera(rests);
  // The round as batch sees a session: the set the robot ran with, each
  // run's return error; then batch's estimators.
  measure::SessionMeasurement session;
  session.session.nominal = ToWheelParams(current_);
  session.camera_scale_sigma = camera_scale_ ? camera_scale_->relative_sigma : 0.0;
  if (camera_scale_) session.camera_scale = *camera_scale_;
  if (auto f = MeasureRests(rests, iteration, &session)) return f;
  if (round_ == 1 && options_.explain) BuildRecordedSession(*iteration, rests);
  iteration->session_estimate = measure::EstimateSession({session});
  const measure::SessionEstimate& e = iteration->session_estimate;
  if (!e.any()) {
    std::string notes;
    for (const std::string& n : e.notes) notes += "; " + n;
    return Failure{StationStatus::kEstimateFailed, "no estimate from the round's runs" + notes};
  }
  iteration->corrected = ToParamSet(measure::CorrectedParams(ToWheelParams(current_), e), current_.ticks_per_rev);
  // Turn slip: the spins' track factors by rate.
  if (e.track) {
    std::vector<SpinTrack> spins;
    for (size_t k = 0; k < e.track->runs.size(); ++k)
      for (const StationRun& run : iteration->runs)
        if (run.name == e.track->runs[k] && run.spec.turn_rate_rad_s)
          spins.push_back({*run.spec.turn_rate_rad_s, e.track->values[k]});
    iteration->turn_slip = AnalyzeTurnRates(spins, options_.turn_slip_sigmas);
  }
  if (!e.umbmark) return std::nullopt;
  iteration->input = *e.umbmark_input;
  iteration->estimate = *e.umbmark;
  iteration->emax_sigma_m = EmaxSystSigma(iteration->estimate, iteration->runs);
  return std::nullopt;
}
// The camera's length scale, as batch finds it: with a floor reference the
// mount's height becomes the reference's; otherwise, or when the reference
// cannot be used (the log says why), the robot tag's printed size stands.
void Station::EstimateScale(vision::CameraMount* mount, const vision::EdgeShiftEstimate* edge_shift) {
  const size_t flags_before = flags_.size();
  camera_scale_ = measure::EstimateCameraScale(
      setup_.intrinsics, setup_.tag, setup_.tag_size_sigma_mm, plane_estimated_ ? &plane_ : nullptr,
      setup_.floor_reference ? &*setup_.floor_reference : nullptr, floor_frames_, options_.camera_scale, mount,
      &flags_, edge_shift);
  floor_frames_.clear();
  floor_frames_.shrink_to_fit();
  Log("camera scale: " + camera_scale_->explanation);
  if (setup_.floor_reference) {
    std::string seen;
    for (const vision::FloorTagSighting& t : camera_scale_->floor_tags) {
      seen += Format("%s%d: %d/%d frames", seen.empty() ? "" : ", ", t.id, t.frames_used, t.frames_seen);
      for (const vision::ObservationFlag flag : t.flags) seen += std::string(" ") + vision::ToString(flag);
    }
    Log("floor tags " + seen);
    for (size_t i = flags_before; i < flags_.size(); ++i) Log(std::string("flag: ") + measure::ToString(flags_[i]));
    if (camera_scale_->source == measure::CameraScale::Source::kFloorReference)
      Log(Format("camera height %.1f mm from the floor reference (sigma %.2f mm); the plane said %.1f mm",
                 mount->height_mm, camera_scale_->sigma_camera_height_mm, plane_.mount.height_mm));
  }
}

// One run of the first round as explain measures it: the rests' and the run's
// frames posed on the camera's model, the telemetry on the camera's clock.
calibration::MeasuredRun Station::RecordedRun(const StationRun& run, const Recording& recording,
                                              const std::pair<RestFrames, RestFrames>& rest,
                                              Clock::time_point origin) const {
  calibration::MeasuredRun m;
  m.name = run.name;
  m.spec = run.spec;
  m.start_rest = run.start_rest;
  m.end_rest = run.end_rest;
  m.return_error = run.return_error;
  auto add_frame = [&](const vision::FrameObservation& f) {
    calibration::CameraRecord c;
    c.t_s = f.t_s;
    if (f.corners_px) {
      const vision::PlanarPoseResult pose = vision::MeasureTagPose(*camera_, setup_.tag, *f.corners_px);
      c.valid = pose.ok();
      c.T_world_robot = pose.T_world_robot;
    }
    m.camera.push_back(c);
  };
  for (const auto& f : rest.first.found) add_frame(f);
  for (const auto& f : recording.frames) add_frame(f);
  for (const auto& f : rest.second.found) add_frame(f);
  const std::vector<DriverTelemetry>& tel = recording.telemetry;
  if (tel.size() >= 2) {
    const std::optional<double> offset = TelemetryClockOffset(recording, rest, origin);
    if (offset) {
      for (const DriverTelemetry& t : tel)
        m.telemetry.push_back({t.robot_t_s + *offset, t.left_ticks, t.right_ticks, t.odometry});
    } else {
      Log(run.name + ": its telemetry could not be put on the camera's clock; explain leaves it out");
    }
  }
  return m;
}

// Camera clock - robot clock for a run's telemetry (see BuildRecordedSession);
// nullopt when it cannot be told.
std::optional<double> Station::TelemetryClockOffset(const Recording& recording,
                                                    const std::pair<RestFrames, RestFrames>& rest,
                                                    Clock::time_point origin) const {
  const std::vector<DriverTelemetry>& tel = recording.telemetry;
  std::optional<double> offset;  // camera clock - robot clock
  if (setup_.camera_on_robot_clock) {
    offset = 0.0;
  } else if (tel.front().received) {
    if (const auto line = FitCameraClock(recording.clock, origin)) {
      const auto [a, b] = *line;
      double least = std::numeric_limits<double>::infinity();
      for (const DriverTelemetry& t : tel) least = std::min(least, a + b * Seconds(*t.received - origin) - t.robot_t_s);
      offset = least;
    }
  } else {
    offset = MotionClockOffset(tel, rest.first.found.back(), rest.second.found.front(), recording.frames);
  }
  return offset;
}

// The first round as a measured session for explain: each frame's pose on
// the camera's final model, the telemetry put on the camera's clock. The
// clocks: the camera's time against the host's at each grab, fitted by a
// line (a real camera: slope 1; the virtual one: the time scale); a sample
// then arrived at a + b * received, at least the link's latency after the
// robot stamped it, so robot time + min(a + b * received - robot time) is
// the camera time of the least delayed sample and of every other. (The
// virtual camera's clock is the robot's: no mapping, camera_on_robot_clock.)
void Station::BuildRecordedSession(const StationIteration& iteration,
                                   const std::vector<std::pair<RestFrames, RestFrames>>& rests) {
  // The steady clock's origin for the lines through (steady s, camera s),
  // each run's on its own grabs (a real camera: slope 1; its stamps need not
  // share the host clock's origin).
  const Clock::time_point origin = Clock::now();
  calibration::MeasuredSession session;
  session.believed = ToWheelParams(current_);
  session.camera_scale_sigma = camera_scale_ ? camera_scale_->relative_sigma : 0.0;
  for (size_t i = 0; i < iteration.runs.size() && i < recording_.size(); ++i) {
    const StationRun& run = iteration.runs[i];
    session.runs.push_back(RecordedRun(run, recording_[i], rests[i], origin));
  }
  SetFrameNoise(session);
  recorded_ = std::move(session);
  recording_.clear();
}

void Station::Cleanup(StationResult* result) {
  const Result<std::string> stopped = driver_->Stop();
  result->robot_stopped = stopped.ok();
  std::vector<std::string> done = {stopped.ok() ? *stopped : stopped.message};
  if (!driver_->Reachable()) {
    result->cleanup = done.front();
    return;
  }
  if (applied_since_start_) {
    ParamSet active;
    if (const Status restored = driver_->Apply(initial_, 0, &active); restored) {
      result->restored = true;
      current_ = active;
      done.push_back("the unverified parameter set was replaced by the initial one");
    } else {
      done.push_back("could not restore the initial parameters (" + restored.message + ")");
    }
  }
  if (driver_->CanReadBack()) {
    if (const auto back = driver_->ReadBack()) {
      result->params_final = *back;
      done.push_back(back->SameBits(initial_) ? "parameters as they were" : "PARAMETERS DIFFER FROM THE INITIAL SET");
    } else {
      done.push_back("could not read the parameters back");
    }
  } else if (!applied_since_start_ || result->restored) {
    // What the driver was last told to apply (it cannot be read back).
    result->params_final = current_;
    done.push_back(current_.SameBits(initial_) ? "parameters as they were (as applied; the driver cannot read them)"
                                               : "PARAMETERS DIFFER FROM THE INITIAL SET");
  } else {
    done.push_back("the robot may keep the unverified set: restoring it failed and the driver cannot read it");
  }
  std::string joined;
  for (const std::string& d : done) joined += (joined.empty() ? "" : "; ") + d;
  result->cleanup = joined;
}

// The result as it ends, with or without a failure (which cleans up a
// robot left with a set the station applied).
StationResult Station::Finish(std::optional<Failure> failure, Clock::time_point t0, StationResult result) {
  if (failure) {
    result.status = failure->status;
    result.message = failure->message;
    Log("stopping: " + failure->message);
    if (setup_.live) setup_.live->SetWarning("station", "stopped: " + failure->message);
    if (result.params_initial) {
      Cleanup(&result);
      Log(result.cleanup);
    }
  } else {
    result.status = StationStatus::kOk;
  }
  result.plane = plane_;
  result.plane_estimated = plane_estimated_;
  result.camera_scale = camera_scale_;
  result.flags = flags_;
  result.plan_summary = plan_summary_;
  if (result.iterations.size() >= 2 && result.iterations.front().estimate.ok() &&
      result.iterations.back().estimate.ok() && result.iterations.back().estimate.emax_syst_m > 0.0) {
    result.improvement = result.iterations.front().estimate.emax_syst_m / result.iterations.back().estimate.emax_syst_m;
  }
  result.wall_s = Seconds(Clock::now() - t0);
  return result;
}

// The options, the plan and the tag detector, before the robot is touched.
std::optional<Station::Failure> Station::CheckInputs(StationResult* result) {
  std::string why;
  if (!options_.IsValid(&why)) return Failure{StationStatus::kInvalidInput, "options: " + why};
  if (setup_.floor_reference && !setup_.floor_reference->IsValid(&why))
    return Failure{StationStatus::kInvalidInput, "floor reference: " + why};
  if (!driver_ || !setup_.camera) return Failure{StationStatus::kInvalidInput, "no robot driver or no camera"};
  result->driver = driver_->Describe();
  if (setup_.plan.empty() && !setup_.default_plan) return Failure{StationStatus::kInvalidInput, "the plan is empty"};
  int cw = 0, ccw = 0;
  for (const calibration::RunSpec& spec : setup_.plan) {
    using calibration::Procedure;
    if (spec.procedure != Procedure::kUmbmark && spec.procedure != Procedure::kStraight &&
        spec.procedure != Procedure::kSpin && spec.procedure != Procedure::kOutAndBack) {
      return Failure{StationStatus::kInvalidInput,
                     "the plan's " + std::string(calibration::ToString(spec.procedure)) +
                         " run: the station drives umbmark, straight, spin and out_and_back"};
    }
    if (!spec.IsValid(&why)) return Failure{StationStatus::kInvalidInput, "the plan: " + why};
    if (spec.procedure != Procedure::kUmbmark) continue;
    (spec.direction == calibration::Direction::kCw ? cw : ccw)++;
  }
  if ((cw == 0) != (ccw == 0))
    return Failure{StationStatus::kInvalidInput, "the plan's UMBMark squares need both cw and ccw runs"};
  if (!driver_->CanApply() && options_.max_rounds > 1)
    Log("the driver cannot apply parameters: one round, then the corrected set is written for you to load");
  auto observer = vision::TagObserver::Create(setup_.tag, setup_.intrinsics, options_.track);
  if (!observer) return Failure{StationStatus::kInvalidInput, "tag detector: " + observer.message};
  observer_ = std::move(*observer);
  guess_camera_.emplace(setup_.intrinsics, setup_.mount_guess);
  return std::nullopt;
}

// The robot connected, the tag found at rest at the start, the plan made
// (the default plan from where the robot stands when none was given).
std::optional<Station::Failure> Station::ConnectAndPlan(StationResult* result, RestFrames* rest) {
  if (const Status connected = driver_->Connect(&initial_, [this](const std::string& l) { Log(l); }); !connected)
    return Failure{CauseOf(connected, StationStatus::kRobotLink), connected.message};
  current_ = initial_;
  result->params_initial = initial_;
  result->robot = driver_->Info();
  {
    std::ostringstream ps;
    ps << "robot parameters: " << initial_;
    Log(ps.str());
  }

  if (auto f = CaptureRest(rest, setup_.floor_reference ? &floor_frames_ : nullptr)) return f;
  const int need = static_cast<int>(std::ceil(options_.min_rest_found_fraction * rest->grabbed));
  if (static_cast<int>(rest->found.size()) < std::max(1, need)) {
    return Failure{StationStatus::kTagNotFound,
                   Format("tag %s id %d not found at the start: seen in %zu of %d frames%s (is the robot in view, "
                          "the tag family and id right?)",
                          setup_.tag.family.c_str(), setup_.tag.id, rest->found.size(), rest->grabbed,
                          rest->wrong_id > 0 ? ", other tag ids seen" : "")};
  }
  Log(Format("tag %d found at the start in %zu/%d frames", setup_.tag.id, rest->found.size(), rest->grabbed));
  plan_ = setup_.plan;
  if (plan_.empty()) {
    plan_ = MakeDefaultPlan(*rest, &plan_summary_);
    if (plan_.empty()) return Failure{StationStatus::kInvalidInput, plan_summary_};
    Log(plan_summary_);
  }
  return std::nullopt;
}

// A round's estimates, in one line of the log.
void Station::LogRound(int round, const StationIteration& iteration) const {
  const calibration::UmbmarkSummary& s = iteration.estimate;
  const measure::SessionEstimate& e = iteration.session_estimate;
  std::string line = Format("round %d:", round);
  if (s.ok())
    line += Format(" E_max,syst %.3f mm%s, Ed %.7f, Eb %.7f;", s.emax_syst_m * kMToMm,
                   iteration.emax_sigma_m ? Format(" (sigma %.3f mm)", *iteration.emax_sigma_m * kMToMm).c_str() : "",
                   s.coupled.Ed, s.coupled.Eb);
  for (const auto& [label, pooled] :
       {std::pair{"ratio", &e.ratio}, std::pair{"scale", &e.scale}, std::pair{"track", &e.track}})
    if (*pooled)
      line += Format(" %s %.6f%s;", label, (*pooled)->mean,
                     (*pooled)->standard_error ? Format(" ± %.6f", *(*pooled)->standard_error).c_str() : "");
  Log(line);
  if (!iteration.turn_slip.advice.empty()) Log(iteration.turn_slip.advice);
}

// Done? What is left is within the measurement's uncertainty of the
// previous round, or no better than it.
void Station::Decide(const StationIteration& previous, StationIteration* iteration) const {
  const calibration::UmbmarkSummary& s = iteration->estimate;
  if (const std::optional<std::string> within = WithinUncertainty(*iteration, previous, options_.converge_sigmas)) {
    iteration->converged = true;
    iteration->note = "converged: what is left is within the measurement uncertainty (" + *within + ")";
  } else if (s.ok() && previous.estimate.ok() && s.emax_syst_m >= previous.estimate.emax_syst_m) {
    iteration->converged = true;
    iteration->note = "stopped: no improvement on the previous round";
  }
}

// The corrected set applied (pushed, read back and verified where the
// driver can), for the next round to verify.
std::optional<Station::Failure> Station::ApplyCorrected(int round, StationIteration* iteration) {
  std::string why;
  const ParamSet target = *iteration->corrected;
  if (!target.IsValid(&why)) {
    return Failure{StationStatus::kEstimateFailed, "corrected parameters out of range: " + why};
  }
  // The last point where Ctrl-C is honoured before the apply; the apply
  // itself runs to its end (a push: staged, read back, committed, verified).
  if (StopRequested()) {
    return Failure{StationStatus::kInterrupted, "interrupted before the push"};
  }
  std::ostringstream os;
  os << (driver_->CanReadBack() ? "pushing " : "applying ") << target;
  Log(os.str());
  ParamSet active;
  if (const Status applied = driver_->Apply(target, round, &active); !applied) {
    return Failure{CauseOf(applied, StationStatus::kPushRefused), applied.message};
  }
  applied_since_start_ = !active.SameBits(initial_);
  current_ = active;
  iteration->pushed = target;
  Log(driver_->CanReadBack() ? "pushed and verified (read back)" : "applied (the next round verifies it)");
  return std::nullopt;
}

// Rounds until the estimate converges: drive the plan, measure, estimate,
// decide, apply.
std::optional<Station::Failure> Station::RunRounds(StationResult* result, RestFrames* rest) {
  const int max_rounds = driver_->CanApply() ? options_.max_rounds : 1;
  for (int round = 1; round <= max_rounds; ++round) {
    StationIteration iteration;
    iteration.params_used = current_;
    round_ = round;
    Log(Format("round %d of at most %d", round, max_rounds));
    std::vector<std::pair<RestFrames, RestFrames>> rests;
    for (size_t i = 0; i < plan_.size(); ++i) {
      if (StopRequested()) return Failure{StationStatus::kInterrupted, "interrupted"};
      StationRun run;
      RestFrames start = *rest;
      if (auto f = DriveRun(plan_[i], static_cast<int>(i) + 1, static_cast<int>(plan_.size()), &run, rest)) {
        iteration.runs.push_back(run);
        result->iterations.push_back(std::move(iteration));
        return f;
      }
      rests.emplace_back(std::move(start), *rest);
      iteration.runs.push_back(run);
    }
    if (auto f = MeasureRound(&iteration, rests)) {
      result->iterations.push_back(std::move(iteration));
      return f;
    }
    ShowEstimates(iteration);
    LogRound(round, iteration);
    if (round >= 2) Decide(result->iterations.back(), &iteration);
    if (!driver_->CanApply()) {
      iteration.note = "not applied: the driver has no apply command; load the corrected set and run the "
                       "station again to verify it";
      result->params_recommended = iteration.corrected;
      Log(iteration.note);
      result->iterations.push_back(std::move(iteration));
      break;
    }
    if (!iteration.converged && round == max_rounds) iteration.note = "maximum number of rounds reached";
    if (iteration.converged || round == max_rounds) {
      Log(iteration.note);
      result->iterations.push_back(std::move(iteration));
      break;
    }
    std::optional<Failure> failure = ApplyCorrected(round, &iteration);
    result->iterations.push_back(std::move(iteration));
    if (failure) return failure;
  }
  // What the last round found, for the user.
  for (const StationIteration& it : result->iterations)
    if (!it.turn_slip.advice.empty()) result->findings = {it.turn_slip.advice};
  return std::nullopt;
}

// Explain on the first round as recorded (the robot as it came), when the
// driver gave its ticks; its findings and advice for the user.
void Station::ExplainFirstRound(StationResult* result) {
  int with_telemetry = 0;
  if (recorded_)
    for (const calibration::MeasuredRun& m : recorded_->runs) with_telemetry += m.telemetry.size() >= 2 ? 1 : 0;
  if (with_telemetry > 0) {
    Log(Format("explain: the first round's %d runs with telemetry", with_telemetry));
    calibration::ExplainResult explain = calibration::Explain(*recorded_);
    std::istringstream brief(explain.BriefReport());
    for (std::string line; std::getline(brief, line);) Log("explain: " + line);
    if (explain.ok()) {
      double gap_before = explain.gap_before_m();
      for (const calibration::ExplainStep& step : explain.steps) {
        std::string text = "explain: " + std::string(calibration::ToString(step.effect));
        for (const calibration::ParameterEstimate& p : step.params)
          text += Format(" (%s %.5g ± %.2g)", p.name.c_str(), p.value, p.sigma);
        text += Format(" explains %.3f mm of the camera's gap: ",
                       std::sqrt(std::max(0.0, gap_before * gap_before - step.gap_after_m * step.gap_after_m)) * kMToMm);
        gap_before = step.gap_after_m;
        result->findings.push_back(text + std::string(calibration::Describe(step.effect).advice));
      }
    }
    result->explain = std::move(explain);
  } else if (options_.explain) {
    Log("explain: no telemetry from the driver; only the camera's estimators ran");
  }
  result->recorded = std::move(recorded_);
}

// The parameters the robot ends with: read back, or as applied.
std::optional<Station::Failure> Station::ReadFinalParams(StationResult* result) {
  if (driver_->CanReadBack()) {
    const auto back = driver_->ReadBack();
    if (!back) return Failure{StationStatus::kRobotLink, "reading the final parameters failed"};
    result->params_final = *back;
  } else {
    result->params_final = current_;
  }
  return std::nullopt;
}

// The procedure: check the inputs, connect and plan, the rounds, explain the
// first, read the final set back.
StationResult Station::Run() {
  StationResult result;
  const Clock::time_point t0 = Clock::now();
  RestFrames rest;
  std::optional<Failure> failure = CheckInputs(&result);
  if (!failure) failure = ConnectAndPlan(&result, &rest);
  if (!failure) failure = RunRounds(&result, &rest);
  if (!failure) {
    ExplainFirstRound(&result);
    failure = ReadFinalParams(&result);
  }
  return Finish(std::move(failure), t0, std::move(result));
}

}  // namespace

std::optional<double> EmaxSystSigma(const calibration::UmbmarkSummary& s, const std::vector<StationRun>& runs) {
  // Radial, for the larger centre of gravity; from the spread of repeated
  // runs, else from the camera's own sigmas.
  const bool cw_larger = s.cw.radius_m() >= s.ccw.radius_m();
  const calibration::CentreOfGravity& cg = cw_larger ? s.cw : s.ccw;
  double camera_var_x = 0.0, camera_var_y = 0.0;
  int n = 0;
  for (const StationRun& run : runs) {
    if (run.spec.procedure != calibration::Procedure::kUmbmark) continue;
    if ((run.spec.direction == calibration::Direction::kCw) != cw_larger) continue;
    camera_var_x += run.return_error.covariance(0, 0);
    camera_var_y += run.return_error.covariance(1, 1);
    ++n;
  }
  if (n == 0) return std::nullopt;
  const double sx = cg.sigma_x_m.value_or(std::sqrt(camera_var_x) / n);
  const double sy = cg.sigma_y_m.value_or(std::sqrt(camera_var_y) / n);
  const double r = cg.radius_m();
  return r > 0.0 ? std::hypot(cg.x_m * sx, cg.y_m * sy) / r : std::hypot(sx, sy);
}

// A remainder within the rule cannot be expected to shrink by pushing
// again: a second push would trade an error the size of one estimate's
// uncertainty for another.
std::optional<std::string> WithinUncertainty(const StationIteration& now, const StationIteration& pushed_from,
                                             double k) {
  std::string why;
  const calibration::UmbmarkSummary& s = now.estimate;
  if (s.ok()) {
    if (!now.emax_sigma_m) return std::nullopt;
    const double sigma = std::hypot(*now.emax_sigma_m, pushed_from.emax_sigma_m.value_or(0.0));
    if (s.emax_syst_m > k * sigma) return std::nullopt;
    why = Format("E_max,syst %.3f mm, %.1f sigma of this round's %.3f mm and the pushed estimate's %.3f mm",
                 s.emax_syst_m * kMToMm, sigma > 0.0 ? s.emax_syst_m / sigma : 0.0, *now.emax_sigma_m * kMToMm,
                 pushed_from.emax_sigma_m.value_or(0.0) * kMToMm);
  }
  if (const std::optional<double> z = CvraMaxZ(now.session_estimate, pushed_from.session_estimate)) {
    if (*z > k) return std::nullopt;
    why += Format("%sCVRA factors within %.1f sigma of 1", why.empty() ? "" : "; ", *z);
  }
  if (why.empty()) why = "nothing this round measured has a standard error to judge by";
  return why;
}

const char* ToString(StationStatus status) {
  switch (status) {
    case StationStatus::kOk: return "ok";
    case StationStatus::kInvalidInput: return "invalid_input";
    case StationStatus::kRobotLink: return "robot_link";
    case StationStatus::kTagNotFound: return "tag_not_found";
    case StationStatus::kCameraLost: return "camera_lost";
    case StationStatus::kRunNotCompleted: return "run_not_completed";
    case StationStatus::kPushRefused: return "push_refused";
    case StationStatus::kEstimateFailed: return "estimate_failed";
    case StationStatus::kInterrupted: return "interrupted";
  }
  return "unknown";
}

bool StationOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (max_rounds < 2) return fail("max_rounds must be at least 2 (a pushed set is always verified)");
  if (rest_frames < 2) return fail("rest_frames must be at least 2");
  if (!(min_rest_found_fraction > 0.0 && min_rest_found_fraction <= 1.0))
    return fail("min_rest_found_fraction must be in (0, 1]");
  if (rest_flush_frames < 0) return fail("rest_flush_frames must not be negative");
  if (!(settle_s >= 0.0) || !std::isfinite(settle_s)) return fail("settle_s must be a number, not negative");
  if (max_plane_views < 1) return fail("max_plane_views must be at least 1");
  if (edge_shift_frames < 0) return fail("edge_shift_frames must not be negative (0: off)");
  if (!(min_view_separation_px >= 0.0)) return fail("min_view_separation_px must not be negative");
  if (!(motion_threshold_px > 0.0)) return fail("motion_threshold_px must be positive");
  if (!(still_px > 0.0)) return fail("still_px must be positive");
  if (!(still_s > 0.0)) return fail("still_s must be positive");
  if (start_timeout.count() <= 0) return fail("start_timeout must be positive");
  if (!(turn_slip_sigmas > 0.0)) return fail("turn_slip_sigmas must be positive");
  if (run_timeout.count() <= 0) return fail("run_timeout must be positive");
  if (poll_interval.count() < 0) return fail("poll_interval must not be negative");
  if (!(converge_sigmas > 0.0)) return fail("converge_sigmas must be positive");
  if (floor_frames < 1) return fail("floor_frames must be at least 1");
  if (!(max_turn_rate_rad_s > 0.0) || !std::isfinite(max_turn_rate_rad_s))
    return fail("max_turn_rate_rad_s must be a positive number");
  if (!(heading_check_rad > 0.0 && heading_check_rad < M_PI)) return fail("heading_check_rad must be in (0, pi)");
  if (!(camera_scale.systematic_scale_sigma >= 0.0) || !(camera_scale.tag_print_sigma >= 0.0))
    return fail("camera_scale: systematic_scale_sigma and tag_print_sigma must not be negative");
  if (!camera_scale.quality_gate.IsValid(why)) return false;
  return track.IsValid(why) && plane.IsValid(why);
}

StationResult RunStation(const StationSetup& setup, const StationOptions& options) {
  Station station(setup, options);
  return station.Run();
}

}  // namespace odocal::station
