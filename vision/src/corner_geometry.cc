#include "corner_geometry.h"

#include <algorithm>
#include <cmath>

namespace odocal::vision::internal {

std::optional<TagExtent> CheckRefinementInput(const cv::Mat& grey,
                                              const std::array<cv::Point2d, 4>& corners_px,
                                              const CornerRefineOptions& options, std::string* why) {
  if (!options.IsValid(why)) return std::nullopt;
  if (grey.empty() || grey.type() != CV_8UC1) {
    *why = "refinement needs an 8-bit grey image";
    return std::nullopt;
  }
  TagExtent extent;
  double perimeter = 0.0;
  for (int k = 0; k < 4; ++k) {
    perimeter += cv::norm(corners_px[(k + 1) % 4] - corners_px[k]);
    extent.centre_px += corners_px[k] * 0.25;
  }
  extent.cell_px = perimeter / 4.0 / options.width_at_border;
  if (extent.cell_px < options.min_cell_px) {
    *why = "tag too small for edge refinement";
    return std::nullopt;
  }
  extent.half_width_px = std::min(options.max_half_width_px, 0.45 * extent.cell_px);
  return extent;
}

void CornersFromEdges(const std::array<EdgeLine, 4>& lines, const CameraModel* camera,
                      const std::array<cv::Point2d, 4>& input_corners_px, double cell_px,
                      CornerRefineResult* result) {
  std::array<cv::Point2d, 4> refined;
  for (int k = 0; k < 4; ++k) {
    const EdgeLine& a = lines[(k + 3) % 4];
    const EdgeLine& b = lines[k];
    const double den = a.dir.x * b.dir.y - a.dir.y * b.dir.x;
    if (std::abs(den) < 1e-6) {
      result->message = "degenerate edges";
      return;
    }
    const cv::Point2d d = b.point - a.point;
    refined[k] = a.point + a.dir * ((d.x * b.dir.y - d.y * b.dir.x) / den);
  }
  if (camera) {
    const auto& in = camera->intrinsics();
    for (auto& c : refined) {
      const auto px =
          camera->ProjectCamera(Eigen::Vector3d((c.x - in.cx) / in.fx, (c.y - in.cy) / in.fy, 1.0));
      c = cv::Point2d(px->x(), px->y());
    }
  }
  for (int k = 0; k < 4; ++k) {
    if (cv::norm(refined[k] - input_corners_px[k]) > std::max(1.5, 0.3 * cell_px)) {
      result->message = "refined corner moved implausibly far; keeping the input";
      return;
    }
  }
  result->ok = true;
  result->corners_px = refined;
}

}  // namespace odocal::vision::internal
