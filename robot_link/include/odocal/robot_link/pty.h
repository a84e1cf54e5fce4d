// Pseudo-terminal pairs for the virtual robot: the robot side holds the
// master end, and the slave path (/dev/pts/N) is a real tty that the host
// opens exactly like /dev/ttyUSB0, termios and all.
#ifndef ODOCAL_ROBOT_LINK_PTY_H_
#define ODOCAL_ROBOT_LINK_PTY_H_

#include <string>

#include "odocal/base/status.h"
#include "odocal/robot_link/unique_fd.h"

namespace odocal::robot_link {

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
