#include "odocal/report/json.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "odocal/base/format.h"
#include "odocal/base/units.h"

namespace odocal::report {
namespace {


nlohmann::json OrNull(const std::optional<double>& value, double scale = 1.0) {
  return value ? nlohmann::json(*value * scale) : nlohmann::json(nullptr);
}

nlohmann::json FirstOrderJson(const calibration::FirstOrderEstimate& e) {
  return {
      {"alpha_deg", e.alpha_rad * kRadToDeg},
      {"beta_deg", e.beta_rad * kRadToDeg},
      {"R_mm", FiniteOrNull(e.R_m * kMToMm)},
      {"Ed", e.Ed},
      {"Eb", e.Eb},
      {"c_left", e.c_left},
      {"c_right", e.c_right},
      {"sigma", {{"alpha_deg", OrNull(e.sigma_alpha_rad, kRadToDeg)},
                 {"beta_deg", OrNull(e.sigma_beta_rad, kRadToDeg)},
                 {"Ed", OrNull(e.sigma_Ed)},
                 {"Eb", OrNull(e.sigma_Eb)}}},
  };
}

std::string WithSigma(double value, const std::optional<double>& sigma, int precision,
                      double scale = 1.0) {
  std::string s = Fixed(value * scale, precision);
  if (sigma) s += " +/- " + Fixed(*sigma * scale, precision);
  return s;
}

}  // namespace

nlohmann::json FiniteOrNull(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

nlohmann::json PoseJson(const calibration::Pose2& pose) {
  return {{"x_mm", pose.x() * kMToMm}, {"y_mm", pose.y() * kMToMm},
          {"heading_deg", pose.heading() * kRadToDeg}};
}

nlohmann::json ReturnErrorJson(const calibration::Pose2& error) {
  return {{"x_mm", error.x() * kMToMm}, {"y_mm", error.y() * kMToMm},
          {"theta_deg", error.heading() * kRadToDeg}};
}

nlohmann::json TicksPerRevJson(double ticks_per_rev) {
  const double whole = std::round(ticks_per_rev);
  if (std::abs(ticks_per_rev - whole) < 1e-9 && std::abs(whole) < 9e15)
    return static_cast<long long>(whole);
  return ticks_per_rev;
}

nlohmann::json WheelParamsJson(const calibration::WheelParams& p) {
  return {{"left_wheel_diameter_mm", p.left_wheel_diameter_m * kMToMm},
          {"right_wheel_diameter_mm", p.right_wheel_diameter_m * kMToMm},
          {"track_mm", p.track_m * kMToMm},
          {"ticks_per_rev", TicksPerRevJson(p.ticks_per_rev)}};
}

nlohmann::json Ros2Json(const calibration::Ros2Multipliers& m) {
  return {{"wheel_separation_multiplier", m.wheel_separation_multiplier},
          {"left_wheel_radius_multiplier", m.left_wheel_radius_multiplier},
          {"right_wheel_radius_multiplier", m.right_wheel_radius_multiplier}};
}

nlohmann::json UmbmarkJson(const calibration::UmbmarkInput& input,
                           const calibration::UmbmarkSummary& s) {
  const calibration::CoupledEstimate& c = s.coupled;
  nlohmann::json interval = nullptr;
  if (c.sigma_Ed && c.sigma_Eb && c.t95) {
    interval = {{"Ed", {c.Ed - *c.t95 * *c.sigma_Ed, c.Ed + *c.t95 * *c.sigma_Ed}},
                {"Eb", {c.Eb - *c.t95 * *c.sigma_Eb, c.Eb + *c.t95 * *c.sigma_Eb}}};
  }
  const bool repeated = s.cw.n >= 2;
  nlohmann::json runs = {{"cw", nlohmann::json::array()}, {"ccw", nlohmann::json::array()}};
  for (const auto& [key, list] : {std::pair{"cw", &input.cw}, std::pair{"ccw", &input.ccw}})
    for (const calibration::ReturnError& e : *list) {
      nlohmann::json j = {{"x_mm", e.x_m * kMToMm}, {"y_mm", e.y_m * kMToMm}};
      if (e.heading_rad) j["theta_deg"] = *e.heading_rad * kRadToDeg;
      runs[key].push_back(j);
    }
  return {
      {"return_errors", runs},
      {"side_mm", input.side_m * kMToMm},
      {"track_mm", input.track_m * kMToMm},
      {"n_cw", s.cw.n},
      {"n_ccw", s.ccw.n},
      {"x_cg_cw_mm", s.cw.x_m * kMToMm},
      {"y_cg_cw_mm", s.cw.y_m * kMToMm},
      {"x_cg_ccw_mm", s.ccw.x_m * kMToMm},
      {"y_cg_ccw_mm", s.ccw.y_m * kMToMm},
      {"sigma_cg",
       {{"x_cw_mm", OrNull(s.cw.sigma_x_m, 1e3)},
        {"y_cw_mm", OrNull(s.cw.sigma_y_m, 1e3)},
        {"x_ccw_mm", OrNull(s.ccw.sigma_x_m, 1e3)},
        {"y_ccw_mm", OrNull(s.ccw.sigma_y_m, 1e3)}}},
      {"emax_syst_mm", s.emax_syst_m * kMToMm},
      {"first_order_x", FirstOrderJson(s.from_x)},
      {"first_order_y", FirstOrderJson(s.from_y)},
      {"estimate",
       {{"method", "coupled exact-square least squares"},
        {"Ed", c.Ed},
        {"Eb", c.Eb},
        {"sigma_Ed", OrNull(c.sigma_Ed)},
        {"sigma_Eb", OrNull(c.sigma_Eb)},
        {"correlation", OrNull(c.correlation)},
        {"interval95", interval},
        {"used_heading", c.used_heading},
        {"track_corrected_mm", s.track_corrected_m * kMToMm},
        {"turn_scale", s.turn_scale},
        {"c_left", s.c_left},
        {"c_right", s.c_right}}},
      {"quality",
       {{"uncertainty", repeated ? "from the spread of " + std::to_string(s.cw.n) +
                                       " runs a direction, propagated"
                                 : "none: one run a direction (repeat runs for an uncertainty)"},
        {"rms_weighted_residual", c.rms_weighted_residual},
        {"iterations", c.iterations}}},
  };
}

std::string UmbmarkTable(const calibration::UmbmarkInput& input,
                         const calibration::UmbmarkSummary& s) {
  std::ostringstream os;
  os << "UMBMark  side " << Fixed(input.side_m * kMToMm, 1) << " mm, track "
     << Fixed(input.track_m * kMToMm, 1) << " mm, " << s.cw.n << " cw + " << s.ccw.n << " ccw runs\n\n";
  os << "  centre of gravity    x [mm]               y [mm]\n";
  os << "  cw                   " << std::left << std::setw(21)
     << WithSigma(s.cw.x_m, s.cw.sigma_x_m, 2, 1e3) << WithSigma(s.cw.y_m, s.cw.sigma_y_m, 2, 1e3)
     << "\n";
  os << "  ccw                  " << std::setw(21)
     << WithSigma(s.ccw.x_m, s.ccw.sigma_x_m, 2, 1e3)
     << WithSigma(s.ccw.y_m, s.ccw.sigma_y_m, 2, 1e3) << "\n";
  os << "  E_max,syst           " << Fixed(s.emax_syst_m * kMToMm, 2) << " mm\n\n";
  os << "                       alpha [deg]  beta [deg]   Ed           Eb\n";
  for (const auto& [label, fo] : {std::pair{"first order, from x", s.from_x},
                                  std::pair{"first order, from y", s.from_y}}) {
    os << "  " << std::setw(21) << label << std::setw(13) << Fixed(fo.alpha_rad * kRadToDeg, 4)
       << std::setw(13) << Fixed(fo.beta_rad * kRadToDeg, 4) << std::setw(13) << Fixed(fo.Ed, 6)
       << Fixed(fo.Eb, 6) << "\n";
  }
  os << "  " << std::setw(47) << "coupled (exact square)" << std::setw(13)
     << Fixed(s.coupled.Ed, 6) << Fixed(s.coupled.Eb, 6) << "\n";
  if (s.coupled.sigma_Ed && s.coupled.sigma_Eb) {
    os << "  " << std::setw(47) << "  1-sigma" << std::setw(13) << Fixed(*s.coupled.sigma_Ed, 6)
       << Fixed(*s.coupled.sigma_Eb, 6) << "\n";
  } else {
    os << "  (one run a direction: no uncertainty; repeat runs to get one)\n";
  }
  os << "\n  corrected track      " << Fixed(s.track_corrected_m * kMToMm, 3) << " mm\n";
  os << "  turn scale           " << Fixed(s.turn_scale, 6) << "\n";
  os << "  c_left, c_right      " << Fixed(s.c_left, 6) << ", " << Fixed(s.c_right, 6)
     << "  (multiply each wheel's diameter, i.e. its travel per tick)\n";
  return os.str();
}

}  // namespace odocal::report
