// How the station makes a robot move, and how corrected parameters reach it
// (station.yaml `robot: {driver: link | command | operator}`):
//
//   link      odocal's serial protocol (robot_link::Client): the robot drives
//             each run itself and says when it is done; parameter sets are
//             pushed (staged, read back, committed, verified) and read back.
//   command   a shell command per run, from a template ("ros2 run my_robot
//             drive_square --direction {direction} --side {side_mm}"); exit
//             0 = the run is done, anything else = it failed; a run that
//             outlasts the station's run timeout is killed (its process
//             group: SIGTERM, then SIGKILL) and an optional `stop` command
//             runs. Its stdout and stderr go to the run's log file.
//   operator  a person drives: the station says which run on the terminal
//             and the camera tells when the robot started and stopped.
//
// command and operator cannot push: the station writes the corrected set
// (the firmware export, the ROS 2 multipliers) and, when an `apply` command
// template is configured, runs it with the file's path; the next round then
// verifies it, as with the link. Without one the station measures once and
// leaves the files for the user to load.
//
// Placeholders in the command templates: {procedure} {direction} {side_mm}
// {distance_mm} {turns} {repeats} {speed_mm_s} {turn_rate_deg_s} {run}
// {run_name} {log} {telemetry}; in `apply`: {file} (the firmware export),
// {ros2} (the multipliers), {left_wheel_diameter_mm}
// {right_wheel_diameter_mm} {track_mm} {ticks_per_rev}. An unknown
// placeholder is an error when the template is read (CheckTemplate).
#ifndef ODOCAL_STATION_DRIVER_H_
#define ODOCAL_STATION_DRIVER_H_

#include <chrono>
#include <functional>
#include <iosfwd>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/calibration/pose2.h"
#include "odocal/calibration/procedures.h"
#include "odocal/robot_link/client.h"
#include "odocal/robot_link/params.h"
#include "odocal/robot_link/transport.h"

namespace odocal::station {

// A driver's error is a Status. Its code says what went wrong, and the station's
// cause (station.h StationStatus) follows from the code and the call:
// - the line's codes (IsLinkFailure: kLineCut, kTimeout, kCrcErrors, kOpenFailed, kIoError,
//   kVersionMismatch, kTableMismatch, kProtocolError) are the robot link's, whatever the call;
// - otherwise Start's and Poll's (kNack: refused; kFailed: failed, a non-zero exit, killed;
//   kInvalidArgument: a command template that does not expand) mean the run was not completed,
//   and Apply's (kNack, kVerifyFailed, kFailed, kInvalidArgument) that the push was refused.
// A driver that is not on a line (command, operator) never returns the line's codes.
bool IsLinkFailure(StatusCode code);

// The run the station asks for, as the templates see it.
struct RunRequest {
  calibration::RunSpec spec;
  int index = 0, total = 0;  // 1-based
  std::string name;          // "run03_spin_ccw"
  std::string log_path;      // where the driver writes the run's log (may be empty)
  std::string telemetry_path;  // where a command may write telemetry (may be empty)
};

// "the clockwise 2000 mm UMBMark square", "3 counter-clockwise turns in place at 45 deg/s".
std::string DescribeForOperator(const calibration::RunSpec& spec);

enum class RunProgress { kRunning, kDone };

// One telemetry sample of the last run: the robot's clock, and when it
// arrived where the driver knows (the link); the station puts it on the
// camera's clock by the arrivals, or else by when the camera saw the motion
// start and end.
struct DriverTelemetry {
  double robot_t_s = 0.0;
  std::optional<std::chrono::steady_clock::time_point> received;
  int64_t left_ticks = 0, right_ticks = 0;
  calibration::Pose2 odometry;  // the robot's belief, in the run's start frame
};

class RobotDriver {
 public:
  virtual ~RobotDriver() = default;
  virtual std::string Describe() const = 0;
  // Connects; `params` gets the set the robot runs with.
  virtual Status Connect(robot_link::ParamSet* params, const std::function<void(const std::string&)>& log) = 0;
  virtual Status Start(const RunRequest& run) = 0;
  // kDone once the driver knows the run ended well; an error when it ended
  // badly. A driver that cannot tell (operator) stays kRunning: the camera
  // decides (EndsByCamera).
  virtual Result<RunProgress> Poll() = 0;
  virtual bool EndsByCamera() const { return false; }
  // Best effort, never throws: stops whatever runs. What it did; an error
  // (kLineCut, kFailed) saying why when the robot could not be told to stop.
  virtual Result<std::string> Stop() = 0;
  // Whether Apply can change the robot's parameters.
  virtual bool CanApply() const = 0;
  // Makes `target` the robot's set; `round` names the files written.
  // `active` gets what the robot runs with afterwards.
  virtual Status Apply(const robot_link::ParamSet& target, int round, robot_link::ParamSet* active) = 0;
  // The set as the robot reports it (nullopt when asking failed), where the
  // driver can ask (CanReadBack).
  virtual bool CanReadBack() const { return false; }
  virtual std::optional<robot_link::ParamSet> ReadBack() { return std::nullopt; }
  // False once the driver can no longer reach the robot at all.
  virtual bool Reachable() const { return true; }
  // What the robot said of itself when connected (the link's handshake: its name, its serial):
  // the name its records are kept under. Drivers that cannot ask: nothing.
  virtual std::optional<robot_link::RobotInfo> Info() const { return std::nullopt; }
  // The last run's telemetry (moved out), where the driver has any: the
  // link's, at 50 Hz while a run lasts; the command's {telemetry} CSV
  // (docs/formats.md), when it wrote one. `note` says why a file was not used.
  virtual std::vector<DriverTelemetry> TakeTelemetry(std::string* /*note*/) { return {}; }
};

// ---- link -------------------------------------------------------------------
std::unique_ptr<RobotDriver> MakeLinkDriver(robot_link::Transport& transport,
                                            const robot_link::ClientOptions& options);

// ---- command and operator ---------------------------------------------------
struct ExternalDriverOptions {
  std::string run_command;    // command: required; operator: unused
  std::string stop_command;   // optional, after a kill or a failure
  std::string apply_command;  // optional
  std::chrono::milliseconds apply_timeout{60000};
  // The set the robot runs with (the operator's word: it cannot be read).
  robot_link::ParamSet params;
  // Where exports and apply logs go.
  std::string work_dir = ".";
  // Extra environment for the commands (e.g. ODOCAL_ROBOT_PORT).
  std::map<std::string, std::string> environment;
  // The operator's terminal.
  std::ostream* prompt = nullptr;
};

// Template text with its placeholders replaced; kInvalidArgument naming an
// unknown placeholder or an unbalanced brace.
Result<std::string> ExpandTemplate(const std::string& text, const std::map<std::string, std::string>& values);
// Whether `text` uses only the placeholders the driver fills for `kind`
// ("run" or "apply"); kInvalidArgument naming the first unknown one.
Status CheckTemplate(const std::string& text, const std::string& kind);

std::unique_ptr<RobotDriver> MakeCommandDriver(const ExternalDriverOptions& options);
std::unique_ptr<RobotDriver> MakeOperatorDriver(const ExternalDriverOptions& options);

}  // namespace odocal::station

#endif  // ODOCAL_STATION_DRIVER_H_
