// A microcontroller running the firmware library in an emulator, with its
// UART on a pseudo-terminal: the ATmega328P under simavr (odocal-avr-board)
// or the LM3S6965 Cortex-M3 under QEMU (run_qemu.sh). The part's parameter
// storage (EEPROM / a flash page pair) lives in an image file that outlives
// the emulator, so a kill -9 is a power cut and a restart on the same image
// is the next boot. And FaultyPty: a pty of our own bridged to the target's
// through FaultInjectingTransport, for a noisy line.
#ifndef ODOCAL_TESTS_ROBOT_LINK_EMULATED_TARGET_H_
#define ODOCAL_TESTS_ROBOT_LINK_EMULATED_TARGET_H_

#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <chrono>
#include <filesystem>
#include <memory>
#include <ostream>
#include <string>
#include <thread>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/robot_link/fault_injection.h"
#include "odocal/robot_link/pty.h"
#include "odocal/robot_link/serial_transport.h"

extern char** environ;

namespace odocal::robot_link::testing {

struct TargetKind {
  std::string name;         // "avr", "lm3s6965"
  std::string robot_name;   // what HELLO answers
  std::vector<std::string> command;  // with {image} for the storage image
  // Where slot A's record sits in the storage image (the EEPROM, or the flash page pair).
  size_t slot_a_offset = 0;
};

inline void PrintTo(const TargetKind& kind, std::ostream* os) { *os << kind.name; }

class EmulatedTarget {
 public:
  // Starts the emulator on `image` (created by the board when missing) and
  // waits for its "pty /dev/pts/N" line.
  static Result<std::unique_ptr<EmulatedTarget>> Start(const TargetKind& kind, const std::string& image,
                                                       std::chrono::seconds timeout = std::chrono::seconds(20)) {
    std::vector<std::string> args;
    for (const std::string& a : kind.command) args.push_back(a == "{image}" ? image : a);
    int out[2];
    using R = Result<std::unique_ptr<EmulatedTarget>>;
    if (pipe(out) != 0) return R::Error(StatusCode::kIoError, "pipe failed");
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, out[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&fa, out[0]);
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);  // its own group: kill takes QEMU too
    posix_spawnattr_setpgroup(&attr, 0);
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = -1;
    const int rc = posix_spawn(&pid, argv[0], &fa, &attr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&attr);
    close(out[1]);
    if (rc != 0) {
      close(out[0]);
      return R::Error(StatusCode::kOpenFailed, "cannot start " + args[0] + ": " + std::strerror(rc));
    }
    auto target = std::unique_ptr<EmulatedTarget>(new EmulatedTarget(pid, out[0]));
    // Read lines until "pty PATH".
    std::string buffer;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      pollfd p{out[0], POLLIN, 0};
      if (poll(&p, 1, 100) <= 0) continue;
      char c;
      const ssize_t n = read(out[0], &c, 1);
      if (n <= 0) break;  // the emulator exited before saying where its pty is
      if (c != '\n') {
        buffer.push_back(c);
        continue;
      }
      if (buffer.rfind("pty ", 0) == 0) {
        target->pty_ = buffer.substr(4);
        return R::Ok(std::move(target));
      }
      buffer.clear();
    }
    return R::Error(StatusCode::kTimeout, args[0] + " did not report its pty within " + std::to_string(timeout.count()) + " s");
  }

  ~EmulatedTarget() { Kill(); }

  const std::string& pty() const { return pty_; }

  // Power cut: SIGKILL to the whole process group, then reap.
  void Kill() {
    if (pid_ <= 0) return;
    ::kill(-pid_, SIGKILL);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    if (out_ >= 0) close(out_);
    out_ = -1;
  }

 private:
  EmulatedTarget(pid_t pid, int out) : pid_(pid), out_(out) {}
  pid_t pid_;
  int out_;
  std::string pty_;
};

// odocal talks to `path()`; every byte to and from the target crosses a
// FaultInjectingTransport (both directions, seeded).
class FaultyPty {
 public:
  static Result<std::unique_ptr<FaultyPty>> Start(const std::string& target_pty, const FaultOptions& faults) {
    using R = Result<std::unique_ptr<FaultyPty>>;
    Result<std::unique_ptr<SerialTransport>> serial = SerialTransport::Open(target_pty);
    if (!serial.ok()) return R::From(serial);
    Result<Pty> pty = OpenPty();
    if (!pty.ok()) return R::From(pty);
    auto self = std::unique_ptr<FaultyPty>(new FaultyPty(std::move(*serial), std::move(*pty), faults));
    self->thread_ = std::thread([p = self.get()] { p->Bridge(); });
    return R::Ok(std::move(self));
  }
  ~FaultyPty() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  const std::string& path() const { return pty_.slave_path; }

  // Stops bridging until Resume(), so that another reader can have the
  // target's pty (two readers of one tty would take each other's bytes).
  void Pause() {
    paused_ = true;
    while (!idle_) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  void Resume() { paused_ = false; }
  const FaultInjectingTransport::Counters& counters() const { return faulty_.counters(); }

 private:
  FaultyPty(std::unique_ptr<SerialTransport> serial, Pty pty, const FaultOptions& faults)
      : serial_(std::move(serial)), pty_(std::move(pty)), faulty_(*serial_, faults) {}

  void Bridge() {
    uint8_t buf[256];
    while (!stop_) {
      if (paused_) {
        idle_ = true;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        continue;
      }
      idle_ = false;
      // Host to target.
      const ssize_t n = read(pty_.master.get(), buf, sizeof buf);
      if (n > 0) faulty_.Write(std::span<const uint8_t>(buf, static_cast<size_t>(n)));
      // Target to host.
      const IoResult r = faulty_.Read(buf, std::chrono::milliseconds(2));
      if (r.status == IoStatus::kOk && r.bytes > 0) {
        size_t done = 0;
        while (done < r.bytes && !stop_) {
          const ssize_t w = write(pty_.master.get(), buf + done, r.bytes - done);
          if (w > 0) done += static_cast<size_t>(w);
          else std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
      }
    }
  }

  std::unique_ptr<SerialTransport> serial_;
  Pty pty_;
  FaultInjectingTransport faulty_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> paused_{false};
  std::atomic<bool> idle_{false};
  std::thread thread_;
};

}  // namespace odocal::robot_link::testing

#endif  // ODOCAL_TESTS_ROBOT_LINK_EMULATED_TARGET_H_
