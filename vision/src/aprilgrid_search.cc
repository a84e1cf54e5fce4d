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

namespace {

// Tag cells (the bitmap's centre at 0, y up) -> the undistorted plane
// (normalised through `lens`, else pixels); nullopt where a corner has none.
std::optional<cv::Matx33d> CellsToPlane(const TagCorners& corners, int n, const CameraModel* lens) {
  const double h = 0.5 * n;
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
  return cv::Matx33d(cv::getPerspectiveTransform(tag, image_f));
}

}  // namespace

std::optional<CodeCheck> CheckTagCode(const cv::Mat& grey, const TagCorners& corners, const TagCells& cells,
                                      const CameraModel* lens) {
  const double h = 0.5 * cells.n;
  const auto plane = CellsToPlane(corners, cells.n, lens);
  if (!plane) return std::nullopt;
  const cv::Matx33d& H = *plane;
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

namespace {

// The bitmap drawn at `kScale` samples a cell, with `kPad` cells of white around.
constexpr int kScale = 8, kPad = 2;

// How many outer rings of the bitmap are all one colour: the border.
int BorderRings(const TagCells& cells) {
  const auto ring_of = [&](int row, int col) { return std::min({row, col, cells.n - 1 - row, cells.n - 1 - col}); };
  std::vector<bool> uniform(static_cast<size_t>(cells.n), true);
  for (int row = 0; row < cells.n; ++row)
    for (int col = 0; col < cells.n; ++col)
      if (cells.Black(row, col) != cells.Black(ring_of(row, col), ring_of(row, col)))
        uniform[static_cast<size_t>(ring_of(row, col))] = false;
  int border = 0;
  while (border < cells.n / 2 && uniform[static_cast<size_t>(border)]) ++border;
  return border;
}

// The image's pixels over the data area: where each lies on the tag (cells)
// and its grey level.
struct DataSamples {
  std::vector<cv::Point2d> where;  // cells
  std::vector<double> observed;
};

// The data area pixel by pixel (every `stride`-th in a large tag), each
// pixel's place on the tag through the inverse of `H` (cells -> the
// undistorted plane); those within `inner` cells of the centre. Nullopt when
// the tag's box misses the image.
std::optional<DataSamples> SampleDataArea(const cv::Mat& grey, const TagCorners& corners, const cv::Matx33d& H,
                                          double inner, const CameraModel* lens) {
  cv::Rect box = cv::boundingRect(std::vector<cv::Point2f>{
      cv::Point2f(static_cast<float>(corners[0].x), static_cast<float>(corners[0].y)),
      cv::Point2f(static_cast<float>(corners[1].x), static_cast<float>(corners[1].y)),
      cv::Point2f(static_cast<float>(corners[2].x), static_cast<float>(corners[2].y)),
      cv::Point2f(static_cast<float>(corners[3].x), static_cast<float>(corners[3].y))});
  box &= cv::Rect(0, 0, grey.cols, grey.rows);
  if (box.empty()) return std::nullopt;
  const int stride = std::max(1, static_cast<int>(std::sqrt(box.area() / 20000.0)));
  std::vector<cv::Point2d> pixels;
  for (int y = box.y; y < box.y + box.height; y += stride)
    for (int x = box.x; x < box.x + box.width; x += stride) pixels.emplace_back(x, y);
  std::vector<cv::Point2d> plane = lens ? lens->UndistortToNormalized(pixels) : pixels;
  const cv::Matx33d Hinv = H.inv();
  DataSamples samples;
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (!std::isfinite(plane[i].x) || !std::isfinite(plane[i].y)) continue;
    const cv::Point2d c = Apply(Hinv, plane[i]);
    if (!(std::abs(c.x) < inner && std::abs(c.y) < inner)) continue;
    samples.where.push_back(c);
    samples.observed.push_back(grey.at<std::uint8_t>(static_cast<int>(pixels[i].y), static_cast<int>(pixels[i].x)));
  }
  return samples;
}

// The tag's bitmap at `kScale` samples a cell (white 1), `kPad` cells of white around.
cv::Mat DrawBitmap(const TagCells& cells) {
  const int side = (cells.n + 2 * kPad) * kScale;
  cv::Mat bitmap(side, side, CV_32F, cv::Scalar(1.0f));
  for (int row = 0; row < cells.n; ++row)
    for (int col = 0; col < cells.n; ++col)
      if (cells.Black(row, col))
        bitmap(cv::Rect((col + kPad) * kScale, (row + kPad) * kScale, kScale, kScale)).setTo(0.0f);
  return bitmap;
}

// The blurred bitmap at tag point `where` (cells, centre at 0, y up; `h`
// half the tag's cells), bilinearly.
double BitmapAt(const cv::Mat& blurred, const cv::Point2d& where, double h) {
  const int side = blurred.rows;
  // Bitmap column/row of the point, in samples (pixel centres at +0.5).
  const double x = (where.x + h + kPad) * kScale - 0.5, y = (h - where.y + kPad) * kScale - 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  const auto at = [&](int yy, int xx) {
    return static_cast<double>(blurred.at<float>(std::clamp(yy, 0, side - 1), std::clamp(xx, 0, side - 1)));
  };
  return (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1)) +
         fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1));
}

}  // namespace

std::optional<DataCorrelation> CorrelateTagData(const cv::Mat& grey, const TagCorners& corners, const TagCells& cells,
                                                const CameraModel* lens) {
  const double h = 0.5 * cells.n;
  const auto to_plane = CellsToPlane(corners, cells.n, lens);
  if (!to_plane) return std::nullopt;
  const cv::Matx33d& H = *to_plane;
  DataCorrelation out;
  // The border: the outer rings of the bitmap all one colour.
  const int border = BorderRings(cells);
  // The data area pixel by pixel, each pixel's place on the tag through the
  // inverse homography.
  const double inner = h - border;  // the data bits
  const std::optional<DataSamples> samples = SampleDataArea(grey, corners, H, inner, lens);
  if (!samples) return std::nullopt;
  const std::vector<cv::Point2d>& where = samples->where;
  const std::vector<double>& observed = samples->observed;
  if (where.size() < 16) return std::nullopt;
  // The bitmap drawn at `kScale` samples a cell (white 1), blurred.
  const cv::Mat bitmap = DrawBitmap(cells);
  double perimeter = 0.0;
  for (int k = 0; k < 4; ++k) perimeter += cv::norm(corners[(k + 1) % 4] - corners[k]);
  const double cell_px = perimeter / 4.0 / cells.n;
  double sum_o = 0.0, sum_oo = 0.0;
  for (double o : observed) sum_o += o, sum_oo += o * o;
  const double n = static_cast<double>(observed.size());
  const double var_o = sum_oo - sum_o * sum_o / n;
  for (const double blur_px : {0.35, 0.6, 0.9, 1.3}) {
    cv::Mat blurred;
    const double sigma = blur_px / cell_px * kScale;
    cv::GaussianBlur(bitmap, blurred, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
    double sum_e = 0.0, sum_ee = 0.0, sum_oe = 0.0;
    for (size_t i = 0; i < where.size(); ++i) {
      const double e = BitmapAt(blurred, where[i], h);
      sum_e += e, sum_ee += e * e, sum_oe += observed[i] * e;
    }
    const double var_e = sum_ee - sum_e * sum_e / n, cov = sum_oe - sum_o * sum_e / n;
    if (!(var_e > 0.0) || !(var_o > 0.0)) continue;
    const double r = cov / std::sqrt(var_e * var_o);
    if (r > out.correlation) {
      out.correlation = r;
      out.contrast = cov / var_e;
    }
  }
  return out;
}

}  // namespace odocal::vision::internal
