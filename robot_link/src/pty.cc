#include "odocal/robot_link/pty.h"

#include <fcntl.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstring>

namespace odocal::robot_link {

Result<Pty> OpenPty() {
  int master = -1, slave = -1;
  char name[PATH_MAX] = {};
  termios tio{};
  ::cfmakeraw(&tio);
  tio.c_cflag |= CS8 | CLOCAL | CREAD;
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  if (::openpty(&master, &slave, name, &tio, nullptr) != 0) {
    return Result<Pty>::Error(StatusCode::kOpenFailed,
                              std::string("openpty failed: ") + std::strerror(errno));
  }
  Pty pty;
  pty.master = UniqueFd(master);
  pty.slave = UniqueFd(slave);
  pty.slave_path = name;
  ::fcntl(master, F_SETFD, FD_CLOEXEC);
  ::fcntl(slave, F_SETFD, FD_CLOEXEC);
  // The robot loop polls; a full output buffer drops bytes like a UART whose
  // reader is gone, instead of blocking the robot.
  ::fcntl(master, F_SETFL, ::fcntl(master, F_GETFL) | O_NONBLOCK);
  return Result<Pty>::Ok(std::move(pty));
}

}  // namespace odocal::robot_link
