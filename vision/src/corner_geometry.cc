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
  result->status = StatusCode::kOk;
  result->corners_px = refined;
}

EdgeBandSamples SampleEdgeBand(const cv::Mat& grey, const cv::Point& origin, const cv::Point2d& a_px,
                               const cv::Point2d& b_px, const cv::Point2d& centre_px,
                               const CameraModel* camera, double half_width, double end_margin) {
  EdgeBandSamples band;
  const cv::Point2d ab = b_px - a_px;
  const double len = cv::norm(ab);
  const cv::Point2d dir = ab * (1.0 / len);
  cv::Point2d normal(-dir.y, dir.x);
  if ((0.5 * (a_px + b_px) - centre_px).dot(normal) < 0) normal = -normal;  // outwards
  band.normal_px = normal;
  const int x0 = std::max(origin.x, static_cast<int>(std::floor(std::min(a_px.x, b_px.x) - half_width - 1)));
  const int x1 = std::min(origin.x + grey.cols - 1, static_cast<int>(std::ceil(std::max(a_px.x, b_px.x) + half_width + 1)));
  const int y0 = std::max(origin.y, static_cast<int>(std::floor(std::min(a_px.y, b_px.y) - half_width - 1)));
  const int y1 = std::min(origin.y + grey.rows - 1, static_cast<int>(std::ceil(std::max(a_px.y, b_px.y) + half_width + 1)));
  std::vector<cv::Point2d> centres;
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      const cv::Point2d q(x, y);
      const double t = (q - a_px).dot(dir) / len;
      const double d = (q - a_px).dot(normal);
      if (t < end_margin || t > 1.0 - end_margin || std::abs(d) > half_width) continue;
      centres.push_back(q);
      band.value.push_back(grey.at<uint8_t>(y - origin.y, x - origin.x));
      band.offset_px.push_back(d);
    }
  }
  band.undistorted = camera && !centres.empty() ? camera->UndistortPixels(centres) : centres;
  band.jacobian.assign(centres.size(), cv::Vec4d(1.0, 0.0, 0.0, 1.0));
  if (camera && !centres.empty()) {
    // Central differences over half a pixel: the map is smooth on that scale.
    constexpr double h = 0.25;
    std::vector<cv::Point2d> probes;
    probes.reserve(4 * centres.size());
    for (const cv::Point2d& q : centres) {
      probes.emplace_back(q.x + h, q.y);
      probes.emplace_back(q.x - h, q.y);
      probes.emplace_back(q.x, q.y + h);
      probes.emplace_back(q.x, q.y - h);
    }
    const std::vector<cv::Point2d> u = camera->UndistortPixels(probes);
    // A pixel the lens cannot undistort (a fisheye's rays at or beyond 90
    // degrees off the axis have no pinhole image) is left out of the band.
    size_t kept = 0;
    for (size_t i = 0; i < centres.size(); ++i) {
      const cv::Point2d dx = (u[4 * i] - u[4 * i + 1]) * (0.5 / h), dy = (u[4 * i + 2] - u[4 * i + 3]) * (0.5 / h);
      const cv::Point2d& q = band.undistorted[i];
      if (!(std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(dx.x) && std::isfinite(dx.y) &&
            std::isfinite(dy.x) && std::isfinite(dy.y)))
        continue;
      band.undistorted[kept] = q;
      band.jacobian[kept] = cv::Vec4d(dx.x, dy.x, dx.y, dy.y);
      band.value[kept] = band.value[i];
      band.offset_px[kept] = band.offset_px[i];
      ++kept;
    }
    band.undistorted.resize(kept);
    band.jacobian.resize(kept);
    band.value.resize(kept);
    band.offset_px.resize(kept);
  }
  std::vector<cv::Point2d> ends = {a_px, b_px};
  if (camera) ends = camera->UndistortPixels(ends);
  const cv::Point2d u_dir = (ends[1] - ends[0]) * (1.0 / cv::norm(ends[1] - ends[0]));
  cv::Point2d u_normal(-u_dir.y, u_dir.x);
  if (u_normal.dot(normal) < 0) u_normal = -u_normal;
  band.start_angle = std::atan2(u_normal.y, u_normal.x);
  band.start_offset = u_normal.dot(ends[0]);
  if (!std::isfinite(band.start_angle) || !std::isfinite(band.start_offset)) {
    // The segment's ends have no pinhole image: no band.
    band.undistorted.clear();
    band.jacobian.clear();
    band.value.clear();
    band.offset_px.clear();
  }
  return band;
}

}  // namespace odocal::vision::internal
