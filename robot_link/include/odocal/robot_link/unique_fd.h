// RAII for POSIX file descriptors (serial ports, pty ends): closed exactly
// once, movable, never copied.
#ifndef ODOCAL_ROBOT_LINK_UNIQUE_FD_H_
#define ODOCAL_ROBOT_LINK_UNIQUE_FD_H_

#include <unistd.h>

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
  void Reset() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

}  // namespace odocal::robot_link

#endif  // ODOCAL_ROBOT_LINK_UNIQUE_FD_H_
