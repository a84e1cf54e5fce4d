// How far a tape can be trusted: hand-measured return errors (config/manual_csv.h)
// against the camera's measurement of the same runs, per axis by Bland-Altman
// (calibration/bland_altman.h; differences manual - camera), and the verdict:
// the error bound of one tape reading, how uncertain the limits themselves
// are, and the return errors the tape is good for. No I/O: `odocal validate`
// reads the files and writes the report.
//
// Return errors are true - odometry in the run's start frame (measure.h);
// units at this edge as in the CSV: millimetres and degrees.
#ifndef ODOCAL_MEASURE_TAPE_VALIDATION_H_
#define ODOCAL_MEASURE_TAPE_VALIDATION_H_

#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/calibration/bland_altman.h"
#include "odocal/calibration/rest.h"
#include "odocal/config/manual_csv.h"

namespace odocal::measure {

// One tape reading and the camera's usable return error of its run.
struct TapePair {
  const config::ManualReading* reading = nullptr;
  calibration::RelativePose camera;

  double camera_x_mm() const;
  double camera_y_mm() const;
  double camera_theta_deg() const;
  double sigma_x_mm() const;
  double sigma_y_mm() const;
  double sigma_theta_deg() const;
};

// The agreement on one axis: x and y always, theta when any reading has it.
struct AxisAgreement {
  std::string key;   // "x", "y", "theta"
  std::string unit;  // "mm", "deg"
  calibration::BlandAltmanResult agreement;  // ok(): see TapeValidation::notes otherwise
  double camera_sigma_max = 0.0;             // the largest camera sigma on this axis
  std::vector<const config::ManualReading*> readings;  // in the order of the differences
  bool position() const { return key != "theta"; }
};

struct TapeValidation {
  // False when x or y has no agreement statistics (fewer than 3 pairs).
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::vector<AxisAgreement> axes;  // only those whose statistics could be computed
  std::vector<std::string> notes;   // an axis without statistics, and why
  // Over x and y: how far one tape reading is from the camera at the
  // confidence, bias included (BlandAltmanResult::error_bound)...
  double error_bound_mm = 0.0;
  // ...the limits of agreement's far confidence bounds...
  double limits_worst_case_mm = 0.0;
  int position_n = 0;  // readings behind the position axes
  // ...and the return errors the tape is good for: its error a third or
  // less of what it measures keeps E_max,syst within ~30 %, rounded up to
  // 1, 2 or 5 x 10^k mm.
  double usable_above_emax_mm = 0.0;
  // Below this many readings the limits themselves are uncertain.
  static constexpr int kFewReadings = 30;
  bool few_readings() const { return position_n < kFewReadings; }
};

// `pairs`: the readings whose run has a usable camera return error.
TapeValidation ValidateTape(const std::vector<TapePair>& pairs,
                            const calibration::BlandAltmanOptions& options);

// A round figure at or above v: 1, 2, 5 x 10^k; 0 for v <= 0.
double NiceCeil(double v);

}  // namespace odocal::measure

#endif  // ODOCAL_MEASURE_TAPE_VALIDATION_H_
