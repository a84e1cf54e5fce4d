// What the station drives: the built-in default plan, sized to the camera's
// view, and what spins at two turn rates say about turn slip.
//
// The default plan determines Ed, Eb and Es together and exposes turn slip:
//   UMBMark squares, cw and ccw        Ed and Eb (coupled fit)
//   straights ahead and back           Es (scale), against the camera's length
//   spins at a slow and a fast rate    the track at each rate: turn slip
// Sizes come from the floor the camera sees at the tag's height: the
// largest square (and straight) of a ladder of round sizes for which the
// tag stays in view at every corner from where the robot stands.
//
// Turn slip (sim/effects.h turn_slip; trajectory_fit.h): an in-place turn at
// omega achieves (1 - f |omega|) of what the wheels rolled, so a spin
// measures the effective track factor Eb(omega) = Eb0 / (1 - f omega).
// Two rates give f = (Eb2 - Eb1) / (Eb2 w2 - Eb1 w1) and Eb0 = Eb1 (1 - f w1);
// the sigmas by first-order propagation of the two groups' standard errors.
//
// Units: SI (m, rad, rad/s).
#ifndef ODOCAL_STATION_PLAN_H_
#define ODOCAL_STATION_PLAN_H_

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "odocal/base/units.h"
#include "odocal/calibration/pose2.h"
#include "odocal/calibration/procedures.h"

namespace odocal::station {

struct DefaultPlanOptions {
  int squares_per_direction = 2;
  int straight_pairs = 2;  // each: ahead, then back
  int spins_per_rate = 2;  // per rate: one ccw, one cw, alternating
  int spin_turns = 2;
  double slow_turn_rate_rad_s = DegToRad(30.0);
  double fast_turn_rate_rad_s = DegToRad(120.0);
  // Round sizes tried, largest first (m).
  std::vector<double> sizes_m = {2.0, 1.5, 1.2, 1.0, 0.8, 0.6, 0.5, 0.4, 0.3, 0.25, 0.2, 0.15};
};

// The default plan from where the robot stands (`start`, world) with its tag
// at `T_robot_tag`; `in_view(p)` says whether the tag's centre at world
// point p is fully in the image. Empty with `why` when not even the
// smallest square fits; `summary` says what was chosen.
std::vector<calibration::RunSpec> DefaultPlan(const std::function<bool(const Eigen::Vector2d&)>& in_view,
                                              const calibration::Pose2& start,
                                              const calibration::Pose2& T_robot_tag,
                                              const DefaultPlanOptions& options, std::string* summary);

// One spin's effective track factor (CVRA TrackFromCamera) at its turn rate.
struct SpinTrack {
  double turn_rate_rad_s = 0.0;
  double track_factor = 0.0;
};

struct TurnRateGroup {
  double turn_rate_rad_s = 0.0;
  int runs = 0;
  double mean = 0.0;
  std::optional<double> standard_error;  // with two runs or more
};

struct TurnSlipResult {
  std::vector<TurnRateGroup> groups;  // by rate, ascending
  // With two rates (the slowest and the fastest group), each with a
  // standard error: f (per rad/s) and the track factor at zero rate.
  std::optional<double> slip_per_rad_s, slip_sigma;
  std::optional<double> track_factor_at_rest, track_factor_at_rest_sigma;
  bool significant = false;  // |f| beyond `z` sigma
  std::string advice;        // in words, when significant
};

// Groups spins by rate (rates within 1 % are one group) and compares the
// slowest with the fastest. `z`: the significance threshold in sigmas.
TurnSlipResult AnalyzeTurnRates(const std::vector<SpinTrack>& spins, double z = 3.0);

}  // namespace odocal::station

#endif  // ODOCAL_STATION_PLAN_H_
