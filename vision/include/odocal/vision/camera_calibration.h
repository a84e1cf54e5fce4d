// Camera calibration: intrinsics (pinhole + k1 k2 p1 p2 k3) from images of a
// planar board, with OpenCV (Zhang's method as cv::calibrateCamera implements
// it; Zhang, "A flexible new technique for camera calibration", PAMI 2000).
// A pure function of the images: loading them and writing the result are in
// rig/ (odocal calibrate-camera).
//
// Boards:
//   chessboard  COLS x ROWS inner corners, square side; cv::findChessboardCorners
//               (cv::findChessboardCornersSB as the fallback) then cv::cornerSubPix.
//   ChArUco     COLS x ROWS squares, square and marker sides, ArUco dictionary;
//               cv::aruco marker detection and corner interpolation (needs
//               OpenCV's contrib aruco module; CharucoAvailable() says whether
//               this build has it).
//   aprilgrid   Kalibr's target: COLS x ROWS AprilTags (tag36h11b2, i.e. with a
//               2-bit black border, by default), tag side = the black border's
//               outer edge, gap = spacing x tag side, ids first_id... row by
//               row from the bottom-left tag. Any 4 or more of its tags make a
//               view; each tag's corners are refined by the exact edge model
//               (RefineTagCornersByEdgeModel), the same that measures the
//               robot's tag. Board frame (Kalibr's): origin at tag first_id's
//               bottom-left corner, x along the columns, y up the printed
//               bitmaps; tag (col, row) corner k at
//               (col (1 + spacing) s, row (1 + spacing) s) + s {(0,0), (1,0), (1,1), (0,1)}[k],
//               k in libapriltag's (and TagCornersInTag's) order.
// Frames: the board frame is OpenCV's object-point frame of each board type
// (z = 0 on the board); pixels are OpenCV's (centres at integers).
// Units: metres inside; the reprojection errors are in pixels.
#ifndef ODOCAL_VISION_CAMERA_CALIBRATION_H_
#define ODOCAL_VISION_CAMERA_CALIBRATION_H_

#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/base/status.h"
#include "odocal/vision/camera_model.h"

namespace odocal::vision {

struct CalibrationBoard {
  enum class Type { kChessboard, kCharuco, kAprilgrid };
  Type type = Type::kChessboard;
  int cols = 0;            // chessboard: inner corners across; ChArUco: squares across;
                           // aprilgrid: tags across
  int rows = 0;            // the same down
  double square_m = 0.0;   // aprilgrid: the tag side (outer black edge)
  double marker_m = 0.0;   // ChArUco only
  std::string dictionary;  // ChArUco only, OpenCV's name, e.g. "DICT_5X5_100"
  double spacing = 0.0;    // aprilgrid only: gap between tags / tag side (Kalibr's tagSpacing)
  int first_id = 0;        // aprilgrid only: the bottom-left tag's id
  std::string tag_family = "tag36h11b2";  // aprilgrid only (tag.h's IsKnownTagFamily)

  bool IsValid(std::string* why) const;
  // Corners a view can show at most.
  int MaxCorners() const;
  // Aprilgrid: whether `id` is on the board, and tag `id`'s corner k in the
  // board frame (z = 0); nullopt for another id or board type.
  std::optional<cv::Point3f> AprilgridCorner(int id, int k) const;
};

// Whether this build can detect ChArUco boards (OpenCV's aruco module).
bool CharucoAvailable();

// One image's board corners, matched to their positions on the board.
struct BoardDetection {
  bool found = false;
  std::string message;                  // why not, when not found
  std::vector<cv::Point2f> image_points;
  std::vector<cv::Point3f> object_points;
  // Aprilgrid only: the tags used, in order, each owning 4 consecutive
  // points (corner order as in tag.h); each point's 1-sigma (px, per axis)
  // from the edge fits; and the board's tags seen but not used, with why.
  std::vector<int> tag_ids;
  std::vector<double> point_sigma_px;
  std::vector<std::pair<int, std::string>> tags_refused;
  // Aprilgrid: the view's edge shift (edge_shift.h), already removed from
  // image_points; 0 when not measured.
  double edge_shift_px = 0.0;
  double edge_shift_sigma_px = 0.0;
};

struct BoardDetectionOptions {
  // cornerSubPix half window [px]; it is also capped at 40 % of the smallest
  // corner spacing seen, so that it never reaches into the next square.
  int subpix_half_window_px = 5;
  // ChArUco views with fewer interpolated corners are rejected: below ~6
  // the view adds little and may be nearly collinear.
  int min_charuco_corners = 6;
  // Chessboards: when cv::findChessboardCorners fails, try
  // cv::findChessboardCornersSB (finds steeper views; slower on images
  // without a board).
  bool sector_fallback = true;
  // Aprilgrid: views with fewer tags are rejected (4 tags: 16 corners on a
  // plane, enough for a homography with redundancy).
  int min_aprilgrid_tags = 4;
  // Aprilgrid: libapriltag sees the image upsampled this many times (cubic)
  // and looks for quads at decimate = the same factor, i.e. at the original
  // resolution, but decodes the bits and fits its edges on the interpolated
  // image. Kalibr targets fill the image with small tags (2-3 px a cell at
  // 640x480): on the 30 real frames 3 finds 948 tags where 1 finds 895, in
  // the plain pass (1047 with the thinned and painted passes, camera_calibration.cc;
  // yac: 1007). The corners are then refined on the original image.
  // 0 (the default): 1920 / the image's longer side, rounded, 1 to 3 (640 and
  // 752 px: 3; 1024-1280: 2; 1920 and more: 1). Upsampling a large image
  // helps nothing and costs much: a D435i frame scaled to 3840 x 2880 took
  // 82 s and 460 MB at 3 and found no tag; at 1, 36 tags.
  int aprilgrid_upsample = 0;
  // Aprilgrid: the tags are looked for and refined in the image stretched
  // between its local black and white over a window of this fraction of the
  // longer side (a fisheye's vignetting, uneven light: camera_calibration.cc's
  // EvenContrast); 0: in the image as it is.
  double aprilgrid_even_contrast_window = 0.05;
  // Aprilgrid: a tag with a corner closer than this to the image's border is
  // refused (its edges' bands are cut by the border and the corner
  // extrapolated: 0.4 px off on a rendered 752 x 480 view, sigma 0.035).
  // Kalibr's minBorderDistance, the same default.
  double aprilgrid_min_border_px = 4.0;
  // Aprilgrid: a tag with a corner whose stated sigma exceeds this many times
  // the view's median corner sigma is refused: the calibration weighs every
  // corner alike, and a corner this uncertain against its view's others (a
  // 17 px tag at a fisheye's rim: 0.33 px, 0.75 px off, in a view of 0.03-0.05
  // px) is worth less than its pull. Relative, since a sigma in pixels scales
  // with the resolution and the blur (a D435i frame scaled 6x: 0.26-1.5 px).
  double aprilgrid_max_corner_sigma_ratio = 5.0;
  // Aprilgrid: tags smaller than this (mean side, px) are not refined, nor
  // used. 8 px: 0.8 px a bit of a b2 tag, the edge model's band 0.7 px to
  // either side of each edge; on a rendered 190-degree lens tags of 10-15 px
  // came out 0.1-0.25 px rms, their sigmas saying so (docs/vision.md).
  double aprilgrid_min_tag_px = 8.0;
  // Aprilgrid: at most this many passes with the corner squares painted
  // white around the tags found so far (camera_calibration.cc); each stops
  // the search when it finds no new tag.
  int aprilgrid_paint_rounds = 4;
  // ... each square through the homography of the nearest found tag within
  // this many tags of it (0: the squares touching found tags; 1: also their
  // neighbours'), the board's homography beyond.
  double aprilgrid_paint_reach = 1.0;
  // Aprilgrid: at most this many rounds looking for the tags no pass found
  // where the found ones put them (the board's homography, through the lens
  // when known), each refined from there and kept when its own cells read
  // as its bitmap: at most this fraction of its cells (and the white ring
  // around it) on the wrong side of the threshold, the white and black cells
  // this many grey levels apart. A neighbouring id's bitmap differs in at
  // least 11 of tag36h11's 36 bits.
  int aprilgrid_predict_rounds = 3;
  double aprilgrid_predicted_max_mismatch = 0.04;
  double aprilgrid_predicted_min_contrast = 20.0;
  // ... or, a small tag (a cell 1-1.5 px: blur greys its isolated bits,
  // 6-11 of 36 misread at their centres on a rendered 190-degree lens), when
  // every pixel over its data bits correlates with its bitmap, blurred as
  // the image is, at least this well, better by this margin than with any
  // other id of the board's, with this contrast (grey levels) at least.
  // Rendered 8-15 px tags: their own id 0.84-0.99, the best other id
  // 0.64-0.87, 0.10 or more below; a plain square ~0.
  double aprilgrid_predicted_min_correlation = 0.8;
  double aprilgrid_predicted_min_margin = 0.05;
  // Aprilgrid: each tag edge's line fitted on through the corner squares'
  // edges that continue it (CornerRefineOptions::collinear_extension).
  bool aprilgrid_collinear_edges = true;
  // ... a refit kept only when each corner lies within 4 of its first fit's
  // sigmas of that fit shifted by the view's edge shift, or this close, or
  // this fraction of the tag's side (px per px) close.
  double aprilgrid_refit_min_disagreement_px = 0.15;
  double aprilgrid_refit_disagreement_per_px = 0.02;
  // Aprilgrid: measure the edge shift inside the tags and remove it from
  // their corners (edge_shift.h). On the 30 real D435i frames the tags' edges
  // lie ~0.16 px inside the print (docs/vision.md, "Real photographs").
  bool aprilgrid_edge_shift = true;
  // ... in every (n / this)-th of the view's n tags (8-9 of a 6 x 6 grid) (~60 ms each for a
  // 28 px tag): their mean is the view's (the view's tags share the print
  // and the optics).
  int aprilgrid_edge_shift_tags = 8;
  // Aprilgrid: each tag placed by its whole pattern (RefineTagByPattern:
  // every black/white boundary, the tag's own shift removed) instead of its
  // four outer edges.
  bool aprilgrid_whole_tag_fit = false;
  // Aprilgrid: a quick look, for choosing views (SelectViews): libapriltag's
  // corners as found (its convention mapped to OpenCV's, not refined, each
  // stated 0.5 px), no painted or predicted passes, no edge shift. Finds
  // most tags in ~30 ms where the refinement takes ~0.9 s (a 640x480 D435i
  // frame); never for calibrating.
  bool aprilgrid_corners_only = false;
  // (Each tag corrected by its own shift instead was tried on the real frames:
  // no better, 0.2405 vs 0.2391 px board residual.)
  // Aprilgrid: the lens the tags' edges are seen through, when known (a
  // first calibration, or a camera file). A straight printed edge is a curve
  // in the image; the edge model then fits it as one (corner_refine.h), and the
  // corners do not move with the curvature of the lens at their tag.
  std::optional<Intrinsics> lens;

  // Valid: a half window of at least 1 px, min_charuco_corners >= 4 (a
  // view with fewer corners cannot enter CalibrateCamera), min_aprilgrid_tags
  // >= 1 and aprilgrid_quad_decimate >= 1.
  bool IsValid(std::string* why) const;
};

// `image`: 8-bit grey, or BGR / BGRA (converted to grey). Not found (with
// the reason in `message`) rather than an exception when OpenCV objects or
// the options are invalid.
BoardDetection DetectBoard(const cv::Mat& image, const CalibrationBoard& board,
                           const BoardDetectionOptions& options = {});

// At most max_views of the found `views`, chosen for their spread of poses
// (a calibration sequence of thousands of video frames is mostly the same
// pose again; a few dozen views that differ fix the intrinsics as well).
// Each view is described by where its homography puts the four corners of
// the board's extent (over every view's object points), divided by the
// image's diagonal: position, size, tilt and turn at once. The view with the
// most corners first, then again and again the view farthest from every
// view chosen (farthest-point sampling). Indices into `views`, ascending;
// every found view when there are no more than max_views (or max_views <= 0).
std::vector<size_t> SelectViews(const std::vector<BoardDetection>& views, cv::Size image_size, int max_views);

struct CameraCalibrationOptions {
  int min_views = 3;     // fewer usable views: kInvalidArgument
  // Estimate k3 too (OpenCV's default). For lenses with a modest field of view
  // k3 is poorly observed and trades off against k1, k2; fix it (to 0) there.
  bool fix_k3 = false;
  bool fix_tangential = false;  // p1 = p2 = 0
  // plumb_bob: cv::calibrateCamera. equidistant (a fisheye): cv::fisheye::
  // calibrate (k1..k4, no skew; fix_k3 and fix_tangential do not apply), its
  // sigmas from a delete-a-group jackknife over the views (OpenCV's fisheye
  // calibration gives none).
  LensModel lens = LensModel::kPlumbBob;
  // Fisheye: each corner's residual weighed by min(1, the views' median
  // corner sigma / its own) when the views state sigmas (aprilgrid): a small
  // dark tag at the rim pulls less than its stated uncertainty allows.
  // OpenCV's plumb_bob calibration takes no weights.
  bool weight_by_corner_sigma = true;
  // The jackknife's refits on at most this many workers (0: one per core).
  int threads = 0;
  // Aprilgrid: each tag's lift off the board's plane [m], by id
  // (MeasureBoardShape, board_shape.h): the board is then calibrated as
  // lifted, not flat. OpenCV's plumb_bob fit of a board that is not planar
  // starts from a camera: `initial`, the same views calibrated as flat,
  // which the lifts need.
  std::map<int, double> board_lift_m;
  std::optional<Intrinsics> initial;

  bool IsValid(std::string* why) const;
};

struct CameraCalibrationResult {
  // kInvalidArgument: bad options, image size or views, or fewer usable views
  // than min_views; kFailed: OpenCV gave no valid camera. The message says which.
  StatusCode status = StatusCode::kFailed;
  std::string message;
  Intrinsics intrinsics;
  // Over all corners of all views, and per view (input order) [px].
  double rms_reprojection_error_px = 0.0;
  std::vector<double> per_view_rms_px;
  // One-sigma of fx, fy, cx, cy and the distortion in Intrinsics::distortion's
  // order (plumb_bob k1, k2, p1, p2, k3; equidistant k1..k4, 0): plumb_bob's
  // from OpenCV's covariance (assumes the corner errors are independent with
  // the observed RMS), equidistant's from the jackknife over views.
  std::array<double, 9> sigma{};
  int views = 0;
  int corners = 0;
  // Views (input order) the fisheye fit left out: no pose for them through
  // the lens, even once adjusted (fisheye_fit.h). per_view_rms_px still has them.
  std::vector<int> views_left_out;

  bool ok() const { return status == StatusCode::kOk; }
};

// Views without a detection (found = false) must be filtered out by the caller.
CameraCalibrationResult CalibrateCamera(const std::vector<BoardDetection>& views,
                                        const cv::Size& image_size,
                                        const CameraCalibrationOptions& options = {});

// Where a calibration's corners fall in the image. The lens is measured where
// they are and extrapolated elsewhere: views that all hold the board in one
// part of the image leave the centre and the focal length to the model's
// form, an error the sigmas (OpenCV's covariance, the jackknife over views)
// do not see, since every view shares it. Real D435i frames through a fisheye
// turned 35 degrees, the board in one corner (21 of 64 cells): fx 2.6 and cy
// 3.5 sigma off the truth, from odocal's corners and from yac's alike
// (docs/vision.md, "Towards a wide fisheye's rim").
struct ImageCoverage {
  int grid = 0;           // cells per side of the image
  int cells_covered = 0;  // of grid * grid, holding at least one corner
  double fraction = 0.0;  // cells_covered / (grid * grid)
  // The corners' extent as fractions of the image's width and height.
  double x_min = 0.0, x_max = 0.0, y_min = 0.0, y_max = 0.0;
  // Below this the calibration says its lens is extrapolated (calibrate-camera's warning).
  static constexpr double kWarnBelow = 0.5;
};
ImageCoverage MeasureCoverage(const std::vector<BoardDetection>& views, cv::Size image_size, int grid = 8);

// calibrate-camera's --model auto: plumb_bob and the fisheye fitted to the
// same views, compared by their RMS over the views both posed (each view
// weighted by its corners). The fisheye is chosen when its RMS is under 95 %
// of plumb_bob's: it has one coefficient fewer, so fitting better is not
// over-fitting, and a tie goes to the usual model.
struct LensModelChoice {
  double plumb_bob_rms_px = NAN;
  double fisheye_rms_px = NAN;
  int views = 0;  // compared on
  LensModel chosen = LensModel::kPlumbBob;
};
LensModelChoice CompareLensModels(const std::vector<BoardDetection>& views, const CameraCalibrationResult& plumb_bob,
                                  const CameraCalibrationResult& fisheye);

// calibrate-camera's steps once the boards are found, for every command that
// needs a lens from images of a board (calibrate-camera, detect without a
// calibration). With `choose_model`, plumb_bob and the fisheye are both fitted
// and CompareLensModels picks (options.lens is then ignored); otherwise
// options.lens is fitted. An aprilgrid's corners come from its tags' edges,
// which the lens bends (through a fisheye by 0.15 px rms at a tag's corners,
// docs/vision.md): each view is then found again through that lens
// (`image(i)` returns view i's image) and the camera calibrated again; a view
// whose second pass finds no board keeps its first.
struct LensFromViews {
  CameraCalibrationResult result;          // the second pass's when it ran and succeeded
  std::optional<LensModelChoice> choice;   // with choose_model
  double first_pass_rms_px = NAN;          // when the second pass replaced the first
  std::vector<BoardDetection> views;       // as calibrated (the second pass's where it found the board)
};
LensFromViews CalibrateLensFromViews(std::vector<BoardDetection> views, const cv::Size& image_size,
                                     const CalibrationBoard& board, CameraCalibrationOptions options,
                                     bool choose_model, const std::function<cv::Mat(size_t)>& image);

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_CAMERA_CALIBRATION_H_
