// odocal calibrate-camera IMAGES|DIRS... --board SPEC --out camera.yaml [--format opencv|ros] [--json]
//
// Loads the images, finds the board in each (vision::DetectBoard), calibrates
// (vision::CalibrateCamera) and writes the camera file (config/camera_file.h) with the
// reprojection errors. Images without the board are named and skipped.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core/utils/logger.hpp>

#include "cli_util.h"
#include "commands.h"
#include "odocal/base/format.h"
#include "odocal/base/parallel.h"
#include "odocal/base/units.h"
#include "odocal/config/camera_file.h"
#include "odocal/media/image_file.h"
#include "odocal/vision/board_shape.h"
#include "odocal/vision/camera_calibration.h"

namespace odocal::app {
namespace {

constexpr const char* kCalibrateCamera = "calibrate-camera";

struct ImageOutcome {
  std::string path;
  bool used = false;
  std::string reason;  // when not used
  int corners = 0;
  double rms_px = 0.0;
  bool left_out = false;  // board found, but no pose for it through the fitted fisheye lens
  bool not_chosen = false;  // board seen, another view chosen (--max-views)
};

nlohmann::json Finite(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

// `rms_as_flat_px`: with --board-shape fit, the RMS of the calibration that
// took the board as flat (NaN: the board was not fitted).
nlohmann::json BoardShapeJson(const vision::BoardShape& shape, double rms_as_flat_px) {
  nlohmann::json tags = nlohmann::json::array();
  for (const vision::TagLift& t : shape.tags)
    tags.push_back({{"id", t.id}, {"lift_mm", t.lift_mm}, {"sigma_mm", t.sigma_mm}, {"corners", t.corners}});
  return {{"flat", shape.flat},
          {"fitted", std::isfinite(rms_as_flat_px)},
          {"rms_as_flat_px", Finite(rms_as_flat_px)},
          {"rms_lift_mm", shape.rms_lift_mm},
          {"max_abs_lift_mm", shape.max_abs_lift_mm},
          {"max_lift_id", shape.max_lift_id},
          {"chi2_per_dof", shape.chi2_per_dof},
          {"dof", shape.dof},
          {"explained_fraction", shape.explained_fraction},
          {"tags", tags}};
}

// One line: is the board flat, and if not by how much and where.
std::string BoardShapeLine(const vision::BoardShape& shape, double rms_as_flat_px) {
  if (shape.flat)
    return "board: flat within what these views can tell (tag lifts RMS " + Fixed(shape.rms_lift_mm, 2) +
           " mm, chi2/dof " + Fixed(shape.chi2_per_dof, 2) + ")";
  const std::string what = "the board is not flat (or not printed to its layout): its tags sit off its plane by " +
                           Fixed(shape.rms_lift_mm, 2) + " mm RMS, up to " + Fixed(shape.max_abs_lift_mm, 2) +
                           " mm (tag " + std::to_string(shape.max_lift_id) + "), chi2/dof " +
                           Fixed(shape.chi2_per_dof, 1);
  if (std::isfinite(rms_as_flat_px))
    return what + "; calibrated with each tag at its lift (--board-shape fit; RMS " + Fixed(rms_as_flat_px, 4) +
           " px as flat)";
  return "warning: " + what +
         "; the calibration takes it as flat (--board-shape fit calibrates it as it is; a board on glass or "
         "aluminium calibrates better)";
}

// One image as first searched.
struct Searched {
  cv::Size size;
  std::string unreadable;  // why, when the image could not be read
  vision::BoardDetection detection;
  bool full = false;  // the full search's detection, not the quick look's
};

// The quick look (libapriltag's corners alone, without the full search's
// painted and predicted passes) can miss a board the full search finds:
// small tags whose corner squares still touch them, a lens or light the data
// sets we have do not show. When it saw fewer views than max_views, up to
// kProbes of the images it saw no board in are searched fully, evenly spaced;
// if any of them shows the board, every such image is.
void SearchWhatTheQuickLookMissed(const std::vector<std::string>& paths, const vision::CalibrationBoard& board,
                                  int max_views, int threads, std::vector<Searched>* searched) {
  constexpr size_t kProbes = 8;
  std::vector<size_t> unseen;
  int seen = 0;
  for (size_t i = 0; i < searched->size(); ++i) {
    const Searched& s = (*searched)[i];
    if (!s.unreadable.empty()) continue;
    if (s.detection.found) ++seen;
    else unseen.push_back(i);
  }
  if (seen >= max_views || unseen.empty()) return;
  const auto search = [&](size_t i) {
    Searched& s = (*searched)[i];
    s.detection = vision::DetectBoard(media::ReadGreyImage(paths[i]).grey, board);
    s.full = true;
  };
  std::vector<size_t> probes;
  const size_t n = std::min(kProbes, unseen.size());
  for (size_t k = 0; k < n; ++k) probes.push_back(unseen[k * unseen.size() / n]);
  ParallelFor(probes.size(), static_cast<unsigned>(threads), [&](size_t k) { search(probes[k]); });
  const bool missed = std::any_of(probes.begin(), probes.end(), [&](size_t i) { return (*searched)[i].detection.found; });
  if (!missed) return;
  std::cerr << "odocal " << kCalibrateCamera << ": the quick look (--max-views) missed the board in images the full "
            << "search finds it in: searching all " << unseen.size() << " of them fully\n";
  ParallelFor(unseen.size(), static_cast<unsigned>(threads), [&](size_t k) {
    if (!(*searched)[unseen[k]].full) search(unseen[k]);
  });
}

}  // namespace

struct CalibrateCameraArgs {
  std::vector<std::string> images;
  std::string board;
  std::string out;
  std::string format = "opencv";
  std::string camera_name = "camera";
  bool fix_k3 = false;
  std::string model = "auto";
  bool json = false;
  int threads = 0;  // 0: one per core
  int max_views = 60;  // 0: every view
  std::string board_shape = "report";  // report | fit
};

namespace {

// What the user asked for, checked before any work.
struct CalibrateRequest {
  vision::CalibrationBoard board;
  config::CameraFileFormat format{};
  bool auto_model = false;
  vision::LensModel lens = vision::LensModel::kPlumbBob;  // auto: plumb_bob first
};

CalibrateRequest ParseRequest(const CalibrateCameraArgs& args) {
  CalibrateRequest r;
  r.board = ParseBoardOption(kCalibrateCamera, "--board", args.board);
  const auto format = config::ParseCameraFileFormat(args.format);
  if (!format) Fail(kCalibrateCamera, kExitBadInput, "--format: expected opencv or ros, got '" + args.format + "'");
  r.format = *format;
  r.auto_model = args.model == "auto";
  const auto lens = r.auto_model ? std::optional(vision::LensModel::kPlumbBob) : vision::ParseLensModel(args.model);
  if (!lens) Fail(kCalibrateCamera, kExitBadInput, "--model: expected auto, plumb_bob or fisheye, got '" + args.model + "'");
  if (*lens == vision::LensModel::kEquidistant && args.fix_k3)
    Fail(kCalibrateCamera, kExitBadInput, "--fix-k3 is plumb_bob's; the fisheye model has k1..k4");
  r.lens = *lens;
  // Where the camera file goes, settled before minutes of detection: its
  // directory made if missing, a directory named as the file refused.
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(args.out, ec)) Fail(kCalibrateCamera, kExitBadInput, "--out " + args.out + ": is a directory");
  const fs::path parent = fs::path(args.out).parent_path();
  if (!parent.empty() && !fs::is_directory(parent, ec) && !fs::create_directories(parent, ec))
    Fail(
        kCalibrateCamera, kExitBadInput,
        "--out " + args.out + ": cannot make the directory " + parent.string() + (ec ? " (" + ec.message() + ")" : ""));
  return r;
}

// The images and the views of the board in them.
struct Views {
  std::vector<std::string> paths;
  std::vector<Searched> searched;
  bool choose = false;  // more images than --max-views
  bool quick = false;   // ... an aprilgrid first only looked for
  std::vector<ImageOutcome> outcomes;
  std::vector<vision::BoardDetection> views;
  std::vector<size_t> view_image;  // views[i] came from outcomes[view_image[i]]
  cv::Size size;
  int views_seen = 0;
  size_t chosen_count = 0;
};

// Every image read and searched on its own worker (the edge models'
// fits are most of the time: ~0.9 s a 640x480 aprilgrid frame); then, in
// the images' order, the first readable one sets the size. More images
// than --max-views (a video's frames): an aprilgrid is first only looked
// for (libapriltag's corners, ~30 ms a frame), the views are chosen
// for their spread of poses (vision::SelectViews), and only those refined.
Views FindViews(const CalibrateCameraArgs& args, const vision::CalibrationBoard& board) {
  Views v;
  v.paths = ExpandDirectories(kCalibrateCamera, args.images, ImageExtensions());
  v.choose = args.max_views > 0 && v.paths.size() > static_cast<size_t>(args.max_views);
  vision::BoardDetectionOptions look;
  look.aprilgrid_corners_only = v.choose && board.type == vision::CalibrationBoard::Type::kAprilgrid;
  v.quick = look.aprilgrid_corners_only;
  v.searched.resize(v.paths.size());
  ParallelFor(v.paths.size(), static_cast<unsigned>(args.threads), [&](size_t i) {
    const std::string& path = v.paths[i];
    const cv::Mat image =
        std::filesystem::is_regular_file(path) ? media::ReadGreyImage(path).grey : cv::Mat();
    if (image.empty()) {
      v.searched[i].unreadable = !std::filesystem::exists(path)        ? "no such file"
                                 : std::filesystem::is_directory(path) ? "is a directory"
                                                                       : "cannot be read as an image";
      return;
    }
    v.searched[i].size = image.size();
    v.searched[i].detection = vision::DetectBoard(image, board, look);
    v.searched[i].full = !look.aprilgrid_corners_only;
  });
  if (v.quick) SearchWhatTheQuickLookMissed(v.paths, board, args.max_views, args.threads, &v.searched);
  for (size_t i = 0; i < v.paths.size(); ++i) {
    ImageOutcome o;
    o.path = v.paths[i];
    Searched& s = v.searched[i];
    if (!s.unreadable.empty()) {
      o.reason = s.unreadable;
    } else if (!v.size.empty() && s.size != v.size) {
      o.reason = "size " + std::to_string(s.size.width) + "x" + std::to_string(s.size.height) +
                 " differs from the first image's " + std::to_string(v.size.width) + "x" +
                 std::to_string(v.size.height);
    } else {
      v.size = s.size;
      vision::BoardDetection& d = s.detection;
      if (d.found) {
        o.used = true;
        o.corners = static_cast<int>(d.image_points.size());
        v.views.push_back(std::move(d));
        v.view_image.push_back(v.outcomes.size());
      } else if (!s.full) {
        // Not seen by the quick look: so named, not as the full search's verdict.
        o.reason = "board not found by the quick look (--max-views): " + d.message;
      } else {
        o.reason = d.message;
      }
    }
    if (!o.used) std::cerr << "odocal " << kCalibrateCamera << ": skipping " << o.path << ": " << o.reason << "\n";
    v.outcomes.push_back(o);
  }
  v.views_seen = static_cast<int>(v.views.size());
  v.chosen_count = v.views.size();
  return v;
}

// The views chosen among those seen (--max-views); an aprilgrid's refined now.
void ChooseViews(const CalibrateCameraArgs& args, const vision::CalibrationBoard& board, Views* v) {
  const std::vector<size_t> chosen = vision::SelectViews(v->views, v->size, args.max_views);
  v->chosen_count = chosen.size();
  std::vector<bool> keep(v->views.size(), false);
  for (size_t i : chosen) keep[i] = true;
  for (size_t i = 0; i < v->views.size(); ++i) {
    if (keep[i]) continue;
    ImageOutcome& o = v->outcomes[v->view_image[i]];
    o.used = false;
    o.not_chosen = true;
    o.reason = "board seen; not among the " + std::to_string(chosen.size()) +
               " views chosen for their spread of poses (--max-views)";
  }
  std::vector<vision::BoardDetection> kept_views;
  std::vector<size_t> kept_image;
  for (size_t i : chosen) {
    kept_views.push_back(std::move(v->views[i]));
    kept_image.push_back(v->view_image[i]);
  }
  if (v->quick) {
    ParallelFor(kept_views.size(), static_cast<unsigned>(args.threads), [&](size_t i) {
      if (v->searched[kept_image[i]].full) return;  // found by the full search already
      kept_views[i] = vision::DetectBoard(media::ReadGreyImage(v->outcomes[kept_image[i]].path).grey, board);
    });
  }
  v->views.clear();
  v->view_image.clear();
  for (size_t i = 0; i < kept_views.size(); ++i) {
    ImageOutcome& o = v->outcomes[kept_image[i]];
    if (kept_views[i].found) {
      o.corners = static_cast<int>(kept_views[i].image_points.size());
      v->views.push_back(std::move(kept_views[i]));
      v->view_image.push_back(kept_image[i]);
    } else {
      o.used = false;
      o.reason = kept_views[i].message;
      std::cerr << "odocal " << kCalibrateCamera << ": skipping " << o.path << ": " << o.reason << "\n";
    }
  }
}

// The camera and what was learnt on the way to it.
struct Calibrated {
  vision::CameraCalibrationResult result;
  std::optional<vision::LensModelChoice> choice;
  double first_pass_rms_px = NAN;
  double fisheye_rms_px = NAN;  // a plumb_bob fit that a fisheye fits twice as well
  std::optional<vision::BoardShape> shape;
  double rms_as_flat_px = NAN;  // --board-shape fit: the RMS as flat
  vision::ImageCoverage coverage;  // of the views calibrated
};

// An aprilgrid's flatness, as these views see it (vision/board_shape.h);
// --board-shape fit: a board that is not flat calibrated as it is, each tag
// at its lift (taken as flat, a +-1 mm board moved fx and cx by up to 0.7 px
// in BoardShape.CalibratingWithTheLiftsTakesTheShapeOutOfTheIntrinsics).
void BoardShapeOf(const CalibrateCameraArgs& args, const vision::CalibrationBoard& board,
                  const std::vector<vision::BoardDetection>& views, cv::Size size,
                  const vision::CameraCalibrationOptions& options, Calibrated* c) {
  if (board.type == vision::CalibrationBoard::Type::kAprilgrid) {
    c->shape = vision::MeasureBoardShape(views, board, c->result.intrinsics);
    if (!c->shape->ok()) c->shape.reset();
  }
  if (args.board_shape == "fit" && !c->shape)
    std::cerr << "odocal " << kCalibrateCamera << ": --board-shape fit: "
              << (board.type == vision::CalibrationBoard::Type::kAprilgrid
                      ? "the board's shape could not be measured from these views"
                      : "a board's shape is measured on aprilgrids only")
              << "; calibrated as flat\n";
  if (args.board_shape == "fit" && c->shape && !c->shape->flat) {
    vision::CameraCalibrationOptions lifted = options;
    for (const vision::TagLift& t : c->shape->tags) lifted.board_lift_m[t.id] = kMmToM * t.lift_mm;
    lifted.initial = c->result.intrinsics;
    vision::CameraCalibrationResult fitted = vision::CalibrateCamera(views, size, lifted);
    if (!fitted.ok())
      Fail(kCalibrateCamera, kExitFailure, "--board-shape fit: " + fitted.message + " (no camera file written)");
    c->rms_as_flat_px = c->result.rms_reprojection_error_px;
    c->result = std::move(fitted);
  }
}

// The lens (--model auto: both models, vision::CompareLensModels), then an
// aprilgrid's tags refined again through it (vision::CalibrateLensFromViews);
// a plumb_bob fit that leaves pixels checked against the fisheye; the
// board's shape measured and, with --board-shape fit, fitted.
Calibrated Calibrate(const CalibrateCameraArgs& args, const CalibrateRequest& request, Views* v) {
  const vision::CalibrationBoard& board = request.board;
  vision::CameraCalibrationOptions options;
  options.fix_k3 = args.fix_k3;
  options.lens = request.lens;
  options.threads = args.threads;
  if (static_cast<int>(v->views.size()) < options.min_views) {
    Fail(kCalibrateCamera, kExitFailure,
         "only " + std::to_string(v->views.size()) + " of " + std::to_string(v->outcomes.size()) +
             " images show the board; need at least " + std::to_string(options.min_views) +
             " (no camera file written)");
  }
  vision::LensFromViews lens_fit = vision::CalibrateLensFromViews(
      v->views, v->size, board, options, request.auto_model,
      [&](size_t i) { return media::ReadGreyImage(v->outcomes[v->view_image[i]].path).grey; });
  if (lens_fit.choice && lens_fit.choice->chosen == vision::LensModel::kEquidistant) {
    options.lens = vision::LensModel::kEquidistant;
    options.fix_k3 = false;
  }
  Calibrated c;
  c.result = std::move(lens_fit.result);
  c.choice = lens_fit.choice;
  c.first_pass_rms_px = lens_fit.first_pass_rms_px;
  if (!c.result.ok()) Fail(kCalibrateCamera, kExitFailure, c.result.message + " (no camera file written)");
  for (size_t i = 0; i < v->views.size(); ++i)
    v->outcomes[v->view_image[i]].corners = static_cast<int>(lens_fit.views[i].image_points.size());
  // A plumb_bob fit that leaves pixels: is it a fisheye? The same views
  // through the equidistant model; suggested when it halves the error (a
  // 190-degree lens fitted as plumb_bob: 2.39 px, as a fisheye 0.034 px).
  if (!request.auto_model && request.lens == vision::LensModel::kPlumbBob && c.result.rms_reprojection_error_px > 0.5) {
    vision::CameraCalibrationOptions other = options;
    other.lens = vision::LensModel::kEquidistant;
    other.fix_k3 = false;
    const vision::CameraCalibrationResult f = vision::CalibrateCamera(v->views, v->size, other);
    if (f.ok() && f.rms_reprojection_error_px < 0.5 * c.result.rms_reprojection_error_px)
      c.fisheye_rms_px = f.rms_reprojection_error_px;
  }
  BoardShapeOf(args, board, lens_fit.views, v->size, options, &c);
  c.coverage = vision::MeasureCoverage(lens_fit.views, v->size);
  for (size_t i = 0; i < v->views.size(); ++i) v->outcomes[v->view_image[i]].rms_px = c.result.per_view_rms_px[i];
  for (int i : c.result.views_left_out) v->outcomes[v->view_image[i]].left_out = true;
  return c;
}

// The coefficients by the lens's names (plumb_bob k1 k2 p1 p2 k3, equidistant k1..k4).
std::vector<std::string> CoefficientNames(const vision::Intrinsics& in) {
  return in.lens == vision::LensModel::kEquidistant ? std::vector<std::string>{"k1", "k2", "k3", "k4"}
                                                    : std::vector<std::string>{"k1", "k2", "p1", "p2", "k3"};
}

nlohmann::json CoverageJson(const vision::ImageCoverage& c) {
  return {{"grid", c.grid},
          {"cells_covered", c.cells_covered},
          {"fraction", c.fraction},
          {"x_span", {c.x_min, c.x_max}},
          {"y_span", {c.y_min, c.y_max}},
          {"extrapolated", c.fraction < vision::ImageCoverage::kWarnBelow}};
}

// How much of the image the corners reach, and a warning when the lens is
// mostly extrapolated.
std::string CoverageLines(const vision::ImageCoverage& c) {
  const auto percent = [](double f) { return std::to_string(static_cast<int>(std::lround(100.0 * f))); };
  std::string text = "  coverage: the corners reach " + std::to_string(c.cells_covered) + " of " +
                     std::to_string(c.grid * c.grid) + " cells (" + std::to_string(c.grid) + " x " +
                     std::to_string(c.grid) + ") of the image (" + percent(c.fraction) + " %), x " + percent(c.x_min) +
                     "-" + percent(c.x_max) + " %, y " + percent(c.y_min) + "-" + percent(c.y_max) + " %\n";
  if (c.fraction < vision::ImageCoverage::kWarnBelow)
    text += "  warning: the lens is measured on " + percent(c.fraction) +
            " % of the image and extrapolated elsewhere, an error the sigmas above do not include; add views with "
            "the board near the image's edges and corners\n";
  return text;
}

// --json: the camera, how it was found, and every image's outcome.
void PrintJson(const CalibrateCameraArgs& args, const CalibrateRequest& request, const Views& v, const Calibrated& c) {
  const vision::CameraCalibrationResult& result = c.result;
  const vision::Intrinsics& in = result.intrinsics;
  const std::vector<std::string> names = CoefficientNames(in);
  nlohmann::json distortion = nlohmann::json::array();
  nlohmann::json sigma = {{"fx", result.sigma[0]}, {"fy", result.sigma[1]}, {"cx", result.sigma[2]},
                          {"cy", result.sigma[3]}};
  for (size_t i = 0; i < names.size(); ++i) {
    distortion.push_back(in.distortion[i]);
    sigma[names[i]] = result.sigma[4 + i];
  }
  nlohmann::json images = nlohmann::json::array();
  for (const ImageOutcome& o : v.outcomes) {
    if (o.used) {
      images.push_back({{"path", o.path}, {"used", !o.left_out}, {"corners", o.corners}, {"rms_px", o.rms_px}});
      if (o.left_out) images.back()["reason"] = "no pose through the fitted fisheye lens (left out)";
    } else {
      images.push_back({{"path", o.path}, {"used", false}, {"reason", o.reason}});
    }
  }
  const auto& choice = c.choice;
  const nlohmann::json doc = {
      {"out", args.out},
      {"format", config::CameraFileFormatName(request.format)},
      {"image_width", in.width},
      {"image_height", in.height},
      {"fx", in.fx},
      {"fy", in.fy},
      {"cx", in.cx},
      {"cy", in.cy},
      {"distortion_model", vision::LensModelName(in.lens)},
      {"distortion", distortion},
      {"sigma", sigma},
      {"rms_reprojection_error_px", result.rms_reprojection_error_px},
      {"first_pass_rms_px", Finite(c.first_pass_rms_px)},
      {"fisheye_rms_px", Finite(c.fisheye_rms_px)},
      {"model_choice", choice ? nlohmann::json{{"plumb_bob_rms_px", Finite(choice->plumb_bob_rms_px)},
                                               {"fisheye_rms_px", Finite(choice->fisheye_rms_px)},
                                               {"views_compared", choice->views},
                                               {"chosen", vision::LensModelName(choice->chosen)}}
                              : nlohmann::json()},
      {"views_used", result.views},
      {"view_choice", v.choose ? nlohmann::json{{"max_views", args.max_views},
                                                {"images_with_the_board", v.views_seen},
                                                {"chosen", static_cast<int>(v.chosen_count)}}
                               : nlohmann::json()},
      {"corners_used", result.corners},
      {"coverage", CoverageJson(c.coverage)},
      {"board_shape", c.shape ? BoardShapeJson(*c.shape, c.rms_as_flat_px) : nlohmann::json()},
      {"images", images},
  };
  std::cout << doc.dump(2) << std::endl;
}

// The camera with its sigmas, and a line per image.
void PrintText(const CalibrateCameraArgs& args, const CalibrateRequest& request, const Views& v, const Calibrated& c) {
  const vision::CameraCalibrationResult& result = c.result;
  const vision::Intrinsics& in = result.intrinsics;
  const std::vector<std::string> names = CoefficientNames(in);
  const bool fisheye = in.lens == vision::LensModel::kEquidistant;
  std::cout << "Camera calibration  " << in.width << "x" << in.height << ", " << result.views << " of "
            << v.outcomes.size() << " images, " << result.corners << " corners\n\n";
  std::cout << "  fx " << std::setw(12) << Fixed(in.fx, 3) << "  +/- " << Fixed(result.sigma[0], 3) << " px\n"
            << "  fy " << std::setw(12) << Fixed(in.fy, 3) << "  +/- " << Fixed(result.sigma[1], 3) << " px\n"
            << "  cx " << std::setw(12) << Fixed(in.cx, 3) << "  +/- " << Fixed(result.sigma[2], 3) << " px\n"
            << "  cy " << std::setw(12) << Fixed(in.cy, 3) << "  +/- " << Fixed(result.sigma[3], 3) << " px\n";
  std::cout << "  lens " << vision::LensModelName(in.lens)
            << (fisheye ? " (sigmas from a jackknife over the views)" : "") << "\n";
  if (const auto& choice = c.choice)
    std::cout << "  (--model auto: first-pass RMS over " << choice->views << " views " << Fixed(choice->plumb_bob_rms_px, 4)
              << " px as plumb_bob, " << Fixed(choice->fisheye_rms_px, 4) << " px as a fisheye; "
              << vision::LensModelName(choice->chosen) << " chosen)\n";
  for (size_t i = 0; i < names.size(); ++i) {
    std::cout << "  " << names[i] << " " << std::setw(12) << Fixed(in.distortion[i], 6) << "  +/- "
              << Fixed(result.sigma[4 + i], 6) << "\n";
  }
  std::cout << "\n  RMS reprojection error " << Fixed(result.rms_reprojection_error_px, 4) << " px";
  if (std::isfinite(c.first_pass_rms_px))
    std::cout << " (the tags' edges refined through the lens; " << Fixed(c.first_pass_rms_px, 4)
              << " px as straight lines)";
  std::cout << "\n" << CoverageLines(c.coverage);
  if (std::isfinite(c.fisheye_rms_px))
    std::cout << "  warning: the same views fit the fisheye (equidistant) model with RMS " << Fixed(c.fisheye_rms_px, 4)
              << " px: this looks like a fisheye lens; calibrate again with --model fisheye\n";
  std::cout << "\n";
  if (v.choose)
    std::cout << "  " << v.chosen_count << " of the " << v.views_seen << " images showing the board chosen for their "
              << "spread of poses (--max-views " << args.max_views << "; 0 uses every view)\n\n";
  for (const ImageOutcome& o : v.outcomes) {
    if (o.not_chosen) continue;
    std::cout << "  " << o.path << ": "
              << (o.used ? Fixed(o.rms_px, 4) + " px RMS, " + std::to_string(o.corners) + " corners" +
                               (o.left_out ? " (left out of the fit: no pose through the fisheye lens)" : "")
                         : "skipped (" + o.reason + ")")
              << "\n";
  }
  if (c.shape) std::cout << "  " << BoardShapeLine(*c.shape, c.rms_as_flat_px) << "\n";
  std::cout << "\n  wrote " << args.out << " (" << config::CameraFileFormatName(request.format) << ")\n";
}

}  // namespace

void RunCalibrateCamera(const CalibrateCameraArgs& args) {
  // Every unreadable image is reported once, by us, in one line.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);
  const CalibrateRequest request = ParseRequest(args);
  const vision::CalibrationBoard& board = request.board;
  Views v = FindViews(args, board);
  if (v.choose) ChooseViews(args, board, &v);
  if (board.type == vision::CalibrationBoard::Type::kAprilgrid && v.views.empty()) {
    // The board named is not the board filmed (or not with enough of it):
    // bad input rather than a failed calibration.
    Fail(kCalibrateCamera, kExitBadInput,
         "--board aprilgrid " + std::to_string(board.cols) + "x" + std::to_string(board.rows) + " (" +
             board.tag_family + ", ids " + std::to_string(board.first_id) + "-" +
             std::to_string(board.first_id + board.cols * board.rows - 1) + "): no image of " +
             std::to_string(v.outcomes.size()) + " shows 4 or more of its tags (no camera file written)");
  }
  const Calibrated c = Calibrate(args, request, &v);
  config::CameraFile file;
  file.intrinsics = c.result.intrinsics;
  file.camera_name = args.camera_name;
  file.rms_reprojection_error_px = c.result.rms_reprojection_error_px;
  file.per_view_reprojection_errors_px = c.result.per_view_rms_px;
  if (const Status error = config::WriteCameraFile(args.out, file, request.format); !error)
    Fail(kCalibrateCamera, kExitFailure, error.message);
  if (args.json) {
    PrintJson(args, request, v, c);
    return;
  }
  PrintText(args, request, v, c);
}

void RegisterCalibrateCameraCommand(CLI::App& app) {
  auto args = std::make_shared<CalibrateCameraArgs>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate-camera",
      "Camera intrinsics (fx fy cx cy and the lens's distortion, plumb_bob or fisheye) from images of a\n"
      "calibration board.\n"
      "Images where the board is not found are named and skipped; at least 3 must remain.\n"
      "Writes OpenCV FileStorage or ROS camera_info YAML with the reprojection errors.");
  cmd->add_option("images", args->images,
                  "Images of the board (any format OpenCV reads), or directories of them (e.g. a Kalibr data set's cam0/data)")
      ->required();
  cmd->add_option("--board", args->board,
                  "chessboard:COLSxROWS:SQUARE_MM (inner corners, e.g. chessboard:9x6:25) or\n"
                  "charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICT (squares, e.g. charuco:7x5:40:30:DICT_5X5_100) or\n"
                  "aprilgrid:COLSxROWS:TAG_MM:SPACING[:FIRST_ID] (Kalibr's target: tags with a 2-bit border,\n"
                  "TAG_MM the outer black edge, gap = SPACING x tag, e.g. aprilgrid:6x6:88:0.3) or\n"
                  "a Kalibr target.yaml (target_type: aprilgrid)")
      ->required();
  cmd->add_option("--out", args->out, "Camera file to write")->required();
  cmd->add_option("--format", args->format, "opencv (default) or ros");
  cmd->add_option("--camera-name", args->camera_name, "camera_name in ROS files (default: camera)");
  cmd->add_flag("--fix-k3", args->fix_k3, "Keep k3 = 0 (lenses with a modest field of view)");
  cmd->add_option("--model", args->model,
                  "Lens model: auto (default: both fitted, the fisheye when it fits the views 5 % better), plumb_bob "
                  "(OpenCV's k1 k2 p1 p2 k3) or fisheye (equidistant, cv::fisheye's k1..k4)");
  cmd->add_flag("--json", args->json, "Print one JSON object");
  cmd->add_option("--threads", args->threads, "Worker threads for the images (default: one per core)")
      ->check(CLI::Range(0, kMaxCount));
  cmd->add_option("--board-shape", args->board_shape,
                  "Aprilgrid: report (default) whether the board was flat, or fit: a board that is not is then "
                  "calibrated with each tag's measured lift off its plane")
      ->check(CLI::IsMember({"report", "fit"}));
  cmd->add_option("--max-views", args->max_views,
                  "With more images than this (a video's frames), calibrate from this many views chosen for their "
                  "spread of poses (default: 60; 0: every view)")
      ->check(CLI::Range(0, kMaxCount));
  cmd->callback([args]() { RunCalibrateCamera(*args); });
}

}  // namespace odocal::app
