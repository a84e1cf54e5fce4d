#include "odocal/robot_link/firmware_host.h"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "odocal/base/units.h"

namespace odocal::robot_link {
namespace {

ParamSet FromC(const olf_params_t& p) {
  return ParamSet{p.left_wheel_diameter_mm, p.right_wheel_diameter_mm, p.track_mm,
                  p.ticks_per_rev};
}
olf_params_t ToC(const ParamSet& p) {
  olf_params_t c;
  c.left_wheel_diameter_mm = p.left_wheel_diameter_mm;
  c.right_wheel_diameter_mm = p.right_wheel_diameter_mm;
  c.track_mm = p.track_mm;
  c.ticks_per_rev = p.ticks_per_rev;
  return c;
}

calibration::RunSpec ToRunSpec(const RunCommand& c) {
  using calibration::RunSpec;
  switch (c.procedure) {
    case calibration::Procedure::kUmbmark:
      return RunSpec::Umbmark(c.direction, c.amount_mm * kMmToM);
    case calibration::Procedure::kStraight:
      return RunSpec::Straight(c.amount_mm * kMmToM);
    case calibration::Procedure::kSpin: return RunSpec::Spin(static_cast<int>(c.count), c.direction);
    case calibration::Procedure::kOutAndBack:
      return RunSpec::OutAndBack(c.amount_mm * kMmToM, static_cast<int>(c.count), c.direction);
    case calibration::Procedure::kRecorded: break;  // never decoded from the wire
    case calibration::Procedure::kCircle: break;    // never decoded from the wire
  }
  return RunSpec{};
}

}  // namespace

// ---- FakeMotionBackend ------------------------------------------------------

bool FakeMotionBackend::StartRun(const RunCommand& command) {
  if (running_) return false;
  plan_ = calibration::PlanPrimitives(ToRunSpec(command));
  if (plan_.empty()) return false;
  primitive_ = 0;
  done_in_primitive_ = 0.0;
  left_mm_ = right_mm_ = 0.0;
  x_mm_ = y_mm_ = heading_rad_ = 0.0;
  running_ = true;
  stop_requested_ = false;
  ++runs_started_;
  return true;
}

void FakeMotionBackend::SetParams(const ParamSet& params) { params_ = params; }

StepResult FakeMotionBackend::Step(double dt_s) {
  StepResult out;
  while (running_ && !stop_requested_ && dt_s > 0.0 && primitive_ < plan_.size()) {
    const calibration::Primitive& p = plan_[primitive_];
    const double total = std::abs(p.amount);
    const double sign = p.amount < 0.0 ? -1.0 : 1.0;
    const bool straight = p.kind == calibration::Primitive::Kind::kStraight;
    const double rate = straight ? options_.speed_mm_s * kMmToM : options_.turn_rate_rad_s;
    const double step = std::min(rate * dt_s, total - done_in_primitive_);
    if (straight) {
      const double d_mm = sign * step * kMToMm;
      x_mm_ += d_mm * std::cos(heading_rad_);
      y_mm_ += d_mm * std::sin(heading_rad_);
      left_mm_ += d_mm;
      right_mm_ += d_mm;
    } else {
      const double a = sign * step;
      heading_rad_ += a;
      left_mm_ -= a * params_.track_mm / 2.0;
      right_mm_ += a * params_.track_mm / 2.0;
    }
    done_in_primitive_ += step;
    dt_s -= step / rate;
    if (done_in_primitive_ >= total - 1e-12) {
      ++primitive_;
      done_in_primitive_ = 0.0;
    }
  }
  const auto ticks = [&](double travel_mm, double diameter_mm) {
    return diameter_mm > 0.0
               ? static_cast<int32_t>(std::lround(travel_mm / (M_PI * diameter_mm) *
                                                  params_.ticks_per_rev))
               : 0;
  };
  out.sample = {ticks(left_mm_, params_.left_wheel_diameter_mm),
                ticks(right_mm_, params_.right_wheel_diameter_mm), x_mm_, y_mm_,
                calibration::WrapAngle(heading_rad_)};
  if (running_ && (stop_requested_ || primitive_ >= plan_.size())) {
    out.finished = true;
    out.status = stop_requested_ ? RunStatus::kStopped : RunStatus::kCompleted;
    running_ = false;
  }
  return out;
}

// ---- Storage ----------------------------------------------------------------

bool MemoryStorage::Read(uint32_t offset, std::span<uint8_t> out) {
  if (offset > image_.size() || out.size() > image_.size() - offset) return false;
  std::memcpy(out.data(), image_.data() + offset, out.size());
  return true;
}

bool MemoryStorage::Write(uint32_t offset, std::span<const uint8_t> data) {
  if (offset > image_.size() || data.size() > image_.size() - offset) return false;
  size_t n = data.size();
  if (budget_) n = static_cast<size_t>(std::min<uint64_t>(n, *budget_));
  std::memcpy(image_.data() + offset, data.data(), n);
  if (budget_) *budget_ -= n;
  return n == data.size();
}

Result<std::unique_ptr<FileStorage>> FileStorage::Open(const std::string& path) {
  using R = Result<std::unique_ptr<FileStorage>>;
  std::unique_ptr<FileStorage> s(new FileStorage(path));
  std::ifstream in(path, std::ios::binary);
  if (in) {
    in.read(reinterpret_cast<char*>(s->image_.data()), s->image_.size());
    if (in.gcount() != static_cast<std::streamsize>(s->image_.size())) {
      return R::Error(StatusCode::kOpenFailed, "storage file " + path + " is truncated");
    }
  } else if (errno != ENOENT) {
    return R::Error(StatusCode::kOpenFailed, "cannot read storage file " + path + ": " +
                                                 std::strerror(errno));
  }
  return R::Ok(std::move(s));
}

bool FileStorage::Read(uint32_t offset, std::span<uint8_t> out) {
  if (offset > image_.size() || out.size() > image_.size() - offset) return false;
  std::memcpy(out.data(), image_.data() + offset, out.size());
  return true;
}

bool FileStorage::Write(uint32_t offset, std::span<const uint8_t> data) {
  if (offset > image_.size() || data.size() > image_.size() - offset) return false;
  std::array<uint8_t, OLF_STORAGE_SIZE> next = image_;
  std::memcpy(next.data() + offset, data.data(), data.size());
  const std::string tmp = path_ + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return false;
  const bool written = ::write(fd, next.data(), next.size()) == static_cast<ssize_t>(next.size());
  const bool synced = written && ::fsync(fd) == 0;
  ::close(fd);
  if (!synced || std::rename(tmp.c_str(), path_.c_str()) != 0) {
    ::unlink(tmp.c_str());
    return false;
  }
  image_ = next;
  return true;
}

// ---- FirmwareRobot ----------------------------------------------------------

FirmwareRobot::FirmwareRobot(const RobotOptions& options, MotionBackend& backend,
                             Storage* storage, std::function<void(std::span<const uint8_t>)> output)
    : options_(options), backend_(backend), storage_(storage), output_(std::move(output)) {
  olf_config_t config{};
  config.robot_name = options_.robot_name.c_str();
  config.defaults = ToC(options_.defaults);
  if (storage_) {
    config.storage.read = &StorageReadCb;
    config.storage.write = &StorageWriteCb;
    config.storage.user = this;
  }
  config.callbacks.write = &WriteCb;
  config.callbacks.start_run = &StartRunCb;
  config.callbacks.stop = &StopCb;
  config.callbacks.params_applied = &ParamsAppliedCb;
  config.callbacks.user = this;
  olf_init(&ctx_, &config);
}

void FirmwareRobot::Feed(std::span<const uint8_t> bytes) {
  olf_feed_bytes(&ctx_, bytes.data(), bytes.size());
}

void FirmwareRobot::Tick(double dt_s) {
  clock_s_ += dt_s;
  if (ctx_.state != OLF_STATE_RUNNING) {
    backend_.Idle(dt_s);
    return;
  }
  const StepResult r = backend_.Step(dt_s);
  const olf_telemetry_t t{now_ms(),       r.sample.left_ticks, r.sample.right_ticks,
                          r.sample.x_mm, r.sample.y_mm,       r.sample.heading_rad};
  olf_emit_telemetry(&ctx_, &t);
  if (r.finished) olf_run_complete(&ctx_, static_cast<uint8_t>(r.status), &t);
}

ParamSet FirmwareRobot::active() const { return FromC(ctx_.active); }

void FirmwareRobot::WriteCb(void* user, const uint8_t* data, size_t len) {
  auto* self = static_cast<FirmwareRobot*>(user);
  if (self->output_) self->output_(std::span(data, len));
}

int FirmwareRobot::StartRunCb(void* user, const olf_run_cmd_t* cmd) {
  auto* self = static_cast<FirmwareRobot*>(user);
  RunCommand c;
  switch (cmd->procedure) {
    case OLF_PROC_UMBMARK: c.procedure = calibration::Procedure::kUmbmark; break;
    case OLF_PROC_STRAIGHT: c.procedure = calibration::Procedure::kStraight; break;
    case OLF_PROC_SPIN: c.procedure = calibration::Procedure::kSpin; break;
    case OLF_PROC_OUT_AND_BACK: c.procedure = calibration::Procedure::kOutAndBack; break;
    default: return 0;
  }
  c.direction = cmd->direction == OLF_DIR_CW ? calibration::Direction::kCw
                                             : calibration::Direction::kCcw;
  c.amount_mm = cmd->amount_mm;
  c.count = cmd->count;
  c.speed_mm_s = cmd->speed_mm_s;
  c.turn_rate_deg_s = cmd->turn_rate_ddeg_s * 0.1;
  return self->backend_.StartRun(c) ? 1 : 0;
}

void FirmwareRobot::StopCb(void* user) { static_cast<FirmwareRobot*>(user)->backend_.Stop(); }

void FirmwareRobot::ParamsAppliedCb(void* user, const olf_params_t* params) {
  static_cast<FirmwareRobot*>(user)->backend_.SetParams(FromC(*params));
}

int FirmwareRobot::StorageReadCb(void* user, uint32_t offset, uint8_t* data, uint32_t len) {
  return static_cast<FirmwareRobot*>(user)->storage_->Read(offset, std::span(data, len)) ? 1 : 0;
}

int FirmwareRobot::StorageWriteCb(void* user, uint32_t offset, const uint8_t* data, uint32_t len) {
  return static_cast<FirmwareRobot*>(user)->storage_->Write(offset, std::span(data, len)) ? 1 : 0;
}

// ---- LoopbackTransport -------------------------------------------------------

LoopbackTransport::LoopbackTransport(const RobotOptions& options, MotionBackend& backend,
                                     Storage* storage)
    : robot_(options, backend, storage, [this](std::span<const uint8_t> bytes) {
        from_robot_.insert(from_robot_.end(), bytes.begin(), bytes.end());
      }) {}

IoResult LoopbackTransport::Write(std::span<const uint8_t> data) {
  robot_.Feed(data);
  return {IoStatus::kOk, data.size(), ""};
}

IoResult LoopbackTransport::Read(std::span<uint8_t> buffer, std::chrono::milliseconds) {
  if (from_robot_.empty()) return {IoStatus::kTimeout, 0, ""};
  size_t n = 0;
  while (n < buffer.size() && !from_robot_.empty()) {
    buffer[n++] = from_robot_.front();
    from_robot_.pop_front();
  }
  return {IoStatus::kOk, n, ""};
}

// ---- FirmwareHost -------------------------------------------------------------

bool FirmwareHostOptions::IsValid(std::string* why) const {
  if (tick.count() <= 0 || !(time_scale > 0.0)) {
    if (why) *why = "tick and time_scale must be positive";
    return false;
  }
  return true;
}

Result<std::unique_ptr<FirmwareHost>> FirmwareHost::Start(const FirmwareHostOptions& options,
                                                          MotionBackend& backend) {
  using R = Result<std::unique_ptr<FirmwareHost>>;
  std::string why;
  if (!options.IsValid(&why)) return R::Error(StatusCode::kInvalidArgument, why);
  std::unique_ptr<Storage> storage;
  if (!options.storage_path.empty()) {
    Result<std::unique_ptr<FileStorage>> fs = FileStorage::Open(options.storage_path);
    if (!fs) return R::From(fs);
    storage = std::move(*fs.value);
  } else {
    storage = std::make_unique<MemoryStorage>();
  }
  Result<Pty> pty = OpenPty();
  if (!pty) return R::From(pty);
  return R::Ok(std::unique_ptr<FirmwareHost>(
      new FirmwareHost(options, backend, std::move(*pty.value), std::move(storage))));
}

FirmwareHost::FirmwareHost(const FirmwareHostOptions& options, MotionBackend& backend, Pty pty,
                           std::unique_ptr<Storage> storage)
    : options_(options), pty_(std::move(pty)), storage_(std::move(storage)) {
  robot_ = std::make_unique<FirmwareRobot>(
      options_.robot, backend, storage_.get(), [this](std::span<const uint8_t> bytes) {
        // Called on the robot thread only. Bytes nobody reads are dropped
        // (EAGAIN), like a UART transmitting into an unplugged cable.
        if (!pty_.master.valid()) return;
        size_t done = 0;
        while (done < bytes.size()) {
          const ssize_t n = ::write(pty_.master.get(), bytes.data() + done, bytes.size() - done);
          if (n <= 0) {
            if (n < 0 && errno == EINTR) continue;
            return;
          }
          done += static_cast<size_t>(n);
        }
      });
  thread_ = std::thread([this] { Loop(); });
}

FirmwareHost::~FirmwareHost() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void FirmwareHost::CutCable() {
  cut_ = true;
  // Wait for the robot thread to drop the line so the caller sees the cut.
  while (true) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!pty_.master.valid()) break;
    }
    std::this_thread::sleep_for(options_.tick);
  }
}

void FirmwareHost::Loop() {
  using Clock = std::chrono::steady_clock;
  auto next_tick = Clock::now() + options_.tick;
  uint8_t buf[256];
  while (!stop_) {
    if (cut_ && pty_.master.valid()) {
      std::lock_guard<std::mutex> lock(mutex_);
      pty_.master.Reset();
    }
    const auto now = Clock::now();
    const int wait_ms = static_cast<int>(
        std::max<int64_t>(0, std::chrono::duration_cast<std::chrono::milliseconds>(next_tick - now)
                                 .count()));
    if (pty_.master.valid()) {
      pollfd p{pty_.master.get(), POLLIN, 0};
      if (::poll(&p, 1, wait_ms) > 0 && (p.revents & POLLIN)) {
        const ssize_t n = ::read(pty_.master.get(), buf, sizeof buf);
        if (n > 0) {
          std::lock_guard<std::mutex> lock(mutex_);
          robot_->Feed(std::span(buf, static_cast<size_t>(n)));
        }
      }
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms));
    }
    if (Clock::now() >= next_tick) {
      const double dt_s =
          std::chrono::duration<double>(options_.tick).count() * options_.time_scale;
      std::lock_guard<std::mutex> lock(mutex_);
      robot_->Tick(dt_s);
      next_tick += options_.tick;
      // After a stall (debugger, loaded CI machine) do not replay the backlog.
      if (Clock::now() > next_tick + 10 * options_.tick) next_tick = Clock::now() + options_.tick;
    }
  }
}

ParamSet FirmwareHost::active() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return robot_->active();
}

bool FirmwareHost::running() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return robot_->running();
}

uint16_t FirmwareHost::last_run_id() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return robot_->ctx().last_run_id;
}

olf_counters_t FirmwareHost::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return robot_->ctx().counters;
}

}  // namespace odocal::robot_link
