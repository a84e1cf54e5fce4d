// Runs found in one continuous recording, and matched to a plan.
//
// A long video (or pose log) holds several runs separated by rests. The
// rests are found as everywhere else (rest.h, FindRests); each stretch of
// motion between two rests is a segment, and what the robot did in it is
// read off the measured poses alone:
//   turned     the heading change summed along the motion (unwrapped, CCW +)
//   path       the distance travelled by the tag's centre
//   returned   the distance from the start rest to the end rest
//   in place   the share of |turning| done while the centre barely moved
// A segment is then
//   spin          |turned| ~ N turns, all of it in place, nothing driven at a
//                 steady heading (the tracked point may circle the axle)
//   umbmark       |turned| ~ 1 turn, returned near the start, turning in
//                 place; side = path / 4; cw when turned < 0
//   circle        |turned| ~ N turns, returned near the start, turning while
//                 moving; radius = path / (2 pi N)
//   out_and_back  |turned| ~ 0 net, returned near the start, 180 deg turns in
//                 place; distance = path / (2 repeats); cw when the first
//                 turn is to the right
//   straight      |turned| small, returned ~ excursion (the distance is the
//                 displacement: the tracked point may be yawed on the robot)
//   recorded      anything else
// A camera over the start area loses the robot for most of a run: when a
// gap in the sightings leaves the heading unknown (seen_turning.h) the
// procedure cannot be read (`readable` false). Such a segment is the planned
// run unless what *was* seen contradicts it (a turn the wrong way while in
// view, an end heading or displacement the plan cannot give, farther from
// the start than the plan goes): SegmentContradicts.
// MatchSegmentsToPlan aligns the segments with the plan in order (an edit
// distance: a run missing, a segment extra, a segment that is not the run
// planned at its place -- half as much when it is the planned procedure
// driven another way) and names every disagreement with its times, and any
// other reading of the recording that is as good.
//
// Units: SI (m, rad, s). Pure math: poses in, segments out.
#ifndef ODOCAL_CALIBRATION_SEGMENT_H_
#define ODOCAL_CALIBRATION_SEGMENT_H_

#include <optional>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/calibration/procedures.h"
#include "odocal/calibration/rest.h"
#include "odocal/calibration/seen_turning.h"

namespace odocal::calibration {

struct MotionSegment {
  RestWindow start_rest, end_rest;  // the rests either side
  double turned_rad = 0.0;          // signed, unwrapped, CCW positive
  double first_turn_rad = 0.0;      // the first in-place turn's sign and size (out_and_back)
  double path_m = 0.0;
  double returned_m = 0.0;          // |end rest - start rest| (positions)
  double excursion_m = 0.0;         // the farthest the centre got from the start rest
  double straight_m = 0.0;          // driven at a steady heading (in 50 mm steps)
  double in_place_fraction = 0.0;   // of |turning| done while the centre barely moved
  double in_place_turning_rad = 0.0;  // |turning| done in place
  RunSpec inferred;                 // kRecorded when nothing fits
  // The heading as seen, in chains across the gaps (one chain: all seen).
  SeenTurning seen;
  // Whether the procedure could be read: every gap in the sightings was
  // bridged. Otherwise `inferred` is kRecorded and the plan decides.
  bool readable = true;

  // The span a run measured over this segment needs: from the start of
  // the rest before to the end of the rest after.
  double begin_s() const { return start_rest.t_begin_s; }
  double end_s() const { return end_rest.t_end_s; }
};

// Segments of the motion in `samples` (time ordered; invalid samples are
// gaps), each between two rests of `rest_options`. Motion before the first
// rest or after the last has no rest on one side and is not a segment.
// `unwrap` says which gaps in the sightings the heading is unwrapped across.
std::vector<MotionSegment> SegmentMotion(const std::vector<PoseSample>& samples,
                                         const RestOptions& rest_options = {},
                                         const SeenTurningOptions& unwrap = {});

// "umbmark cw, side 2.000 m", "spin ccw, 3 turns", ... (mm in the text).
std::string Describe(const RunSpec& spec);

// Describe(inferred), or for a segment that could not be read "a motion
// out of view for 41.3 s of 45.2 s".
std::string DescribeSeen(const MotionSegment& segment);

// Whether a segment's inferred spec is the planned run: same procedure and
// direction (and turns), size within `size_tolerance` (relative) of it.
bool SegmentMatches(const RunSpec& planned, const RunSpec& inferred, double size_tolerance = 0.25);

// For a segment that could not be read: nullopt when what was seen agrees
// with `planned`, else one sentence why not. Readable segments are judged by
// SegmentMatches instead.
std::optional<std::string> SegmentContradicts(const RunSpec& planned, const MotionSegment& segment,
                                              double size_tolerance = 0.25);

struct PlanMatch {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  // Per planned run, the index of its segment (when ok: every run has one).
  std::vector<int> segment_of_run;
  // Every disagreement, one line each, naming the run and the segment's
  // times: "run 'ccw2' (umbmark ccw, side 2000 mm): missing (nothing between
  // 81.2 s and 83.0 s)", "extra segment 112.4-140.9 s (spin cw, 2 turns):
  // not in the plan", "run 'cw3' (umbmark cw, ...): the segment at
  // 150.1-201.4 s is umbmark ccw, side 1998 mm".
  std::vector<std::string> problems;
  // Other alignments as good as the one above whose disagreements differ
  // (e.g. which of two squares driven alike is the extra one): the
  // recording cannot tell them apart, so the message must give them too.
  // At most three; `more_readings` when there were more.
  std::vector<std::vector<std::string>> other_readings;
  bool more_readings = false;
};

// Aligns `segments` with the runs `planned` (names for the messages) in
// order, at the least cost: a run missing, a segment extra or a segment
// that is another procedure costs 2, the planned procedure driven another
// way (direction, size, turns) 1. A segment that could not be read costs
// nothing against a run it does not contradict, 2 against one it does. So a run missing next to a square driven
// the wrong way reads as that (3), not as the square missing and its
// neighbour replaced by a square (4).
PlanMatch MatchSegmentsToPlan(const std::vector<MotionSegment>& segments,
                              const std::vector<RunSpec>& planned,
                              const std::vector<std::string>& names,
                              double size_tolerance = 0.25);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_SEGMENT_H_
