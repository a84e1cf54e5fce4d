// Why a run's number is missing or doubtful: the kinds of flag a measurement
// can raise, each with a stable text form (what report.json's "flags" and the
// CLI print) and whether it leaves the run without a return error.
//
// The text of a flag is its kind's name, then, when it has one, its detail
// after the kind's separator: "tag_out_of_view_mid_run:1.2s",
// "image_quality:start_rest:overexposed", "video_unreadable: <message>".
// Tools read these strings: a kind's name and separator never change.
#ifndef ODOCAL_CALIBRATION_RUN_FLAG_H_
#define ODOCAL_CALIBRATION_RUN_FLAG_H_

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "odocal/base/format.h"

namespace odocal::calibration {

enum class RunFlagKind {
  // The recording itself (video runs).
  kVideoUnreadable,       // fatal; detail: the decoder's message
  kTimestampsUnreadable,  // the frames keep the video's own stamps
  kTelemetryUnreadable,   // detail: the reader's message
  kTelemetryMalformed,    // detail: the reader's message
  kNoTelemetry,           // (stand-in camera) the run has no telemetry
  // The tag.
  kTagNeverSeen,           // fatal
  kWrongTagId,             // fatal; detail: which id was expected
  kDuplicateTagId,         // fatal; detail: the id and in how many frames
  kTagOutOfViewMidRun,     // detail: the longest gap, "1.2s"
  // The rests.
  kNoStartRest,            // fatal
  kNoEndRest,              // fatal
  kShortStartRest,
  kShortEndRest,
  kImageQuality,           // fatal; detail: "start_rest:<reason>" or "end_rest:<reason>"
  kExactRefinementFailed,
  // Pose-log runs (pose_log.h).
  kNanFrames,                // detail: how many
  kTrackerJump,              // detail: how many frames
  kTrackerNeverValid,
  kClockOffset,              // detail: the offset, "+0.120s"
  kStartRestFromStillWheels,
  kStartRestFromFirstPose,
  kEndRestFromStillWheels,
  kEndRestFromLastPose,
  kDefaultFrameSigma,
};

// The kind's name in the flag's text ("tag_out_of_view_mid_run").
const char* Name(RunFlagKind kind);
// Whether a run with a flag of this kind has no return error.
bool IsFatal(RunFlagKind kind);

struct RunFlag {
  RunFlagKind kind = RunFlagKind::kNoStartRest;
  std::string detail;  // empty: the flag is its kind's name alone

  static RunFlag Of(RunFlagKind kind, std::string detail = {}) { return {kind, std::move(detail)}; }
  bool fatal() const { return IsFatal(kind); }
  // The stable text form: Name(kind), then the separator and detail if any.
  std::string ToString() const;
  bool operator==(const RunFlag& other) const = default;
};

std::ostream& operator<<(std::ostream& os, const RunFlag& flag);

// The flag a text form names (the inverse of ToString); nullopt for text
// that names no kind.
std::optional<RunFlag> ParseRunFlag(const std::string& text);

// Whether any of the flags leaves its run without a return error.
bool AnyFatal(const std::vector<RunFlag>& flags);

// The text forms, in order (report.json's "flags").
using odocal::ToStrings;  // base/format.h: each flag's ToString()

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_RUN_FLAG_H_
