// Manual (tape-measured) return errors, for `odocal validate`.
//
// Format (CSV, UTF-8/ASCII, comma-separated; blank lines and lines starting
// with '#' are ignored; a header line is required):
//
//   run,x_mm,y_mm[,theta_deg]
//   run01_umbmark_cw,-12.5,4.0,0.8
//   run02_umbmark_ccw,10.0,-3.5,
//
// - run: the run's name as in the session file (`runs[].name`).
// - x_mm, y_mm: the run's return error as measured by hand, millimetres, in
//   the run's start frame (x along the start heading, y to the left): true -
//   odometry, the same quantity the camera measures (docs/conventions.md).
// - theta_deg (optional column; a cell may be empty): the end heading minus
//   the start heading, degrees, counter-clockwise positive.
// A run may appear on several lines (several operators, or the same tape
// read several times): each line is one reading.
// Columns are matched by name in the header; other units (x_cm, theta_rad,
// ...) and unknown columns are errors, as are missing cells and non-numbers.
// Every error names the file and the line: "manual.csv:4: ...".
#ifndef ODOCAL_CONFIG_MANUAL_CSV_H_
#define ODOCAL_CONFIG_MANUAL_CSV_H_

#include <optional>
#include <string>
#include <vector>

#include "odocal/base/status.h"

namespace odocal::config {

struct ManualReading {
  std::string run;
  int line = 0;  // 1-based line in the file
  double x_mm = 0.0;
  double y_mm = 0.0;
  std::optional<double> theta_deg;
};

// An error whose message is "FILE:LINE: what" (or "FILE: what") otherwise.
Result<std::vector<ManualReading>> ReadManualCsv(const std::string& path);

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_MANUAL_CSV_H_
