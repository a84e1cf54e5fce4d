// The host side of the odolink protocol: requests with timeouts and retries,
// the atomic parameter push, runs, and the robot's event stream.
//
// Units at this edge are the wire's: millimetres, radians, milliseconds of
// the robot's clock; poses are in the run's start frame (REP-103: x forward,
// y left, heading counter-clockwise positive). RunCommand converts from the
// calibration module's RunSpec, which is in metres.
//
// Retries are safe: a request is retransmitted with the same sequence number
// and the robot answers a repeat from its cached reply instead of executing it
// twice (docs/protocol.md, "Idempotent retries").
#ifndef ODOCAL_ROBOT_LINK_CLIENT_H_
#define ODOCAL_ROBOT_LINK_CLIENT_H_

#include <chrono>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <map>
#include <optional>
#include <string>

#include "odocal/base/status.h"
#include "odocal/calibration/procedures.h"
#include "odocal/robot_link/codec.h"
#include "odocal/robot_link/params.h"
#include "odocal/robot_link/transport.h"
#include "odolink/olf_wire.h"

namespace odocal::robot_link {

struct ClientOptions {
  // How long one attempt waits for its reply. 200 ms is ~100 frame times at
  // 115200 baud: generous for a robot answering from its main loop.
  std::chrono::milliseconds reply_timeout{200};
  // Attempts per request (first try included). At 1 % byte corruption a round
  // trip fails ~40 % of the time; 10 attempts make a lost request ~1e-4.
  int max_attempts = 10;
  // First sequence number; nullopt draws one at random so a new session does
  // not collide with the robot's cached reply from an old one.
  std::optional<uint16_t> first_seq;
  // WaitRunComplete asks for STATUS when no event came for this long, so a
  // lost run-complete event costs a poll, not the run.
  std::chrono::milliseconds status_poll_interval{500};

  bool IsValid(std::string* why) const;
};

enum class BootSource : uint8_t { kDefaults = 0, kSlotA = 1, kSlotB = 2 };

struct RobotInfo {
  int protocol_version = 0;
  std::string robot_name;
  int param_count = 0;
  uint32_t table_crc = 0;
  uint32_t active_set_crc = 0;
  BootSource boot_source = BootSource::kDefaults;
};

// A procedure as the wire carries it (millimetres).
struct RunCommand {
  calibration::Procedure procedure = calibration::Procedure::kUmbmark;
  calibration::Direction direction = calibration::Direction::kCw;
  double amount_mm = 0.0;  // side (umbmark), distance (straight, out_and_back)
  uint32_t count = 0;      // turns (spin), repeats (out_and_back)
  // The run's speeds, 0: the robot's default. Sent only when one is set
  // (a RUN_START of 18 bytes instead of 14); rounded to 1 mm/s, 0.1 deg/s.
  double speed_mm_s = 0.0;
  double turn_rate_deg_s = 0.0;

  static RunCommand FromRunSpec(const calibration::RunSpec& spec);
};

enum class RunState : uint8_t { kIdle = 0, kRunning = 1 };
enum class RunStatus : uint8_t { kCompleted = 0, kStopped = 1, kFailed = 2 };
std::string_view ToString(RunStatus status);

struct TelemetrySample {
  uint32_t t_ms = 0;
  int32_t left_ticks = 0;
  int32_t right_ticks = 0;
  double x_mm = 0.0;
  double y_mm = 0.0;
  double heading_rad = 0.0;
  RunState state = RunState::kIdle;
  uint16_t run_id = 0;
};

struct RunComplete {
  uint16_t run_id = 0;
  RunStatus status = RunStatus::kCompleted;
  uint32_t t_ms = 0;
  int32_t left_ticks = 0;
  int32_t right_ticks = 0;
  double x_mm = 0.0;  // final odometry pose, start frame
  double y_mm = 0.0;
  double heading_rad = 0.0;
};

struct RobotStatus {
  RunState state = RunState::kIdle;
  uint16_t run_id = 0;       // running run, 0 when idle
  uint16_t last_run_id = 0;  // last finished run, 0 if none
  RunComplete last_run;      // valid when last_run_id != 0
  uint32_t frames_ok = 0;    // the robot's own link counters
  uint32_t crc_errors = 0;
  uint32_t framing_errors = 0;
};

struct PushReport {
  ParamSet active;      // read back after the commit, bitwise equal to the target
  uint32_t checksum = 0;
};

class Client {
 public:
  struct Counters {
    uint64_t requests = 0;
    uint64_t retransmissions = 0;
    uint64_t timeouts = 0;
    uint64_t stale_replies = 0;  // replies to an earlier seq (late duplicates)
  };

  // `transport` must outlive the client.
  explicit Client(Transport& transport, const ClientOptions& options = {});

  // Handshake: checks protocol version and parameter table. Call first.
  Result<RobotInfo> Hello();
  Result<ParamSet> GetParams(olf_param_set_id which = OLF_SET_ACTIVE);
  Result<ParamValue> GetParam(std::string_view name);
  // One value, committed atomically with the rest of the active set; returns
  // the new active set as read back.
  Result<ParamSet> SetParam(std::string_view name, const ParamValue& value);
  // Stage the whole set, read the staged set back, commit with its checksum,
  // read the active set back. Ok only when the robot verifiably holds `target`.
  Result<PushReport> PushParams(const ParamSet& target);
  // The previous set becomes active again (and the current one previous).
  Result<ParamSet> Rollback();

  Result<uint16_t> StartRun(const RunCommand& command);  // returns the run id
  Status Stop();
  Status SetTelemetryRate(uint16_t rate_hz);
  Result<RobotStatus> GetStatus();
  // Waits for the run-complete event of `run_id` (polling STATUS if events are
  // lost); telemetry received meanwhile goes to the telemetry callback.
  Result<RunComplete> WaitRunComplete(uint16_t run_id, std::chrono::milliseconds timeout);

  void SetTelemetryCallback(std::function<void(const TelemetrySample&)> callback) {
    telemetry_callback_ = std::move(callback);
  }
  const Counters& counters() const { return counters_; }
  const FrameDecoder::Counters& decoder_counters() const { return decoder_.counters(); }

 private:
  // One request/reply exchange with retries. Returns the ACK body after the
  // echoed request type, or the error (NACKs become kNack with the reason).
  Result<Bytes> Transact(uint8_t type, const Bytes& body);
  // Reads and dispatches frames until `until` or until a reply with `seq`
  // arrives (returned). Events go to the callbacks on the way.
  Result<Frame> Pump(std::optional<uint16_t> seq, std::chrono::steady_clock::time_point until);
  void HandleEvent(const Frame& frame);
  Result<ParamSet> ParseParamSet(const Bytes& body, olf_param_set_id which, uint32_t* mask);

  Transport& transport_;
  ClientOptions options_;
  uint16_t next_seq_;
  FrameDecoder decoder_;
  std::map<uint16_t, RunComplete> completed_runs_;
  std::function<void(const TelemetrySample&)> telemetry_callback_;
  Counters counters_;
};

std::string_view ErrorName(uint8_t olf_error);
std::ostream& operator<<(std::ostream& os, const RobotInfo& info);

}  // namespace odocal::robot_link

#endif  // ODOCAL_ROBOT_LINK_CLIENT_H_
