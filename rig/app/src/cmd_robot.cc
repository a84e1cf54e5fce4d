// odocal robot info|get|set|push|rollback|run --port DEV: hand use of the robot
// link (`run` drives one procedure: what a station `command` driver's script
// or a person at the keyboard calls). Every failure prints one line on stderr naming the cause and exits
// with a code per cause (see kExit* below), after which the robot holds
// exactly what it held before, or the verified new set.
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <thread>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "odocal/base/units.h"
#include "odocal/calibration/procedures.h"
#include "odocal/robot_link/client.h"
#include "odocal/robot_link/serial_transport.h"

namespace odocal::app {
namespace {

namespace rl = odocal::robot_link;

// Exit codes, one per cause a script may want to tell apart.
constexpr int kExitOther = 1;
constexpr int kExitOpen = 2;        // wrong device path, permissions, not a tty
constexpr int kExitTimeout = 3;     // robot not answering
constexpr int kExitCrc = 4;         // frames arrive but fail CRC (noise, baud)
constexpr int kExitVersion = 5;     // other protocol version or parameter table
constexpr int kExitLineCut = 6;     // cable pulled, device gone
constexpr int kExitRefused = 7;     // robot refused (NACK)
constexpr int kExitVerify = 8;      // read-back differs
constexpr int kExitRunFailed = 9;   // run: stopped, failed, timed out
constexpr int kExitInterrupted = 130;  // run: SIGINT/SIGTERM, the robot stopped

int ExitCode(odocal::StatusCode s) {
  switch (s) {
    case odocal::StatusCode::kOpenFailed: return kExitOpen;
    case odocal::StatusCode::kTimeout: return kExitTimeout;
    case odocal::StatusCode::kCrcErrors: return kExitCrc;
    case odocal::StatusCode::kVersionMismatch:
    case odocal::StatusCode::kTableMismatch: return kExitVersion;
    case odocal::StatusCode::kLineCut: return kExitLineCut;
    case odocal::StatusCode::kNack: return kExitRefused;
    case odocal::StatusCode::kVerifyFailed: return kExitVerify;
    default: return kExitOther;
  }
}

[[noreturn]] void FailRobot(int code, const std::string& message) {
  std::cerr << "odocal robot: " << message << "\n";
  throw CLI::RuntimeError(code);
}

template <typename T>
T Check(odocal::Result<T> r) {
  if (!r.ok()) FailRobot(ExitCode(r.status), r.message);
  return std::move(*r.value);
}

struct LinkFlags {
  std::string port;
  int baud = 115200;
  int timeout_ms = 200;
  int attempts = 10;
};

// An open, handshaken connection.
struct Session {
  std::unique_ptr<rl::SerialTransport> transport;
  std::unique_ptr<rl::Client> client;
  rl::RobotInfo info;
};

Session Connect(const LinkFlags& f) {
  rl::SerialOptions serial;
  serial.baud = f.baud;
  Session s;
  s.transport = Check(rl::SerialTransport::Open(f.port, serial));
  rl::ClientOptions options;
  options.reply_timeout = std::chrono::milliseconds(f.timeout_ms);
  options.max_attempts = f.attempts;
  std::string why;
  if (!options.IsValid(&why)) FailRobot(kExitOther, why);
  s.client = std::make_unique<rl::Client>(*s.transport, options);
  s.info = Check(s.client->Hello());
  return s;
}

void PrintSet(const rl::ParamSet& set) {
  for (size_t i = 0; i < rl::ParamTable().size(); ++i) {
    std::cout << rl::ParamTable()[i].name << " = " << rl::FormatValue(set.Get(i)) << "\n";
  }
}

size_t ParamIndexOrFail(const std::string& name) {
  const std::optional<size_t> index = rl::FindParam(name);
  if (!index) {
    std::string known;
    for (const rl::ParamInfo& p : rl::ParamTable()) known += " " + std::string(p.name);
    FailRobot(kExitOther, "unknown parameter '" + name + "' (known:" + known + ")");
  }
  return *index;
}

rl::ParamValue ValueOrFail(size_t index, const std::string& text) {
  std::optional<rl::ParamValue> v = rl::ParseValue(index, text);
  if (!v) {
    FailRobot(kExitOther, "bad value '" + text + "' for " + std::string(rl::ParamTable()[index].name) +
                         (rl::ParamTable()[index].type == rl::ParamType::kU32
                              ? " (expected an unsigned integer)"
                              : " (expected a number)"));
  }
  return *v;
}

void AddLinkFlags(CLI::App* cmd, LinkFlags* f) {
  cmd->add_option("--port", f->port, "serial device: /dev/ttyUSB0, /dev/ttyACM0, /dev/pts/N")
      ->required();
  cmd->add_option("--baud", f->baud, "baud rate (8N1)")->capture_default_str();
  cmd->add_option("--timeout-ms", f->timeout_ms, "reply timeout per attempt, ms")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--attempts", f->attempts, "attempts per request")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
}


// `robot run`: one procedure, driven to its end.
struct RunFlags {
  std::string procedure;
  std::string direction = "ccw";
  double side_mm = 0.0, distance_mm = 0.0;
  int turns = 0, repeats = 1;
  double speed_mm_s = 0.0, turn_rate_deg_s = 0.0;
  double timeout_s = 300.0;
  std::string telemetry;
};

std::atomic<bool> g_run_stop{false};
void OnRunSignal(int) { g_run_stop = true; }

calibration::RunSpec RunSpecOrFail(const RunFlags& f) {
  using calibration::Procedure;
  const std::optional<Procedure> p = calibration::ParseProcedure(f.procedure);
  if (!p || (*p != Procedure::kUmbmark && *p != Procedure::kStraight && *p != Procedure::kSpin &&
             *p != Procedure::kOutAndBack))
    FailRobot(kExitOther, "--procedure '" + f.procedure + "': expected umbmark, straight, spin or out_and_back");
  const calibration::Direction d = f.direction == "cw" ? calibration::Direction::kCw : calibration::Direction::kCcw;
  calibration::RunSpec spec;
  switch (*p) {
    case Procedure::kUmbmark: spec = calibration::RunSpec::Umbmark(d, f.side_mm * kMmToM); break;
    case Procedure::kStraight: spec = calibration::RunSpec::Straight(f.distance_mm * kMmToM); break;
    case Procedure::kSpin: spec = calibration::RunSpec::Spin(f.turns, d); break;
    default: spec = calibration::RunSpec::OutAndBack(f.distance_mm * kMmToM, f.repeats, d); break;
  }
  if (f.speed_mm_s > 0.0) spec.speed_m_s = f.speed_mm_s * kMmToM;
  if (f.turn_rate_deg_s > 0.0) spec.turn_rate_rad_s = DegToRad(f.turn_rate_deg_s);
  std::string why;
  if (!spec.IsValid(&why)) FailRobot(kExitOther, "run: " + why + " (--side-mm, --distance-mm, --turns, --repeats)");
  return spec;
}

// Starts the run and polls STATUS until it ends; telemetry (with --telemetry)
// to a CSV as batch reads it (docs/formats.md). SIGINT/SIGTERM or the
// timeout stop the robot over the link before exiting.
void DriveOneRun(const LinkFlags& link, const RunFlags& f) {
  const calibration::RunSpec spec = RunSpecOrFail(f);
  std::ofstream csv;
  if (!f.telemetry.empty()) {
    csv.open(f.telemetry);
    if (!csv) FailRobot(kExitOther, "--telemetry " + f.telemetry + ": cannot write");
    csv << "t_s,left_ticks,right_ticks,x_mm,y_mm,heading_deg,moving\n";
  }
  // The handler first: a SIGTERM while the link is being opened must not
  // kill the process silently (the caller reads this log to know whether
  // the robot moved).
  std::signal(SIGINT, OnRunSignal);
  std::signal(SIGTERM, OnRunSignal);
  Session s = Connect(link);
  if (!f.telemetry.empty()) {
    s.client->SetTelemetryCallback([&csv](const rl::TelemetrySample& t) {
      char line[160];
      std::snprintf(line, sizeof(line), "%.3f,%d,%d,%.4f,%.4f,%.6f,%d\n", t.t_ms * kMsToS, t.left_ticks, t.right_ticks,
                    t.x_mm, t.y_mm, RadToDeg(t.heading_rad), t.state == rl::RunState::kRunning ? 1 : 0);
      csv << line;
    });
    Check(s.client->SetTelemetryRate(50));
  }
  if (g_run_stop) FailRobot(kExitInterrupted, "interrupted before the run started: the robot did not move");
  const uint16_t id = Check(s.client->StartRun(rl::RunCommand::FromRunSpec(spec)));
  std::cerr << "odocal robot: run " << id << " started\n";
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    const bool timed_out = std::chrono::steady_clock::now() - t0 > std::chrono::duration<double>(f.timeout_s);
    if (g_run_stop || timed_out) {
      const odocal::Status stopped = s.client->Stop();
      FailRobot(timed_out ? kExitRunFailed : kExitInterrupted,
           std::string(timed_out ? "run not completed within --timeout-s" : "interrupted") +
               (stopped.ok() ? ": robot stopped" : ": could not stop the robot (" + stopped.message + ")"));
    }
    const rl::RobotStatus status = Check(s.client->GetStatus());
    if (status.state == rl::RunState::kIdle) {
      if (status.last_run_id != id) FailRobot(kExitRunFailed, "the robot is idle and does not know run " + std::to_string(id));
      if (status.last_run.status != rl::RunStatus::kCompleted)
        FailRobot(kExitRunFailed, "the robot reports the run " + std::string(rl::ToString(status.last_run.status)));
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (!f.telemetry.empty()) s.client->SetTelemetryRate(0);
  std::cout << "run " << id << " completed\n";
}

// `robot info`: the handshake and the robot's status.
void AddRobotInfoCommand(CLI::App* robot, const std::shared_ptr<LinkFlags>& flags) {
  CLI::App* info = robot->add_subcommand("info", "handshake and print what the robot reports");
  AddLinkFlags(info, flags.get());
  info->callback([flags] {
    Session s = Connect(*flags);
    const rl::RobotStatus status = Check(s.client->GetStatus());
    std::cout << "robot: " << s.info.robot_name << "\n"
              << "protocol_version: " << s.info.protocol_version << "\n"
              << "parameters: " << s.info.param_count << "\n"
              << "boot_source: "
              << (s.info.boot_source == rl::BootSource::kDefaults ? "defaults" : "storage") << "\n"
              << "state: " << (status.state == rl::RunState::kRunning ? "running" : "idle") << "\n"
              << "link_frames_ok: " << status.frames_ok << "\n"
              << "link_crc_errors: " << status.crc_errors << "\n";
  });
}

// `robot get`: the active, staged or previous set (all of it, or the named parameters).
void AddRobotGetCommand(CLI::App* robot, const std::shared_ptr<LinkFlags>& flags) {
  auto get_names = std::make_shared<std::vector<std::string>>();
  auto which = std::make_shared<std::string>("active");
  CLI::App* get = robot->add_subcommand("get", "print parameters (all, or the named ones)");
  AddLinkFlags(get, flags.get());
  get->add_option("names", *get_names, "parameter names");
  get->add_option("--which", *which, "which set: active, staged, previous")
      ->check(CLI::IsMember({"active", "staged", "previous"}))
      ->capture_default_str();
  get->callback([flags, get_names, which] {
    for (const std::string& n : *get_names) ParamIndexOrFail(n);
    Session s = Connect(*flags);
    const olf_param_set_id id = *which == "staged"     ? OLF_SET_STAGED
                                : *which == "previous" ? OLF_SET_PREVIOUS
                                                       : OLF_SET_ACTIVE;
    const rl::ParamSet set = Check(s.client->GetParams(id));
    if (get_names->empty()) {
      PrintSet(set);
      return;
    }
    for (const std::string& n : *get_names) {
      std::cout << n << " = " << rl::FormatValue(set.Get(ParamIndexOrFail(n))) << "\n";
    }
  });
}

// `robot set`: one parameter, committed atomically.
void AddRobotSetCommand(CLI::App* robot, const std::shared_ptr<LinkFlags>& flags) {
  auto set_name = std::make_shared<std::string>();
  auto set_value = std::make_shared<std::string>();
  CLI::App* set = robot->add_subcommand("set", "change one parameter (committed atomically): NAME VALUE or NAME=VALUE");
  AddLinkFlags(set, flags.get());
  set->add_option("name", *set_name, "parameter name, or NAME=VALUE as push takes it")->required();
  set->add_option("value", *set_value, "new value");
  set->callback([flags, set_name, set_value] {
    // NAME=VALUE as push takes it, or NAME VALUE; not both, not neither.
    if (const size_t eq = set_name->find('='); eq != std::string::npos) {
      if (!set_value->empty())
        FailRobot(kExitOther, "give NAME VALUE or NAME=VALUE, not both ('" + *set_name + "' and '" + *set_value + "')");
      *set_value = set_name->substr(eq + 1);
      set_name->resize(eq);
    }
    if (set_value->empty()) FailRobot(kExitOther, "no value for '" + *set_name + "': NAME VALUE or NAME=VALUE");
    const size_t index = ParamIndexOrFail(*set_name);
    const rl::ParamValue value = ValueOrFail(index, *set_value);
    Session s = Connect(*flags);
    PrintSet(Check(s.client->SetParam(*set_name, value)));
  });
}

// `robot push`: a whole set staged, read back, committed and verified.
void AddRobotPushCommand(CLI::App* robot, const std::shared_ptr<LinkFlags>& flags) {
  auto assignments = std::make_shared<std::vector<std::string>>();
  CLI::App* push = robot->add_subcommand(
      "push", "stage a whole set (NAME=VALUE; unnamed ones keep their value), read it back, "
              "commit it with its checksum, verify the active set");
  AddLinkFlags(push, flags.get());
  push->add_option("assignments", *assignments, "NAME=VALUE ...")->required();
  push->callback([flags, assignments] {
    std::map<size_t, rl::ParamValue> changes;
    for (const std::string& a : *assignments) {
      const size_t eq = a.find('=');
      if (eq == std::string::npos) FailRobot(kExitOther, "expected NAME=VALUE, got '" + a + "'");
      const size_t index = ParamIndexOrFail(a.substr(0, eq));
      changes[index] = ValueOrFail(index, a.substr(eq + 1));
    }
    Session s = Connect(*flags);
    rl::ParamSet target = Check(s.client->GetParams());
    for (const auto& [index, value] : changes) target.Set(index, value);
    const rl::PushReport report = Check(s.client->PushParams(target));
    PrintSet(report.active);
    std::cout << "verified: checksum 0x" << std::hex << report.checksum << std::dec << "\n";
  });
}

// `robot rollback`: the previous set active again.
void AddRobotRollbackCommand(CLI::App* robot, const std::shared_ptr<LinkFlags>& flags) {
  CLI::App* rollback = robot->add_subcommand("rollback", "make the previous set active again");
  AddLinkFlags(rollback, flags.get());
  rollback->callback([flags] {
    Session s = Connect(*flags);
    PrintSet(Check(s.client->Rollback()));
  });
}

// `robot run`: one procedure driven to its end (DriveOneRun).
void AddRobotRunCommand(CLI::App* robot, const std::shared_ptr<LinkFlags>& flags) {
  auto run = std::make_shared<RunFlags>();
  CLI::App* run_cmd = robot->add_subcommand(
      "run", "drive one procedure to its end (exit 0: completed; 9: stopped, failed or timed out; "
             "130: interrupted, the robot stopped)");
  AddLinkFlags(run_cmd, flags.get());
  run_cmd->add_option("--procedure", run->procedure, "umbmark, straight, spin, out_and_back")->required();
  run_cmd->add_option("--direction", run->direction, "cw or ccw")
      ->check(CLI::IsMember({"cw", "ccw"}))
      ->capture_default_str();
  run_cmd->add_option("--side-mm", run->side_mm, "umbmark: the square's side");
  run_cmd->add_option("--distance-mm", run->distance_mm, "straight (negative: backwards), out_and_back");
  run_cmd->add_option("--turns", run->turns, "spin: whole turns");
  run_cmd->add_option("--repeats", run->repeats, "out_and_back: repeats")->capture_default_str();
  run_cmd->add_option("--speed-mm-s", run->speed_mm_s, "straights' speed (0: the robot's default)");
  run_cmd->add_option("--turn-rate-deg-s", run->turn_rate_deg_s, "in-place turns' rate (0: the robot's default)");
  run_cmd->add_option("--timeout-s", run->timeout_s, "stop the robot and fail after this long")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  run_cmd->add_option("--telemetry", run->telemetry, "write the run's telemetry CSV (docs/formats.md)");
  run_cmd->callback([flags, run] { DriveOneRun(*flags, *run); });
}

}  // namespace

void RegisterRobotCommand(CLI::App& app) {
  CLI::App* robot = app.add_subcommand("robot", "talk to a robot over its serial link");
  robot->require_subcommand(1);

  auto flags = std::make_shared<LinkFlags>();
  AddRobotInfoCommand(robot, flags);
  AddRobotGetCommand(robot, flags);
  AddRobotSetCommand(robot, flags);
  AddRobotPushCommand(robot, flags);
  AddRobotRollbackCommand(robot, flags);
  AddRobotRunCommand(robot, flags);
}

}  // namespace odocal::app
