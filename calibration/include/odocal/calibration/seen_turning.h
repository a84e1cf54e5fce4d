// How far a robot turned, as far as a camera that loses it can tell.
//
// A camera gives the robot's heading only modulo a full turn. Between two
// sightings dt apart the robot turned the wrapped difference w plus some
// whole number of turns, and by at most max_turn_rate * dt either way: when
// only one of w + 2 pi k lies within that reach (|w| + reach < 2 pi, with a
// margin), the turn is known. Otherwise (a square's three corners driven out
// of view wrap to +90 deg) it is not. So the sightings fall into chains of
// consecutive sightings each bridged to the last; within a chain the turning
// is known, and the total only when one chain spans the whole motion.
// Whether a gap is bridged follows from its length, the step seen and the
// robot's fastest turn: a bound, not a guess.
//
// What was seen is then held against the plan (its primitives, procedures.h):
//   the total, when known, within the tolerance of the plan's;
//   always, the net heading change modulo a turn (start and end are seen);
//   each chain's turning must be something the plan does: a chain anchored
//   at the start (or the end) stays within the plan's cumulative heading
//   profile from the start (or to the end); any chain's turning lies within
//   the plan's least and greatest heading change over a stretch.
// A cw square driven ccw is caught when its last corner is turned in view
// (+90 deg where the plan only ever turns right), whatever was out of view.
//
// Units: SI (s, rad), CCW positive. Pure math.
#ifndef ODOCAL_CALIBRATION_SEEN_TURNING_H_
#define ODOCAL_CALIBRATION_SEEN_TURNING_H_

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "odocal/base/units.h"
#include "odocal/calibration/procedures.h"

namespace odocal::calibration {

struct HeadingSighting {
  double t_s = 0.0;
  double heading_rad = 0.0;
};

struct SeenTurningOptions {
  // The fastest the robot turns (rad/s), with a margin for overshoot.
  double max_turn_rate_rad_s = 2.0 * M_PI;
  // What a sighting's heading may be off by (frame noise, a tag seen at
  // the edge of the view): taken off the margin between the two unwraps.
  double heading_margin_rad = DegToRad(10.0);

  bool IsValid(std::string* why) const;
  // Whether a step seen as `wrapped_rad` (in (-pi, pi]) over `gap_s` has
  // one unwrap the robot could have turned.
  bool Bridges(double wrapped_rad, double gap_s) const {
    return max_turn_rate_rad_s * gap_s + heading_margin_rad < 2.0 * M_PI - std::abs(wrapped_rad);
  }
};

// Consecutive sightings, each bridged to the last.
struct TurnChain {
  double t_begin_s = 0.0, t_end_s = 0.0;
  double turned_rad = 0.0;              // last - first, unwrapped
  double lowest_rad = 0.0, highest_rad = 0.0;  // the least and greatest heading, relative to the first
  int sightings = 0;
};

struct SeenTurning {
  std::vector<TurnChain> chains;  // in time order; empty without sightings
  double net_wrapped_rad = 0.0;   // last sighting - first, wrapped to (-pi, pi]
  double unseen_s = 0.0;          // time in gaps that were not bridged
  double largest_gap_s = 0.0;     // between any two consecutive sightings

  // One chain from the first sighting to the last.
  bool whole() const { return chains.size() == 1; }
  std::optional<double> total_rad() const {
    return whole() ? std::optional<double>(chains.front().turned_rad) : std::nullopt;
  }
};

// `sightings` in time order; the first and last are where the motion starts
// and ends (the rests' headings).
SeenTurning TrackSeenTurning(const std::vector<HeadingSighting>& sightings, const SeenTurningOptions& options);

// The plan's heading profile: the cumulative heading (CCW +) at each
// primitive boundary, starting at 0 (a turn or arc is monotone between).
std::vector<double> PlannedHeadings(const std::vector<Primitive>& plan);

// nullopt when what was seen agrees with `plan` within `tolerance_rad`;
// otherwise one sentence saying what the camera saw and what the plan does
// ("the camera saw the robot turn +2 deg, the plan turns -360 deg", "while
// in view at 31.2-34.0 s the camera saw the robot turn +91 deg, and the plan
// turns no more than 0 deg that way").
std::optional<std::string> ContradictsPlan(const SeenTurning& seen, const std::vector<Primitive>& plan,
                                           double tolerance_rad);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_SEEN_TURNING_H_
