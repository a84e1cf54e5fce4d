#include "odocal/robot_link/client.h"

#include <algorithm>
#include <cassert>
#include <array>
#include <ostream>
#include <random>
#include <sstream>

#include "odocal/base/units.h"

namespace odocal::robot_link {
namespace {

using Clock = std::chrono::steady_clock;

std::string_view TypeName(uint8_t type) {
  switch (type) {
    case OLF_MSG_HELLO: return "HELLO";
    case OLF_MSG_PARAM_GET: return "PARAM_GET";
    case OLF_MSG_PARAM_SET: return "PARAM_SET";
    case OLF_MSG_STAGE_BEGIN: return "STAGE_BEGIN";
    case OLF_MSG_STAGE_PUT: return "STAGE_PUT";
    case OLF_MSG_PARAMS_READ: return "PARAMS_READ";
    case OLF_MSG_COMMIT: return "COMMIT";
    case OLF_MSG_ROLLBACK: return "ROLLBACK";
    case OLF_MSG_RUN_START: return "RUN_START";
    case OLF_MSG_STOP: return "STOP";
    case OLF_MSG_TELEMETRY_RATE: return "TELEMETRY_RATE";
    case OLF_MSG_STATUS: return "STATUS";
    default: return "UNKNOWN";
  }
}

uint8_t WireProcedure(calibration::Procedure p) {
  switch (p) {
    case calibration::Procedure::kUmbmark: return OLF_PROC_UMBMARK;
    case calibration::Procedure::kStraight: return OLF_PROC_STRAIGHT;
    case calibration::Procedure::kSpin: return OLF_PROC_SPIN;
    case calibration::Procedure::kOutAndBack: return OLF_PROC_OUT_AND_BACK;
    case calibration::Procedure::kRecorded: return 0;  // not drivable: the firmware refuses 0
    case calibration::Procedure::kCircle: return 0;    // simulator only: not on the wire yet
  }
  return 0;
}

bool ValueMatchesType(size_t index, const ParamValue& value) {
  return (ParamTable()[index].type == ParamType::kF64) == std::holds_alternative<double>(value);
}

std::string Hex32(uint32_t v) {
  std::ostringstream os;
  os << "0x" << std::hex << v;
  return os.str();
}

}  // namespace

std::string_view ToString(RunStatus status) {
  switch (status) {
    case RunStatus::kCompleted: return "completed";
    case RunStatus::kStopped: return "stopped";
    case RunStatus::kFailed: return "failed";
  }
  return "?";
}

std::string_view ErrorName(uint8_t e) {
  switch (e) {
    case OLF_ERR_BAD_VERSION: return "unsupported protocol version";
    case OLF_ERR_UNKNOWN_TYPE: return "unknown request type";
    case OLF_ERR_MALFORMED: return "malformed request";
    case OLF_ERR_UNKNOWN_PARAM: return "unknown parameter";
    case OLF_ERR_TYPE_MISMATCH: return "wrong parameter type";
    case OLF_ERR_OUT_OF_RANGE: return "value out of range";
    case OLF_ERR_STAGE_INCOMPLETE: return "staged set incomplete";
    case OLF_ERR_CHECKSUM: return "checksum of the staged set does not match";
    case OLF_ERR_STORAGE: return "persisting to storage failed, previous set kept";
    case OLF_ERR_BUSY: return "a run is in progress";
    case OLF_ERR_NO_PREVIOUS: return "no previous parameter set";
    case OLF_ERR_REJECTED: return "the robot's motion code refused the run";
    case OLF_ERR_BAD_PROCEDURE: return "invalid procedure arguments";
    default: return "unknown error";
  }
}

bool ClientOptions::IsValid(std::string* why) const {
  const auto fail = [why](const char* what) {
    if (why) *why = what;
    return false;
  };
  if (reply_timeout.count() <= 0) return fail("reply_timeout must be positive");
  if (max_attempts < 1) return fail("max_attempts must be at least 1");
  if (status_poll_interval.count() <= 0) return fail("status_poll_interval must be positive");
  return true;
}

RunCommand RunCommand::FromRunSpec(const calibration::RunSpec& spec) {
  RunCommand c;
  c.procedure = spec.procedure;
  c.direction = spec.direction;
  switch (spec.procedure) {
    case calibration::Procedure::kUmbmark:
      c.amount_mm = spec.side_m * kMToMm;
      break;
    case calibration::Procedure::kStraight:
      c.amount_mm = spec.distance_m * kMToMm;
      break;
    case calibration::Procedure::kSpin: c.count = static_cast<uint32_t>(spec.turns); break;
    case calibration::Procedure::kOutAndBack:
      c.amount_mm = spec.distance_m * kMToMm;
      c.count = static_cast<uint32_t>(spec.repeats);
      break;
    case calibration::Procedure::kRecorded: break;
    case calibration::Procedure::kCircle: break;  // refused by WireProcedure
  }
  if (spec.speed_m_s) c.speed_mm_s = *spec.speed_m_s * kMToMm;
  if (spec.turn_rate_rad_s) c.turn_rate_deg_s = RadToDeg(*spec.turn_rate_rad_s);
  return c;
}

Client::Client(Transport& transport, const ClientOptions& options)
    : transport_(transport), options_(options) {
  assert(options.IsValid(nullptr) && "ClientOptions out of range");
  if (options.first_seq) {
    next_seq_ = *options.first_seq;
  } else {
    std::random_device rd;
    next_seq_ = static_cast<uint16_t>(rd());
  }
}

void Client::HandleEvent(const Frame& f) {
  ByteReader r(f.body);
  if (f.type == OLF_MSG_TELEMETRY) {
    TelemetrySample s;
    uint8_t state = 0;
    if (r.U32(&s.t_ms) && r.I32(&s.left_ticks) && r.I32(&s.right_ticks) && r.F64(&s.x_mm) &&
        r.F64(&s.y_mm) && r.F64(&s.heading_rad) && r.U8(&state) && r.U16(&s.run_id) &&
        r.AtEnd()) {
      s.state = static_cast<RunState>(state);
      if (telemetry_callback_) telemetry_callback_(s);
    }
  } else if (f.type == OLF_MSG_RUN_COMPLETE) {
    RunComplete c;
    uint8_t status = 0;
    if (r.U16(&c.run_id) && r.U8(&status) && r.U32(&c.t_ms) && r.I32(&c.left_ticks) &&
        r.I32(&c.right_ticks) && r.F64(&c.x_mm) && r.F64(&c.y_mm) && r.F64(&c.heading_rad) &&
        r.AtEnd()) {
      c.status = static_cast<RunStatus>(status);
      completed_runs_[c.run_id] = c;
    }
  }
}

Result<Frame> Client::Pump(std::optional<uint16_t> seq, Clock::time_point until) {
  std::array<uint8_t, 512> buf;
  while (true) {
    const auto now = Clock::now();
    if (now >= until) return Result<Frame>::Error(StatusCode::kTimeout, "");
    const auto left = std::chrono::ceil<std::chrono::milliseconds>(until - now);
    const IoResult io = transport_.Read(buf, left);
    switch (io.status) {
      case IoStatus::kOk: break;
      // The transport waited as long as asked (a loopback answers at once).
      case IoStatus::kTimeout: return Result<Frame>::Error(StatusCode::kTimeout, "");
      case IoStatus::kClosed:
        return Result<Frame>::Error(StatusCode::kLineCut,
                                    "serial line to " + transport_.Describe() +
                                        " cut (cable pulled or device gone): " + io.message);
      case IoStatus::kError: return Result<Frame>::Error(StatusCode::kIoError, io.message);
    }
    std::optional<Frame> wanted;
    for (size_t i = 0; i < io.bytes; ++i) {
      std::optional<Frame> f = decoder_.Feed(buf[i]);
      if (!f) continue;
      if (f->type >= OLF_MSG_TELEMETRY) {
        if (f->version == OLF_PROTOCOL_VERSION) HandleEvent(*f);
      } else if (seq && f->seq == *seq && !wanted) {
        wanted = std::move(f);
      } else {
        ++counters_.stale_replies;
      }
    }
    // Bytes after the reply in this chunk stay undecoded only if they follow
    // `wanted`; the decoder already consumed them, events included.
    if (wanted) return Result<Frame>::Ok(std::move(*wanted));
    if (!seq) return Result<Frame>::Ok(Frame{});
  }
}

Result<Bytes> Client::Transact(uint8_t type, const Bytes& body) {
  using R = Result<Bytes>;
  const uint16_t seq = next_seq_++;
  const Bytes wire = EncodeFrame(Frame{OLF_PROTOCOL_VERSION, type, seq, body});
  const FrameDecoder::Counters before = decoder_.counters();
  ++counters_.requests;
  for (int attempt = 1; attempt <= options_.max_attempts; ++attempt) {
    if (attempt > 1) ++counters_.retransmissions;
    const IoResult w = transport_.Write(wire);
    if (w.status == IoStatus::kClosed) {
      return R::Error(StatusCode::kLineCut, "serial line to " + transport_.Describe() +
                                                " cut (cable pulled or device gone): " + w.message);
    }
    if (w.status != IoStatus::kOk) return R::Error(StatusCode::kIoError, w.message);
    Result<Frame> reply = Pump(seq, Clock::now() + options_.reply_timeout);
    if (reply.status == StatusCode::kTimeout) {
      ++counters_.timeouts;
      continue;
    }
    if (!reply.ok()) return R::From(reply);
    const Frame& f = *reply.value;
    if (f.version != OLF_PROTOCOL_VERSION) {
      return R::Error(StatusCode::kVersionMismatch,
                      "robot on " + transport_.Describe() + " speaks protocol version " +
                          std::to_string(f.version) + ", odocal speaks version " +
                          std::to_string(OLF_PROTOCOL_VERSION));
    }
    if (f.type == OLF_MSG_NACK && f.body.size() >= 2 && f.body[0] == type) {
      if (f.body[1] == OLF_ERR_BAD_VERSION) {
        const int robot_version = f.body.size() >= 3 ? f.body[2] : -1;
        return R::Error(StatusCode::kVersionMismatch,
                        "robot on " + transport_.Describe() + " speaks protocol version " +
                            std::to_string(robot_version) + ", odocal speaks version " +
                            std::to_string(OLF_PROTOCOL_VERSION));
      }
      return R::Error(StatusCode::kNack, "robot refused " + std::string(TypeName(type)) + ": " +
                                             std::string(ErrorName(f.body[1])));
    }
    if (f.type != OLF_MSG_ACK || f.body.empty() || f.body[0] != type) {
      return R::Error(StatusCode::kProtocolError,
                      "unexpected reply to " + std::string(TypeName(type)) + ": " + ToHex(f.body));
    }
    return R::Ok(Bytes(f.body.begin() + 1, f.body.end()));
  }
  const uint64_t bad = (decoder_.counters().crc_errors - before.crc_errors) +
                       (decoder_.counters().framing_errors - before.framing_errors);
  const std::string what = "no valid reply to " + std::string(TypeName(type)) + " from " +
                           transport_.Describe() + " after " +
                           std::to_string(options_.max_attempts) + " attempts of " +
                           std::to_string(options_.reply_timeout.count()) + " ms";
  if (bad > 0) {
    return R::Error(StatusCode::kCrcErrors,
                    what + ": " + std::to_string(bad) +
                        " frames failed their CRC/framing check (noisy line "
                        "or wrong baud rate?)");
  }
  return R::Error(StatusCode::kTimeout, "robot not answering: " + what);
}

Result<RobotInfo> Client::Hello() {
  using R = Result<RobotInfo>;
  Result<Bytes> r = Transact(OLF_MSG_HELLO, {});
  if (!r) return R::From(r);
  RobotInfo info;
  ByteReader in(*r.value);
  uint8_t version = 0, count = 0, boot = 0;
  if (!(in.U8(&version) && in.U8(&count) && in.U32(&info.table_crc) &&
        in.U32(&info.active_set_crc) && in.U8(&boot) && in.Str8(&info.robot_name) &&
        in.AtEnd())) {
    return R::Error(StatusCode::kProtocolError, "malformed HELLO reply: " + ToHex(*r.value));
  }
  info.protocol_version = version;
  info.param_count = count;
  info.boot_source = static_cast<BootSource>(boot);
  if (version != OLF_PROTOCOL_VERSION) {
    return R::Error(StatusCode::kVersionMismatch, "robot '" + info.robot_name +
                                                      "' speaks protocol version " +
                                                      std::to_string(version) +
                                                      ", odocal speaks version " +
                                                      std::to_string(OLF_PROTOCOL_VERSION));
  }
  if (info.table_crc != ParamTableCrc()) {
    return R::Error(StatusCode::kTableMismatch,
                    "robot '" + info.robot_name + "' has another parameter table (checksum " +
                        Hex32(info.table_crc) + ", odocal expects " + Hex32(ParamTableCrc()) +
                        "): firmware and odocal disagree on parameter names or types");
  }
  return R::Ok(info);
}

Result<ParamSet> Client::ParseParamSet(const Bytes& body, olf_param_set_id which,
                                       uint32_t* mask) {
  using R = Result<ParamSet>;
  ByteReader in(body);
  uint8_t got_which = 0, count = 0;
  uint32_t got_mask = 0, crc = 0;
  const auto malformed = [&] {
    return R::Error(StatusCode::kProtocolError, "malformed PARAMS_READ reply: " + ToHex(body));
  };
  if (!(in.U8(&got_which) && in.U32(&got_mask) && in.U32(&crc) && in.U8(&count))) {
    return malformed();
  }
  if (got_which != which || count != ParamTable().size()) return malformed();
  ParamSet set;
  // Entries come in table order (the order Hello's table checksum vouches
  // for): type, then value.
  for (size_t i = 0; i < count; ++i) {
    uint8_t type = 0;
    if (!in.U8(&type) || type != static_cast<uint8_t>(ParamTable()[i].type)) return malformed();
    if (type == OLF_TYPE_F64) {
      double v;
      if (!in.F64(&v)) return malformed();
      set.Set(i, v);
    } else {
      uint32_t v;
      if (!in.U32(&v)) return malformed();
      set.Set(i, v);
    }
  }
  if (!in.AtEnd()) return malformed();
  // The robot's checksum of its own set must match ours of what we decoded:
  // an end-to-end check on top of the frame CRC.
  if (set.Checksum() != crc) {
    return R::Error(StatusCode::kVerifyFailed, "parameter set checksum mismatch (robot " +
                                                   Hex32(crc) + ", decoded " +
                                                   Hex32(set.Checksum()) + ")");
  }
  if (mask) *mask = got_mask;
  return R::Ok(set);
}

Result<ParamSet> Client::GetParams(olf_param_set_id which) {
  Result<Bytes> r = Transact(OLF_MSG_PARAMS_READ, Bytes{static_cast<uint8_t>(which)});
  if (!r) return Result<ParamSet>::From(r);
  return ParseParamSet(*r.value, which, nullptr);
}

Result<ParamValue> Client::GetParam(std::string_view name) {
  using R = Result<ParamValue>;
  if (name.empty() || name.size() > OLF_MAX_NAME) {
    return R::Error(StatusCode::kInvalidArgument, "bad parameter name '" + std::string(name) + "'");
  }
  Result<Bytes> r = Transact(OLF_MSG_PARAM_GET, ByteWriter().Str8(std::string(name)).Take());
  if (!r) return R::From(r);
  ByteReader in(*r.value);
  uint8_t type = 0;
  in.U8(&type);
  if (type == OLF_TYPE_F64) {
    double v;
    if (in.F64(&v) && in.AtEnd()) return R::Ok(v);
  } else if (type == OLF_TYPE_U32) {
    uint32_t v;
    if (in.U32(&v) && in.AtEnd()) return R::Ok(v);
  }
  return R::Error(StatusCode::kProtocolError, "malformed PARAM_GET reply: " + ToHex(*r.value));
}

Result<ParamSet> Client::SetParam(std::string_view name, const ParamValue& value) {
  using R = Result<ParamSet>;
  const std::optional<size_t> index = FindParam(name);
  if (!index)
    return R::Error(StatusCode::kInvalidArgument, "unknown parameter '" + std::string(name) + "'");
  if (!ValueMatchesType(*index, value)) {
    return R::Error(StatusCode::kInvalidArgument, "wrong type for '" + std::string(name) + "'");
  }
  Result<Bytes> r = Transact(OLF_MSG_PARAM_SET, ParamBody(*index, value));
  if (!r) return R::From(r);
  Result<ParamSet> active = GetParams(OLF_SET_ACTIVE);
  if (!active) return active;
  ParamSet expected = *active.value;
  expected.Set(*index, value);
  if (!active.value->SameBits(expected)) {
    return R::Error(StatusCode::kVerifyFailed, std::string(name) + " reads back as " +
                                                   FormatValue(active.value->Get(*index)));
  }
  return active;
}

Result<PushReport> Client::PushParams(const ParamSet& target) {
  using R = Result<PushReport>;
  std::string why;
  if (!target.IsValid(&why)) return R::Error(StatusCode::kInvalidArgument, why);
  if (Result<Bytes> r = Transact(OLF_MSG_STAGE_BEGIN, {}); !r) return R::From(r);
  for (size_t i = 0; i < ParamTable().size(); ++i) {
    if (Result<Bytes> r = Transact(OLF_MSG_STAGE_PUT, ParamBody(i, target.Get(i))); !r) {
      return R::From(r);
    }
  }
  uint32_t mask = 0;
  Result<Bytes> staged_raw =
      Transact(OLF_MSG_PARAMS_READ, Bytes{static_cast<uint8_t>(OLF_SET_STAGED)});
  if (!staged_raw) return R::From(staged_raw);
  Result<ParamSet> staged = ParseParamSet(*staged_raw.value, OLF_SET_STAGED, &mask);
  if (!staged) return R::From(staged);
  if (mask != (1u << ParamTable().size()) - 1 || !staged.value->SameBits(target)) {
    std::ostringstream os;
    os << "staged set read back differs from what was sent, not committed: " << *staged.value;
    return R::Error(StatusCode::kVerifyFailed, os.str());
  }
  Result<Bytes> commit = Transact(OLF_MSG_COMMIT, ByteWriter().U32(target.Checksum()).Take());
  if (!commit && commit.status != StatusCode::kTimeout && commit.status != StatusCode::kCrcErrors) {
    return R::From(commit);  // refused, or the line is gone: nothing more to ask
  }
  // Verify what the robot now runs on. After a lost commit reply this also
  // settles whether the commit happened.
  Result<ParamSet> active = GetParams(OLF_SET_ACTIVE);
  if (!active) {
    if (!commit) {
      return R::Error(commit.status, "commit outcome unknown: " + commit.message + "; " +
                                         active.message);
    }
    return R::From(active);
  }
  if (!active.value->SameBits(target)) {
    if (!commit) {
      return R::Error(commit.status, commit.message + "; robot kept its previous set");
    }
    std::ostringstream os;
    os << "active set after commit differs from the target: " << *active.value;
    return R::Error(StatusCode::kVerifyFailed, os.str());
  }
  return R::Ok(PushReport{*active.value, active.value->Checksum()});
}

Result<ParamSet> Client::Rollback() {
  Result<Bytes> r = Transact(OLF_MSG_ROLLBACK, {});
  if (!r) return Result<ParamSet>::From(r);
  return GetParams(OLF_SET_ACTIVE);
}

Result<uint16_t> Client::StartRun(const RunCommand& c) {
  using R = Result<uint16_t>;
  ByteWriter w;
  w.U8(WireProcedure(c.procedure))
      .U8(c.direction == calibration::Direction::kCw ? OLF_DIR_CW : OLF_DIR_CCW)
      .F64(c.amount_mm)
      .U32(c.count);
  if (c.speed_mm_s > 0.0 || c.turn_rate_deg_s > 0.0) {
    const auto u16 = [](double v) { return static_cast<uint16_t>(std::clamp(std::lround(v), 0L, 65535L)); };
    w.U16(u16(c.speed_mm_s)).U16(u16(c.turn_rate_deg_s * 10.0));
  }
  Bytes body = w.Take();
  Result<Bytes> r = Transact(OLF_MSG_RUN_START, body);
  if (!r) return R::From(r);
  ByteReader in(*r.value);
  uint16_t run_id = 0;
  if (!in.U16(&run_id) || !in.AtEnd()) {
    return R::Error(StatusCode::kProtocolError, "malformed RUN_START reply: " + ToHex(*r.value));
  }
  return R::Ok(run_id);
}

Status Client::Stop() {
  Result<Bytes> r = Transact(OLF_MSG_STOP, {});
  if (!r) return Status::From(r);
  return Status::Ok();
}

Status Client::SetTelemetryRate(uint16_t rate_hz) {
  Result<Bytes> r = Transact(OLF_MSG_TELEMETRY_RATE, ByteWriter().U16(rate_hz).Take());
  if (!r) return Status::From(r);
  return Status::Ok();
}

Result<RobotStatus> Client::GetStatus() {
  using R = Result<RobotStatus>;
  Result<Bytes> r = Transact(OLF_MSG_STATUS, {});
  if (!r) return R::From(r);
  RobotStatus s;
  ByteReader in(*r.value);
  uint8_t state = 0, last_status = 0;
  if (!(in.U8(&state) && in.U16(&s.run_id) && in.U16(&s.last_run_id) && in.U8(&last_status) &&
        in.U32(&s.last_run.t_ms) && in.F64(&s.last_run.x_mm) && in.F64(&s.last_run.y_mm) &&
        in.F64(&s.last_run.heading_rad) && in.U32(&s.frames_ok) && in.U32(&s.crc_errors) &&
        in.U32(&s.framing_errors) && in.AtEnd())) {
    return R::Error(StatusCode::kProtocolError, "malformed STATUS reply: " + ToHex(*r.value));
  }
  s.state = static_cast<RunState>(state);
  s.last_run.run_id = s.last_run_id;
  s.last_run.status = static_cast<RunStatus>(last_status);
  return R::Ok(s);
}

Result<RunComplete> Client::WaitRunComplete(uint16_t run_id, std::chrono::milliseconds timeout) {
  using R = Result<RunComplete>;
  const auto deadline = Clock::now() + timeout;
  auto last_poll = Clock::now();
  while (true) {
    if (auto it = completed_runs_.find(run_id); it != completed_runs_.end()) {
      RunComplete c = it->second;
      completed_runs_.erase(it);
      return R::Ok(c);
    }
    const auto now = Clock::now();
    if (now >= deadline) {
      return R::Error(StatusCode::kTimeout,
                      "run " + std::to_string(run_id) + " on " + transport_.Describe() +
                          " did not complete within " + std::to_string(timeout.count()) + " ms");
    }
    Result<Frame> r = Pump(std::nullopt, std::min(deadline, now + options_.status_poll_interval));
    if (!r && r.status != StatusCode::kTimeout) return R::From(r);
    if (r.status == StatusCode::kTimeout ||
        Clock::now() - last_poll >= options_.status_poll_interval) {
      // Quiet line or a long stretch without the event: ask. A lost
      // run-complete event is thus recovered from STATUS.
      last_poll = Clock::now();
      Result<RobotStatus> s = GetStatus();
      if (s.status == StatusCode::kLineCut || s.status == StatusCode::kIoError) return R::From(s);
      if (s && completed_runs_.count(run_id) == 0 && s.value->state == RunState::kIdle) {
        if (s.value->last_run_id == run_id) return R::Ok(s.value->last_run);
        return R::Error(StatusCode::kProtocolError,
                        "robot is idle and does not know run " + std::to_string(run_id) +
                            " (restarted?)");
      }
    }
  }
}

std::ostream& operator<<(std::ostream& os, const RobotInfo& info) {
  return os << "robot '" << info.robot_name << "', protocol " << info.protocol_version << ", "
            << info.param_count << " parameters, table " << Hex32(info.table_crc)
            << ", active set " << Hex32(info.active_set_crc);
}

}  // namespace odocal::robot_link
