// The edge shift of a tag's image: how far every boundary between black and
// white lies from where the print puts it, measured in the tag itself.
//
// A tone curve (gamma) with blur, ink spread, a sensor's bloom or a phone's
// sharpening move every black/white edge by about the same distance s along
// its normal, towards the white when the black grows. The outer corners,
// the intersections of the four outer edges, then describe a square 2s px
// larger than the print: the tag looks nearer (or farther) than it is, and
// a camera scaled by the tag's apparent size is off by 2s / side (1 % for
// s = 0.3 px on a 60 px tag). The centre and the heading do not move.
//
// Nothing outside the tag is needed to measure s: inside it, black and white
// cells of equal printed width look unequal by 2s. Fitted model (linear in
// the grey level, every pixel of the tag's black square and a margin of its
// white surround): the tag's cell pattern, its black cells grown by s on
// every side that faces white, mapped by the homography of the refined outer
// corners shrunk by the same s (so the outer edges stay where the edge fit
// found them), blurred by an isotropic Gaussian (width per pixel through the
// homography's and the lens's local scale, plus the pixel's own box as its
// variance 1/12), between a dark and a light level. Parameters: s, the blur,
// the two levels. Exact for a Gaussian blur of a print whose cells are
// squares, to first order in the tag's perspective; the blur of neighbouring
// cells (2-3 px cells on a Kalibr grid at 640 x 480) is in the model, so
// narrow cells do not look narrower than they are.
//
// Pixels: OpenCV convention (pixel centres at integers), distorted image
// pixels in and out; with a camera the pattern is straight in the undistorted
// plane (a fisheye's curved edges included).
#ifndef ODOCAL_VISION_EDGE_SHIFT_H_
#define ODOCAL_VISION_EDGE_SHIFT_H_

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/base/solver_settings.h"
#include "odocal/base/status.h"
#include "odocal/vision/camera_model.h"

namespace odocal::vision {

// The cells inside a tag's black border (its outer edge included): n x n,
// row-major, row 0 at the top of the printed bitmap, true = black. Corner k of
// the detector (tag.h: p[0] bottom-left, counter-clockwise in the image) is
// the printed square's corner (-n/2, -n/2), (n/2, -n/2), (n/2, n/2),
// (-n/2, n/2) in cells, y up the bitmap.
struct TagCells {
  int n = 0;
  std::vector<std::uint8_t> black;

  bool Black(int row, int col) const {
    return row >= 0 && col >= 0 && row < n && col < n && black[static_cast<size_t>(row * n + col)] != 0;
  }
  // From libapriltag's bitmap of the family's tag `id` (any family tag.h
  // knows, the 2-bit-border ones included); kInvalidArgument naming the
  // family or the id otherwise.
  static Result<TagCells> Of(const std::string& family, int id);
};

struct EdgeShiftOptions {
  // The white surround included beyond the outer edge (cells).
  double margin_cells = 0.6;
  // Left out: the squares of this many cells at each outer corner, where a
  // Kalibr grid's corner squares touch the tag and blur rounds the corner.
  double corner_cells = 1.5;
  // Cells narrower than this (px) are not measured (ok = false). 1.3: a
  // Kalibr tag of 13 px, a fisheye's view of an aprilgrid at a metre; the
  // shift within 0.04 px of the ink from 1.35 px cells (edge_shift_test),
  // and on the real D435i frames resampled through a fisheye at 1.3-1.4 px
  // it took out the 0.11 px the corners sat inside the print (2 px before:
  // not measured there, docs/vision.md "Real photographs through a fisheye").
  double min_cell_px = 1.3;
  // The blur's upper bound, as a fraction of a cell: beyond it the pattern
  // is a grey smear whose shift the levels and the blur absorb.
  double max_blur_cells = 0.5;
  // At most about this many pixels are fitted: a larger tag's are taken one
  // in k x k (k = 2 from ~130 px tags). A 180 px tag (a 640x480 aprilgrid
  // frame scaled 6x) cost ~1 s a tag, 90 % of its detection.
  double max_pixels = 16000.0;
  SolverSettings solver{.max_iterations = 30, .function_tolerance = 1e-10, .parameter_tolerance = 1e-10};

  bool IsValid(std::string* why) const;
};

struct EdgeShiftResult {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;
  // s (px, along the edges' normals, positive when the black looks larger),
  // and its 1-sigma from the fit (Gauss-Newton, scaled by the residual).
  double shift_px = 0.0;
  double sigma_px = 0.0;
  double blur_px = 0.0;      // the Gaussian's sigma, pixel box excluded
  double rms_grey = 0.0;     // fit residual, grey levels
  double cell_px = 0.0;      // mean cell width
  double side_px = 0.0;      // mean side of the outer square as given
  int pixels = 0;
};

// s from one tag image. `grey` may be a crop whose pixel (0, 0) is image
// pixel `origin`; `corners_px` the refined outer corners in image pixels.
EdgeShiftResult MeasureEdgeShift(const cv::Mat& grey, const std::array<cv::Point2d, 4>& corners_px,
                                 const TagCells& cells, const CameraModel* camera,
                                 const EdgeShiftOptions& options = {}, const cv::Point& origin = {0, 0});

// The whole tag fitted at once: the same model with the outer square's four
// corners free too, so that every black/white boundary of the tag (some 80 on
// tag36h11, not only the outer four edges) places and turns it. `corners_px`
// (refined outer corners) is the start; the result's corners are the print's
// (the shift removed), or the input when !shift.ok().
struct TagPatternResult {
  EdgeShiftResult shift;
  std::array<cv::Point2d, 4> corners_px{};
};
TagPatternResult RefineTagByPattern(const cv::Mat& grey, const std::array<cv::Point2d, 4>& corners_px,
                                    const TagCells& cells, const CameraModel* camera,
                                    const EdgeShiftOptions& options = {}, const cv::Point& origin = {0, 0});

// One shift for many views of one tag (the camera's tone curve and blur and
// the print's ink do not change between them): the mean, its sigma the larger
// of the views' spread and their fits' sigmas over sqrt(n), in quadrature with
// `systematic_px` (what the model leaves on images it does not invert: a
// gamma-2.2 disk-PSF camera leaves ~0.02 px, tests/vision/edge_shift_test.cc).
struct EdgeShiftEstimate {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;
  double shift_px = 0.0;
  double sigma_px = 0.0;
  double spread_px = 0.0;  // the views' standard deviation
  double side_px = 0.0;    // the tag's mean side in those views
  int views = 0;
  // What the shift does to a length the tag's apparent size scales: the
  // relative error of that scale when the shift is left in (2 s / side), and
  // the relative sigma of it once removed.
  double RelativeScaleError() const { return side_px > 0.0 ? 2.0 * shift_px / side_px : 0.0; }
  double RelativeScaleSigma() const { return side_px > 0.0 ? 2.0 * sigma_px / side_px : 0.0; }
};
EdgeShiftEstimate PoolEdgeShifts(const std::vector<EdgeShiftResult>& views, double systematic_px = 0.02);

// The corners of the printed square: `corners_px` (the outer edges' corners,
// each edge s px outwards of the print) moved so that every edge moves s px
// inwards — the square scaled about its centre through its homography.
std::array<cv::Point2d, 4> RemoveEdgeShift(const std::array<cv::Point2d, 4>& corners_px, double shift_px,
                                           const CameraModel* camera);

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_EDGE_SHIFT_H_
