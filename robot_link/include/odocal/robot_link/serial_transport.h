// POSIX serial transport (termios): USB-serial adapters (/dev/ttyUSB*), CDC-ACM
// boards (/dev/ttyACM*) and pseudo-terminals (/dev/pts/*) alike. The port is
// put in raw 8N1 mode without flow control; reads wait with poll(2), so a
// timeout is a real wall-clock bound.
#ifndef ODOCAL_ROBOT_LINK_SERIAL_TRANSPORT_H_
#define ODOCAL_ROBOT_LINK_SERIAL_TRANSPORT_H_

#include <memory>
#include <string>

#include "odocal/base/status.h"
#include "odocal/robot_link/transport.h"
#include "odocal/robot_link/unique_fd.h"

namespace odocal::robot_link {

struct SerialOptions {
  // Standard rates from 9600 to 4000000; pseudo-terminals ignore it.
  int baud = 115200;
  // Drop whatever the OS buffered before we opened (stale replies, boot noise).
  bool flush_on_open = true;

  bool IsValid(std::string* why) const;
};

class SerialTransport final : public Transport {
 public:
  // kOpenFailed with the OS reason ("No such file or directory", "Permission
  // denied", "not a terminal") when the port cannot be used.
  static Result<std::unique_ptr<SerialTransport>> Open(const std::string& path,
                                                       const SerialOptions& options = {});
  SerialTransport(const SerialTransport&) = delete;
  SerialTransport& operator=(const SerialTransport&) = delete;

  IoResult Write(std::span<const uint8_t> data) override;
  IoResult Read(std::span<uint8_t> buffer, std::chrono::milliseconds timeout) override;
  std::string Describe() const override { return path_; }

 private:
  SerialTransport(UniqueFd fd, std::string path) : fd_(std::move(fd)), path_(std::move(path)) {}
  UniqueFd fd_;
  std::string path_;
};

}  // namespace odocal::robot_link

#endif  // ODOCAL_ROBOT_LINK_SERIAL_TRANSPORT_H_
