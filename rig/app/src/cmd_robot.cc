// odocal robot info|get|set|push|rollback --port DEV: hand use of the robot
// link. Every failure prints one line on stderr naming the cause and exits
// with a code per cause (see kExit* below), after which the robot holds
// exactly what it held before, or the verified new set.
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "commands.h"
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

[[noreturn]] void Fail(int code, const std::string& message) {
  std::cerr << "odocal robot: " << message << "\n";
  throw CLI::RuntimeError(code);
}

template <typename T>
T Check(odocal::Result<T> r) {
  if (!r.ok()) Fail(ExitCode(r.status), r.message);
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
  if (!options.IsValid(&why)) Fail(kExitOther, why);
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
    Fail(kExitOther, "unknown parameter '" + name + "' (known:" + known + ")");
  }
  return *index;
}

rl::ParamValue ValueOrFail(size_t index, const std::string& text) {
  std::optional<rl::ParamValue> v = rl::ParseValue(index, text);
  if (!v) {
    Fail(kExitOther, "bad value '" + text + "' for " + std::string(rl::ParamTable()[index].name) +
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

}  // namespace

void RegisterRobotCommand(CLI::App& app) {
  CLI::App* robot = app.add_subcommand("robot", "talk to a robot over its serial link");
  robot->require_subcommand(1);

  auto flags = std::make_shared<LinkFlags>();

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

  auto set_name = std::make_shared<std::string>();
  auto set_value = std::make_shared<std::string>();
  CLI::App* set = robot->add_subcommand("set", "change one parameter (committed atomically)");
  AddLinkFlags(set, flags.get());
  set->add_option("name", *set_name, "parameter name")->required();
  set->add_option("value", *set_value, "new value")->required();
  set->callback([flags, set_name, set_value] {
    const size_t index = ParamIndexOrFail(*set_name);
    const rl::ParamValue value = ValueOrFail(index, *set_value);
    Session s = Connect(*flags);
    PrintSet(Check(s.client->SetParam(*set_name, value)));
  });

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
      if (eq == std::string::npos) Fail(kExitOther, "expected NAME=VALUE, got '" + a + "'");
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

  CLI::App* rollback = robot->add_subcommand("rollback", "make the previous set active again");
  AddLinkFlags(rollback, flags.get());
  rollback->callback([flags] {
    Session s = Connect(*flags);
    PrintSet(Check(s.client->Rollback()));
  });
}

}  // namespace odocal::app
