// The virtual robot's link side: the firmware C library (olf) with a motion
// backend and a storage behind it, either in-process (LoopbackTransport, for
// fast deterministic tests) or on the master end of a real pseudo-terminal in
// its own thread (FirmwareHost), where the host connects through the same
// SerialTransport it uses for a real robot.
//
// Units: the wire's (mm, rad, ms). Poses are odometry in the run's start frame
// (REP-103). Simulated time: FirmwareHost advances the robot clock by
// `tick * time_scale` per wall-clock tick, so a 10 s run can take 0.5 s.
//
// MotionBackend is the seam for the simulated robot (odocal::sim): implement it
// on top of the simulator and hand it to FirmwareHost; FakeMotionBackend is a
// kinematically exact stand-in for link tests.
#ifndef ODOCAL_ROBOT_LINK_FIRMWARE_HOST_H_
#define ODOCAL_ROBOT_LINK_FIRMWARE_HOST_H_

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/base/units.h"
#include "odocal/robot_link/client.h"
#include "odocal/robot_link/params.h"
#include "odocal/robot_link/pty.h"
#include "odocal/robot_link/transport.h"
#include "odolink/olf.h"

namespace odocal::robot_link {

// ---- Motion ---------------------------------------------------------------

struct MotionSample {
  int32_t left_ticks = 0;  // since run start
  int32_t right_ticks = 0;
  double x_mm = 0.0;  // odometry pose, run start frame
  double y_mm = 0.0;
  double heading_rad = 0.0;
};

struct StepResult {
  MotionSample sample;
  bool finished = false;
  RunStatus status = RunStatus::kCompleted;  // meaningful when finished
};

// What the firmware library drives. All calls come from the robot's thread.
class MotionBackend {
 public:
  virtual ~MotionBackend() = default;
  // Begin a run; false refuses it (the host gets "motion code refused").
  virtual bool StartRun(const RunCommand& command) = 0;
  // Advance the running run by dt_s seconds of robot time.
  virtual StepResult Step(double dt_s) = 0;
  // Immediate stop: the next Step reports finished with kStopped.
  virtual void Stop() = 0;
  // The robot clock advanced by dt_s with no run (Step is called only while
  // one runs): a backend that keeps the robot's clock counts it.
  virtual void Idle(double /*dt_s*/) {}
  // The active parameter set changed (boot, commit, set, rollback): the
  // odometry must use these from now on.
  virtual void SetParams(const ParamSet& params) = 0;
};

// Drives the calibration module's primitive plan at constant speeds with
// perfect wheels: odometry equals the plan. Enough to exercise the link.
class FakeMotionBackend final : public MotionBackend {
 public:
  struct Options {
    double speed_mm_s = 400.0;
    double turn_rate_rad_s = 3.0;
  };
  FakeMotionBackend() : FakeMotionBackend(Options{}) {}
  explicit FakeMotionBackend(const Options& options) : options_(options) {}

  bool StartRun(const RunCommand& command) override;
  StepResult Step(double dt_s) override;
  void Stop() override { stop_requested_ = true; }
  void SetParams(const ParamSet& params) override;

  int runs_started() const { return runs_started_; }
  const ParamSet& params() const { return params_; }

 private:
  Options options_;
  ParamSet params_;
  std::vector<calibration::Primitive> plan_;
  size_t primitive_ = 0;
  double done_in_primitive_ = 0.0;  // m or rad
  double left_mm_ = 0.0, right_mm_ = 0.0;
  double x_mm_ = 0.0, y_mm_ = 0.0, heading_rad_ = 0.0;
  bool running_ = false;
  bool stop_requested_ = false;
  int runs_started_ = 0;
};

// ---- Storage --------------------------------------------------------------

// Byte-addressed non-volatile memory of OLF_STORAGE_SIZE bytes.
class Storage {
 public:
  virtual ~Storage() = default;
  virtual bool Read(uint32_t offset, std::span<uint8_t> out) = 0;
  virtual bool Write(uint32_t offset, std::span<const uint8_t> data) = 0;
};

// RAM image; `power_budget_bytes` makes writes stop after that many bytes
// (the rest of that write and all later ones are lost): a power cut.
class MemoryStorage final : public Storage {
 public:
  MemoryStorage() { image_.fill(0xFF); }  // erased flash reads 0xFF
  bool Read(uint32_t offset, std::span<uint8_t> out) override;
  bool Write(uint32_t offset, std::span<const uint8_t> data) override;
  void SetPowerBudget(std::optional<uint64_t> bytes) { budget_ = bytes; }
  const std::array<uint8_t, OLF_STORAGE_SIZE>& image() const { return image_; }

 private:
  std::array<uint8_t, OLF_STORAGE_SIZE> image_;
  std::optional<uint64_t> budget_;
};

// A file holding the storage image. Each write produces a complete new image
// in `path.tmp`, fsyncs it and renames it over `path` (rename is atomic on
// POSIX file systems): the file is the old image or the new one.
class FileStorage final : public Storage {
 public:
  // Loads `path` if it exists (an absent file reads as erased).
  static Result<std::unique_ptr<FileStorage>> Open(const std::string& path);
  bool Read(uint32_t offset, std::span<uint8_t> out) override;
  bool Write(uint32_t offset, std::span<const uint8_t> data) override;

 private:
  explicit FileStorage(std::string path) : path_(std::move(path)) { image_.fill(0xFF); }
  std::string path_;
  std::array<uint8_t, OLF_STORAGE_SIZE> image_;
};

// ---- The firmware with its callbacks ----------------------------------------

struct RobotOptions {
  std::string robot_name = "odocal-virtual";
  // Used when storage holds no valid record (first boot).
  ParamSet defaults{72.0, 72.0, 270.0, 4096};
};

// olf_ctx_t wired to a MotionBackend and a Storage. Not thread-safe.
class FirmwareRobot {
 public:
  // `backend` and `storage` (may be null: nothing persists) must outlive it.
  FirmwareRobot(const RobotOptions& options, MotionBackend& backend, Storage* storage,
                std::function<void(std::span<const uint8_t>)> output);
  FirmwareRobot(const FirmwareRobot&) = delete;
  FirmwareRobot& operator=(const FirmwareRobot&) = delete;

  void Feed(std::span<const uint8_t> bytes);
  // Advances the robot clock by dt_s: steps a running run, emits telemetry,
  // reports completion.
  void Tick(double dt_s);

  ParamSet active() const;
  bool running() const { return ctx_.state == OLF_STATE_RUNNING; }
  const olf_ctx_t& ctx() const { return ctx_; }
  uint32_t now_ms() const { return static_cast<uint32_t>(clock_s_ * kSToMs); }

 private:
  static void WriteCb(void* user, const uint8_t* data, size_t len);
  static int StartRunCb(void* user, const olf_run_cmd_t* cmd);
  static void StopCb(void* user);
  static void ParamsAppliedCb(void* user, const olf_params_t* params);
  static int StorageReadCb(void* user, uint32_t offset, uint8_t* data, uint32_t len);
  static int StorageWriteCb(void* user, uint32_t offset, const uint8_t* data, uint32_t len);

  RobotOptions options_;
  MotionBackend& backend_;
  Storage* storage_;
  std::function<void(std::span<const uint8_t>)> output_;
  double clock_s_ = 0.0;
  olf_ctx_t ctx_;
};

// In-process transport straight into a FirmwareRobot: Write feeds the robot,
// Read returns what it answered. Nothing arrives unasked, so a Read with
// nothing queued returns kTimeout at once (the timeout elapsed in no time):
// thousands of retries cost microseconds.
class LoopbackTransport final : public Transport {
 public:
  LoopbackTransport(const RobotOptions& options, MotionBackend& backend, Storage* storage);
  IoResult Write(std::span<const uint8_t> data) override;
  IoResult Read(std::span<uint8_t> buffer, std::chrono::milliseconds timeout) override;
  std::string Describe() const override { return "loopback"; }
  FirmwareRobot& robot() { return robot_; }

 private:
  std::deque<uint8_t> from_robot_;
  FirmwareRobot robot_;
};

// ---- The virtual robot on a pseudo-terminal --------------------------------

struct FirmwareHostOptions {
  RobotOptions robot;
  // Parameters persist here (FileStorage); empty keeps them in RAM only.
  std::string storage_path;
  // Robot loop period (wall clock) and robot seconds per wall second.
  std::chrono::milliseconds tick{2};
  double time_scale = 1.0;

  bool IsValid(std::string* why) const;
};

class FirmwareHost {
 public:
  // Opens the pty, loads storage, boots the firmware and starts the thread.
  static Result<std::unique_ptr<FirmwareHost>> Start(const FirmwareHostOptions& options,
                                                     MotionBackend& backend);
  ~FirmwareHost();  // stops the thread, closes the pty
  FirmwareHost(const FirmwareHost&) = delete;
  FirmwareHost& operator=(const FirmwareHost&) = delete;

  // What to pass as --port.
  const std::string& device_path() const { return pty_.slave_path; }
  // Pulls the cable: closes the pty so the host sees a hang-up. The robot
  // keeps running its run (motion is its own business).
  void CutCable();

  ParamSet active() const;
  bool running() const;
  uint16_t last_run_id() const;
  olf_counters_t counters() const;

 private:
  FirmwareHost(const FirmwareHostOptions& options, MotionBackend& backend, Pty pty,
               std::unique_ptr<Storage> storage);
  void Loop();

  FirmwareHostOptions options_;
  Pty pty_;
  std::unique_ptr<Storage> storage_;
  mutable std::mutex mutex_;  // guards robot_ against the accessors
  std::unique_ptr<FirmwareRobot> robot_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> cut_{false};
  std::thread thread_;
};

}  // namespace odocal::robot_link

#endif  // ODOCAL_ROBOT_LINK_FIRMWARE_HOST_H_
