// The hands-off station: one loop that makes the robot drive a plan
// (UMBMark squares, straights, spins, out-and-backs: plan.h) through a
// driver (driver.h: the odolink serial protocol, a shell command per run, or
// a person at the terminal), measures each run's start and end rest from an
// overhead camera as the frames come, estimates what the plan measures
// (measure::EstimateSession, as batch: UMBMark's coupled Ed and Eb, CVRA's
// ratio, scale and track; turn slip from spins at two rates), applies the
// corrected parameter set (the link pushes it: staged, read back, committed
// with its checksum, verified; command and operator run the `apply`
// command) and verifies it with new runs, until what is left is within the
// measurement uncertainty or a maximum number of rounds. A driver that
// cannot apply measures one round and leaves the corrected set to the user.
//
// The camera also watches each run: a run during which the tag never moved
// fails ("the command exited 0 but the robot did not move"), and a run whose
// heading change is not the plan's (a square driven the wrong way, a spin of
// the wrong number of turns) fails naming both.
//
// The same loop drives a real robot and camera (media::CaptureSource), or
// the built-in virtual robot on a pseudo-terminal with the virtual camera
// rendering it live (simulation::SimCameraSource): RunStation sees a
// RobotDriver and a media::FrameSource, nothing else.
//
// The camera's length scale is batch's (measure::EstimateCameraScale): from
// a floor reference (StationSetup::floor_reference) when one is given and
// its tags are seen in the first start rest, else from the robot tag's
// printed size; the log and report.json say which, and why.
//
// Frames and units: camera poses as in vision/ (world REP-103, the camera's
// tag plane); return errors true - odometry in the run's start frame (SI
// inside); parameter sets in the link's units (mm, ticks). Time: a frame's
// t_s is the camera's clock (robot time for the virtual camera).
//
// Failure rule: whatever goes wrong (camera lost, tag not found at the start,
// robot not answering, run not completed, push refused, Ctrl-C), the robot is
// stopped where the driver allows (over the link; the command killed and the
// stop command run; the operator told) and its parameters are left as they
// were at the start: a set applied by an earlier round and not yet verified
// is applied back out. An apply itself is never interrupted (the stop request
// is read between steps).
#ifndef ODOCAL_STATION_STATION_H_
#define ODOCAL_STATION_STATION_H_

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/base/units.h"
#include "odocal/calibration/explain.h"
#include "odocal/calibration/measured_session.h"
#include "odocal/calibration/procedures.h"
#include "odocal/calibration/rest.h"
#include "odocal/calibration/umbmark.h"
#include "odocal/config/scenario.h"
#include "odocal/measure/estimate_session.h"
#include "odocal/measure/measure.h"
#include "odocal/media/frame_source.h"
#include "odocal/robot_link/client.h"
#include "odocal/robot_link/params.h"
#include "odocal/robot_link/transport.h"
#include "odocal/sim/sim_motion_backend.h"
#include "odocal/station/driver.h"
#include "odocal/station/plan.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/floor_reference.h"
#include "odocal/vision/planar_pose.h"
#include "odocal/vision/tag.h"
#include "odocal/vision/tag_observer.h"

namespace odocal::live {
class LiveState;
}  // namespace odocal::live

namespace odocal::station {

struct StationOptions {
  // Measured rounds. Every round but the last may push a corrected set; the
  // last one only verifies, so a pushed set is always verified.
  int max_rounds = 3;
  // Frames averaged per rest (the sqrt(n) of calibration/rest.h).
  int rest_frames = 12;
  // A rest needs the tag in at least this fraction of its frames.
  double min_rest_found_fraction = 0.5;
  // Frames thrown away before a rest (a real camera's buffer still holds the
  // robot moving) and the wall time to let the robot settle after a run.
  int rest_flush_frames = 0;
  double settle_s = 0.0;
  // Wall time allowed for one run, and between status polls (a frame is
  // taken at each poll while the robot moves).
  std::chrono::milliseconds run_timeout{120000};
  std::chrono::milliseconds poll_interval{30};
  // The camera plane (tilt, height) from the first round's distinct views;
  // the operator's guess when there are too few.
  // The tracker searches the whole frame at every frame the tag is lost:
  // the station sees a moving robot at its poll rate, far apart in time.
  vision::VideoTrackOptions track = [] {
    vision::VideoTrackOptions o;
    o.reacquire_every = 1;
    return o;
  }();
  vision::CameraPlaneOptions plane;
  int max_plane_views = 300;
  // The first round's rest frames in which the tag's edge shift is measured:
  // every (n / this)-th (vision/edge_shift.h; as batch's
  // MeasureOptions::edge_shift_views); 0 = off.
  int edge_shift_frames = 16;
  double min_view_separation_px = 8.0;
  // Floors on a return error's sigma (what the spread of a rest's frames
  // cannot see). The station doubles the position floor to 0.02 mm, the
  // end-to-end agreement of its live, unpipelined camera return errors with
  // rendered truth (docs/vision.md): with the batch's 0.01 mm its first tests
  // saw verification rounds 3.1 sigma from zero with no error left to correct.
  calibration::SystematicFloor systematic_floor{0.02e-3, DegToRad(0.005)};
  // Converged when E_max,syst is within this many of its standard errors
  // and every CVRA factor within this many of 1, each error counting the
  // pushed estimate's too (WithinUncertainty), or when a round does not
  // improve on the one before.
  double converge_sigmas = 3.0;
  // The camera watching a run: the tag has moved once a corner is this far
  // from where it stood; it has stopped (drivers that end by the camera:
  // operator) once every corner stayed within still_px for still_s of the
  // camera's clock. An operator who has not started after start_timeout
  // fails the run.
  double motion_threshold_px = 3.0;
  double still_px = 0.7;
  double still_s = 1.5;
  std::chrono::milliseconds start_timeout{60000};
  // What the camera saw the robot turn, held against the plan
  // (calibration/seen_turning.h): the total when every gap between
  // sightings could be unwrapped, else the end heading modulo a turn and
  // the turning seen in view. Further than this from the plan fails the run
  // (a square the wrong way turns 720 deg from the plan).
  double heading_check_rad = DegToRad(60.0);
  // The fastest the robot turns, for runs whose plan sets no turn rate
  // (those use 1.25 times theirs): across a gap between sightings in
  // which it could turn the step seen or that step's other unwrap, the
  // total turn is unknown (seen_turning.h).
  double max_turn_rate_rad_s = DegToRad(240.0);
  // Turn slip is reported when the slow and fast spins differ by this many sigmas.
  double turn_slip_sigmas = 3.0;
  // Run explain on the first round when it has telemetry.
  bool explain = true;
  // The camera's length scale (measure::EstimateCameraScale, as batch): the
  // print tolerance assumed for the robot tag, the apparent size's floor, the
  // quality gate of the floor tags; and with a floor reference, how many full
  // frames of the first start rest it is measured in.
  measure::CameraScaleOptions camera_scale;
  int floor_frames = 8;

  bool IsValid(std::string* why) const;
};

struct StationSetup {
  // How the robot moves (driver.h); must outlive RunStation. Without one,
  // `transport` (must outlive RunStation) is driven by the link driver.
  RobotDriver* driver = nullptr;
  robot_link::Transport* transport = nullptr;
  robot_link::ClientOptions client;
  // Where a driver writes each run's log ("DIR/runs/run01_umbmark_cw.log");
  // empty: no logs.
  std::string run_log_dir;
  media::FrameSource* camera = nullptr;
  vision::Intrinsics intrinsics;
  vision::CameraMount mount_guess;  // the operator's; tilt and height are refined
  vision::TagSpec tag;
  // The tag's printed size as measured (1 sigma, mm); unset: the print
  // tolerance of options.camera_scale is assumed.
  std::optional<double> tag_size_sigma_mm;
  // Floor tags at taped distances (vision/floor_reference.h): the camera's
  // height, hence every distance, from the tape rather than the robot tag's
  // print. Measured in the first start rest's frames once the plane is known;
  // when it cannot be used the station says why and keeps the tag-size scale.
  std::optional<vision::FloorReference> floor_reference;
  // The runs of one round (umbmark, straight, spin, out_and_back; squares
  // cw and ccw of one side). Empty with `default_plan`: the default plan,
  // sized to the camera's view from where the robot stands (plan.h).
  std::vector<calibration::RunSpec> plan;
  std::optional<DefaultPlanOptions> default_plan;
  // The camera stamps its frames with the robot's clock (the virtual
  // camera renders robot time): telemetry needs no mapping for explain.
  // Otherwise it is put on the camera's clock by the times the frames and
  // the samples arrived at the host.
  bool camera_on_robot_clock = false;
  // Set (e.g. from a signal handler) to stop cleanly; may be null.
  const std::atomic<bool>* stop_requested = nullptr;
  // The live view (rig/live): every frame with the tag's outline and pose,
  // the run and plan, the estimates, the failure; may be null.
  live::LiveState* live = nullptr;
  // One line of progress at a time (the CLI prints them on stderr).
  std::function<void(const std::string&)> progress;
};

enum class StationStatus {
  kOk,
  kInvalidInput,      // plan, options, camera size
  kRobotLink,         // not answering, line cut, CRC errors, wrong protocol
  kTagNotFound,       // not at the start
  kCameraLost,        // no frame, or the tag not seen at a later rest
  kRunNotCompleted,   // refused, stopped, failed or timed out
  kPushRefused,       // the robot refused or could not verify the new set; apply failed
  kEstimateFailed,
  kInterrupted,       // stop requested (Ctrl-C)
};
const char* ToString(StationStatus status);

struct StationRun {
  calibration::RunSpec spec;
  std::string name;  // run01_umbmark_cw
  uint16_t run_id = 0;  // index in the round
  calibration::RestWindow start_rest;
  calibration::RestWindow end_rest;
  calibration::RelativePose return_error;
  int moving_frames = 0;
  int moving_found = 0;
  double max_motion_px = 0.0;  // farthest a corner got from the start rest
  // The heading change the camera saw (unwrapped, CCW +), when no gap
  // between its sightings was too long to unwrap.
  std::optional<double> turned_rad;
  // Time between sightings too long to unwrap the heading across (s).
  double unseen_s = 0.0;
  // Frames the camera should have delivered while the robot moved and the
  // station did not get (by the camera's frame rate, when it states one).
  int frames_dropped = 0;
  std::string log_path;  // the driver's log of the run, if any
};

struct StationIteration {
  robot_link::ParamSet params_used;  // what the robot ran with
  std::vector<StationRun> runs;
  // Everything the round measured, as batch estimates it.
  measure::SessionEstimate session_estimate;
  // UMBMark's, when the plan has squares (estimate.ok() false otherwise).
  calibration::UmbmarkInput input;
  calibration::UmbmarkSummary estimate;
  std::optional<double> emax_sigma_m;  // standard error of E_max,syst
  TurnSlipResult turn_slip;
  // The corrected set this round's estimate gives (from params_used).
  std::optional<robot_link::ParamSet> corrected;
  std::optional<robot_link::ParamSet> pushed;  // applied by the driver
  bool converged = false;
  std::string note;  // why nothing was pushed
};

struct StationResult {
  StationStatus status = StationStatus::kInvalidInput;
  std::string message;
  std::optional<robot_link::RobotInfo> robot;
  std::optional<robot_link::ParamSet> params_initial;
  // Read back from the robot at the end (after a restore on failure); for a
  // driver that cannot read, what it was last applied.
  std::optional<robot_link::ParamSet> params_final;
  // The corrected set the last round gives, when the driver could not apply
  // it (no apply command): for the user to load.
  std::optional<robot_link::ParamSet> params_recommended;
  std::string driver;  // Describe()
  std::string plan_summary;  // the default plan's sizes, when it was used
  std::vector<std::string> findings;  // significant effects, with what to do
  // The first round as recorded (the robot as it came): camera poses of
  // every frame seen, telemetry on the camera's clock where the driver has
  // it (link); and what explain (calibration/explain.h) found in it.
  std::optional<calibration::MeasuredSession> recorded;
  std::optional<calibration::ExplainResult> explain;
  bool restored = false;  // an unverified push was undone
  bool robot_stopped = true;  // false: a stop over the link failed
  std::string cleanup;  // what the failure handling did, in words
  vision::CameraPlaneResult plane;
  bool plane_estimated = false;
  // Where the camera's length scale came from (set once the first round was
  // measured); the camera model's height is camera_scale->camera_height_mm.
  std::optional<measure::CameraScale> camera_scale;
  std::vector<measure::SessionFlag> flags;  // floor_reference_unusable, floor_reference_inconsistent
  std::vector<StationIteration> iterations;
  std::optional<double> improvement;  // first E_max,syst / last
  double wall_s = 0.0;

  bool ok() const { return status == StationStatus::kOk; }
};

// Runs the loop. Never throws; the result says how it went.
StationResult RunStation(const StationSetup& setup, const StationOptions& options);

// The standard error of E_max,syst (radial, for the larger of the two
// centres of gravity): from the spread of repeated squares, else from the
// camera's covariance of each run's return error. nullopt without squares.
std::optional<double> EmaxSystSigma(const calibration::UmbmarkSummary& s, const std::vector<StationRun>& runs);

// The convergence rule, for a round measured after the robot took the
// estimate of round `pushed_from`: E_max,syst within `k` of this round's and
// the pushed estimate's standard errors together (the push left an error of
// about the latter's size, which this round measures with its own), and
// every CVRA factor within `k` of 1 likewise. Says why when it holds (also
// when nothing the round measured has a standard error: nothing to judge
// by, said so), nullopt when not. A UMBMark estimate without a standard
// error of E_max,syst does not hold.
std::optional<std::string> WithinUncertainty(const StationIteration& now, const StationIteration& pushed_from,
                                             double k);

}  // namespace odocal::station

#endif  // ODOCAL_STATION_STATION_H_
