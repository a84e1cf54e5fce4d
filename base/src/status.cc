#include "odocal/base/status.h"

namespace odocal {

std::string_view ToString(StatusCode code) {
  switch (code) {
    case StatusCode::kOk: return "ok";
    case StatusCode::kInvalidArgument: return "invalid argument";
    case StatusCode::kNotFound: return "not found";
    case StatusCode::kBadFile: return "bad file";
    case StatusCode::kNoConvergence: return "no convergence";
    case StatusCode::kFailed: return "failed";
    case StatusCode::kIoError: return "I/O error";
    case StatusCode::kOpenFailed: return "cannot open device";
    case StatusCode::kLineCut: return "line cut";
    case StatusCode::kTimeout: return "robot not answering";
    case StatusCode::kCrcErrors: return "CRC errors";
    case StatusCode::kVersionMismatch: return "protocol version mismatch";
    case StatusCode::kTableMismatch: return "parameter table mismatch";
    case StatusCode::kNack: return "robot refused";
    case StatusCode::kVerifyFailed: return "verification failed";
    case StatusCode::kProtocolError: return "protocol error";
  }
  return "?";
}

}  // namespace odocal
