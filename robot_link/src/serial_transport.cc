#include "odocal/robot_link/serial_transport.h"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace odocal::robot_link {
namespace {

std::optional<speed_t> BaudConstant(int baud) {
  switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 500000: return B500000;
    case 921600: return B921600;
    case 1000000: return B1000000;
    case 2000000: return B2000000;
    case 3000000: return B3000000;
    case 4000000: return B4000000;
    default: return std::nullopt;
  }
}

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

}  // namespace

bool SerialOptions::IsValid(std::string* why) const {
  if (!BaudConstant(baud)) {
    if (why) *why = "unsupported baud rate " + std::to_string(baud);
    return false;
  }
  return true;
}

Result<std::unique_ptr<SerialTransport>> SerialTransport::Open(const std::string& path,
                                                               const SerialOptions& options) {
  using R = Result<std::unique_ptr<SerialTransport>>;
  std::string why;
  if (!options.IsValid(&why)) return R::Error(StatusCode::kInvalidArgument, why);
  // O_NONBLOCK: a port with modem-control lines down must not block open();
  // every later wait goes through poll() with an explicit timeout.
  UniqueFd owned(::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC));
  if (!owned.valid()) return R::Error(StatusCode::kOpenFailed, Errno("cannot open " + path));
  const int fd = owned.get();
  auto fail = [](const std::string& msg) { return R::Error(StatusCode::kOpenFailed, msg); };
  if (!::isatty(fd)) return fail("cannot use " + path + ": not a serial device (not a tty)");
  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) return fail(Errno("cannot configure " + path));
  ::cfmakeraw(&tio);                   // no echo, no line editing, no CR/LF mangling
  tio.c_cflag &= ~(CSTOPB | PARENB | CRTSCTS);  // 8N1, no hardware flow control
  tio.c_cflag |= CS8 | CLOCAL | CREAD;  // ignore modem lines: adapters often lack DCD
  tio.c_iflag &= ~(IXON | IXOFF | IXANY);
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  const speed_t speed = *BaudConstant(options.baud);
  ::cfsetispeed(&tio, speed);
  ::cfsetospeed(&tio, speed);
  if (::tcsetattr(fd, TCSANOW, &tio) != 0) return fail(Errno("cannot configure " + path));
  if (options.flush_on_open) ::tcflush(fd, TCIOFLUSH);
  return R::Ok(std::unique_ptr<SerialTransport>(new SerialTransport(std::move(owned), path)));
}

IoResult SerialTransport::Write(std::span<const uint8_t> data) {
  size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::write(fd_.get(), data.data() + done, data.size() - done);
    if (n > 0) {
      done += static_cast<size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      // Output buffer full: a device that does not drain within a second is
      // as good as gone.
      pollfd p{fd_.get(), POLLOUT, 0};
      const int r = ::poll(&p, 1, 1000);
      if (r == 0) return {IoStatus::kTimeout, done, "write to " + path_ + " stalled"};
      if (r > 0 && (p.revents & (POLLHUP | POLLERR))) {
        return {IoStatus::kClosed, done, path_ + " hung up"};
      }
      continue;
    }
    if (n < 0 && (errno == EIO || errno == ENXIO || errno == ENODEV)) {
      return {IoStatus::kClosed, done, Errno("line to " + path_ + " is gone")};
    }
    return {IoStatus::kError, done, Errno("write to " + path_ + " failed")};
  }
  return {IoStatus::kOk, done, ""};
}

IoResult SerialTransport::Read(std::span<uint8_t> buffer, std::chrono::milliseconds timeout) {
  pollfd p{fd_.get(), POLLIN, 0};
  int r;
  do {
    r = ::poll(&p, 1, static_cast<int>(timeout.count()));
  } while (r < 0 && errno == EINTR);
  if (r < 0) return {IoStatus::kError, 0, Errno("poll on " + path_ + " failed")};
  if (r == 0) return {IoStatus::kTimeout, 0, ""};
  if (!(p.revents & POLLIN) && (p.revents & (POLLHUP | POLLERR | POLLNVAL))) {
    return {IoStatus::kClosed, 0, "line to " + path_ + " hung up"};
  }
  const ssize_t n = ::read(fd_.get(), buffer.data(), buffer.size());
  if (n > 0) return {IoStatus::kOk, static_cast<size_t>(n), ""};
  if (n == 0) return {IoStatus::kClosed, 0, "line to " + path_ + " hung up"};
  if (errno == EAGAIN || errno == EINTR) return {IoStatus::kTimeout, 0, ""};
  if (errno == EIO || errno == ENXIO || errno == ENODEV) {
    return {IoStatus::kClosed, 0, Errno("line to " + path_ + " is gone")};
  }
  return {IoStatus::kError, 0, Errno("read from " + path_ + " failed")};
}

}  // namespace odocal::robot_link
