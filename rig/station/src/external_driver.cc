// The command and operator drivers (driver.h): the robot moves by a shell
// command per run or by a person; parameters reach it through an `apply`
// command, if any.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <set>
#include <sstream>
#include <thread>

#include "odocal/base/format.h"
#include "odocal/base/units.h"
#include "odocal/config/files.h"
#include "odocal/measure/pose_log.h"
#include "odocal/report/exports.h"
#include "odocal/station/driver.h"

extern char** environ;

namespace odocal::station {
namespace {

using robot_link::ParamSet;
using Clock = std::chrono::steady_clock;

std::string Number(double v) { return Format("%.10g", v); }
// Every bit of a parameter (an applied set must be the one estimated).
std::string Exact(double v) { return Format("%.17g", v); }

const std::set<std::string>& RunKeys() {
  static const std::set<std::string> keys = {"procedure", "direction", "side_mm",         "distance_mm",
                                             "turns",     "repeats",   "speed_mm_s",      "turn_rate_deg_s",
                                             "run",       "run_name",  "log",             "telemetry"};
  return keys;
}
const std::set<std::string>& ApplyKeys() {
  static const std::set<std::string> keys = {"file",     "ros2",         "left_wheel_diameter_mm",
                                             "right_wheel_diameter_mm", "track_mm", "ticks_per_rev"};
  return keys;
}

std::map<std::string, std::string> RunValues(const RunRequest& run) {
  const calibration::RunSpec& s = run.spec;
  return {{"procedure", std::string(calibration::ToString(s.procedure))},
          {"direction", s.direction == calibration::Direction::kCw ? "cw" : "ccw"},
          {"side_mm", Number(s.side_m * kMToMm)},
          {"distance_mm", Number(s.distance_m * kMToMm)},
          {"turns", std::to_string(s.turns)},
          {"repeats", std::to_string(s.repeats)},
          {"speed_mm_s", Number(s.speed_m_s.value_or(0.0) * kMToMm)},
          {"turn_rate_deg_s", Number(RadToDeg(s.turn_rate_rad_s.value_or(0.0)))},
          {"run", std::to_string(run.index)},
          {"run_name", run.name},
          {"log", run.log_path},
          {"telemetry", run.telemetry_path}};
}

// The last non-empty line of a log, for an error message.
std::string LastLine(const std::string& path) {
  std::ifstream in(path);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

// A shell command in its own process group, output to a log file.
class Child {
 public:
  ~Child() { Kill(); }

  bool Spawn(const std::string& command, const std::string& log_path,
             const std::map<std::string, std::string>& env, std::string* why) {
    posix_spawn_file_actions_t actions;
    posix_spawnattr_t attr;
    posix_spawn_file_actions_init(&actions);
    posix_spawnattr_init(&attr);
    posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    const std::string log = log_path.empty() ? "/dev/null" : log_path;
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attr, 0);
    std::vector<std::string> env_text;
    for (char** e = environ; *e; ++e) {
      const std::string entry = *e;
      const std::string key = entry.substr(0, entry.find('='));
      if (!env.count(key)) env_text.push_back(entry);
    }
    for (const auto& [k, v] : env) env_text.push_back(k + "=" + v);
    std::vector<char*> envp;
    for (std::string& e : env_text) envp.push_back(e.data());
    envp.push_back(nullptr);
    std::string shell = "/bin/sh", dash_c = "-c", text = command;
    char* argv[] = {shell.data(), dash_c.data(), text.data(), nullptr};
    const int rc = posix_spawn(&pid_, "/bin/sh", &actions, &attr, argv, envp.data());
    posix_spawn_file_actions_destroy(&actions);
    posix_spawnattr_destroy(&attr);
    if (rc != 0) {
      pid_ = -1;
      *why = std::string("cannot start /bin/sh: ") + std::strerror(rc);
      return false;
    }
    return true;
  }

  // nullopt while it runs; its wait status once it ended.
  std::optional<int> Poll() {
    if (pid_ <= 0) return exit_status_;
    int status = 0;
    const pid_t r = waitpid(pid_, &status, WNOHANG);
    if (r == pid_) {
      pid_ = -1;
      exit_status_ = status;
    }
    return exit_status_;
  }

  // SIGTERM to the group, SIGKILL after `grace`; true when something was
  // killed. Waits for the whole group (the shell's children too: a driving
  // program may stop the robot on SIGTERM before it exits).
  bool Kill(std::chrono::milliseconds grace = std::chrono::milliseconds(2000)) {
    if (pid_ <= 0 || Poll()) return false;
    const pid_t group = pid_;
    ::kill(-group, SIGTERM);
    const Clock::time_point until = Clock::now() + grace;
    while (Clock::now() < until) {
      Poll();
      if (pid_ <= 0 && ::kill(-group, 0) != 0) return true;  // the group is empty
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ::kill(-group, SIGKILL);
    if (pid_ > 0) {
      int status = 0;
      waitpid(pid_, &status, 0);
      pid_ = -1;
      exit_status_ = status;
    }
    return true;
  }

 private:
  pid_t pid_ = -1;
  std::optional<int> exit_status_;
};

std::string DescribeExit(int status) {
  if (WIFEXITED(status)) return "exited with " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) return "was killed by signal " + std::to_string(WTERMSIG(status));
  return "ended";
}

// What command and operator share: the believed set, and apply.
class ExternalDriver : public RobotDriver {
 public:
  explicit ExternalDriver(const ExternalDriverOptions& options) : options_(options) {}

  Status Connect(ParamSet* params, const std::function<void(const std::string&)>& log) override {
    *params = options_.params;
    log("driver: " + Describe() + "; the robot's parameters as configured (this driver cannot read them)");
    if (options_.apply_command.empty())
      log("no apply command: the station measures, writes the corrected set and stops");
    return Status::Ok();
  }

  bool CanApply() const override { return !options_.apply_command.empty(); }

  Status Apply(const ParamSet& target, int round, ParamSet* active) override {
    const std::string stem = options_.work_dir + "/apply/round" + std::to_string(round);
    if (const Status e = config::EnsureDirectory(options_.work_dir + "/apply"); !e)
      return Status::Error(StatusCode::kFailed, e.message);
    const calibration::WheelParams corrected = robot_link::ToWheelParams(target);
    const std::string firmware = stem + ".firmware.yaml", ros2 = stem + ".ros2.yaml", log = stem + ".log";
    for (const auto& [path, text] :
         {std::pair{firmware, report::FirmwareExportYaml(corrected)},
          std::pair{ros2, report::Ros2ExportYaml(robot_link::ToWheelParams(options_.params), corrected)}}) {
      if (const Status e = config::WriteFileAtomically(path, text); !e)
        return Status::Error(StatusCode::kFailed, e.message);
    }
    const auto command =
        ExpandTemplate(options_.apply_command, {{"file", firmware},
                                                {"ros2", ros2},
                                                {"left_wheel_diameter_mm", Exact(target.left_wheel_diameter_mm)},
                                                {"right_wheel_diameter_mm", Exact(target.right_wheel_diameter_mm)},
                                                {"track_mm", Exact(target.track_mm)},
                                                {"ticks_per_rev", std::to_string(target.ticks_per_rev)}});
    if (!command) return Status::Error(StatusCode::kInvalidArgument, "apply: " + command.message);
    Child child;
    std::string why;
    if (!child.Spawn(*command, log, options_.environment, &why))
      return Status::Error(StatusCode::kFailed, "apply: " + why);
    const Clock::time_point until = Clock::now() + options_.apply_timeout;
    std::optional<int> status;
    while (!(status = child.Poll())) {
      if (Clock::now() > until) {
        child.Kill();
        return Status::Error(StatusCode::kFailed, "apply: no answer within " +
                                                      Number(options_.apply_timeout.count() * kMsToS) +
                                                      " s, killed (log: " + log + ")");
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (!WIFEXITED(*status) || WEXITSTATUS(*status) != 0) {
      const std::string last = LastLine(log);
      return Status::Error(StatusCode::kFailed, "apply: the command " + DescribeExit(*status) +
                                                    (last.empty() ? "" : ": " + last) + " (log: " + log + ")");
    }
    *active = target;
    return Status::Ok();
  }

 protected:
  // Runs the stop command, when there is one; says what happened.
  std::string RunStopCommand() {
    if (options_.stop_command.empty()) return "";
    Child child;
    std::string why;
    if (!child.Spawn(options_.stop_command, options_.work_dir + "/stop.log", options_.environment, &why))
      return "; stop command: " + why;
    const Clock::time_point until = Clock::now() + std::chrono::seconds(10);
    while (!child.Poll() && Clock::now() < until) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    const std::optional<int> status = child.Poll();
    if (!status) {
      child.Kill();
      return "; the stop command hung and was killed";
    }
    return "; stop command " + DescribeExit(*status);
  }

  ExternalDriverOptions options_;
};

class CommandDriver final : public ExternalDriver {
 public:
  using ExternalDriver::ExternalDriver;
  std::string Describe() const override { return "command \"" + options_.run_command + "\""; }

  Status Start(const RunRequest& run) override {
    const auto command = ExpandTemplate(options_.run_command, RunValues(run));
    if (!command) return Status::Error(StatusCode::kInvalidArgument, "command: " + command.message);
    log_ = run.log_path;
    telemetry_path_ = run.telemetry_path;
    if (!telemetry_path_.empty()) std::filesystem::remove(telemetry_path_);
    if (!log_.empty()) {
      std::ofstream(log_, std::ios::app) << "$ " << *command << "\n";
    }
    child_ = std::make_unique<Child>();
    std::string why;
    if (!child_->Spawn(*command, log_, options_.environment, &why))
      return Status::Error(StatusCode::kFailed, "command: " + why);
    return Status::Ok();
  }

  Result<RunProgress> Poll() override {
    using R = Result<RunProgress>;
    if (!child_) return R::Ok(RunProgress::kDone);
    const std::optional<int> status = child_->Poll();
    if (!status) return R::Ok(RunProgress::kRunning);
    child_.reset();
    if (WIFEXITED(*status) && WEXITSTATUS(*status) == 0) return R::Ok(RunProgress::kDone);
    const std::string last = log_.empty() ? "" : LastLine(log_);
    return R::Error(StatusCode::kFailed, "the command " + DescribeExit(*status) + (last.empty() ? "" : ": " + last) +
                                             (log_.empty() ? "" : " (log: " + log_ + ")"));
  }

  Result<std::string> Stop() override {
    std::string what =
        (child_ && child_->Kill() ? "the run's command killed" : "no command running") + RunStopCommand();
    child_.reset();
    return Result<std::string>::Ok(std::move(what));
  }

  // The {telemetry} CSV, when the command wrote one (robot clock; no arrival times).
  std::vector<DriverTelemetry> TakeTelemetry(std::string* note) override {
    std::vector<DriverTelemetry> out;
    if (telemetry_path_.empty() || !std::filesystem::exists(telemetry_path_)) return out;
    const auto records = measure::ReadTelemetryCsv(telemetry_path_, robot_link::ToWheelParams(options_.params));
    if (!records) {
      if (note) *note = "telemetry not used: " + records.message;
      return out;
    }
    for (const calibration::TelemetryRecord& r : *records)
      out.push_back({r.t_s, std::nullopt, r.left_ticks, r.right_ticks, r.odometry});
    return out;
  }

 private:
  std::unique_ptr<Child> child_;
  std::string log_;
  std::string telemetry_path_;
};

class OperatorDriver final : public ExternalDriver {
 public:
  using ExternalDriver::ExternalDriver;
  std::string Describe() const override { return "operator at the terminal"; }

  Status Start(const RunRequest& run) override {
    running_ = true;
    Say("==> run " + std::to_string(run.index) + "/" + std::to_string(run.total) + ": drive " +
        DescribeForOperator(run.spec) + " now. The camera sees when you start and when you stop.");
    return Status::Ok();
  }
  Result<RunProgress> Poll() override { return Result<RunProgress>::Ok(RunProgress::kRunning); }
  bool EndsByCamera() const override { return true; }
  Result<std::string> Stop() override {
    if (!running_) return Result<std::string>::Ok("no run in progress" + RunStopCommand());
    running_ = false;
    Say("==> STOP the robot now and leave it where it is.");
    return Result<std::string>::Ok("the operator was told to stop the robot" + RunStopCommand());
  }

 private:
  void Say(const std::string& line) {
    if (options_.prompt) *options_.prompt << line << std::endl;
  }
  bool running_ = false;
};

}  // namespace

std::string DescribeForOperator(const calibration::RunSpec& s) {
  const std::string way = s.direction == calibration::Direction::kCw ? "clockwise" : "counter-clockwise";
  const std::string rate =
      s.turn_rate_rad_s ? " at " + Number(std::round(RadToDeg(*s.turn_rate_rad_s))) + " deg/s" : "";
  switch (s.procedure) {
    case calibration::Procedure::kUmbmark:
      return Format("the %s %.0f mm UMBMark square", way.c_str(), s.side_m * kMToMm);
    case calibration::Procedure::kStraight:
      return Format("straight %s %.0f mm", s.distance_m < 0 ? "backwards" : "ahead", std::abs(s.distance_m) * kMToMm);
    case calibration::Procedure::kSpin:
      return Format("%d %s turn%s in place%s", s.turns, way.c_str(), s.turns == 1 ? "" : "s", rate.c_str());
    case calibration::Procedure::kOutAndBack:
      return Format("out %.0f mm and back, turning %s, %d time%s", s.distance_m * kMToMm, way.c_str(), s.repeats,
                    s.repeats == 1 ? "" : "s");
    default:
      return std::string(calibration::ToString(s.procedure));
  }
}

Result<std::string> ExpandTemplate(const std::string& text, const std::map<std::string, std::string>& values) {
  const auto fail = [](std::string why) {
    return Result<std::string>::Error(StatusCode::kInvalidArgument, std::move(why));
  };
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '}') return fail("'}' without '{' at character " + std::to_string(i + 1) + " of \"" + text + "\"");
    if (text[i] != '{') {
      out += text[i];
      continue;
    }
    const size_t close = text.find('}', i);
    if (close == std::string::npos) return fail("'{' without '}' in \"" + text + "\"");
    const std::string key = text.substr(i + 1, close - i - 1);
    const auto it = values.find(key);
    if (it == values.end()) return fail("unknown placeholder {" + key + "} in \"" + text + "\"");
    out += it->second;
    i = close;
  }
  return Result<std::string>::Ok(std::move(out));
}

Status CheckTemplate(const std::string& text, const std::string& kind) {
  std::map<std::string, std::string> blanks;
  for (const std::string& k : kind == "apply" ? ApplyKeys() : RunKeys()) blanks[k] = "";
  const Result<std::string> expanded = ExpandTemplate(text, blanks);
  if (!expanded) return Status::Error(expanded.status, expanded.message);
  return Status::Ok();
}

std::unique_ptr<RobotDriver> MakeCommandDriver(const ExternalDriverOptions& options) {
  return std::make_unique<CommandDriver>(options);
}
std::unique_ptr<RobotDriver> MakeOperatorDriver(const ExternalDriverOptions& options) {
  return std::make_unique<OperatorDriver>(options);
}

}  // namespace odocal::station
