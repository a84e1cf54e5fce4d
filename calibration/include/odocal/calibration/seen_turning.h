// How far a robot turned, as far as a camera that loses it can tell.
//
// A camera gives the robot's heading only modulo a full turn. Between two
// sightings close in time the turn is the wrapped difference; across a gap
// in which the robot could have turned half a turn or more it is unknown
// (a square's three corners driven out of view wrap to +90 deg). So the
// sightings fall into chains: consecutive sightings each within
// `max_turn_rate_rad_s * dt <= max_unwrap_rad` of the last. Within a chain
// the turning is known; the total is known only when one chain spans the
// whole motion. Whether a gap is bridged depends on its length and the
// robot's fastest turn, never on how many frames happened to arrive.
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

#include "odocal/calibration/procedures.h"

namespace odocal::calibration {

struct HeadingSighting {
  double t_s = 0.0;
  double heading_rad = 0.0;
};

struct SeenTurningOptions {
  // The fastest the robot turns (rad/s); a gap of dt between sightings is
  // bridged when max_turn_rate_rad_s * dt <= max_unwrap_rad.
  double max_turn_rate_rad_s = 2.0 * M_PI;
  // Below half a turn, with a margin for heading noise and overshoot.
  double max_unwrap_rad = 2.0 * M_PI / 3.0;

  bool IsValid(std::string* why) const;
  // The longest gap that is bridged (s).
  double MaxGapS() const { return max_unwrap_rad / max_turn_rate_rad_s; }
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
