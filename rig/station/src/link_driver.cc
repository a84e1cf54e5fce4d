// The link driver (driver.h): odocal's serial protocol.
#include <sstream>

#include "odocal/base/units.h"
#include "odocal/station/driver.h"

namespace odocal::station {
namespace {

using robot_link::ParamSet;

class LinkDriver final : public RobotDriver {
 public:
  LinkDriver(robot_link::Transport& transport, const robot_link::ClientOptions& options)
      : transport_(transport), client_(transport, options) {
    client_.SetTelemetryCallback([this](const robot_link::TelemetrySample& t) {
      if (!running_ || t.run_id != run_id_) return;
      telemetry_.push_back({t.t_ms * kMsToS, std::chrono::steady_clock::now(), t.left_ticks, t.right_ticks,
                            calibration::Pose2::FromXYHeading(t.x_mm * kMmToM, t.y_mm * kMmToM, t.heading_rad)});
    });
  }

  std::string Describe() const override { return "link on " + transport_.Describe(); }

  Status Connect(ParamSet* params, const std::function<void(const std::string&)>& log) override {
    log("connecting to the robot on " + transport_.Describe());
    const auto hello = client_.Hello();
    if (!hello) return Lost("handshake: " + hello.message, hello.status);
    info_ = *hello.value;
    std::ostringstream os;
    os << *hello.value;
    log(os.str());
    const auto read = client_.GetParams();
    if (!read) return Lost("reading the parameters: " + read.message, read.status);
    *params = *read.value;
    // The station polls STATUS and measures with the camera: telemetry
    // would only fill the line.
    if (const auto r = client_.SetTelemetryRate(0); !r)
      return Lost("setting the telemetry rate: " + r.message, r.status);
    return Status::Ok();
  }

  Status Start(const RunRequest& run) override {
    // Telemetry while the run lasts: the ticks for the station's explain.
    telemetry_.clear();
    if (const auto r = client_.SetTelemetryRate(kTelemetryHz); !r)
      return Lost("setting the telemetry rate: " + r.message, r.status);
    const auto started = client_.StartRun(robot_link::RunCommand::FromRunSpec(run.spec));
    if (!started) {
      if (started.status == StatusCode::kNack) return Status::Error(StatusCode::kNack, "start: " + started.message);
      return Lost("start: " + started.message, started.status);
    }
    run_id_ = *started.value;
    running_ = true;
    return Status::Ok();
  }

  // Asking STATUS ourselves (rather than waiting for the event) tells a
  // robot that stopped answering from a run that is merely long.
  Result<RunProgress> Poll() override {
    const auto status = client_.GetStatus();
    if (!status) return Result<RunProgress>::From(Lost(status.message, status.status));
    if (status.value->state != robot_link::RunState::kIdle) return Result<RunProgress>::Ok(RunProgress::kRunning);
    running_ = false;
    if (const auto r = client_.SetTelemetryRate(0); !r)
      return Result<RunProgress>::From(Lost("setting the telemetry rate: " + r.message, r.status));
    if (status.value->last_run_id != run_id_)
      return Result<RunProgress>::Error(StatusCode::kProtocolError,
                                        "the robot is idle and does not know the run (restarted?)");
    const robot_link::RunComplete& done = status.value->last_run;
    if (done.status != robot_link::RunStatus::kCompleted)
      return Result<RunProgress>::Error(StatusCode::kFailed,
                                        "the robot reports the run " + std::string(robot_link::ToString(done.status)));
    return Result<RunProgress>::Ok(RunProgress::kDone);
  }

  // Stop whatever runs, even when we believe nothing does: a stop is harmless.
  Result<std::string> Stop() override {
    using R = Result<std::string>;
    if (!line_ok_)
      return R::Error(StatusCode::kLineCut, "the line is gone: the robot could not be stopped or read over the link");
    const auto stop = client_.Stop();
    if (!stop) return R::Error(stop.status, "could not stop the robot over the link (" + stop.message + ")");
    const bool was_running = running_;
    running_ = false;
    return R::Ok(was_running ? "robot stopped" : "robot idle");
  }

  bool CanApply() const override { return true; }

  Status Apply(const ParamSet& target, int, ParamSet* active) override {
    const auto push = client_.PushParams(target);
    if (!push) {
      const bool refused = push.status == StatusCode::kNack || push.status == StatusCode::kVerifyFailed;
      if (refused) return Status::Error(push.status, "push: " + push.message);
      return Lost("push: " + push.message, push.status);
    }
    *active = push.value->active;
    return Status::Ok();
  }

  bool CanReadBack() const override { return true; }
  std::optional<ParamSet> ReadBack() override {
    if (!line_ok_) return std::nullopt;
    const auto back = client_.GetParams();
    if (!back) return std::nullopt;
    return *back.value;
  }

  bool Reachable() const override { return line_ok_; }
  std::optional<robot_link::RobotInfo> Info() const override { return info_; }
  std::vector<DriverTelemetry> TakeTelemetry(std::string*) override { return std::move(telemetry_); }

 private:
  // An error on the line: the robot link's cause, whatever its code.
  Status Lost(const std::string& message, StatusCode code) {
    if (code == StatusCode::kLineCut) line_ok_ = false;
    return Status::Error(IsLinkFailure(code) ? code : StatusCode::kProtocolError, message);
  }

  static constexpr uint16_t kTelemetryHz = 50;
  robot_link::Transport& transport_;
  std::vector<DriverTelemetry> telemetry_;
  robot_link::Client client_;
  std::optional<robot_link::RobotInfo> info_;
  uint16_t run_id_ = 0;
  bool running_ = false;
  bool line_ok_ = true;
};

}  // namespace

bool IsLinkFailure(StatusCode code) {
  switch (code) {
    case StatusCode::kLineCut:
    case StatusCode::kTimeout:
    case StatusCode::kCrcErrors:
    case StatusCode::kOpenFailed:
    case StatusCode::kIoError:
    case StatusCode::kVersionMismatch:
    case StatusCode::kTableMismatch:
    case StatusCode::kProtocolError:
      return true;
    default:
      return false;
  }
}

std::unique_ptr<RobotDriver> MakeLinkDriver(robot_link::Transport& transport,
                                            const robot_link::ClientOptions& options) {
  return std::make_unique<LinkDriver>(transport, options);
}

}  // namespace odocal::station
