// Pseudo-terminal pairs for the virtual robot: the robot side holds the
// master end, and the slave path (/dev/pts/N) is a real tty that the host
// opens exactly like /dev/ttyUSB0, termios and all.
#ifndef ODOCAL_ROBOT_LINK_PTY_H_
#define ODOCAL_ROBOT_LINK_PTY_H_

#include <string>

#include "odocal/robot_link/result.h"

namespace odocal::robot_link {

// Owns a file descriptor; closes it once.
class UniqueFd {
 public:
  UniqueFd() = default;
  explicit UniqueFd(int fd) : fd_(fd) {}
  ~UniqueFd() { Reset(); }
  UniqueFd(UniqueFd&& other) noexcept : fd_(other.Release()) {}
  UniqueFd& operator=(UniqueFd&& other) noexcept {
    if (this != &other) {
      Reset();
      fd_ = other.Release();
    }
    return *this;
  }
  UniqueFd(const UniqueFd&) = delete;
  UniqueFd& operator=(const UniqueFd&) = delete;

  int get() const { return fd_; }
  bool valid() const { return fd_ >= 0; }
  int Release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }
  void Reset();

 private:
  int fd_ = -1;
};

struct Pty {
  UniqueFd master;
  // Kept open by the robot side so the master does not read EIO while no
  // host is connected (the pty would otherwise report a hang-up between two
  // CLI invocations).
  UniqueFd slave;
  std::string slave_path;
};

// openpty(3), both ends raw (no echo, no line discipline), master
// non-blocking.
Result<Pty> OpenPty();

}  // namespace odocal::robot_link

#endif  // ODOCAL_ROBOT_LINK_PTY_H_
