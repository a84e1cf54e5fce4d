// report.json's entries for what a batch of sessions says about the wheels
// (measure/estimate_session.h): "umbmark", "cvra", "trajectory_fit"; and which
// of them an export holds (measure/estimator_choice.h): "estimator_choice".
// Units at this edge: millimetres and milliseconds, the unit in the key.
#ifndef ODOCAL_REPORT_SESSION_ESTIMATE_JSON_H_
#define ODOCAL_REPORT_SESSION_ESTIMATE_JSON_H_

#include <nlohmann/json.hpp>

#include "odocal/calibration/robot_model.h"
#include "odocal/calibration/trajectory_fit.h"
#include "odocal/measure/estimate_session.h"
#include "odocal/measure/estimator_choice.h"

namespace odocal::report {

// report.json's "umbmark" (UmbmarkJson of the squares used); null without UMBMark.
nlohmann::json SessionUmbmarkJson(const measure::SessionEstimate& estimate);

// report.json's "cvra": {ratio: {Ed, sigma_Ed, n, runs}, scale: {scale, ...},
// track: {track_factor, ...}}, each only when measured; empty without any.
nlohmann::json CvraJson(const measure::SessionEstimate& estimate);

// report.json's "trajectory_fit": frames, gap and noise floor, the clock
// offset, Ed, Es, Eb and turn_gain with their sigma (null when not
// identifiable), and, when every one is identifiable, the corrected
// parameters and their ROS 2 multipliers.
nlohmann::json TrajectoryFitJson(const calibration::WheelParams& nominal,
                                 const calibration::TrajectoryFitResult& fit);

// report.json's "estimator_choice": {requested, chosen, cross_validated,
// why, runs (the held-out runs scored), candidates[] {name, defined,
// corrected (its parameters fitted on every run, null when undefined),
// heldout_final_error_mm {mean, sigma, max} (null when not cross-validated),
// per_run_mm, heldout_rms_error_mm {mean, sigma} (over every frame of the
// same replays; reported, not used for the choice)}, notes}.
nlohmann::json EstimatorChoiceJson(const std::string& requested, const measure::EstimatorChoice& choice);

}  // namespace odocal::report

#endif  // ODOCAL_REPORT_SESSION_ESTIMATE_JSON_H_
