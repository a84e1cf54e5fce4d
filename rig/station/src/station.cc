#include "odocal/station/station.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <cstdio>
#include <sstream>
#include <thread>

#include <opencv2/imgproc.hpp>

#include "odocal/calibration/corrections.h"
#include "odocal/measure/measure.h"

namespace odocal::station {
namespace {

using Clock = std::chrono::steady_clock;
using robot_link::ParamSet;
using robot_link::ToParamSet;
using robot_link::ToWheelParams;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

std::string Format(const char* format, auto... args) {
  char buffer[512];
  std::snprintf(buffer, sizeof(buffer), format, args...);
  return buffer;
}

// One pass of the loop. Members hold what the failure handling needs.
class Station {
 public:
  Station(const StationSetup& setup, const StationOptions& options)
      : setup_(setup), options_(options), client_(*setup.transport, setup.client) {}

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

  void Log(const std::string& line) const {
    if (setup_.progress) setup_.progress(line);
  }
  bool StopRequested() const { return setup_.stop_requested && setup_.stop_requested->load(); }

  std::optional<Failure> Connect();
  // With `keep_grey`, the first options_.floor_frames full frames are kept
  // there too (for the floor reference).
  std::optional<Failure> CaptureRest(RestFrames* rest, std::vector<cv::Mat>* keep_grey = nullptr);
  void EstimateScale(vision::CameraMount* mount);
  // Drives one run; its end rest (the next run's start rest) goes to `rest`.
  std::optional<Failure> DriveRun(const calibration::RunSpec& spec, int index, int total,
                                  StationRun* run, RestFrames* rest);
  std::optional<Failure> MeasureRound(StationIteration* iteration,
                                      const std::vector<std::pair<RestFrames, RestFrames>>& rests);
  void Cleanup(StationResult* result);

  const StationSetup& setup_;
  const StationOptions& options_;
  robot_link::Client client_;
  std::unique_ptr<vision::TagObserver> observer_;
  std::vector<vision::TagCorners> view_candidates_;
  std::optional<vision::CameraModel> camera_;
  std::optional<uint16_t> running_run_;
  ParamSet initial_;
  ParamSet current_;
  bool pushed_since_start_ = false;
  bool link_ok_ = true;
  vision::CameraPlaneResult plane_;
  bool plane_estimated_ = false;
  std::vector<cv::Mat> floor_frames_;
  std::optional<measure::CameraScale> camera_scale_;
  std::vector<std::string> flags_;

 public:
  std::optional<robot_link::RobotInfo> info_;
};

std::optional<Station::Failure> Station::Connect() {
  Log("connecting to the robot on " + setup_.transport->Describe());
  const auto hello = client_.Hello();
  if (!hello) return Failure{StationStatus::kRobotLink, "handshake: " + hello.message};
  info_ = *hello.value;
  std::ostringstream os;
  os << *hello.value;
  Log(os.str());
  const auto params = client_.GetParams();
  if (!params) return Failure{StationStatus::kRobotLink, "reading the parameters: " + params.message};
  initial_ = current_ = *params.value;
  std::ostringstream ps;
  ps << "robot parameters: " << initial_;
  Log(ps.str());
  // The station polls STATUS and measures with the camera: telemetry would
  // only fill the line.
  if (const auto r = client_.SetTelemetryRate(0); !r)
    return Failure{StationStatus::kRobotLink, "setting the telemetry rate: " + r.message};
  return std::nullopt;
}

// Frames of the robot standing still: the tag's corners, kept with their crops
// for the exact refinement once the camera plane is known.
std::optional<Station::Failure> Station::CaptureRest(RestFrames* rest, std::vector<cv::Mat>* keep_grey) {
  std::string error;
  if (options_.settle_s > 0.0)
    std::this_thread::sleep_for(std::chrono::duration<double>(options_.settle_s));
  for (int i = 0; i < options_.rest_flush_frames; ++i) {
    if (!setup_.camera->Grab(&error))
      return Failure{StationStatus::kCameraLost, setup_.camera->Describe() + ": " + error};
  }
  // Search the first rest frame in full: while the robot was out of view the
  // tracker searches only every few frames.
  observer_->Reset();
  for (int i = 0; i < options_.rest_frames; ++i) {
    const auto frame = setup_.camera->Grab(&error);
    if (!frame) return Failure{StationStatus::kCameraLost, setup_.camera->Describe() + ": " + error};
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
    rest->wrong_id += obs.status == vision::DetectStatus::kWrongId ? 1 : 0;
    if (obs.corners_px) {
      view_candidates_.push_back(*obs.corners_px);
      rest->found.push_back(std::move(obs));
    }
  }
  return std::nullopt;
}

std::optional<Station::Failure> Station::DriveRun(const calibration::RunSpec& spec, int index,
                                                  int total, StationRun* run, RestFrames* rest) {
  run->spec = spec;
  const std::string what = Format("run %d/%d (UMBMark %s, %.0f mm)", index, total,
                                  std::string(calibration::ToString(spec.direction)).c_str(), spec.side_m * 1e3);
  const auto started = client_.StartRun(robot_link::RunCommand::FromRunSpec(spec));
  if (!started) {
    return Failure{started.status == odocal::StatusCode::kNack ? StationStatus::kRunNotCompleted
                                                                : StationStatus::kRobotLink,
                   what + ": start: " + started.message};
  }
  run->run_id = *started.value;
  running_run_ = run->run_id;
  Log(what + ": started, run id " + std::to_string(run->run_id));
  const Clock::time_point t0 = Clock::now();
  std::string error;
  for (;;) {
    if (StopRequested()) return Failure{StationStatus::kInterrupted, what + ": interrupted"};
    // Asking STATUS ourselves (rather than waiting for the event) tells a
    // robot that stopped answering from a run that is merely long.
    const auto status = client_.GetStatus();
    if (!status) {
      link_ok_ = status.status != odocal::StatusCode::kLineCut;
      return Failure{StationStatus::kRobotLink, what + ": " + status.message};
    }
    if (status.value->state == robot_link::RunState::kIdle) {
      running_run_.reset();
      if (status.value->last_run_id != run->run_id) {
        return Failure{StationStatus::kRobotLink,
                       what + ": the robot is idle and does not know the run (restarted?)"};
      }
      const robot_link::RunComplete& done = status.value->last_run;
      if (done.status != robot_link::RunStatus::kCompleted) {
        return Failure{StationStatus::kRunNotCompleted,
                       what + ": the robot reports the run " + std::string(robot_link::ToString(done.status))};
      }
      break;
    }
    if (Clock::now() - t0 > options_.run_timeout) {
      return Failure{StationStatus::kRunNotCompleted,
                     what + Format(": not completed within %.0f s", Seconds(options_.run_timeout))};
    }
    // A frame while moving: keeps the track and adds views for the plane.
    const auto frame = setup_.camera->Grab(&error);
    if (!frame) return Failure{StationStatus::kCameraLost, setup_.camera->Describe() + ": " + error};
    vision::FrameObservation obs = observer_->Observe(frame->grey, frame->t_s);
    ++run->moving_frames;
    if (obs.corners_px) {
      ++run->moving_found;
      view_candidates_.push_back(*obs.corners_px);
    }
    std::this_thread::sleep_for(options_.poll_interval);
  }
  RestFrames end_rest;
  if (auto f = CaptureRest(&end_rest)) return f;
  const int need = static_cast<int>(std::ceil(options_.min_rest_found_fraction * end_rest.grabbed));
  if (static_cast<int>(end_rest.found.size()) < std::max(1, need)) {
    return Failure{StationStatus::kCameraLost,
                   Format("camera lost the tag: id %d seen in %zu of %d frames after %s "
                          "(robot out of view, or the camera blocked or moved)",
                          setup_.tag.id, end_rest.found.size(), end_rest.grabbed, what.c_str())};
  }
  Log(Format("%s: completed in %.1f s, tag in %zu/%d rest frames", what.c_str(),
             Seconds(Clock::now() - t0), end_rest.found.size(), end_rest.grabbed));
  *rest = std::move(end_rest);
  return std::nullopt;
}

std::optional<Station::Failure> Station::MeasureRound(
    StationIteration* iteration, const std::vector<std::pair<RestFrames, RestFrames>>& rests) {
  if (!camera_) {
    const std::vector<vision::TagCorners> views = measure::PickPlaneViews(
        view_candidates_, options_.min_view_separation_px, options_.max_plane_views);
    vision::CameraMount mount = setup_.mount_guess;
    if (static_cast<int>(views.size()) >= options_.plane.min_views) {
      plane_ = vision::EstimateCameraOverTagPlane(setup_.intrinsics, setup_.tag, views,
                                                  setup_.mount_guess, options_.plane);
      if (plane_.ok) {
        mount = plane_.mount;
        plane_estimated_ = true;
        Log(Format("camera plane from %d views: roll %.3f deg, pitch %.3f deg, height %.1f mm "
                   "(rms %.3f px)",
                   plane_.views_used, mount.roll_deg, mount.pitch_deg, mount.height_mm,
                   plane_.rms_reprojection_px));
      }
    }
    if (!plane_estimated_)
      Log(Format("camera plane: %zu distinct views, using the operator's mount guess", views.size()));
    EstimateScale(&mount);
    camera_.emplace(setup_.intrinsics, mount);
  }
  calibration::UmbmarkInput& input = iteration->input;
  input.track_m = current_.track_mm * 1e-3;
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
    const calibration::RelativePose r = calibration::Between(*start, *end, options_.systematic_floor);
    run.return_error = r;
    std::string why;
    if (!input.AddRun(run.spec, r.pose, &why))
      return Failure{StationStatus::kEstimateFailed, "UMBMark input: " + why};
  }
  std::string why;
  if (!input.IsValid(&why)) return Failure{StationStatus::kEstimateFailed, "UMBMark input: " + why};
  iteration->estimate = calibration::EstimateUmbmark(input);
  if (!iteration->estimate.ok())
    return Failure{StationStatus::kEstimateFailed, "UMBMark: " + iteration->estimate.message};
  // Standard error of E_max,syst: radial, for the larger centre of gravity;
  // from the spread of repeated runs, else from the camera's own sigmas.
  const calibration::UmbmarkSummary& s = iteration->estimate;
  const bool cw_larger = s.cw.radius_m() >= s.ccw.radius_m();
  const calibration::CentreOfGravity& cg = cw_larger ? s.cw : s.ccw;
  double camera_var_x = 0.0, camera_var_y = 0.0;
  int n = 0;
  for (const StationRun& run : iteration->runs) {
    if ((run.spec.direction == calibration::Direction::kCw) != cw_larger) continue;
    camera_var_x += run.return_error.covariance(0, 0);
    camera_var_y += run.return_error.covariance(1, 1);
    ++n;
  }
  if (n > 0) {
    const double sx = cg.sigma_x_m.value_or(std::sqrt(camera_var_x) / n);
    const double sy = cg.sigma_y_m.value_or(std::sqrt(camera_var_y) / n);
    const double r = cg.radius_m();
    iteration->emax_sigma_m =
        r > 0.0 ? std::hypot(cg.x_m * sx, cg.y_m * sy) / r : std::hypot(sx, sy);
  }
  return std::nullopt;
}

// The camera's length scale, as batch finds it: with a floor reference the
// mount's height becomes the reference's; otherwise, or when the reference
// cannot be used (the log says why), the robot tag's printed size stands.
void Station::EstimateScale(vision::CameraMount* mount) {
  const size_t flags_before = flags_.size();
  camera_scale_ = measure::EstimateCameraScale(
      setup_.intrinsics, setup_.tag, setup_.tag_size_sigma_mm, plane_estimated_ ? &plane_ : nullptr,
      setup_.floor_reference ? &*setup_.floor_reference : nullptr, floor_frames_, options_.camera_scale, mount,
      &flags_);
  floor_frames_.clear();
  floor_frames_.shrink_to_fit();
  Log("camera scale: " + camera_scale_->explanation);
  if (setup_.floor_reference) {
    std::string seen;
    for (const vision::FloorTagSighting& t : camera_scale_->floor_tags) {
      seen += Format("%s%d: %d/%d frames", seen.empty() ? "" : ", ", t.id, t.frames_used, t.frames_seen);
      for (const std::string& flag : t.flags) seen += " " + flag;
    }
    Log("floor tags " + seen);
    for (size_t i = flags_before; i < flags_.size(); ++i) Log("flag: " + flags_[i]);
    if (camera_scale_->source == measure::CameraScale::Source::kFloorReference)
      Log(Format("camera height %.1f mm from the floor reference (sigma %.2f mm); the plane said %.1f mm",
                 mount->height_mm, camera_scale_->sigma_camera_height_mm, plane_.mount.height_mm));
  }
}

void Station::Cleanup(StationResult* result) {
  std::vector<std::string> done;
  if (!link_ok_) {
    result->robot_stopped = false;
    result->cleanup = "the line is gone: the robot could not be stopped or read over the link";
    return;
  }
  // Stop whatever runs, even when we believe nothing does: a stop is harmless.
  const auto stop = client_.Stop();
  if (stop) {
    done.push_back(running_run_ ? "robot stopped" : "robot idle");
  } else {
    result->robot_stopped = false;
    done.push_back("could not stop the robot over the link (" + stop.message + ")");
  }
  if (pushed_since_start_) {
    const auto restore = client_.PushParams(initial_);
    if (restore) {
      result->restored = true;
      done.push_back("the unverified parameter set was replaced by the initial one");
    } else {
      done.push_back("could not restore the initial parameters (" + restore.message + ")");
    }
  }
  if (const auto back = client_.GetParams(); back) {
    result->params_final = *back.value;
    done.push_back(back.value->SameBits(initial_) ? "parameters as they were"
                                                  : "PARAMETERS DIFFER FROM THE INITIAL SET");
  } else {
    done.push_back("could not read the parameters back (" + back.message + ")");
  }
  std::string joined;
  for (const std::string& d : done) joined += (joined.empty() ? "" : "; ") + d;
  result->cleanup = joined;
}

StationResult Station::Run() {
  StationResult result;
  const Clock::time_point t0 = Clock::now();
  auto finish = [&](std::optional<Failure> failure) {
    if (failure) {
      result.status = failure->status;
      result.message = failure->message;
      Log("stopping: " + failure->message);
      if (result.params_initial) {
        Cleanup(&result);
        Log(result.cleanup);
      }
    } else {
      result.status = StationStatus::kOk;
    }
    result.robot = info_;
    result.plane = plane_;
    result.plane_estimated = plane_estimated_;
    result.camera_scale = camera_scale_;
    result.flags = flags_;
    if (result.iterations.size() >= 2 && result.iterations.back().estimate.emax_syst_m > 0.0) {
      result.improvement =
          result.iterations.front().estimate.emax_syst_m / result.iterations.back().estimate.emax_syst_m;
    }
    result.wall_s = Seconds(Clock::now() - t0);
    return result;
  };

  std::string why;
  if (!options_.IsValid(&why)) return finish(Failure{StationStatus::kInvalidInput, "options: " + why});
  if (setup_.floor_reference && !setup_.floor_reference->IsValid(&why))
    return finish(Failure{StationStatus::kInvalidInput, "floor reference: " + why});
  if (!setup_.transport || !setup_.camera)
    return finish(Failure{StationStatus::kInvalidInput, "no robot link or no camera"});
  int cw = 0, ccw = 0;
  for (const calibration::RunSpec& spec : setup_.plan) {
    if (spec.procedure != calibration::Procedure::kUmbmark || spec.side_m != setup_.plan.front().side_m) {
      return finish(Failure{StationStatus::kInvalidInput,
                            "the plan must be UMBMark squares of one side (CVRA runs are not driven yet)"});
    }
    (spec.direction == calibration::Direction::kCw ? cw : ccw)++;
  }
  if (cw == 0 || ccw == 0)
    return finish(Failure{StationStatus::kInvalidInput, "the plan needs cw and ccw UMBMark squares"});
  observer_ = vision::TagObserver::Create(setup_.tag, setup_.intrinsics, options_.track, &why);
  if (!observer_) return finish(Failure{StationStatus::kInvalidInput, "tag detector: " + why});

  if (auto f = Connect()) return finish(f);
  result.params_initial = initial_;

  RestFrames rest;
  if (auto f = CaptureRest(&rest, setup_.floor_reference ? &floor_frames_ : nullptr)) return finish(f);
  const int need = static_cast<int>(std::ceil(options_.min_rest_found_fraction * rest.grabbed));
  if (static_cast<int>(rest.found.size()) < std::max(1, need)) {
    return finish(Failure{
        StationStatus::kTagNotFound,
        Format("tag %s id %d not found at the start: seen in %zu of %d frames%s (is the robot in view, "
               "the tag family and id right?)",
               setup_.tag.family.c_str(), setup_.tag.id, rest.found.size(), rest.grabbed,
               rest.wrong_id > 0 ? ", other tag ids seen" : "")});
  }
  Log(Format("tag %d found at the start in %zu/%d frames", setup_.tag.id, rest.found.size(), rest.grabbed));

  for (int round = 1; round <= options_.max_rounds; ++round) {
    StationIteration iteration;
    iteration.params_used = current_;
    Log(Format("round %d of at most %d", round, options_.max_rounds));
    std::vector<std::pair<RestFrames, RestFrames>> rests;
    for (size_t i = 0; i < setup_.plan.size(); ++i) {
      if (StopRequested()) return finish(Failure{StationStatus::kInterrupted, "interrupted"});
      StationRun run;
      RestFrames start = rest;
      if (auto f = DriveRun(setup_.plan[i], static_cast<int>(i) + 1, static_cast<int>(setup_.plan.size()),
                            &run, &rest)) {
        result.iterations.push_back(std::move(iteration));
        return finish(f);
      }
      rests.emplace_back(std::move(start), rest);
      iteration.runs.push_back(run);
    }
    if (auto f = MeasureRound(&iteration, rests)) {
      result.iterations.push_back(std::move(iteration));
      return finish(f);
    }
    const calibration::UmbmarkSummary& s = iteration.estimate;
    Log(Format("round %d: E_max,syst %.3f mm%s, Ed %.7f, Eb %.7f", round, s.emax_syst_m * 1e3,
               iteration.emax_sigma_m ? Format(" (sigma %.3f mm)", *iteration.emax_sigma_m * 1e3).c_str() : "",
               s.coupled.Ed, s.coupled.Eb));
    if (round >= 2) {
      const double previous = result.iterations.back().estimate.emax_syst_m;
      if (iteration.emax_sigma_m && s.emax_syst_m <= options_.converge_sigmas * *iteration.emax_sigma_m) {
        iteration.converged = true;
        iteration.note = "converged: E_max,syst within the measurement uncertainty";
      } else if (s.emax_syst_m >= previous) {
        iteration.converged = true;
        iteration.note = "stopped: no improvement on the previous round";
      }
    }
    if (!iteration.converged && round == options_.max_rounds)
      iteration.note = "maximum number of rounds reached";
    if (iteration.converged || round == options_.max_rounds) {
      Log(iteration.note);
      result.iterations.push_back(std::move(iteration));
      break;
    }
    // The correction of the set the robot ran with (Borenstein & Feng eq. 17-18).
    const ParamSet target =
        ToParamSet(calibration::ApplyUmbmarkCorrection(ToWheelParams(current_), s.coupled.Ed, s.coupled.Eb),
                   current_.ticks_per_rev);
    if (!target.IsValid(&why)) {
      result.iterations.push_back(std::move(iteration));
      return finish(Failure{StationStatus::kEstimateFailed, "corrected parameters out of range: " + why});
    }
    // The last point where Ctrl-C is honoured before the push; the push
    // itself runs to its end (staged, read back, committed, verified).
    if (StopRequested()) {
      result.iterations.push_back(std::move(iteration));
      return finish(Failure{StationStatus::kInterrupted, "interrupted before the push"});
    }
    std::ostringstream os;
    os << "pushing " << target;
    Log(os.str());
    const auto push = client_.PushParams(target);
    if (!push) {
      result.iterations.push_back(std::move(iteration));
      if (push.status == odocal::StatusCode::kLineCut) link_ok_ = false;
      const bool refused = push.status == odocal::StatusCode::kNack ||
                           push.status == odocal::StatusCode::kVerifyFailed;
      return finish(Failure{refused ? StationStatus::kPushRefused : StationStatus::kRobotLink,
                            "push: " + push.message});
    }
    pushed_since_start_ = !push.value->active.SameBits(initial_);
    current_ = push.value->active;
    iteration.pushed = target;
    Log("pushed and verified (checksum " + Format("%08x", push.value->checksum) + ")");
    result.iterations.push_back(std::move(iteration));
  }
  const auto final_params = client_.GetParams();
  if (!final_params) {
    return finish(Failure{StationStatus::kRobotLink, "reading the final parameters: " + final_params.message});
  }
  result.params_final = *final_params.value;
  return finish(std::nullopt);
}

}  // namespace

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
  if (rest_flush_frames < 0 || settle_s < 0.0) return fail("rest_flush_frames and settle_s must not be negative");
  if (run_timeout.count() <= 0 || poll_interval.count() < 0) return fail("run_timeout must be positive");
  if (!(converge_sigmas > 0.0)) return fail("converge_sigmas must be positive");
  if (floor_frames < 1) return fail("floor_frames must be at least 1");
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
