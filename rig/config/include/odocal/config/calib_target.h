// Kalibr's calibration target file (target.yaml) as an odocal board.
//
// Kalibr (ethz-asl/kalibr, wiki "Calibration targets") writes
//   target_type: 'aprilgrid'
//   tagCols: 6          # tags across
//   tagRows: 6          # tags down
//   tagSize: 0.088      # tag side, the black border's outer edge [m]
//   tagSpacing: 0.3     # gap between tags / tagSize
//   codeOffset: 0       # optional: the first tag's id
// and yac's camera files carry the same target under `calib_target:` with
// snake_case keys (tag_rows, tag_cols, tag_size, tag_spacing). Either is read
// into a vision::CalibrationBoard of type kAprilgrid (tag36h11b2: Kalibr's
// tags have a 2-bit black border). Other target types (checkerboard,
// circlegrid) are refused with the line and key named: odocal takes those as
// --board chessboard:... on the command line.
#ifndef ODOCAL_CONFIG_CALIB_TARGET_H_
#define ODOCAL_CONFIG_CALIB_TARGET_H_

#include <optional>
#include <string>

#include "odocal/base/status.h"
#include "odocal/vision/camera_calibration.h"

namespace odocal::config {

// `name` prefixes the error line ("FILE:LINE: key: what").
std::optional<vision::CalibrationBoard> ParseCalibrationTarget(const std::string& text, const std::string& name,
                                                               std::string* error);
Result<vision::CalibrationBoard> ReadCalibrationTarget(const std::string& path);

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_CALIB_TARGET_H_
