#include "odocal/measure/tape_validation.h"

#include <algorithm>
#include <cmath>

#include "odocal/base/units.h"

namespace odocal::measure {

double TapePair::camera_x_mm() const { return camera.pose.x() * kMToMm; }
double TapePair::camera_y_mm() const { return camera.pose.y() * kMToMm; }
double TapePair::camera_theta_deg() const { return camera.pose.heading() * kRadToDeg; }
double TapePair::sigma_x_mm() const { return camera.sigma_x_m() * kMToMm; }
double TapePair::sigma_y_mm() const { return camera.sigma_y_m() * kMToMm; }
double TapePair::sigma_theta_deg() const { return camera.sigma_heading_rad() * kRadToDeg; }

double NiceCeil(double v) {
  if (!(v > 0.0)) return 0.0;
  const double p = std::pow(10.0, std::floor(std::log10(v)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * p >= v * (1 - 1e-12)) return m * p;
  return 10.0 * p;
}

TapeValidation ValidateTape(const std::vector<TapePair>& pairs,
                            const calibration::BlandAltmanOptions& options) {
  struct Axis {
    std::string key, unit;
    std::vector<double> manual, camera, camera_sigma;
    std::vector<const config::ManualReading*> from;
  };
  std::vector<Axis> axes = {{"x", "mm", {}, {}, {}, {}},
                            {"y", "mm", {}, {}, {}, {}},
                            {"theta", "deg", {}, {}, {}, {}}};
  for (const TapePair& p : pairs) {
    axes[0].manual.push_back(p.reading->x_mm);
    axes[0].camera.push_back(p.camera_x_mm());
    axes[0].camera_sigma.push_back(p.sigma_x_mm());
    axes[0].from.push_back(p.reading);
    axes[1].manual.push_back(p.reading->y_mm);
    axes[1].camera.push_back(p.camera_y_mm());
    axes[1].camera_sigma.push_back(p.sigma_y_mm());
    axes[1].from.push_back(p.reading);
    if (p.reading->theta_deg) {
      axes[2].manual.push_back(*p.reading->theta_deg);
      axes[2].camera.push_back(p.camera_theta_deg());
      axes[2].camera_sigma.push_back(p.sigma_theta_deg());
      axes[2].from.push_back(p.reading);
    }
  }
  TapeValidation v;
  bool position_ok = true;
  for (const Axis& a : axes) {
    if (a.key == "theta" && a.manual.empty()) continue;
    AxisAgreement axis;
    axis.key = a.key;
    axis.unit = a.unit;
    axis.agreement = calibration::BlandAltman(a.manual, a.camera, options);
    const calibration::BlandAltmanResult& r = axis.agreement;
    if (!r.ok()) {
      v.notes.push_back(a.key + ": " + r.message);
      if (axis.position()) position_ok = false;
      continue;
    }
    for (double s : a.camera_sigma) axis.camera_sigma_max = std::max(axis.camera_sigma_max, s);
    axis.readings = a.from;
    if (axis.position()) {
      v.error_bound_mm = std::max(v.error_bound_mm, r.error_bound());
      v.limits_worst_case_mm = std::max({v.limits_worst_case_mm, std::abs(r.lower_limit_ci.lower),
                                         std::abs(r.upper_limit_ci.upper)});
      v.position_n = r.n;
    }
    v.axes.push_back(std::move(axis));
  }
  v.status = position_ok && !v.axes.empty() ? StatusCode::kOk : StatusCode::kFailed;
  // The tape is good for return errors well above its own error: a third
  // or less of what it measures keeps E_max,syst within ~30 %.
  v.usable_above_emax_mm = NiceCeil(3.0 * v.error_bound_mm);
  return v;
}

}  // namespace odocal::measure
