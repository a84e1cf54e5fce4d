// Runs of a session that share one recording, each given its time span.
//
// A session may name one long video (or one pose log) for several runs and
// leave their `start_s`/`end_s` out: the runs are then found in the
// recording (calibration/segment.h: motion between rests, the procedure read
// from the poses) and matched to the session's runs in order. A run with its
// own `start_s` or `end_s` keeps them (an override) and the motion within
// them is left out of the matching. A mismatch -- a run not driven, a run
// more, one driven the wrong way -- is an error naming every such run with
// the segment's times, never a silent reassignment.
//
// Without a plan: a run with `procedure: auto` takes the procedure its
// segment shows; one such run alone in its recording stands for every run
// the recording holds (the plan inferred).
#ifndef ODOCAL_MEASURE_SEGMENT_RUNS_H_
#define ODOCAL_MEASURE_SEGMENT_RUNS_H_

#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/calibration/rest.h"
#include "odocal/calibration/segment.h"
#include "odocal/config/session.h"

namespace odocal::measure {

// What was matched, for the report: one per segmented run.
struct SegmentAssignment {
  std::string run;
  std::string source;  // the video or pose log
  double begin_s = 0.0, end_s = 0.0;
  std::string found;  // what the poses show, calibration::Describe
  // False when the robot was out of view too long to read the procedure:
  // `found` is then the plan's, which nothing seen contradicts.
  bool procedure_seen = true;
};

// Whether the run names its own span (either key set).
bool HasOwnSpan(const config::SessionRun& run);

// The runs of `runs` (pointers into a session; in plan order) sharing the
// recording `source`, whose poses are `samples`: assigns each run without a
// span of its own the span of its matched segment. Only a group of two or
// more runs is segmented (one run takes the whole recording, as before).
// kFailed naming the source and every disagreement.
Status AssignSpansFromRecording(const std::string& source, const std::vector<calibration::PoseSample>& samples,
                                const std::vector<config::SessionRun*>& runs,
                                const calibration::RestOptions& rest_options,
                                std::vector<SegmentAssignment>* assignments);

// Whether `group` (the runs of one recording) is one run with `procedure:
// auto` and no span: the recording's runs are then whatever it holds.
bool IsLoneAutoRun(const std::vector<config::SessionRun*>& group);

// That lone run expanded: one run per motion segment found in `samples`,
// named NAME_01, NAME_02, ..., each with its span and the procedure its poses
// show, appended to `runs`. Squares within 30 % of one side get their median
// side (read from the poses: a few % off; state side_mm in a plan for UMBMark
// to the last digit). kFailed naming source and run when no
// motion between two rests is found.
Status ExpandAutoRun(const config::SessionRun& run, const std::string& source,
                     const std::vector<calibration::PoseSample>& samples, const calibration::RestOptions& rest_options,
                     std::vector<config::SessionRun>* runs, std::vector<SegmentAssignment>* assignments);

// The session's pose-log runs that share a pose log: read, segmented and
// given their spans (before MeasurePoseLogRun reads each span); a lone auto
// run becomes the runs its log holds.
Status AssignPoseLogSpans(config::Session* session, const calibration::RestOptions& rest_options,
                          std::vector<SegmentAssignment>* assignments);

}  // namespace odocal::measure

#endif  // ODOCAL_MEASURE_SEGMENT_RUNS_H_
