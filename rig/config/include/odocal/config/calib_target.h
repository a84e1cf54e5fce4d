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
#include <vector>

#include "odocal/base/status.h"
#include "odocal/vision/camera_calibration.h"

namespace odocal::config {

// `name` prefixes the error line ("FILE:LINE: key: what"); kBadFile when it does not parse.
Result<vision::CalibrationBoard> ParseCalibrationTarget(const std::string& text, const std::string& name);
Result<vision::CalibrationBoard> ReadCalibrationTarget(const std::string& path);

// One corner of yac's aprilgrid detections, the per-frame CSV yac writes
// beside its data sets (`#ts,tag_rows,tag_cols,tag_size,tag_spacing,kp_x,kp_y,
// p_x,p_y,p_z,tag_id,corner_idx`): the pixel (OpenCV's convention) and the
// corner's board point (m). corner_idx is tag.h's corner order.
struct YacAprilgridCorner {
  int tag_id = 0;
  int corner = 0;
  double x_px = 0.0, y_px = 0.0;
  double board_x_m = 0.0, board_y_m = 0.0;
};
// Every corner of one frame's file; '#' lines skipped. A line without 12
// numbers, or a corner index outside 0..3, is an error naming FILE:LINE.
Result<std::vector<YacAprilgridCorner>> ReadYacAprilgridCsv(const std::string& path);

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_CALIB_TARGET_H_
