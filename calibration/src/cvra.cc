#include "odocal/calibration/cvra.h"

#include <cmath>

#include "odocal/calibration/pose2.h"
#include "odocal/calibration/umbmark.h"

namespace odocal::calibration {
namespace {

CvraResult Invalid(const std::string& message) {
  CvraResult r;
  r.status = StatusCode::kInvalidArgument;
  r.message = message;
  return r;
}

CvraResult Ok(double value) {
  CvraResult r;
  r.status = StatusCode::kOk;
  r.message = "ok";
  r.value = value;
  return r;
}

bool Finite(std::initializer_list<double> values) {
  for (double v : values)
    if (!std::isfinite(v)) return false;
  return true;
}

CvraResult RatioFrom(double numerator, double denominator, const char* what) {
  if (!(numerator > 0.0) || !(denominator > 0.0)) {
    return Invalid(std::string(what) +
                   ": the heading error is too large for the distance travelled; the wheel "
                   "ratio would not be positive (check units: mm and degrees)");
  }
  return Ok(numerator / denominator);
}

}  // namespace

CvraResult WheelRatioFromWall(double mean_travel_m, double wall_heading_rad, double track_m) {
  if (!Finite({mean_travel_m, wall_heading_rad, track_m}))
    return Invalid("a value is not a finite number");
  if (!(mean_travel_m > 0.0)) return Invalid("distance-mm must be positive");
  if (!(track_m > 0.0)) return Invalid("track-mm must be positive");
  const double half_difference = wall_heading_rad * track_m / 2.0;
  return RatioFrom(mean_travel_m - half_difference, mean_travel_m + half_difference,
                   "heading-deg");
}

CvraResult WheelRatioFromCamera(double mean_travel_m, double heading_error_rad, double track_m) {
  if (!Finite({mean_travel_m, heading_error_rad, track_m}))
    return Invalid("a value is not a finite number");
  if (!(mean_travel_m > 0.0)) return Invalid("distance-mm must be positive");
  if (!(track_m > 0.0)) return Invalid("track-mm must be positive");
  return RatioFrom(2.0 * mean_travel_m + heading_error_rad * track_m,
                   2.0 * mean_travel_m - heading_error_rad * track_m, "heading-deg");
}

double WheelGainFactor(double Ed) { return (1.0 / Ed - 1.0) / (1.0 / Ed + 1.0); }

CvraResult ScaleFromStraight(double asked_m, double true_dx_m, double true_dy_m,
                             double true_heading_rad) {
  if (!Finite({asked_m, true_dx_m, true_dy_m, true_heading_rad}))
    return Invalid("a value is not a finite number");
  // A run backwards (negative asked) measures the same scale.
  if (!(std::abs(asked_m) > 0.0)) return Invalid("asked-mm must not be zero");
  asked_m = std::abs(asked_m);
  const double chord = std::hypot(true_dx_m, true_dy_m);
  if (!(chord > 0.0)) return Invalid("real distance must be positive");
  if (std::abs(true_heading_rad) >= M_PI / 2.0)
    return Invalid("heading-deg: a straight run that turns 90 degrees or more is not straight");
  // Arc length from chord: s = c * (h/2) / sin(h/2), exact for a constant-curvature run.
  const double half = true_heading_rad / 2.0;
  const double arc = std::abs(half) < 1e-8 ? chord : chord * half / std::sin(half);
  return Ok(arc / asked_m);
}

CvraResult TrackFromWall(double believed_rotation_rad, double wall_heading_rad) {
  if (!Finite({believed_rotation_rad, wall_heading_rad}))
    return Invalid("a value is not a finite number");
  if (std::abs(believed_rotation_rad) < M_PI) return Invalid("turns must be at least one");
  const double g = 1.0 + wall_heading_rad / believed_rotation_rad;
  if (!(g > 0.0)) return Invalid("heading-deg: the track factor would not be positive");
  return Ok(g);
}

CvraResult TrackFromCamera(double believed_rotation_rad, double heading_error_rad) {
  if (!Finite({believed_rotation_rad, heading_error_rad}))
    return Invalid("a value is not a finite number");
  if (std::abs(believed_rotation_rad) < M_PI) return Invalid("turns must be at least one");
  if (std::abs(heading_error_rad) > M_PI)
    return Invalid("heading-deg: a heading error beyond 180 degrees is ambiguous");
  return Ok(believed_rotation_rad / (believed_rotation_rad + heading_error_rad));
}

WheelParams ApplyCvra(const WheelParams& params, std::optional<double> Ed,
                      std::optional<double> scale, std::optional<double> g) {
  WheelParams out = params;
  if (Ed) {
    out.left_wheel_diameter_m *= CorrectionLeft(*Ed);
    out.right_wheel_diameter_m *= CorrectionRight(*Ed);
  }
  const double s = scale.value_or(1.0);
  out.left_wheel_diameter_m *= s;
  out.right_wheel_diameter_m *= s;
  if (g) out.track_m *= *g * s;
  return out;
}

}  // namespace odocal::calibration
