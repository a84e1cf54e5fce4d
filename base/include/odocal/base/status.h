// The one error vocabulary of odocal: a code, a message that names the field or the file in
// words an operator understands, and the value when there is one. Expected failures (a bad
// file, a robot that does not answer, a fit that does not converge) are results, not
// exceptions: nothing throws across a module boundary.
//
//   Result<Session> session = config::LoadSession(path);
//   if (!session) return Result<Report>::From(session);   // passes the error on
//   Use(*session);                                        // or session->runs
//
// A Status is a Result without a value.
#ifndef ODOCAL_BASE_STATUS_H_
#define ODOCAL_BASE_STATUS_H_

#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

namespace odocal {

enum class StatusCode {
  kOk,
  // Inputs
  kInvalidArgument,  // a value the caller gave cannot be used (message names it)
  kNotFound,         // a file or an item that should be there is not
  kBadFile,          // a file is there but cannot be parsed or breaks its format
  // Computation
  kNoConvergence,    // an iterative solver did not converge
  kFailed,           // the computation ran but could not give a usable answer
  // I/O and processes
  kIoError,          // read/write failed on an open file or device
  kOpenFailed,       // device path missing, busy, not a tty, no permission
  // The robot link
  kLineCut,          // the device went away (cable pulled, pty closed)
  kTimeout,          // robot not answering
  kCrcErrors,        // frames arrived but none passed the CRC (noise, baud)
  kVersionMismatch,  // robot speaks another protocol version
  kTableMismatch,    // robot has another parameter table
  kNack,             // robot refused the request (message says why)
  kVerifyFailed,     // read-back differs from what was sent
  kProtocolError,    // a well-formed frame with nonsense inside
};

// The code in an operator's words ("robot not answering", "bad file", ...).
std::string_view ToString(StatusCode code);

struct Empty {};

template <typename T>
struct Result {
  StatusCode status = StatusCode::kOk;
  std::string message;
  std::optional<T> value;

  bool ok() const { return status == StatusCode::kOk; }
  explicit operator bool() const { return ok(); }
  // The value, as with std::optional; only on an ok result.
  T& operator*() { return *value; }
  const T& operator*() const { return *value; }
  T* operator->() { return &*value; }
  const T* operator->() const { return &*value; }
  static Result Ok(T v) { return Result{StatusCode::kOk, "", std::move(v)}; }
  static Result Ok()
    requires std::is_same_v<T, Empty>
  {
    return Result{StatusCode::kOk, "", Empty{}};
  }
  static Result Error(StatusCode code, std::string msg) {
    return Result{code, std::move(msg), std::nullopt};
  }
  // Re-types an error result (the value is dropped).
  template <typename U>
  static Result From(const Result<U>& other) {
    return Result{other.status, other.message, std::nullopt};
  }
};

using Status = Result<Empty>;

template <typename T>
std::ostream& operator<<(std::ostream& os, const Result<T>& r) {
  return os << ToString(r.status) << (r.message.empty() ? "" : ": ") << r.message;
}

}  // namespace odocal

#endif  // ODOCAL_BASE_STATUS_H_
