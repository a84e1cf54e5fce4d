// Results of robot_link operations: a status, a message naming the cause in
// words a station operator understands, and the value when there is one.
// Expected failures (timeouts, CRC errors, a robot refusing) are results, not
// exceptions: nothing throws across the module boundary.
#ifndef ODOCAL_ROBOT_LINK_RESULT_H_
#define ODOCAL_ROBOT_LINK_RESULT_H_

#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <utility>

namespace odocal::robot_link {

enum class Status {
  kOk,
  kInvalidArgument,  // the caller asked for something the protocol cannot say
  kOpenFailed,       // device path missing, busy, not a tty, no permission
  kIoError,          // read/write failed on an open device
  kLineCut,          // the device went away (cable pulled, pty closed)
  kTimeout,          // robot not answering
  kCrcErrors,        // frames arrived but none passed the CRC (noise, baud)
  kVersionMismatch,  // robot speaks another protocol version
  kTableMismatch,    // robot has another parameter table
  kNack,             // robot refused the request (message says why)
  kVerifyFailed,     // read-back differs from what was sent
  kProtocolError,    // a well-formed frame with nonsense inside
};

std::string_view ToString(Status status);

template <typename T>
struct Result {
  Status status = Status::kOk;
  std::string message;
  std::optional<T> value;

  bool ok() const { return status == Status::kOk; }
  explicit operator bool() const { return ok(); }
  static Result Ok(T v) { return Result{Status::kOk, "", std::move(v)}; }
  static Result Error(Status s, std::string msg) { return Result{s, std::move(msg), std::nullopt}; }
  // Re-types an error result (the value is dropped).
  template <typename U>
  static Result From(const Result<U>& other) {
    return Result{other.status, other.message, std::nullopt};
  }
};

struct Empty {};
using Outcome = Result<Empty>;

template <typename T>
std::ostream& operator<<(std::ostream& os, const Result<T>& r) {
  return os << ToString(r.status) << (r.message.empty() ? "" : ": ") << r.message;
}

}  // namespace odocal::robot_link

#endif  // ODOCAL_ROBOT_LINK_RESULT_H_
