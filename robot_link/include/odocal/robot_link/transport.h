// A byte stream to a robot: a serial port, a pseudo-terminal, an in-process
// firmware, or a fault-injecting wrapper around any of these.
#ifndef ODOCAL_ROBOT_LINK_TRANSPORT_H_
#define ODOCAL_ROBOT_LINK_TRANSPORT_H_

#include <chrono>
#include <cstdint>
#include <span>
#include <string>

namespace odocal::robot_link {

enum class IoStatus {
  kOk,
  kTimeout,  // Read only: nothing arrived within the timeout
  kClosed,   // the other end is gone (hang-up, EIO on a pty, cable cut)
  kError,    // any other OS error; message says which
};

struct IoResult {
  IoStatus status = IoStatus::kOk;
  size_t bytes = 0;     // bytes read or written
  std::string message;  // empty when kOk
};

class Transport {
 public:
  virtual ~Transport() = default;
  // Writes all of `data` or fails.
  virtual IoResult Write(std::span<const uint8_t> data) = 0;
  // Reads at least one byte into `buffer` (up to its size), waiting at most
  // `timeout`; kTimeout with bytes == 0 when nothing came.
  virtual IoResult Read(std::span<uint8_t> buffer, std::chrono::milliseconds timeout) = 0;
  // Human-readable name for messages ("/dev/ttyUSB0", "loopback").
  virtual std::string Describe() const = 0;
};

}  // namespace odocal::robot_link

#endif  // ODOCAL_ROBOT_LINK_TRANSPORT_H_
