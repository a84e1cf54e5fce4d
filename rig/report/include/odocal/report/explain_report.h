// The reports of `odocal explain`: explain.json (keys other tools rely on:
// gap_before_mm, steps[{effect, params, gap_after_mm, score}], gap_after_mm,
// effects_added) and a self-contained explain.html (inline SVG) with the
// residuals before and after. Units at this edge: mm, deg, ms; effect
// parameters keyed as scenario files key them.
#ifndef ODOCAL_REPORT_EXPLAIN_REPORT_H_
#define ODOCAL_REPORT_EXPLAIN_REPORT_H_

#include <string>

#include <nlohmann/json.hpp>

#include "odocal/calibration/explain.h"
#include "odocal/calibration/measured_session.h"

namespace odocal::report {

nlohmann::json ExplainJson(const calibration::MeasuredSession& session,
                           const calibration::ExplainResult& result);
// The second pass after a lens error was found in videos: the videos
// measured again with k1 corrected by `k1_correction`, and explained again.
nlohmann::json CameraRefitJson(double k1_correction, const calibration::MeasuredSession& session,
                               const calibration::ExplainResult& result);
std::string ExplainHtml(const calibration::MeasuredSession& session,
                        const calibration::ExplainResult& result);

}  // namespace odocal::report

#endif  // ODOCAL_REPORT_EXPLAIN_REPORT_H_
