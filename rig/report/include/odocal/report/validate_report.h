// `odocal validate`: how far the tape can be trusted. Its report.json
// (docs/formats.md, "validate") and the words people read: each axis's
// Bland-Altman agreement in a sentence, and the verdict. The statistics are
// measure/tape_validation.h's; this is how they are written.
//
// Differences are manual − camera, in the run's start frame. Units at this
// edge: mm, deg.
#ifndef ODOCAL_REPORT_VALIDATE_REPORT_H_
#define ODOCAL_REPORT_VALIDATE_REPORT_H_

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "odocal/calibration/bland_altman.h"
#include "odocal/measure/measure.h"
#include "odocal/measure/tape_validation.h"

namespace odocal::report {

struct ValidateReport {
  nlohmann::json json;                 // report.json
  std::vector<std::string> sentences;  // one per axis, in the axes' order
  std::string verdict;                 // the plain verdict
};

// `validation` must be ok(); `notes` are the readings left out and the
// validation's own notes; `session` holds every run measured (report.json's
// runs and trajectories).
ValidateReport MakeValidateReport(const std::string& session_path, const std::string& manual_path, double confidence,
                                  const std::vector<measure::TapePair>& pairs,
                                  const measure::TapeValidation& validation, const std::vector<std::string>& notes,
                                  const measure::SessionMeasurement& session);

// "x: tape reads 1.20 mm high (95 % CI ...), a single reading within ±2.10 mm of that (...)".
std::string AxisSentence(const std::string& axis, const std::string& unit, const calibration::BlandAltmanResult& r,
                         double confidence);

}  // namespace odocal::report

#endif  // ODOCAL_REPORT_VALIDATE_REPORT_H_
