// SelectViews (camera_calibration.h): farthest-point sampling of the views'
// board poses.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>

#include "odocal/vision/camera_calibration.h"

namespace odocal::vision {

std::vector<size_t> SelectViews(const std::vector<BoardDetection>& views, cv::Size image_size, int max_views) {
  std::vector<size_t> found;
  for (size_t i = 0; i < views.size(); ++i)
    if (views[i].found && views[i].image_points.size() >= 4) found.push_back(i);
  if (max_views <= 0 || found.size() <= static_cast<size_t>(max_views)) return found;

  // The board's extent over every view.
  float x0 = std::numeric_limits<float>::max(), y0 = x0, x1 = -x0, y1 = -x0;
  for (size_t i : found)
    for (const cv::Point3f& p : views[i].object_points) {
      x0 = std::min(x0, p.x), x1 = std::max(x1, p.x);
      y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
    }
  const std::vector<cv::Point2f> extent = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  const double diagonal = std::hypot(image_size.width, image_size.height);
  // Where a view puts the extent's corners, clamped to a band around the
  // image (a steep partial view's extrapolated corners can go anywhere).
  using Descriptor = std::array<double, 8>;
  std::vector<Descriptor> described;
  std::vector<size_t> usable;
  for (size_t i : found) {
    std::vector<cv::Point2f> board;
    for (const cv::Point3f& p : views[i].object_points) board.emplace_back(p.x, p.y);
    const cv::Mat H = cv::findHomography(board, views[i].image_points, 0);
    if (H.empty()) continue;
    std::vector<cv::Point2f> px;
    cv::perspectiveTransform(extent, px, H);
    Descriptor d;
    for (int k = 0; k < 4; ++k) {
      d[2 * k] = std::clamp<double>(px[k].x, -image_size.width, 2.0 * image_size.width) / diagonal;
      d[2 * k + 1] = std::clamp<double>(px[k].y, -image_size.height, 2.0 * image_size.height) / diagonal;
    }
    described.push_back(d);
    usable.push_back(i);
  }
  if (usable.size() <= static_cast<size_t>(max_views)) return usable;

  const auto distance2 = [](const Descriptor& a, const Descriptor& b) {
    double s = 0.0;
    for (size_t k = 0; k < a.size(); ++k) s += (a[k] - b[k]) * (a[k] - b[k]);
    return s;
  };
  size_t first = 0;
  for (size_t j = 1; j < usable.size(); ++j)
    if (views[usable[j]].image_points.size() > views[usable[first]].image_points.size()) first = j;
  std::vector<double> nearest(usable.size(), std::numeric_limits<double>::infinity());
  std::vector<size_t> chosen;
  for (size_t next = first; chosen.size() < static_cast<size_t>(max_views);) {
    chosen.push_back(usable[next]);
    nearest[next] = -1.0;  // chosen
    for (size_t j = 0; j < usable.size(); ++j)
      if (nearest[j] >= 0.0) nearest[j] = std::min(nearest[j], distance2(described[j], described[next]));
    next = static_cast<size_t>(std::max_element(nearest.begin(), nearest.end()) - nearest.begin());
    if (nearest[next] < 0.0) break;
  }
  std::sort(chosen.begin(), chosen.end());
  return chosen;
}

}  // namespace odocal::vision
