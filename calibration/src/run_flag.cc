#include "odocal/calibration/run_flag.h"

#include <array>
#include <cstddef>

namespace odocal::calibration {
namespace {

struct KindInfo {
  RunFlagKind kind;
  const char* name;
  // Between the name and the detail: ": " before a message, ":" before a value.
  const char* separator;
  bool fatal;
};

constexpr std::array kKinds = {
    KindInfo{RunFlagKind::kVideoUnreadable, "video_unreadable", ": ", true},
    KindInfo{RunFlagKind::kTimestampsUnreadable, "timestamps_unreadable", ":", false},
    KindInfo{RunFlagKind::kTelemetryUnreadable, "telemetry_unreadable", ": ", false},
    KindInfo{RunFlagKind::kTelemetryMalformed, "telemetry_malformed", ": ", false},
    KindInfo{RunFlagKind::kNoTelemetry, "no_telemetry", ":", false},
    KindInfo{RunFlagKind::kTagNeverSeen, "tag_never_seen", ":", true},
    KindInfo{RunFlagKind::kWrongTagId, "wrong_tag_id", ": ", true},
    KindInfo{RunFlagKind::kDuplicateTagId, "duplicate_tag_id", ": ", true},
    KindInfo{RunFlagKind::kTagOutOfViewMidRun, "tag_out_of_view_mid_run", ":", false},
    KindInfo{RunFlagKind::kNoStartRest, "no_start_rest", ":", true},
    KindInfo{RunFlagKind::kNoEndRest, "no_end_rest", ":", true},
    KindInfo{RunFlagKind::kShortStartRest, "short_start_rest", ":", false},
    KindInfo{RunFlagKind::kShortEndRest, "short_end_rest", ":", false},
    KindInfo{RunFlagKind::kImageQuality, "image_quality", ":", true},
    KindInfo{RunFlagKind::kExactRefinementFailed, "exact_refinement_failed", ":", false},
    KindInfo{RunFlagKind::kNanFrames, "nan_frames", ":", false},
    KindInfo{RunFlagKind::kTrackerJump, "tracker_jump", ":", false},
    KindInfo{RunFlagKind::kTrackerNeverValid, "tracker_never_valid", ":", false},
    KindInfo{RunFlagKind::kClockOffset, "clock_offset", ":", false},
    KindInfo{RunFlagKind::kStartRestFromStillWheels, "start_rest_from_still_wheels", ":", false},
    KindInfo{RunFlagKind::kStartRestFromFirstPose, "start_rest_from_first_pose", ":", false},
    KindInfo{RunFlagKind::kEndRestFromStillWheels, "end_rest_from_still_wheels", ":", false},
    KindInfo{RunFlagKind::kEndRestFromLastPose, "end_rest_from_last_pose", ":", false},
    KindInfo{RunFlagKind::kDefaultFrameSigma, "default_frame_sigma", ":", false},
};

const KindInfo& Info(RunFlagKind kind) {
  for (const KindInfo& info : kKinds)
    if (info.kind == kind) return info;
  return kKinds.front();  // unreachable: every kind is in the table
}

}  // namespace

const char* Name(RunFlagKind kind) { return Info(kind).name; }

bool IsFatal(RunFlagKind kind) { return Info(kind).fatal; }

std::string RunFlag::ToString() const {
  const KindInfo& info = Info(kind);
  if (detail.empty()) return info.name;
  return std::string(info.name) + info.separator + detail;
}

std::ostream& operator<<(std::ostream& os, const RunFlag& flag) { return os << flag.ToString(); }

std::optional<RunFlag> ParseRunFlag(const std::string& text) {
  // Names hold no ':', so the name ends at the first one.
  const std::string name = text.substr(0, text.find(':'));
  for (const KindInfo& info : kKinds) {
    if (name != info.name) continue;
    if (text.size() == name.size()) return RunFlag::Of(info.kind);
    const std::string separator = info.separator;
    if (text.compare(name.size(), separator.size(), separator) != 0) return std::nullopt;
    return RunFlag::Of(info.kind, text.substr(name.size() + separator.size()));
  }
  return std::nullopt;
}

bool AnyFatal(const std::vector<RunFlag>& flags) {
  for (const RunFlag& f : flags)
    if (f.fatal()) return true;
  return false;
}

}  // namespace odocal::calibration
