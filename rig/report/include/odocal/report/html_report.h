// report.html: a self-contained page (inline SVG and CSS, no scripts, no
// external assets) drawn from any command's report.json, so every command
// that writes one (batch, demo, validate, the station) calls the same function.
//
// What it draws, from the keys it finds (others are listed in the raw JSON at
// the end of the page):
//  - `umbmark` and `iterations[].umbmark`: the return-error scatter with the
//    CW/CCW centres of gravity and their sigma, E_max,syst as a circle
//    (Borenstein & Feng 1996, fig. 5), and the estimate with its uncertainty;
//  - `iterations[].emax_syst_mm`: convergence over iterations (log scale);
//  - `trajectories[]` ({name, direction, points_mm: [[x, y], ...]}, the
//    camera's measurement frame): where the camera saw the robot;
//  - `axes[]` (validate): a Bland-Altman plot per axis, bias and limits of
//    agreement with their confidence intervals, outliers marked;
//  - `runs[]`, `corrected`, `robot_params_final`, `ros2`, `cvra`, `verdict`,
//    `notes`: tables and text, every number with its sigma or flags.
// Units as in report.json: mm and degrees.
#ifndef ODOCAL_REPORT_HTML_REPORT_H_
#define ODOCAL_REPORT_HTML_REPORT_H_

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "odocal/base/status.h"
#include "odocal/measure/measure.h"

namespace odocal::report {

std::string ReportHtml(const nlohmann::json& report, const std::string& title);

// Writes ReportHtml atomically to `path` (config::WriteFileAtomically's errors).
Status WriteReportHtml(const nlohmann::json& report, const std::string& title, const std::string& path);

}  // namespace odocal::report

#endif  // ODOCAL_REPORT_HTML_REPORT_H_
