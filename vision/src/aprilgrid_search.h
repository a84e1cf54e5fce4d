// Internal: the aprilgrid's tags that libapriltag did not find, looked for
// where the tags it did find put them (DetectAprilgrid's last stage).
//
// libapriltag finds a tag by fitting a quad to a thresholded blob. Through a
// fisheye a large tag's edges are curves and no quad fits; a tag of 12-15 px
// has too few pixels for the threshold to keep its border whole. Both are
// still measurable: the board's other tags say where each one is, the edge
// model refines its corners from there (through the lens, where edges are
// curves), and the tag's own bits say whether it is there.
#ifndef ODOCAL_VISION_SRC_APRILGRID_SEARCH_H_
#define ODOCAL_VISION_SRC_APRILGRID_SEARCH_H_

#include <array>
#include <map>
#include <optional>

#include <opencv2/core.hpp>

#include "odocal/vision/camera_calibration.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/edge_shift.h"

namespace odocal::vision::internal {

using TagCorners = std::array<cv::Point2d, 4>;  // tag.h's order, OpenCV pixels

// Where the board's tags are in the image, from tags already measured: with
// a lens, one homography of the board plane to the undistorted (normalised)
// image plane, exact for a plane through any central lens; without one, the
// homography of the nearest measured tag within one tag of the one wanted
// (a tag's own reaches its neighbours with little of an unknown lens's
// bending), the board's pixel homography beyond.
class BoardPrediction {
 public:
  // nullopt unless the measured tags span two rows and two columns.
  static std::optional<BoardPrediction> Fit(const CalibrationBoard& board, const std::map<int, TagCorners>& measured,
                                            const CameraModel* lens);
  // Tag `id`'s corners; nullopt when not on the board or not projectable.
  std::optional<TagCorners> Corners(int id) const;

 private:
  struct Local {
    int col = 0, row = 0;
    cv::Matx33d H;  // board -> pixels
  };
  const CalibrationBoard* board_ = nullptr;
  const CameraModel* lens_ = nullptr;
  cv::Matx33d H_;  // board -> normalised (lens) or pixels (none)
  std::vector<Local> local_;
};

// The tag's cells read at their centres through `corners` (and the lens):
// how many disagree with `cells` (black where the family's bitmap is), and
// the contrast between the cells that should be white and black.
struct CodeCheck {
  int mismatches = 0;
  int cells = 0;
  double contrast = 0.0;  // grey levels
};
std::optional<CodeCheck> CheckTagCode(const cv::Mat& grey, const TagCorners& corners, const TagCells& cells,
                                      const CameraModel* lens);

// For a tag too small for the above (isolated bits blurred to grey): every
// pixel over its data bits (inside the border) against the bitmap blurred as
// the image is, the best Pearson correlation over a few blurs, and that fit's
// grey levels per unit of the bitmap (near 0 on a plain square); nullopt
// when too few pixels lie there.
struct DataCorrelation {
  double correlation = 0.0;
  double contrast = 0.0;  // grey levels
};
std::optional<DataCorrelation> CorrelateTagData(const cv::Mat& grey, const TagCorners& corners, const TagCells& cells,
                                                const CameraModel* lens);

}  // namespace odocal::vision::internal

#endif  // ODOCAL_VISION_SRC_APRILGRID_SEARCH_H_
