#include "aprilgrid_search.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace odocal::vision::internal {
namespace {

cv::Point2d Apply(const cv::Matx33d& H, const cv::Point2d& p, double* w_out = nullptr) {
  const cv::Vec3d q = H * cv::Vec3d(p.x, p.y, 1.0);
  if (w_out) *w_out = q[2];
  return {q[0] / q[2], q[1] / q[2]};
}

// Normalised image point -> distorted pixel; nullopt when not finite.
std::optional<cv::Point2d> Project(const CameraModel& lens, const cv::Point2d& normalised) {
  const auto px = lens.ProjectCamera(Eigen::Vector3d(normalised.x, normalised.y, 1.0));
  if (!px || !std::isfinite(px->x()) || !std::isfinite(px->y())) return std::nullopt;
  return cv::Point2d(px->x(), px->y());
}

// Bilinear grey level; nullopt outside the image.
std::optional<double> Sample(const cv::Mat& grey, const cv::Point2d& p) {
  const int x0 = static_cast<int>(std::floor(p.x)), y0 = static_cast<int>(std::floor(p.y));
  if (!(x0 >= 0 && y0 >= 0 && x0 + 1 < grey.cols && y0 + 1 < grey.rows)) return std::nullopt;
  const double fx = p.x - x0, fy = p.y - y0;
  const auto at = [&](int x, int y) { return static_cast<double>(grey.at<uint8_t>(y, x)); };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) + fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

}  // namespace

std::optional<BoardPrediction> BoardPrediction::Fit(const CalibrationBoard& board,
                                                    const std::map<int, TagCorners>& measured,
                                                    const CameraModel* lens) {
  std::vector<cv::Point2d> on_board, in_image;
  std::set<int> cols, rows;
  BoardPrediction out;
  out.board_ = &board;
  out.lens_ = lens;
  for (const auto& [id, corners] : measured) {
    if (!board.AprilgridCorner(id, 0)) continue;  // not this board's tag
    std::vector<cv::Point2d> b(4), px(corners.begin(), corners.end());
    for (int k = 0; k < 4; ++k) {
      const cv::Point3f c = *board.AprilgridCorner(id, k);
      b[k] = cv::Point2d(c.x, c.y);
    }
    if (lens) {
      px = lens->UndistortToNormalized(px);
      if (!std::all_of(px.begin(), px.end(), [](const cv::Point2d& p) { return std::isfinite(p.x) && std::isfinite(p.y); }))
        continue;
    }
    const int i = id - board.first_id;
    cols.insert(i % board.cols);
    rows.insert(i / board.cols);
    on_board.insert(on_board.end(), b.begin(), b.end());
    in_image.insert(in_image.end(), px.begin(), px.end());
    if (!lens) {
      std::vector<cv::Point2f> bf(b.begin(), b.end()), pf(px.begin(), px.end());
      out.local_.push_back({i % board.cols, i / board.cols, cv::Matx33d(cv::getPerspectiveTransform(bf, pf))});
    }
  }
  if (cols.size() < 2 || rows.size() < 2) return std::nullopt;
  // RANSAC at 2 px (in the normalised plane: 2 px over the focal length).
  const double threshold = lens ? 2.0 / lens->intrinsics().fx : 2.0;
  const cv::Mat H = cv::findHomography(on_board, in_image, cv::RANSAC, threshold);
  if (H.empty()) return std::nullopt;
  out.H_ = cv::Matx33d(H);
  return out;
}

std::optional<TagCorners> BoardPrediction::Corners(int id) const {
  if (!board_->AprilgridCorner(id, 0)) return std::nullopt;
  const int i = id - board_->first_id, col = i % board_->cols, row = i / board_->cols;
  cv::Matx33d H = H_;
  if (!lens_) {
    int best = 2;
    for (const Local& l : local_) {
      const int d = std::max(std::abs(l.col - col), std::abs(l.row - row));
      if (d < best) best = d, H = l.H;
    }
  }
  TagCorners out;
  for (int k = 0; k < 4; ++k) {
    const cv::Point3f c = *board_->AprilgridCorner(id, k);
    double w = 0.0;
    const cv::Point2d p = Apply(H, {c.x, c.y}, &w);
    if (!(w > 0.0) || !std::isfinite(p.x) || !std::isfinite(p.y)) return std::nullopt;  // behind the camera
    if (lens_) {
      const auto px = Project(*lens_, p);
      if (!px) return std::nullopt;
      out[k] = *px;
    } else {
      out[k] = p;
    }
  }
  return out;
}

std::optional<CodeCheck> CheckTagCode(const cv::Mat& grey, const TagCorners& corners, const TagCells& cells,
                                      const CameraModel* lens) {
  const double h = 0.5 * cells.n;
  // Corner k in cells, y up the bitmap (edge_shift.h's TagCells).
  const std::vector<cv::Point2f> tag = {{static_cast<float>(-h), static_cast<float>(-h)},
                                        {static_cast<float>(h), static_cast<float>(-h)},
                                        {static_cast<float>(h), static_cast<float>(h)},
                                        {static_cast<float>(-h), static_cast<float>(h)}};
  std::vector<cv::Point2d> image(corners.begin(), corners.end());
  if (lens) image = lens->UndistortToNormalized(image);
  std::vector<cv::Point2f> image_f;
  for (const cv::Point2d& p : image) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return std::nullopt;
    image_f.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  }
  const cv::Matx33d H(cv::getPerspectiveTransform(tag, image_f));
  // The n x n cells, and the ring of white one cell outside the black border
  // (its four diagonal cells left out: a Kalibr grid's corner squares).
  std::vector<double> value;
  std::vector<bool> black;
  for (int row = -1; row <= cells.n; ++row) {
    for (int col = -1; col <= cells.n; ++col) {
      const bool ring = row < 0 || col < 0 || row == cells.n || col == cells.n;
      if (ring && (row < 0 || row == cells.n) && (col < 0 || col == cells.n)) continue;
      const cv::Point2d centre(-h + col + 0.5, h - row - 0.5);
      cv::Point2d p = Apply(H, centre);
      if (lens) {
        const auto px = Project(*lens, p);
        if (!px) return std::nullopt;
        p = *px;
      }
      const auto v = Sample(grey, p);
      if (!v) return std::nullopt;
      value.push_back(*v);
      black.push_back(!ring && cells.Black(row, col));
    }
  }
  double sum_black = 0.0, sum_white = 0.0;
  int n_black = 0, n_white = 0;
  for (size_t i = 0; i < value.size(); ++i) (black[i] ? sum_black : sum_white) += value[i], ++(black[i] ? n_black : n_white);
  if (n_black == 0 || n_white == 0) return std::nullopt;
  CodeCheck out;
  const double dark = sum_black / n_black, light = sum_white / n_white;
  out.contrast = light - dark;
  const double threshold = 0.5 * (dark + light);
  out.cells = static_cast<int>(value.size());
  for (size_t i = 0; i < value.size(); ++i) out.mismatches += black[i] ? value[i] > threshold : value[i] < threshold;
  return out;
}

}  // namespace odocal::vision::internal
