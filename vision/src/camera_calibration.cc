#include "odocal/base/units.h"
#include "odocal/vision/camera_calibration.h"

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <set>
#include <utility>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "aprilgrid_search.h"
#include "edge_model_refine.h"
#include "fisheye_fit.h"
#include "odocal/calibration/statistics.h"
#include "odocal/base/parallel.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/edge_shift.h"
#include "odocal/vision/tag.h"
#ifdef ODOCAL_HAVE_ARUCO
#include <opencv2/aruco/charuco.hpp>
#endif

namespace odocal::vision {
namespace {

#ifdef ODOCAL_HAVE_ARUCO
// OpenCV's dictionary names, in the order of cv::aruco::PREDEFINED_DICTIONARY_NAME.
const char* const kDictionaries[] = {
    "DICT_4X4_50",  "DICT_4X4_100",  "DICT_4X4_250",  "DICT_4X4_1000",       "DICT_5X5_50",
    "DICT_5X5_100", "DICT_5X5_250",  "DICT_5X5_1000", "DICT_6X6_50",         "DICT_6X6_100",
    "DICT_6X6_250", "DICT_6X6_1000", "DICT_7X7_50",   "DICT_7X7_100",        "DICT_7X7_250",
    "DICT_7X7_1000", "DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9",
    "DICT_APRILTAG_36h10", "DICT_APRILTAG_36h11"};

std::optional<int> DictionaryId(const std::string& name) {
  for (int i = 0; i < static_cast<int>(std::size(kDictionaries)); ++i) {
    if (name == kDictionaries[i]) return i;
  }
  return std::nullopt;
}

cv::Ptr<cv::aruco::CharucoBoard> MakeCharucoBoard(const CalibrationBoard& board) {
  const auto dict = cv::aruco::getPredefinedDictionary(*DictionaryId(board.dictionary));
  return cv::aruco::CharucoBoard::create(board.cols, board.rows, static_cast<float>(board.square_m),
                                         static_cast<float>(board.marker_m), dict);
}
#endif

// Smallest distance between a corner and its successor in the list: the
// corner spacing along a board row (or across a row break, which is longer).
double MinSpacing(const std::vector<cv::Point2f>& points) {
  double best = 1e9;
  for (size_t i = 1; i < points.size(); ++i) best = std::min(best, cv::norm(points[i] - points[i - 1]));
  return best;
}

// DetectBoard's body; DetectBoard turns an OpenCV exception into "not found".
BoardDetection DetectBoardOrThrow(const cv::Mat& image, const CalibrationBoard& board,
                                  const BoardDetectionOptions& options);

// The image stretched between its local black and white: each pixel mapped
// from [lo, hi] to [0, 255], lo and hi the minimum and maximum over a window
// of 2k + 1 px smoothed by a box of k + 1 px (so lo <= pixel <= hi
// everywhere: nothing clipped, and no steps), a range of at least 16 grey
// levels. Locally an affine map of the grey levels: where the blurred edges
// are does not move.
cv::Mat EvenContrast(const cv::Mat& gray, int k) {
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * k + 1, 2 * k + 1));
  cv::Mat lo, hi;
  cv::erode(gray, lo, kernel);
  cv::dilate(gray, hi, kernel);
  cv::Mat g32, lo32, hi32, stretched, out;
  gray.convertTo(g32, CV_32F);
  lo.convertTo(lo32, CV_32F);
  hi.convertTo(hi32, CV_32F);
  cv::blur(lo32, lo32, cv::Size(k + 1, k + 1));
  cv::blur(hi32, hi32, cv::Size(k + 1, k + 1));
  cv::divide((g32 - lo32) * 255.0, cv::max(hi32 - lo32, 16.0), stretched);
  stretched.convertTo(out, CV_8U);
  return out;
}

// Kalibr's aprilgrid: every tag of the board in view, its corners refined by
// the exact edge model; tags off the board, seen twice, or whose edges could
// not be fitted are refused (named in tags_refused).
//
// A search in stages, each a method: Prepare (the image evened and upsampled,
// libapriltag set up, the edge model's band), LookInPasses (the plain and
// thinned images), LookInPaintedPasses (the corner squares painted white),
// LookWherePredicted (the tags the found ones place), SelectTags (clear of
// the border, corners as sure as the view's), then the edge shift
// (FitWholeTags, or MeasureTheEdgeShift and RefitThroughCornerSquares).
struct AprilgridSearch {
  AprilgridSearch(const CalibrationBoard& board, const BoardDetectionOptions& options)
      : board(board), options(options), quick(options.aprilgrid_corners_only) {}

  BoardDetection Run(const cv::Mat& image) {
    if (!Prepare(image)) return out;
    LookInPasses();
    LookInPaintedPasses();
    LookWherePredicted();
    if (!SelectTags()) return out;
    if (!quick && !RemoveTheEdgeShift()) return out;
    out.found = true;
    return out;
  }

  // The image to look in, libapriltag, and the edge model for this board;
  // false (out.message says why) when the detector cannot be made.
  bool Prepare(const cv::Mat& image) {
    // The tags are looked for and refined in the image with its contrast made
    // even (EvenContrast over a window of aprilgrid_even_contrast_window of the
    // longer side). Under a fisheye's vignetting the white at the rim is a
    // third of the centre's and changes by half across one tag: one threshold
    // per tile of libapriltag misses the dark tags, and an edge fitted with
    // constant levels on either side leans with the light (a tag's own edges
    // and the longer lines through its corner squares then disagree by
    // 0.4-1.7 px, and the tag is refused). A rendered 190-degree lens darkened
    // by 0.6 cos^4 off the axis: 114 of 137 tags, 0.112 px rms, as it is;
    // 135, 0.063 px, evened (KalibrTagRendered.AVignettedFisheyeFindsItsDarkTags).
    gray = options.aprilgrid_even_contrast_window > 0.0
               ? EvenContrast(image, std::max(8, static_cast<int>(std::lround(options.aprilgrid_even_contrast_window *
                                                                              std::max(image.cols, image.rows)))))
               : image;
    // 0: by the image's size (aprilgrid_upsample's comment).
    up = options.aprilgrid_upsample > 0
             ? options.aprilgrid_upsample
             : std::clamp(static_cast<int>(std::lround(1920.0 / std::max(gray.cols, gray.rows))), 1, 3);
    DetectorOptions detector_options;
    detector_options.family = board.tag_family;
    detector_options.quad_decimate = static_cast<float>(up);
    created = TagDetector::Create(detector_options);
    if (!created.ok()) {
      out.message = "aprilgrid: " + created.message;
      return false;
    }
    // Five passes: the plain image, the same with the black thinned by 1,
    // 2 and 3 pixels of the upsampled image. Kalibr's corner squares touch each
    // tag's corners; where the touch survives thresholding, the white around a
    // tag is cut into four strips, and libapriltag's quad finder (which pairs
    // one black with one white component) sees four lone edges, no quad. A
    // rendered aprilgrid at 25-40 px a tag: 1 tag of 36 found in the plain
    // image. Thinning opens the touches; too much of it erases the bits, hence
    // several; and the corner squares painted white (below). The
    // thinned passes' corners lie a little inside the tag; the edge model
    // refits every tag's corners on the (evened) image either way.
    big = gray;
    if (up > 1) cv::resize(gray, big, cv::Size(), up, up, cv::INTER_CUBIC);
    // The edge model's band reaches 0.45 "cell" to either side of an edge,
    // a cell being the tag's side / width_at_border. On an aprilgrid the black
    // border is 2 cells wide (b2 families) and the gap 3 cells (spacing 0.3),
    // so the band may span 2 cells: small tags (2-3 px a cell on a 640x480
    // camera at 2 m) are then refined instead of refused as too small.
    const int width = TagWidthAtBorder(board.tag_family);
    const bool two_bit = board.tag_family.size() > 2 && board.tag_family.substr(board.tag_family.size() - 2) == "b2";
    const int gap_cells = static_cast<int>(std::floor(board.spacing * width + 1e-9));
    const int unit = std::max(1, std::min(two_bit ? 2 : 1, gap_cells));
    refine.width_at_border = std::max(3, width / unit);
    refine.min_cell_px = options.aprilgrid_min_tag_px / refine.width_at_border;
    if (options.lens) lens_model.emplace(*options.lens, CameraMount{});
    lens = lens_model ? &*lens_model : nullptr;
    return true;
  }

  // Pixel centres at integers in both images: x = (X + 0.5) / up - 0.5.
  cv::Point2d ToImage(const cv::Point2d& c) const {
    return cv::Point2d((c.x + 0.5) / up - 0.5, (c.y + 0.5) / up - 0.5);
  }
  cv::Point2d ToBig(const cv::Point2d& c) const { return cv::Point2d((c.x + 0.5) * up - 0.5, (c.y + 0.5) * up - 0.5); }

  // A pass's tags of the board; how many were refined that were not before.
  int Add(const cv::Mat& pass_image) {
    const std::vector<TagDetection> pass = created.detector->Detect(pass_image).detections;
    std::map<int, int> count;
    for (const TagDetection& d : pass) ++count[d.id];
    int added = 0;
    for (const TagDetection& d : pass) {
      if (!board.AprilgridCorner(d.id, 0)) continue;  // another board's tag, or a stray one
      auto it = tags.find(d.id);
      if (it != tags.end() && it->second.refined.ok()) continue;
      if (count[d.id] > 1) ambiguous[d.id] = std::max(ambiguous[d.id], count[d.id]);
      if (ambiguous.count(d.id)) continue;
      std::array<cv::Point2d, 4> corners;
      for (int k = 0; k < 4; ++k) corners[k] = ToImage(d.corners_px[k]);
      FoundTag f;
      if (quick) {
        f.refined.status = StatusCode::kOk;
        f.refined.corners_px = corners;
        f.cov.fill(cv::Matx22d(0.25, 0.0, 0.0, 0.25));
      } else {
        f.refined = internal::RefineTagCornersByEdgeModelWithCovariance(gray, corners, lens, refine, {0, 0}, &f.cov);
      }
      added += f.refined.ok() ? 1 : 0;
      tags[d.id] = f;
    }
    return added;
  }

  // The plain image, then thinned (the comment in Prepare).
  void LookInPasses() {
    Add(big);
    for (const int k : {3, 5, 7}) {
      cv::Mat thinned;
      cv::dilate(big, thinned, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k)));
      Add(thinned);
    }
  }

  // Then passes with the corner squares painted white where the refined tags
  // found so far put them, so that the white around every tag is one region.
  // Each round paints two images: every square through one homography of the
  // whole board (from tags spanning two rows and two columns), and each
  // square through the homography of the nearest tag within
  // aprilgrid_paint_reach tags of it (its own four corners; the board's
  // beyond). The board's homography is the better guess through a pinhole
  // lens; a tag's own reaches its neighbours with little of a fisheye's
  // bending, where the board's is pixels off. A square 4 % of a tag larger
  // all round covers the rest. Repeated while a round refines new tags: each
  // ring of found tags opens the next. On the 30 real D435i frames: 1047 tags
  // (the board's homography alone: 1041); a steep rendered fisheye view: 7
  // (2). Painted with the paper's own white there (the local maximum over a
  // tag's side), not 255: under a lens's vignetting the paper at the rim is
  // grey, and a square of 255 beside it moves libapriltag's local threshold
  // above the paper, which then reads as black (a rendered 190-degree view
  // darkened by cos^4 of the angle off axis, before the contrast was made
  // even: 3 tags of 14 with 255, 14 with the paper's white).
  // A printed square's side, its corner squares' and the pitch of the grid (m).
  double Pitch() const {
    const double s = board.square_m, g = board.spacing * s;
    return s + g;
  }

  // The paper's white near each pixel of `big`, made on first use.
  const cv::Mat& PaperWhite() {
    if (!paper.empty()) return paper;
    std::vector<double> sides;
    for (const auto& [id, f] : tags)
      if (f.refined.ok())
        sides.push_back(0.5 *
                        (cv::norm(f.refined.corners_px[2] - f.refined.corners_px[0]) +
                         cv::norm(f.refined.corners_px[3] - f.refined.corners_px[1])) /
                        std::sqrt(2.0));
    const int k = std::max(3, static_cast<int>(std::lround(sides.empty() ? 9.0 : calibration::Median(sides))) | 1);
    cv::Mat local_max;
    cv::dilate(gray, local_max, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k)));
    cv::resize(local_max, paper, big.size(), 0, 0, cv::INTER_LINEAR);
    return paper;
  }

  // Corner square (i, j) through the board-to-`big` homography H, 4 % of a tag larger all round.
  void PaintSquare(cv::Mat& mask, const cv::Mat& H, int i, int j) const {
    const double s = board.square_m, g = board.spacing * s, pitch = s + g, e = 0.04 * s;
    const double x0 = i * pitch - g - e, x1 = i * pitch + e, y0 = j * pitch - g - e, y1 = j * pitch + e;
    const std::vector<cv::Point2f> square = {cv::Point2f(static_cast<float>(x0), static_cast<float>(y0)),
                                             cv::Point2f(static_cast<float>(x1), static_cast<float>(y0)),
                                             cv::Point2f(static_cast<float>(x1), static_cast<float>(y1)),
                                             cv::Point2f(static_cast<float>(x0), static_cast<float>(y1))};
    std::vector<cv::Point2f> px;
    cv::perspectiveTransform(square, px, H);
    std::vector<cv::Point> poly;
    for (const auto& p : px) poly.emplace_back(cvRound(p.x), cvRound(p.y));
    cv::fillConvexPoly(mask, poly, cv::Scalar(255), cv::LINE_AA);
  }

  // `big` with the squares in `mask` (anti-aliased coverage) painted the paper's white.
  // cv::blendLinear's arithmetic, on the painted pixels only (the mask is
  // 0 on most of `big`, where the blend gives `big` back; three whole-image
  // float passes were a tenth of an aprilgrid frame's time).
  cv::Mat PaintedImage(const cv::Mat& mask) {
    const cv::Mat& white = PaperWhite();
    cv::Mat painted = big.clone();
    for (int y = 0; y < mask.rows; ++y) {
      const std::uint8_t* m = mask.ptr<std::uint8_t>(y);
      const std::uint8_t* w = white.ptr<std::uint8_t>(y);
      std::uint8_t* o = painted.ptr<std::uint8_t>(y);
      for (int x = 0; x < mask.cols; ++x) {
        if (m[x] == 0) continue;
        const float w1 = m[x] * static_cast<float>(1.0 / 255.0), w2 = 1.0f - w1;
        o[x] = cv::saturate_cast<std::uint8_t>((w[x] * w1 + o[x] * w2) / (w1 + w2 + 1e-5f));
      }
    }
    return painted;
  }

  void LookInPaintedPasses() {
    const double pitch = Pitch();
    for (int round = 0; round < (quick ? 0 : options.aprilgrid_paint_rounds); ++round) {
      std::vector<cv::Point2f> on_board, in_image;
      struct Local {
        int col, row;
        cv::Mat H;
      };
      std::vector<Local> local;
      for (const auto& [id, f] : tags) {
        if (!f.refined.ok()) continue;
        std::vector<cv::Point2f> tag_board, tag_image;
        for (int k = 0; k < 4; ++k) {
          const cv::Point3f b = *board.AprilgridCorner(id, k);
          tag_board.emplace_back(b.x, b.y);
          tag_image.emplace_back(ToBig(f.refined.corners_px[k]));
        }
        on_board.insert(on_board.end(), tag_board.begin(), tag_board.end());
        in_image.insert(in_image.end(), tag_image.begin(), tag_image.end());
        const float min_x = std::min({tag_board[0].x, tag_board[1].x, tag_board[2].x, tag_board[3].x});
        const float min_y = std::min({tag_board[0].y, tag_board[1].y, tag_board[2].y, tag_board[3].y});
        local.push_back({static_cast<int>(std::lround(min_x / pitch)), static_cast<int>(std::lround(min_y / pitch)),
                         cv::getPerspectiveTransform(tag_board, tag_image)});
      }
      if (local.empty()) break;
      // The board's homography only from tags that span two rows and two
      // columns: tags in one row leave it free across the row.
      std::set<int> cols, rows;
      for (const Local& l : local) cols.insert(l.col), rows.insert(l.row);
      const cv::Mat H = on_board.size() >= 16 && cols.size() >= 2 && rows.size() >= 2
                            ? cv::findHomography(on_board, in_image, cv::RANSAC, 3.0 * up)
                            : cv::Mat();
      int added = 0;
      if (!H.empty()) {
        cv::Mat mask = cv::Mat::zeros(big.size(), CV_8U);
        for (int j = 0; j <= board.rows; ++j)
          for (int i = 0; i <= board.cols; ++i) PaintSquare(mask, H, i, j);
        added += Add(PaintedImage(mask));
      }
      cv::Mat mask = cv::Mat::zeros(big.size(), CV_8U);
      for (int j = 0; j <= board.rows; ++j) {
        for (int i = 0; i <= board.cols; ++i) {
          // Square (i, j) touches tags (i - 1 .. i, j - 1 .. j); its distance
          // to tag (c, r) in tags is max(|i - c - 0.5|, |j - r - 0.5|) - 0.5.
          const Local* nearest = nullptr;
          double best = options.aprilgrid_paint_reach;
          for (const Local& l : local) {
            const double d = std::max(std::abs(i - l.col - 0.5), std::abs(j - l.row - 0.5)) - 0.5;
            if (d <= best) best = d, nearest = &l;
          }
          if (nearest)
            PaintSquare(mask, nearest->H, i, j);
          else if (!H.empty())
            PaintSquare(mask, H, i, j);
        }
      }
      added += Add(PaintedImage(mask));
      if (added == 0) break;
    }
  }

  void LookWherePredicted() {
    // Last, the tags no pass found, looked for where the found ones put them
    // (aprilgrid_search.h): refined from there by the edge model and kept when
    // their own bits are there. Through a fisheye a large tag's edges are curves
    // no quad fits; repeated while it finds tags, each ring opening the next.
    for (int round = 0; round < (quick ? 0 : options.aprilgrid_predict_rounds); ++round) {
      std::map<int, internal::TagCorners> measured;
      for (const auto& [id, f] : tags)
        if (f.refined.ok() && !ambiguous.count(id)) measured[id] = f.refined.corners_px;
      const auto prediction = internal::BoardPrediction::Fit(board, measured, lens);
      if (!prediction) break;
      int added = 0;
      for (int i = 0; i < board.cols * board.rows; ++i) {
        const int id = board.first_id + i;
        if (measured.count(id) || ambiguous.count(id)) continue;
        const auto predicted = prediction->Corners(id);
        if (!predicted) continue;
        FoundTag f;
        f.refined = internal::RefineTagCornersByEdgeModelWithCovariance(gray, *predicted, lens, refine, {0, 0}, &f.cov);
        if (!f.refined.ok()) continue;
        const auto cells = TagCells::Of(board.tag_family, id);
        const auto code = cells ? internal::CheckTagCode(gray, f.refined.corners_px, *cells, lens) : std::nullopt;
        // The bits read at their centres; for a small tag, its whole data
        // area against its bitmap's and every other id's.
        bool accepted = code && code->contrast >= options.aprilgrid_predicted_min_contrast &&
                        code->mismatches <= options.aprilgrid_predicted_max_mismatch * code->cells;
        if (!accepted && cells) {
          const auto own = internal::CorrelateTagData(gray, f.refined.corners_px, *cells, lens);
          if (own && own->correlation >= options.aprilgrid_predicted_min_correlation &&
              own->contrast >= options.aprilgrid_predicted_min_contrast) {
            double rival = 0.0;
            for (int other = board.first_id; other < board.first_id + board.cols * board.rows; ++other) {
              if (other == id) continue;
              const auto other_cells = TagCells::Of(board.tag_family, other);
              const auto r = other_cells ? internal::CorrelateTagData(gray, f.refined.corners_px, *other_cells, lens)
                                         : std::nullopt;
              if (r) rival = std::max(rival, r->correlation);
            }
            accepted = own->correlation - rival >= options.aprilgrid_predicted_min_margin;
          }
        }
        if (!accepted) continue;
        tags[id] = f;
        ++added;
      }
      if (added == 0) break;
    }
  }

  // The tags kept, into `out`; false (out.message says why) when too few.
  bool SelectTags() {
    int on_board = 0;
    // The tags refined and clear of the border, with their worst corner's
    // sigma; the view's median corner sigma.
    const auto corner_sigma = [](const FoundTag& f, int k) {
      return std::sqrt(0.5 * (f.cov[k](0, 0) + f.cov[k](1, 1)));
    };
    std::vector<std::pair<int, double>> candidates;
    std::vector<double> sigmas;
    for (const auto& [id, f] : tags) {
      ++on_board;
      if (ambiguous.count(id)) continue;
      if (!f.refined.ok()) {
        out.tags_refused.emplace_back(id, "corners not refined: " + f.refined.message);
        continue;
      }
      const CornerRefineResult& r = f.refined;
      const double m = options.aprilgrid_min_border_px;
      if (std::any_of(r.corners_px.begin(), r.corners_px.end(), [&](const cv::Point2d& c) {
            return !(c.x >= m && c.y >= m && c.x <= gray.cols - 1 - m && c.y <= gray.rows - 1 - m);
          })) {
        char why[64];
        std::snprintf(why, sizeof(why), "a corner within %g px of the image's border", m);
        out.tags_refused.emplace_back(id, why);
        continue;
      }
      double worst = 0.0;
      for (int k = 0; k < 4; ++k) {
        sigmas.push_back(corner_sigma(f, k));
        worst = std::max(worst, sigmas.back());
      }
      candidates.emplace_back(id, worst);
    }
    double median_sigma = 0.0;
    if (!sigmas.empty()) {
      std::nth_element(sigmas.begin(), sigmas.begin() + static_cast<long>(sigmas.size() / 2), sigmas.end());
      median_sigma = sigmas[sigmas.size() / 2];
    }
    for (const auto& [id, worst] : candidates) {
      const FoundTag& f = tags.at(id);
      if (!(worst <= options.aprilgrid_max_corner_sigma_ratio * median_sigma)) {
        char why[112];
        std::snprintf(why, sizeof(why), "a corner's sigma %.3f px, over %g times the view's median %.3f px", worst,
                      options.aprilgrid_max_corner_sigma_ratio, median_sigma);
        out.tags_refused.emplace_back(id, why);
        continue;
      }
      out.tag_ids.push_back(id);
      refined.push_back(f.refined.corners_px);
      for (int k = 0; k < 4; ++k) {
        out.image_points.emplace_back(static_cast<float>(f.refined.corners_px[k].x),
                                      static_cast<float>(f.refined.corners_px[k].y));
        out.object_points.push_back(*board.AprilgridCorner(id, k));
        out.point_sigma_px.push_back(corner_sigma(f, k));
      }
    }
    for (const auto& [id, n] : ambiguous) {
      if (!tags.count(id)) ++on_board;
      out.tags_refused.emplace_back(id, "seen " + std::to_string(n) + " times");
    }
    const int used = static_cast<int>(out.tag_ids.size());
    if (used < options.min_aprilgrid_tags) {
      out.message = "aprilgrid " + std::to_string(board.cols) + "x" + std::to_string(board.rows) + " (" +
                    board.tag_family + "): " + std::to_string(used) + " usable tag" + (used == 1 ? "" : "s") + " (" +
                    std::to_string(on_board) + " of the board's seen), need " +
                    std::to_string(options.min_aprilgrid_tags);
      return false;
    }
    return true;
  }

  // The edge shift (edge_shift.h): the black of a real print through a real
  // camera looks larger or smaller than printed, and the tags' edge corners
  // with it, while the board's pitch does not change. Measured inside every
  // (n / aprilgrid_edge_shift_tags)-th tag, one value per view (the view's
  // tags share the print and the optics), removed from every tag; the
  // whole-tag fit instead places each tag by its own pattern and shift.
  // The whole-tag fit instead: each tag placed by its own pattern and shift.
  void FitWholeTags() {
    std::vector<EdgeShiftResult> shifts;
    for (size_t t = 0; t < out.tag_ids.size(); ++t) {
      const auto cells = TagCells::Of(board.tag_family, out.tag_ids[t]);
      if (!cells) continue;
      const TagPatternResult r = RefineTagByPattern(gray, refined[t], *cells, lens);
      shifts.push_back(r.shift);
      for (int k = 0; k < 4; ++k)
        out.image_points[4 * t + k] =
            cv::Point2f(static_cast<float>(r.corners_px[k].x), static_cast<float>(r.corners_px[k].y));
    }
    const EdgeShiftEstimate shift = PoolEdgeShifts(shifts, 0.0);
    out.edge_shift_px = shift.shift_px;
    out.edge_shift_sigma_px = shift.sigma_px;
  }

  // false (out.message says why) when the refit leaves too few tags.
  bool RemoveTheEdgeShift() {
    if (options.aprilgrid_whole_tag_fit) {
      FitWholeTags();
      return true;
    }
    if (!options.aprilgrid_edge_shift) return true;
    std::vector<EdgeShiftResult> shifts;
    const size_t stride = std::max<size_t>(
        1, out.tag_ids.size() / static_cast<size_t>(std::max(1, options.aprilgrid_edge_shift_tags)));
    for (size_t t = 0; t < out.tag_ids.size(); t += stride) {
      if (const auto cells = TagCells::Of(board.tag_family, out.tag_ids[t]))
        shifts.push_back(MeasureEdgeShift(gray, refined[t], *cells, lens));
    }
    const EdgeShiftEstimate shift = PoolEdgeShifts(shifts, 0.0);
    if (!shift.ok()) return true;
    out.edge_shift_px = shift.shift_px;
    out.edge_shift_sigma_px = shift.sigma_px;
    return RefitThroughCornerSquares(shift);
  }

  bool RefitThroughCornerSquares(const EdgeShiftEstimate& shift) {
    // Each tag's edges fitted again where the print's are (the shift
    // known), each line on through the corner squares' edges that continue
    // it; a tag whose lines do not fit so keeps its own edges, shifted.
    CornerRefineOptions through = refine;
    through.edge_shift_px = shift.shift_px;
    through.collinear_extension = options.aprilgrid_collinear_edges ? board.spacing : 0.0;
    // Each edge's own shift within 3 times the spread of the view's tags'
    // shifts (0.015-0.037 px on the real D435i frames).
    through.edge_shift_freedom_px = 3.0 * std::max(shift.spread_px, shift.sigma_px);
    std::vector<size_t> disagreeing;
    for (size_t t = 0; t < out.tag_ids.size(); ++t) {
      std::array<cv::Matx22d, 4> cov;
      const CornerRefineResult r =
          internal::RefineTagCornersByEdgeModelWithCovariance(gray, refined[t], lens, through, {0, 0}, &cov);
      // The refit agrees with the first fit, shifted, within the first
      // fit's sigma: where it does not, one of the two is off by more than
      // it says and the tag is not used. On tags of 8-12 px (1-px cells,
      // 2-px corner squares) a line on through the squares can take a
      // neighbour's edge (0.7 px off, sigma 0.06, on a rendered fisheye
      // rim); 6 of the 1050 tags on the real D435i frames, moved 0.5-0.7
      // px. A large tag's refit may move further: through a lens not
      // modelled its longer lines are straight where its own edges bend.
      const auto fixed = RemoveEdgeShift(refined[t], shift.shift_px, lens);
      if (!r.ok()) {
        for (int k = 0; k < 4; ++k)
          out.image_points[4 * t + k] = cv::Point2f(static_cast<float>(fixed[k].x), static_cast<float>(fixed[k].y));
        continue;
      }
      double side = 0.0, moved = 0.0;
      bool agrees = true;
      for (int k = 0; k < 4; ++k) side += 0.25 * cv::norm(refined[t][(k + 1) % 4] - refined[t][k]);
      for (int k = 0; k < 4; ++k) {
        const double d = cv::norm(r.corners_px[k] - fixed[k]);
        moved = std::max(moved, d);
        agrees =
            agrees && d <= std::max({options.aprilgrid_refit_min_disagreement_px, 4.0 * out.point_sigma_px[4 * t + k],
                                     options.aprilgrid_refit_disagreement_per_px * side});
      }
      if (!agrees) {
        char why[96];
        std::snprintf(why, sizeof(why), "refitted through the corner squares, a corner moved %.2f px", moved);
        out.tags_refused.emplace_back(out.tag_ids[t], why);
        disagreeing.push_back(t);
        continue;
      }
      for (int k = 0; k < 4; ++k) {
        out.image_points[4 * t + k] =
            cv::Point2f(static_cast<float>(r.corners_px[k].x), static_cast<float>(r.corners_px[k].y));
        out.point_sigma_px[4 * t + k] = std::sqrt(0.5 * (cov[k](0, 0) + cov[k](1, 1)));
      }
    }
    for (auto t = disagreeing.rbegin(); t != disagreeing.rend(); ++t) {
      const auto erase = [t](auto& v, long per) {
        const long first = per * static_cast<long>(*t);
        v.erase(v.begin() + first, v.begin() + first + per);
      };
      erase(out.tag_ids, 1);
      erase(out.image_points, 4);
      erase(out.object_points, 4);
      erase(out.point_sigma_px, 4);
    }
    if (static_cast<int>(out.tag_ids.size()) < options.min_aprilgrid_tags) {
      out.message = "aprilgrid: " + std::to_string(out.tag_ids.size()) +
                    " usable tags after the refit through the "
                    "corner squares, need " +
                    std::to_string(options.min_aprilgrid_tags);
      return false;
    }
    return true;
  }

  const CalibrationBoard& board;
  const BoardDetectionOptions& options;
  const bool quick;
  BoardDetection out;
  cv::Mat gray, big;  // the image looked in (evened), and upsampled
  int up = 1;
  TagDetectorResult created;
  CornerRefineOptions refine;
  std::optional<CameraModel> lens_model;
  const CameraModel* lens = nullptr;
  // Every tag of the board is refined on the original image as soon as a
  // pass finds it; a later pass retries a tag whose corners could not be
  // refined (a thinned or painted image moves libapriltag's corners).
  struct FoundTag {
    CornerRefineResult refined;
    std::array<cv::Matx22d, 4> cov;
  };
  std::map<int, FoundTag> tags;
  std::map<int, int> ambiguous;  // ids seen more than once in one pass: how many times
  cv::Mat paper;
  std::vector<std::array<cv::Point2d, 4>> refined;  // per used tag, for the edge shift
};

BoardDetection DetectAprilgrid(const cv::Mat& image, const CalibrationBoard& board,
                               const BoardDetectionOptions& options) {
  return AprilgridSearch(board, options).Run(image);
}

void RefineCorners(const cv::Mat& gray, int half_window, std::vector<cv::Point2f>* points) {
  const int cap = static_cast<int>(std::floor(0.4 * MinSpacing(*points)));
  const int half = std::max(2, std::min(half_window, cap));
  cv::cornerSubPix(gray, *points, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 100, 1e-4));
}

}  // namespace

bool CalibrationBoard::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (type == Type::kChessboard) {
    if (cols < 2 || rows < 2) return fail("a chessboard needs at least 2x2 inner corners");
  } else if (type == Type::kAprilgrid) {
    if (cols < 1 || rows < 1 || cols * rows < 4)
      return fail("an aprilgrid needs at least 4 tags (COLSxROWS)");
    if (!(spacing > 0.0) || !std::isfinite(spacing))
      return fail("the aprilgrid spacing (gap / tag side) must be positive");
    if (!IsKnownTagFamily(tag_family)) return fail("unknown tag family '" + tag_family + "'");
    if (first_id < 0) return fail("the aprilgrid's first id must be >= 0");
    TagSpec last;
    last.family = tag_family;
    last.id = first_id + cols * rows - 1;
    std::string why_tag;
    if (!last.IsValid(&why_tag)) return fail("aprilgrid ids " + std::to_string(first_id) + ".." +
                                             std::to_string(last.id) + ": " + why_tag);
  } else {
    if (cols < 3 || rows < 3) return fail("a ChArUco board needs at least 3x3 squares");
    if (!(marker_m > 0.0) || !(marker_m < square_m))
      return fail("the marker side must be positive and smaller than the square side");
#ifdef ODOCAL_HAVE_ARUCO
    if (!DictionaryId(dictionary)) return fail("unknown ArUco dictionary '" + dictionary + "'");
#endif
  }
  if (!(square_m > 0.0) || !std::isfinite(square_m)) return fail("the square side must be positive");
  return true;
}

int CalibrationBoard::MaxCorners() const {
  switch (type) {
    case Type::kChessboard: return cols * rows;
    case Type::kCharuco: return (cols - 1) * (rows - 1);
    case Type::kAprilgrid: return 4 * cols * rows;
  }
  return 0;
}

std::optional<cv::Point3f> CalibrationBoard::AprilgridCorner(int id, int k) const {
  const int i = id - first_id;
  if (type != Type::kAprilgrid || i < 0 || i >= cols * rows || k < 0 || k > 3) return std::nullopt;
  const double pitch = (1.0 + spacing) * square_m;
  static const int kDx[4] = {0, 1, 1, 0}, kDy[4] = {0, 0, 1, 1};
  return cv::Point3f(static_cast<float>((i % cols) * pitch + kDx[k] * square_m),
                     static_cast<float>((i / cols) * pitch + kDy[k] * square_m), 0.0f);
}

bool BoardDetectionOptions::IsValid(std::string* why) const {
  if (subpix_half_window_px < 1) {
    if (why) *why = "the corner refinement half window must be at least 1 px";
    return false;
  }
  if (min_charuco_corners < 4) {
    if (why) *why = "a ChArUco view needs at least 4 corners (min_charuco_corners >= 4)";
    return false;
  }
  if (min_aprilgrid_tags < 1 || aprilgrid_upsample < 0 || aprilgrid_upsample > 4) {
    if (why) *why = "min_aprilgrid_tags must be >= 1 and aprilgrid_upsample in [0, 4] (0: by the image's size)";
    return false;
  }
  if (!(aprilgrid_even_contrast_window >= 0.0 && aprilgrid_even_contrast_window <= 1.0)) {
    if (why) *why = "aprilgrid_even_contrast_window must be in [0, 1] (0: off)";
    return false;
  }
  if (aprilgrid_edge_shift_tags < 1) {
    if (why) *why = "aprilgrid_edge_shift_tags must be >= 1";
    return false;
  }
  if (!(aprilgrid_min_border_px >= 0.0)) {
    if (why) *why = "aprilgrid_min_border_px must be >= 0";
    return false;
  }
  if (aprilgrid_paint_rounds < 0) {
    if (why) *why = "aprilgrid_paint_rounds must be >= 0";
    return false;
  }
  return true;
}

bool CharucoAvailable() {
#ifdef ODOCAL_HAVE_ARUCO
  return true;
#else
  return false;
#endif
}

BoardDetection DetectBoard(const cv::Mat& image, const CalibrationBoard& board,
                           const BoardDetectionOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) {
    BoardDetection out;
    out.message = "board detection options: " + why;
    return out;
  }
  try {
    return DetectBoardOrThrow(image, board, options);
  } catch (const cv::Exception& e) {
    BoardDetection out;
    out.message = "OpenCV: " + e.err;
    return out;
  }
}

namespace {

// A chessboard's inner corners in `gray`, refined, with their board points.
BoardDetection DetectChessboard(const cv::Mat& gray, const CalibrationBoard& board,
                                const BoardDetectionOptions& options) {
  BoardDetection out;
  const cv::Size pattern(board.cols, board.rows);
  // FAST_CHECK rejects images without a board quickly; ADAPTIVE_THRESH and
  // NORMALIZE_IMAGE cope with uneven lighting. The classic detector misses
  // some strongly tilted views (2 of 96 rendered 10-40 degree views); the
  // sector-based detector finds those, so it is the fallback.
  const bool found = cv::findChessboardCorners(
                         gray, pattern, out.image_points,
                         cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK) ||
                     (options.sector_fallback && cv::findChessboardCornersSB(gray, pattern, out.image_points));
  if (!found) {
    out.message = "chessboard " + std::to_string(board.cols) + "x" + std::to_string(board.rows) + " not found";
    out.image_points.clear();
    return out;
  }
  RefineCorners(gray, options.subpix_half_window_px, &out.image_points);
  // Row-major, x fastest: the order findChessboardCorners returns.
  for (int r = 0; r < board.rows; ++r) {
    for (int c = 0; c < board.cols; ++c) {
      out.object_points.emplace_back(static_cast<float>(c * board.square_m), static_cast<float>(r * board.square_m),
                                     0.0f);
    }
  }
  out.found = true;
  return out;
}

// A ChArUco board's corners in `gray` (interpolated from its markers), with
// their board points; a message when the build has no aruco module.
BoardDetection DetectCharuco(const cv::Mat& gray, const CalibrationBoard& board, const BoardDetectionOptions& options) {
  BoardDetection out;
#ifdef ODOCAL_HAVE_ARUCO
  const auto charuco = MakeCharucoBoard(board);
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(gray, charuco->dictionary, marker_corners, marker_ids);
  if (marker_ids.empty()) {
    out.message = "no " + board.dictionary + " markers found";
    return out;
  }
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, charuco, corners, ids);
  if (static_cast<int>(ids.size()) < options.min_charuco_corners) {
    out.message = "ChArUco board: only " + std::to_string(ids.size()) + " corners found (need " +
                  std::to_string(options.min_charuco_corners) + ")";
    return out;
  }
  if (cv::aruco::testCharucoCornersCollinear(charuco, ids)) {
    out.message = "ChArUco board: the corners found are collinear";
    return out;
  }
  // Pixel convention, converted here once: since opencv_contrib PR #3024
  // (2021, in Debian's 4.6) interpolateCornersCharuco returns corners with
  // (0, 0) at the top-left *corner* of the first pixel, half a pixel away
  // from cornerSubPix / findChessboardCorners / projectPoints, which put it
  // at that pixel's centre (OpenCV issue 22288; undone upstream by PR 28380
  // in the new objdetect detector, 2026). Uncorrected, it moves cx and cy by
  // +0.5 px. camera_calibration_test checks the corners against rendered
  // truth, so an OpenCV with other behaviour fails there, not silently.
  for (const cv::Point2f& p : corners) out.image_points.emplace_back(p.x - 0.5f, p.y - 0.5f);
  for (int id : ids) out.object_points.push_back(charuco->chessboardCorners[id]);
  out.found = true;
#else
  (void)gray;
  (void)board;
  (void)options;
  out.message = "ChArUco boards are not available in this build (OpenCV without the aruco module)";
#endif
  return out;
}

BoardDetection DetectBoardOrThrow(const cv::Mat& image, const CalibrationBoard& board,
                                  const BoardDetectionOptions& options) {
  cv::Mat gray;
  if (image.channels() == 3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  } else {
    gray = image;
  }
  if (gray.depth() != CV_8U) gray.convertTo(gray, CV_8U);

  if (board.type == CalibrationBoard::Type::kAprilgrid) return DetectAprilgrid(gray, board, options);
  if (board.type == CalibrationBoard::Type::kChessboard) return DetectChessboard(gray, board, options);
  return DetectCharuco(gray, board, options);
}

}  // namespace

bool CameraCalibrationOptions::IsValid(std::string* why) const {
  if (min_views < 3) {
    if (why) *why = "min_views must be >= 3 (fewer cannot fix the principal point)";
    return false;
  }
  if (threads < 0) {
    if (why) *why = "threads must be >= 0 (0: one per core)";
    return false;
  }
  for (const auto& [id, lift] : board_lift_m) {
    if (!std::isfinite(lift) || std::abs(lift) > 0.1) {
      if (why) *why = "board_lift_m: tag " + std::to_string(id) + "'s lift must be finite and within 0.1 m";
      return false;
    }
  }
  if (!board_lift_m.empty() && !initial) {
    if (why) *why = "board_lift_m needs initial (the same views calibrated as flat)";
    return false;
  }
  return true;
}

namespace {

// The equidistant lens for `objects`/`images`; nullopt with `why` when no
// camera comes out. cv::fisheye::calibrate gives the start (skew fixed at 0,
// extrinsics recomputed at each step), leaving out views it finds
// ill-conditioned; then the lens and every view's pose are adjusted together
// (fisheye_fit.h), the left-out views back in. When cv::fisheye gives no
// camera at all, the adjustment starts from an ideal equidistant lens at a
// few focal lengths instead. `dropped`: the input indices of views with no
// pose.
std::optional<Intrinsics> FisheyeFit(const std::vector<std::vector<cv::Point3f>>& objects,
                                     const std::vector<std::vector<cv::Point2f>>& images,
                                     const std::vector<std::vector<double>>& weights, const cv::Size& size,
                                     double* rms, std::string* why, std::vector<int>* dropped) {
  // cv::fisheye wants 1xN two- and three-channel double arrays.
  std::vector<cv::Mat> obj, img;
  for (size_t v = 0; v < objects.size(); ++v) {
    cv::Mat o(1, static_cast<int>(objects[v].size()), CV_64FC3), p(1, static_cast<int>(images[v].size()), CV_64FC2);
    for (size_t i = 0; i < objects[v].size(); ++i) {
      o.at<cv::Vec3d>(0, static_cast<int>(i)) = cv::Vec3d(objects[v][i].x, objects[v][i].y, objects[v][i].z);
      p.at<cv::Vec2d>(0, static_cast<int>(i)) = cv::Vec2d(images[v][i].x, images[v][i].y);
    }
    obj.push_back(o);
    img.push_back(p);
  }
  // One ill-conditioned view (a board seen nearly edge-on, or small in the
  // view) leaves cv::fisheye at its starting guess for every view; with
  // CALIB_CHECK_COND it names the view instead, which is left out of the start.
  std::vector<Intrinsics> starts;
  std::string opencv_error;
  for (;;) {
    cv::Matx33d K = cv::Matx33d::eye();
    cv::Vec4d D(0, 0, 0, 0);
    std::vector<cv::Vec3d> rvecs, tvecs;
    try {
      const double e = cv::fisheye::calibrate(
          obj, img, size, K, D, rvecs, tvecs,
          cv::fisheye::CALIB_RECOMPUTE_EXTRINSIC | cv::fisheye::CALIB_FIX_SKEW | cv::fisheye::CALIB_CHECK_COND,
          cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-12));
      if (std::isfinite(e))
        if (const auto start = Intrinsics::FromCv(cv::Mat(K), cv::Mat(D).reshape(1, 1), size.width, size.height,
                                                  LensModel::kEquidistant))
          starts.push_back(*start);
      break;
    } catch (const cv::Exception& e) {
      const std::string marker = "input array ";
      const size_t at = e.err.find(marker);
      const int bad = at == std::string::npos ? -1 : std::atoi(e.err.c_str() + at + marker.size());
      if (bad < 0 || bad >= static_cast<int>(obj.size()) || obj.size() <= 3) {
        opencv_error = e.err;
        break;
      }
      obj.erase(obj.begin() + bad);
      img.erase(img.begin() + bad);
    }
  }
  if (starts.empty()) {
    // An ideal equidistant lens (r = f theta) centred in the image, with the
    // image's half width at 60, 80 or 100 degrees off the axis.
    for (const double half_angle_deg : {60.0, 80.0, 100.0}) {
      const double f = 0.5 * size.width / (half_angle_deg * kDegToRad);
      Intrinsics guess{size.width, size.height, f, f, 0.5 * (size.width - 1), 0.5 * (size.height - 1), {0, 0, 0, 0, 0}};
      guess.lens = LensModel::kEquidistant;
      starts.push_back(guess);
    }
  }
  std::optional<internal::EquidistantFit> best;
  std::string fit_error;
  for (const Intrinsics& start : starts) {
    auto fit = internal::FitEquidistant(objects, images, weights, start, &fit_error);
    if (fit && (!best || fit->weighted_rms_px < best->weighted_rms_px)) best = std::move(fit);
  }
  if (!best) {
    if (why)
      *why = opencv_error.empty() ? fit_error : "cv::fisheye::calibrate failed: " + opencv_error + "; " + fit_error;
    return std::nullopt;
  }
  *rms = best->rms_px;
  if (dropped) *dropped = best->views_left_out;
  return best->intrinsics;
}

void CalibrateFisheye(const std::vector<std::vector<cv::Point3f>>& objects,
                      const std::vector<std::vector<cv::Point2f>>& images,
                      const std::vector<std::vector<double>>& weights, const cv::Size& size, int threads,
                      CameraCalibrationResult* result) {
  std::string why;
  double rms = 0.0;
  const auto fitted = FisheyeFit(objects, images, weights, size, &rms, &why, &result->views_left_out);
  if (!fitted) {
    result->status = StatusCode::kFailed;
    result->message = "calibration gave no valid camera: " + why;
    return;
  }
  result->intrinsics = *fitted;
  result->rms_reprojection_error_px = rms;
  result->views -= static_cast<int>(result->views_left_out.size());
  const cv::Matx33d K(fitted->CameraMatrix());
  const cv::Vec4d D(fitted->distortion[0], fitted->distortion[1], fitted->distortion[2], fitted->distortion[3]);
  // Every view's residual with the fitted lens (a view left out too): its
  // pose from the undistorted corners, then projected through the lens.
  for (size_t v = 0; v < objects.size(); ++v) {
    std::vector<cv::Point3d> o(objects[v].begin(), objects[v].end());
    std::vector<cv::Point2d> seen(images[v].begin(), images[v].end()), normalised, projected;
    cv::fisheye::undistortPoints(seen, normalised, K, D);
    cv::Vec3d rvec, tvec;
    if (!cv::solvePnP(o, normalised, cv::Matx33d::eye(), cv::noArray(), rvec, tvec)) {
      result->per_view_rms_px.push_back(std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    cv::fisheye::projectPoints(o, projected, rvec, tvec, K, D);
    double sq = 0.0;
    for (size_t i = 0; i < projected.size(); ++i) {
      const double dx = projected[i].x - images[v][i].x, dy = projected[i].y - images[v][i].y;
      sq += dx * dx + dy * dy;
    }
    result->per_view_rms_px.push_back(std::sqrt(sq / std::max<size_t>(1, projected.size())));
  }
  // Delete-a-group jackknife over the views (at most 10 groups): the
  // spread the intrinsics would have on other frames of the same camera.
  const int n = static_cast<int>(objects.size());
  const int groups = std::min(n, 10);
  std::vector<std::optional<std::array<double, 8>>> refits(static_cast<size_t>(groups));
  ParallelFor(refits.size(), static_cast<unsigned>(threads), [&](size_t g) {
    std::vector<std::vector<cv::Point3f>> o;
    std::vector<std::vector<cv::Point2f>> p;
    std::vector<std::vector<double>> w;
    for (int v = 0; v < n; ++v)
      if (v % groups != static_cast<int>(g)) {
        o.push_back(objects[v]);
        p.push_back(images[v]);
        if (!weights.empty()) w.push_back(weights[v]);
      }
    double e = 0.0;
    if (o.size() < 3) return;
    if (const auto refit = FisheyeFit(o, p, w, size, &e, nullptr, nullptr))
      refits[g] = std::array<double, 8>{refit->fx, refit->fy, refit->cx, refit->cy, refit->distortion[0],
                                        refit->distortion[1], refit->distortion[2], refit->distortion[3]};
  });
  std::vector<std::array<double, 8>> estimates;
  for (const auto& r : refits)
    if (r) estimates.push_back(*r);
  const int m = static_cast<int>(estimates.size());
  if (m >= 3) {
    for (int k = 0; k < 8; ++k) {
      double mean = 0.0, ss = 0.0;
      for (const auto& e : estimates) mean += e[k] / m;
      for (const auto& e : estimates) ss += (e[k] - mean) * (e[k] - mean);
      result->sigma[k] = std::sqrt((m - 1.0) / m * ss);
    }
  } else {
    result->sigma.fill(std::numeric_limits<double>::quiet_NaN());
  }
  result->status = StatusCode::kOk;
  result->message = "ok";
}

// Each corner weighed by its stated sigma against the views' median
// (min(1, median / sigma): the usual corner 1, an uncertain one less,
// none more: the median stands for the model's own error), when every
// view states them (the aprilgrid's edge fits); else none.
std::vector<std::vector<double>> CornerWeights(const std::vector<BoardDetection>& views) {
  std::vector<std::vector<double>> weights;
  const bool have_sigmas = std::all_of(views.begin(), views.end(), [](const BoardDetection& v) {
    return v.point_sigma_px.size() == v.image_points.size();
  });
  if (have_sigmas) {
    std::vector<double> all;
    for (const BoardDetection& v : views) all.insert(all.end(), v.point_sigma_px.begin(), v.point_sigma_px.end());
    const double median = calibration::Median(all);
    if (median > 0.0) {
      for (const BoardDetection& v : views) {
        weights.emplace_back();
        for (double sigma : v.point_sigma_px) weights.back().push_back(sigma > median ? median / sigma : 1.0);
      }
    }
  }
  return weights;
}

// The plumb-bob lens by cv::calibrateCamera (from the flat calibration when
// the board is lifted) into `result`.
void CalibratePinhole(const std::vector<std::vector<cv::Point3f>>& object_points,
                      const std::vector<std::vector<cv::Point2f>>& image_points, const cv::Size& image_size,
                      const CameraCalibrationOptions& options, CameraCalibrationResult* result) {
  int flags = 0;
  if (options.fix_k3) flags |= cv::CALIB_FIX_K3;
  if (options.fix_tangential) flags |= cv::CALIB_ZERO_TANGENT_DIST;
  cv::Mat K, D, std_intrinsics, std_extrinsics, per_view;
  if (!options.board_lift_m.empty()) {
    // A lifted board is not planar: OpenCV starts from the flat calibration.
    K = options.initial->CameraMatrix();
    D = options.initial->DistortionCoeffs();
    flags |= cv::CALIB_USE_INTRINSIC_GUESS;
  }
  std::vector<cv::Mat> rvecs, tvecs;
  try {
    result->rms_reprojection_error_px = cv::calibrateCamera(
        object_points, image_points, image_size, K, D, rvecs, tvecs, std_intrinsics, std_extrinsics, per_view, flags,
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12));
  } catch (const cv::Exception& e) {
    result->status = StatusCode::kFailed;
    result->message = "cv::calibrateCamera failed: " + e.err;
    return;
  }
  const auto intrinsics = Intrinsics::FromCv(K, D, image_size.width, image_size.height);
  if (!intrinsics || !std::isfinite(result->rms_reprojection_error_px)) {
    result->status = StatusCode::kFailed;
    result->message =
        "calibration gave no valid camera: " + (intrinsics ? std::string("non-finite error") : intrinsics.message);
    return;
  }
  result->intrinsics = *intrinsics;
  for (int i = 0; i < static_cast<int>(per_view.total()); ++i)
    result->per_view_rms_px.push_back(per_view.at<double>(i));
  for (int i = 0; i < 9 && i < static_cast<int>(std_intrinsics.total()); ++i)
    result->sigma[i] = std_intrinsics.at<double>(i);
  result->status = StatusCode::kOk;
  result->message = "ok";
}

}  // namespace

CameraCalibrationResult CalibrateCamera(const std::vector<BoardDetection>& views,
                                        const cv::Size& image_size,
                                        const CameraCalibrationOptions& options) {
  CameraCalibrationResult result;
  std::string why;
  if (!options.IsValid(&why)) {
    result.status = StatusCode::kInvalidArgument;
    result.message = why;
    return result;
  }
  if (image_size.width <= 0 || image_size.height <= 0) {
    result.status = StatusCode::kInvalidArgument;
    result.message = "image size must be positive";
    return result;
  }
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  for (const BoardDetection& v : views) {
    if (!v.found || v.image_points.size() != v.object_points.size() || v.image_points.size() < 4) {
      result.status = StatusCode::kInvalidArgument;
      result.message = "every view must be a detection with at least 4 matched corners";
      return result;
    }
    object_points.push_back(v.object_points);
    // The board as lifted: each tag's corners off its plane by the tag's lift.
    if (!options.board_lift_m.empty() && v.tag_ids.size() * 4 == v.object_points.size())
      for (size_t i = 0; i < v.object_points.size(); ++i)
        if (const auto it = options.board_lift_m.find(v.tag_ids[i / 4]); it != options.board_lift_m.end())
          object_points.back()[i].z = static_cast<float>(it->second);
    image_points.push_back(v.image_points);
    result.corners += static_cast<int>(v.image_points.size());
  }
  result.views = static_cast<int>(views.size());
  if (result.views < options.min_views) {
    result.status = StatusCode::kInvalidArgument;
    result.message = std::to_string(result.views) + " usable view" + (result.views == 1 ? "" : "s") +
                     ", need at least " + std::to_string(options.min_views);
    return result;
  }
  if (options.lens == LensModel::kEquidistant) {
    const std::vector<std::vector<double>> weights =
        options.weight_by_corner_sigma ? CornerWeights(views) : std::vector<std::vector<double>>{};
    CalibrateFisheye(object_points, image_points, weights, image_size, options.threads, &result);
    return result;
  }
  CalibratePinhole(object_points, image_points, image_size, options, &result);
  return result;
}

ImageCoverage MeasureCoverage(const std::vector<BoardDetection>& views, cv::Size image_size, int grid) {
  ImageCoverage c;
  c.grid = grid;
  if (grid <= 0 || image_size.width <= 0 || image_size.height <= 0) return c;
  std::vector<char> covered(static_cast<size_t>(grid) * grid, 0);
  double x0 = 1.0, x1 = 0.0, y0 = 1.0, y1 = 0.0;
  for (const BoardDetection& view : views) {
    for (const cv::Point2f& p : view.image_points) {
      // Pixel centres at integers: the image spans [-0.5, size - 0.5].
      const double x = (p.x + 0.5) / image_size.width, y = (p.y + 0.5) / image_size.height;
      if (!(x >= 0.0 && x <= 1.0 && y >= 0.0 && y <= 1.0)) continue;
      const int i = std::min(grid - 1, static_cast<int>(x * grid)), j = std::min(grid - 1, static_cast<int>(y * grid));
      covered[static_cast<size_t>(j) * grid + i] = 1;
      x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    }
  }
  for (char k : covered) c.cells_covered += k;
  c.fraction = static_cast<double>(c.cells_covered) / (static_cast<double>(grid) * grid);
  if (c.cells_covered > 0) c.x_min = x0, c.x_max = x1, c.y_min = y0, c.y_max = y1;
  return c;
}

LensModelChoice CompareLensModels(const std::vector<BoardDetection>& views, const CameraCalibrationResult& plumb_bob,
                                  const CameraCalibrationResult& fisheye) {
  LensModelChoice c;
  if (!fisheye.ok()) return c;
  if (!plumb_bob.ok()) {
    c.fisheye_rms_px = fisheye.rms_reprojection_error_px;
    c.chosen = LensModel::kEquidistant;
    return c;
  }
  // The fisheye fit may leave views out (no pose through its lens): the two
  // are compared on the views both kept, each view weighted by its corners.
  auto left_out = [](const CameraCalibrationResult& r, size_t i) {
    return std::find(r.views_left_out.begin(), r.views_left_out.end(), static_cast<int>(i)) != r.views_left_out.end();
  };
  double pb = 0.0, fe = 0.0, n = 0.0;
  for (size_t i = 0; i < views.size() && i < plumb_bob.per_view_rms_px.size() && i < fisheye.per_view_rms_px.size(); ++i) {
    if (left_out(plumb_bob, i) || left_out(fisheye, i)) continue;
    const double corners = static_cast<double>(views[i].image_points.size());
    pb += corners * plumb_bob.per_view_rms_px[i] * plumb_bob.per_view_rms_px[i];
    fe += corners * fisheye.per_view_rms_px[i] * fisheye.per_view_rms_px[i];
    n += corners;
    ++c.views;
  }
  if (n == 0.0) return c;
  c.plumb_bob_rms_px = std::sqrt(pb / n);
  c.fisheye_rms_px = std::sqrt(fe / n);
  if (c.fisheye_rms_px < 0.95 * c.plumb_bob_rms_px) c.chosen = LensModel::kEquidistant;
  return c;
}

LensFromViews CalibrateLensFromViews(std::vector<BoardDetection> views, const cv::Size& image_size,
                                     const CalibrationBoard& board, CameraCalibrationOptions options,
                                     bool choose_model, const std::function<cv::Mat(size_t)>& image) {
  LensFromViews out;
  if (choose_model) options.lens = LensModel::kPlumbBob;
  out.result = CalibrateCamera(views, image_size, options);
  if (choose_model) {
    CameraCalibrationOptions other = options;
    other.lens = LensModel::kEquidistant;
    other.fix_k3 = false;
    CameraCalibrationResult fisheye = CalibrateCamera(views, image_size, other);
    out.choice = CompareLensModels(views, out.result, fisheye);
    if (out.choice->chosen == LensModel::kEquidistant) {
      options = other;
      out.result = std::move(fisheye);
    }
  }
  if (out.result.ok() && board.type == CalibrationBoard::Type::kAprilgrid) {
    BoardDetectionOptions through;
    through.lens = out.result.intrinsics;
    std::vector<BoardDetection> again = views;
    ParallelFor(views.size(), static_cast<unsigned>(options.threads), [&](size_t i) {
      BoardDetection d = DetectBoard(image(i), board, through);
      if (d.found) again[i] = std::move(d);
    });
    CameraCalibrationResult second = CalibrateCamera(again, image_size, options);
    if (second.ok()) {
      out.first_pass_rms_px = out.result.rms_reprojection_error_px;
      out.result = std::move(second);
      views = std::move(again);
    }
  }
  out.views = std::move(views);
  return out;
}

}  // namespace odocal::vision
