// odocal detect IMAGE|VIDEO... (--tag SPEC | --board SPEC) [--calibration CAM] [--json OUT] [--annotate DIR]
//
// Every tag of the family in each image (vision::SurveyTags): id, corners
// refined by the edge model with each corner's sigma, and the candidate quads
// libapriltag found but decoded no tag from. With a calibration, each tag's
// pose in the camera frame (--tag: every tag taken at the spec's size) or the
// board's pose with each corner's residual (--board). Everything is checked
// and computed before anything is written; bad input is one line and exit 2.
// Keys: docs/formats.md, "odocal detect".
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgproc.hpp>

#include "cli_util.h"
#include "commands.h"
#include "odocal/base/parallel.h"
#include "odocal/base/units.h"
#include "odocal/config/camera_file.h"
#include "odocal/config/files.h"
#include "odocal/media/image_file.h"
#include "odocal/media/video.h"
#include "odocal/vision/camera_calibration.h"
#include "odocal/vision/tag.h"
#include "odocal/vision/tag_survey.h"

namespace odocal::app {
namespace {

constexpr const char* kDetect = "detect";
namespace fs = std::filesystem;
using nlohmann::json;

struct DetectArgs {
  std::vector<std::string> inputs;
  std::string tag;
  std::string board;
  std::string calibration;
  std::string json_out;
  std::string annotate_dir;
  bool straight_edges = false;  // --board without --calibration: no lens from the images
  int threads = 0;              // 0: one per core
};

// One image (a file, or one frame of a video) and what was found in it.
struct Frame {
  std::string file;
  int frame = -1;  // videos only
  cv::Mat grey;
  std::string read_as;  // how a deeper image file became 8-bit grey (media::GreyImage)
};

bool IsVideo(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".mp4" || ext == ".avi" || ext == ".mkv" || ext == ".mov" || ext == ".webm";
}

json Corners(const std::array<cv::Point2d, 4>& c) {
  json out = json::array();
  for (const auto& p : c) out.push_back({p.x, p.y});
  return out;
}

json PoseJson(const vision::ObjectPose& pose) {
  const Eigen::Vector3d t = pose.T_camera_object.translation();
  const Eigen::AngleAxisd aa(pose.T_camera_object.linear());
  const Eigen::Vector3d rvec = aa.angle() * aa.axis();
  const Eigen::Quaterniond q(pose.T_camera_object.linear());
  json cov = json::array();
  for (int r = 0; r < 6; ++r) {
    json row = json::array();
    for (int c = 0; c < 6; ++c) row.push_back(pose.covariance(r, c));
    cov.push_back(row);
  }
  const auto sd = [&](int i) { return std::sqrt(std::max(0.0, pose.covariance(i, i))); };
  return {{"translation_m", {t.x(), t.y(), t.z()}},
          {"rotation_vector_rad", {rvec.x(), rvec.y(), rvec.z()}},
          {"quaternion_wxyz", {q.w(), q.x(), q.y(), q.z()}},
          {"sigma_translation_mm", {kMToMm * sd(3), kMToMm * sd(4), kMToMm * sd(5)}},
          {"sigma_rotation_deg", {kRadToDeg * sd(0), kRadToDeg * sd(1), kRadToDeg * sd(2)}},
          {"covariance", cov},
          {"rms_residual_px", pose.rms_residual_px},
          {"chi2_per_dof", pose.chi2_per_dof},
          {"covariance_scale", pose.covariance_scale}};
}

std::vector<double> SigmasOrOne(const std::array<double, 4>& s) {
  std::vector<double> out;
  for (double v : s) out.push_back(v > 0.0 ? std::max(v, 1e-3) : 1.0);
  return out;
}

void DrawQuad(cv::Mat* bgr, const std::array<cv::Point2d, 4>& c, const cv::Scalar& colour, int thickness) {
  // Pixel centres at integers (OpenCV's drawing convention too), 4 bits of
  // sub-pixel precision.
  std::vector<cv::Point> pts;
  for (const auto& p : c) pts.emplace_back(cvRound(p.x * 16), cvRound(p.y * 16));
  cv::polylines(*bgr, pts, true, colour, thickness, cv::LINE_AA, 4);
}

// What one image's searches found.
struct Found {
  vision::TagSurvey survey;
  vision::BoardDetection board;
};

// --board without --calibration: the lens calibrated from the images' first-
// pass boards as calibrate-camera calibrates it (at most kMaxLensViews views
// chosen for their spread, the model chosen as --model auto chooses), so
// that a fisheye's curved edges are refined as curves. Videos' frames are
// not used. Sets *lens when it succeeds, with the boards of the views it was
// calibrated on already found through it (their indices in *through_lens);
// returns what detect.json's "lens" says.
json LensFromTheImages(const std::vector<std::string>& inputs, std::vector<Found>* found,
                       const vision::CalibrationBoard& board, int threads, std::optional<vision::Intrinsics>* lens,
                       std::vector<bool>* through_lens) {
  constexpr int kMaxLensViews = 60;
  std::vector<vision::BoardDetection> views;
  std::vector<size_t> view_input;
  cv::Size size;
  for (size_t i = 0; i < inputs.size(); ++i) {
    if (IsVideo(inputs[i]) || !(*found)[i].board.found) continue;
    views.push_back((*found)[i].board);
    view_input.push_back(i);
  }
  vision::CameraCalibrationOptions options;
  json out = {{"source", "none"}, {"edges", "straight"}};
  if (static_cast<int>(views.size()) < options.min_views) {
    const bool videos = std::any_of(inputs.begin(), inputs.end(), [](const std::string& p) { return IsVideo(p); });
    out["why"] = std::to_string(views.size()) + " image(s) show the board" +
                 (videos ? " (a video's frames are not used for a lens)" : "") + "; a lens needs " +
                 std::to_string(options.min_views) + ": name one with --calibration";
    return out;
  }
  size = media::ReadGreyImage(inputs[view_input.front()]).grey.size();
  const std::vector<size_t> chosen = vision::SelectViews(views, size, kMaxLensViews);
  std::vector<vision::BoardDetection> chosen_views;
  for (size_t c : chosen) chosen_views.push_back(views[c]);
  options.threads = threads;
  const vision::LensFromViews fit = vision::CalibrateLensFromViews(
      chosen_views, size, board, options, /*choose_model=*/true,
      [&](size_t v) { return media::ReadGreyImage(inputs[view_input[chosen[v]]]).grey; });
  if (!fit.result.ok()) {
    out["why"] = "no lens from the images: " + fit.result.message;
    return out;
  }
  *lens = fit.result.intrinsics;
  through_lens->assign(inputs.size(), false);
  if (std::isfinite(fit.first_pass_rms_px)) {
    for (size_t v = 0; v < chosen.size(); ++v) {
      (*found)[view_input[chosen[v]]].board = fit.views[v];
      (*through_lens)[view_input[chosen[v]]] = true;
    }
  }
  const vision::Intrinsics& k = fit.result.intrinsics;
  return {{"source", "images"},
          {"edges", "through the lens"},
          {"distortion_model", vision::LensModelName(k.lens)},
          {"views", fit.result.views},
          {"rms_px", fit.result.rms_reprojection_error_px},
          {"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy},
          {"distortion", std::vector<double>(k.distortion.begin(), k.distortion.end())}};
}

}  // namespace

namespace {

// What the user asked for, checked before any work.
struct DetectRequest {
  std::optional<vision::TagSpec> tag;
  std::optional<vision::CalibrationBoard> board;
  std::string family;
  std::optional<vision::Intrinsics> intrinsics;  // --calibration's
  std::optional<vision::CameraModel> camera;     // ... as a camera at the origin
};

DetectRequest ParseRequest(const DetectArgs& args) {
  if (args.tag.empty() == args.board.empty())
    Fail(kDetect, kExitBadInput, "name exactly one of --tag SPEC or --board SPEC");
  DetectRequest r;
  if (!args.tag.empty()) {
    r.tag = ParseTagOption(kDetect, "--tag", args.tag);
    std::string why;
    if (!r.tag->IsValid(&why)) Fail(kDetect, kExitBadInput, "--tag " + args.tag + ": " + why);
    r.family = r.tag->family;
  } else {
    r.board = ParseBoardOption(kDetect, "--board", args.board);
    if (r.board->type != vision::CalibrationBoard::Type::kAprilgrid)
      Fail(kDetect, kExitBadInput, "--board " + args.board + ": detect finds tags; name an aprilgrid (or its target.yaml)");
    r.family = r.board->tag_family;
  }
  if (!args.calibration.empty()) {
    const auto file = config::ReadCameraFile(args.calibration);
    if (!file) Fail(kDetect, kExitBadInput, "--calibration: " + file.message);
    r.intrinsics = file->intrinsics;
    r.camera.emplace(*r.intrinsics, vision::CameraMount{});
  }
  return r;
}

void CheckImageSize(const DetectArgs& args, const DetectRequest& request, const std::string& path,
                    const cv::Mat& grey) {
  const auto& in = request.intrinsics;
  if (in && (grey.cols != in->width || grey.rows != in->height))
    Fail(kDetect, kExitBadInput,
         path + ": " + std::to_string(grey.cols) + "x" + std::to_string(grey.rows) + ", but --calibration " +
             args.calibration + " is for " + std::to_string(in->width) + "x" + std::to_string(in->height));
}

// The inputs: every image read and every video opened now, so a bad one
// fails before any output; video frames are decoded one at a time later. A
// directory stands for the images in it (a Kalibr data set's cam0/data).
std::vector<std::string> CheckInputs(const DetectArgs& args, const DetectRequest& request) {
  const std::vector<std::string> inputs = ExpandDirectories(kDetect, args.inputs, ImageExtensions());
  for (const std::string& path : inputs) {
    if (!fs::is_regular_file(path))
      Fail(kDetect, kExitBadInput, path + ": " + (fs::exists(path) ? "not a regular file" : "no such file"));
    if (IsVideo(path)) {
      media::VideoReader reader;
      const Status opened = reader.Open(path);
      if (!opened.ok()) Fail(kDetect, kExitBadInput, path + ": " + opened.message);
    } else {
      const cv::Mat grey = media::ReadGreyImage(path).grey;
      if (grey.empty()) Fail(kDetect, kExitBadInput, path + ": cannot be read as an image");
      CheckImageSize(args, request, path, grey);
    }
  }
  return inputs;
}

// The board's tags as DetectBoard measured them in place of the survey's,
// the survey's for the rest; quads inside a board tag are not refusals.
// Returns the board tags DetectBoard refused, with why.
json MergeBoardTags(const vision::CalibrationBoard& board, const vision::BoardDetection& bd,
                    vision::TagSurvey* survey) {
  json board_refused = json::array();
  std::vector<vision::SurveyedTag> merged;
  for (size_t i = 0; i < bd.tag_ids.size(); ++i) {
    vision::SurveyedTag t;
    t.id = bd.tag_ids[i];
    t.refined = true;
    t.hamming = -1;
    t.edge_shift_px = bd.edge_shift_px;  // the view's, taken out of every board tag
    t.edge_shift_sigma_px = bd.edge_shift_sigma_px;
    for (int k = 0; k < 4; ++k) {
      t.corners_px[k] = bd.image_points[4 * i + k];
      t.corner_sigma_px[k] = bd.point_sigma_px[4 * i + k];
    }
    merged.push_back(t);
  }
  for (const auto& [id, why] : bd.tags_refused) board_refused.push_back({{"id", id}, {"reason", why}});
  for (const auto& t : survey->tags)
    if (!board.AprilgridCorner(t.id, 0)) merged.push_back(t);
  std::vector<vision::RejectedQuad> rejected;
  for (const auto& q : survey->rejected) {
    const cv::Point2f c(
        static_cast<float>(0.25 * (q.corners_px[0].x + q.corners_px[1].x + q.corners_px[2].x + q.corners_px[3].x)),
        static_cast<float>(0.25 * (q.corners_px[0].y + q.corners_px[1].y + q.corners_px[2].y + q.corners_px[3].y)));
    bool inside = false;
    for (const auto& t : merged) {
      std::vector<cv::Point2f> poly;
      for (const auto& p : t.corners_px) poly.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
      inside = inside || cv::pointPolygonTest(poly, c, false) >= 0;
    }
    if (!inside) rejected.push_back(q);
  }
  survey->tags = std::move(merged);
  survey->rejected = std::move(rejected);
  return board_refused;
}

// One tag's entry of detect.json; with --tag and a calibration, its pose.
json TagJson(const DetectRequest& request, const vision::SurveyedTag& t) {
  json j = {{"id", t.id},
            {"corners_px", Corners(t.corners_px)},
            {"refined", t.refined},
            {"hamming", t.hamming >= 0 ? json(t.hamming) : json(nullptr)},
            {"decision_margin", t.hamming >= 0 ? json(t.decision_margin) : json(nullptr)}};
  if (t.refined) {
    j["corner_sigma_px"] = t.corner_sigma_px;
    j["edge_shift_px"] = std::isfinite(t.edge_shift_px) ? json(t.edge_shift_px) : json(nullptr);
    j["edge_shift_sigma_px"] = std::isfinite(t.edge_shift_sigma_px) ? json(t.edge_shift_sigma_px) : json(nullptr);
  } else {
    j["corner_sigma_px"] = nullptr;
    j["refine_message"] = t.refine_message;
  }
  if (request.tag && request.camera) {
    std::vector<cv::Point3d> object;
    for (const auto& c : vision::TagCornersInTag(request.tag->size_m())) object.emplace_back(c.x(), c.y(), 0.0);
    const std::vector<cv::Point2d> pixels(t.corners_px.begin(), t.corners_px.end());
    const vision::ObjectPose pose =
        vision::EstimateObjectPose(*request.intrinsics, object, pixels, SigmasOrOne(t.corner_sigma_px));
    if (pose.ok()) {
      j["pose_in_camera"] = PoseJson(pose);
    } else {
      j["pose_in_camera"] = nullptr;
      j["pose_message"] = pose.message;
    }
  }
  return j;
}

// The board's entry of an image (tags used, refused, with a calibration its
// pose), each used tag's corner residuals added to `tags`.
json BoardJson(const DetectRequest& request, const vision::TagSurvey& survey, json board_refused, json* tags) {
  const vision::CalibrationBoard& board = *request.board;
  std::vector<cv::Point3d> board_points;
  std::vector<cv::Point2d> board_pixels;
  std::vector<double> board_sigmas;
  std::vector<size_t> board_tag_index;  // tags[] index of each board tag used
  std::map<int, int> seen;
  for (const auto& t : survey.tags) ++seen[t.id];
  for (size_t n = 0; n < survey.tags.size(); ++n) {
    const vision::SurveyedTag& t = survey.tags[n];
    const bool on_board = board.AprilgridCorner(t.id, 0).has_value();
    (*tags)[n]["on_board"] = on_board;
    if (!(on_board && seen[t.id] == 1 && t.refined)) continue;
    board_tag_index.push_back(n);
    for (int k = 0; k < 4; ++k) {
      const cv::Point3f p = *board.AprilgridCorner(t.id, k);
      board_points.emplace_back(p.x, p.y, p.z);
      board_pixels.push_back(t.corners_px[k]);
      board_sigmas.push_back(std::max(t.corner_sigma_px[k], 1e-3));
    }
  }
  const int used = static_cast<int>(board_tag_index.size());
  json b = {{"tags_used", used}, {"usable", used >= 4}, {"tags_refused", std::move(board_refused)}};
  if (used < 4 || !request.camera) return b;
  const vision::ObjectPose pose =
      vision::EstimateObjectPose(*request.intrinsics, board_points, board_pixels, board_sigmas);
  if (!pose.ok()) {
    b["pose_in_camera"] = nullptr;
    b["pose_message"] = pose.message;
    return b;
  }
  b["pose_in_camera"] = PoseJson(pose);
  for (size_t i = 0; i < board_tag_index.size(); ++i) {
    json res = json::array();
    for (int k = 0; k < 4; ++k) {
      const cv::Point2d& e = pose.residuals_px[4 * i + k];
      res.push_back({e.x, e.y});
    }
    (*tags)[board_tag_index[i]]["residuals_px"] = res;
  }
  return b;
}

// --annotate's picture of one image: what was found and what was refused.
std::vector<uchar> AnnotationPng(const DetectRequest& request, const Frame& f, const vision::TagSurvey& survey) {
  cv::Mat bgr;
  cv::cvtColor(f.grey, bgr, cv::COLOR_GRAY2BGR);
  for (const auto& q : survey.rejected) {
    DrawQuad(&bgr, q.corners_px, cv::Scalar(0, 0, 255), 1);
    if (q.decoded_id >= 0) {
      // A tag refused for its border: say so beside it.
      const double bottom = std::max({q.corners_px[0].y, q.corners_px[1].y, q.corners_px[2].y, q.corners_px[3].y});
      const double left = std::min({q.corners_px[0].x, q.corners_px[1].x, q.corners_px[2].x, q.corners_px[3].x});
      cv::putText(bgr, "id " + std::to_string(q.decoded_id) + ": wrong border width",
                  cv::Point(cvRound(left), cvRound(bottom) + 14), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 255),
                  1, cv::LINE_AA);
    }
  }
  for (const auto& t : survey.tags) {
    const bool counted = !request.board || request.board->AprilgridCorner(t.id, 0).has_value();
    DrawQuad(&bgr, t.corners_px, counted ? cv::Scalar(0, 200, 0) : cv::Scalar(0, 200, 255), 1);
    cv::circle(bgr, cv::Point(cvRound(t.corners_px[0].x * 16), cvRound(t.corners_px[0].y * 16)), 3 * 16,
               cv::Scalar(255, 128, 0), 1, cv::LINE_AA, 4);
    const cv::Point2d c = 0.25 * (t.corners_px[0] + t.corners_px[1] + t.corners_px[2] + t.corners_px[3]);
    cv::putText(bgr, std::to_string(t.id), cv::Point(cvRound(c.x) - 6, cvRound(c.y) + 4), cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 255, 0), 1, cv::LINE_AA);
  }
  std::ostringstream legend;
  legend << survey.tags.size() << " " << request.family << " found (green, blue dot = corner 0), "
         << survey.rejected.size() << " quads refused (red)";
  cv::putText(bgr, legend.str(), cv::Point(6, 16), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 255, 255), 1,
              cv::LINE_AA);
  Result<std::vector<uchar>> png = media::EncodePng(bgr);
  if (!png) Fail(kDetect, kExitFailure, f.file + ": the annotation: " + png.message + " (nothing written)");
  return std::move(*png);
}

// The annotation's file: the image's name, a video's frame number after it.
std::string AnnotationPath(const std::string& dir, const Frame& f) {
  std::string name = fs::path(f.file).stem().string();
  if (f.frame >= 0) {
    std::ostringstream n;
    n << name << "_" << std::setw(6) << std::setfill('0') << f.frame;
    name = n.str();
  }
  return (fs::path(dir) / (name + ".png")).string();
}

// Everything detect found, in the inputs' order.
struct DetectOutput {
  json images = json::array();
  std::vector<std::pair<std::string, std::vector<uchar>>> annotations;
  int frames = 0, tags = 0, rejected = 0, board_views = 0;
};

// One image's entry of detect.json (and its annotation).
void AddImage(const DetectArgs& args, const DetectRequest& request, const Frame& f, Found found, DetectOutput* out) {
  ++out->frames;
  vision::TagSurvey& survey = found.survey;
  if (!survey.ok()) Fail(kDetect, kExitFailure, f.file + ": " + survey.message);
  json board_refused = json::array();
  if (request.board) board_refused = MergeBoardTags(*request.board, found.board, &survey);
  json image = {{"file", f.file}, {"width", f.grey.cols}, {"height", f.grey.rows}};
  if (f.frame >= 0) image["frame"] = f.frame;
  if (!f.read_as.empty()) image["read_as"] = f.read_as;
  json tags = json::array();
  for (const vision::SurveyedTag& t : survey.tags) tags.push_back(TagJson(request, t));
  if (request.board) {
    image["board"] = BoardJson(request, survey, std::move(board_refused), &tags);
    out->board_views += image["board"]["usable"].get<bool>() ? 1 : 0;
  }
  json rejected = json::array();
  for (const auto& q : survey.rejected)
    rejected.push_back({{"corners_px", Corners(q.corners_px)},
                        {"reason", q.reason},
                        {"decoded_id", q.decoded_id},
                        {"contrast", q.contrast}});
  image["tags"] = tags;
  image["rejected_quads"] = rejected;
  out->tags += static_cast<int>(survey.tags.size());
  out->rejected += static_cast<int>(survey.rejected.size());
  if (!args.annotate_dir.empty())
    out->annotations.emplace_back(AnnotationPath(args.annotate_dir, f), AnnotationPng(request, f, survey));
  out->images.push_back(image);
}

// The summary on stdout: a line per image.
void PrintSummary(const DetectArgs& args, const DetectRequest& request, const DetectOutput& out) {
  std::cout << out.frames << " image" << (out.frames == 1 ? "" : "s") << ", " << out.tags << " " << request.family
            << " tag" << (out.tags == 1 ? "" : "s") << " found, " << out.rejected << " quad"
            << (out.rejected == 1 ? "" : "s") << " refused\n";
  for (const json& image : out.images) {
    std::cout << "  " << image["file"].get<std::string>();
    if (image.contains("frame")) std::cout << " #" << image["frame"].get<int>();
    std::cout << ": ";
    std::vector<int> ids;
    for (const json& t : image["tags"]) ids.push_back(t["id"].get<int>());
    if (ids.empty()) std::cout << "no tag";
    for (size_t i = 0; i < ids.size(); ++i) std::cout << (i ? "," : "ids ") << ids[i];
    std::cout << "; " << image["rejected_quads"].size() << " refused";
    if (request.tag) {
      const int id = request.tag->id;
      const bool has = std::find(ids.begin(), ids.end(), id) != ids.end();
      std::cout << (has ? "; tag " + std::to_string(id) + " found" : "; tag " + std::to_string(id) + " NOT found");
    }
    if (request.board) std::cout << "; board: " << image["board"]["tags_used"].get<int>() << " tags";
    if (image.contains("read_as")) std::cout << " (" << image["read_as"].get<std::string>() << ")";
    std::cout << "\n";
  }
  if (!args.json_out.empty()) std::cout << "  wrote " << args.json_out << "\n";
  if (!args.annotate_dir.empty())
    std::cout << "  wrote " << out.annotations.size() << " PNGs to " << args.annotate_dir << "\n";
}

// detect.json, the annotations, the summary: written only now that every
// image has been read and searched.
void WriteOutputs(const DetectArgs& args, const DetectRequest& request, const DetectOutput& out, const json& lens) {
  json doc = {{"family", request.family}, {"images", out.images}};
  if (request.tag)
    doc["tag"] = {{"family", request.tag->family}, {"id", request.tag->id}, {"size_mm", request.tag->size_mm}};
  if (const auto& board = request.board)
    doc["board"] = {{"type", "aprilgrid"},       {"cols", board->cols},
                    {"rows", board->rows},       {"tag_mm", board->square_m * kMToMm},
                    {"spacing", board->spacing}, {"first_id", board->first_id}};
  doc["calibration"] = args.calibration.empty() ? json(nullptr) : json(args.calibration);
  doc["lens"] = lens;
  if (!args.annotate_dir.empty()) {
    if (const Status error = config::EnsureDirectory(args.annotate_dir); !error)
      Fail(kDetect, kExitFailure, "--annotate: " + error.message);
    for (const auto& [path, png] : out.annotations) {
      if (const Status error = config::WriteFileAtomically(path, std::string(png.begin(), png.end())); !error)
        Fail(kDetect, kExitFailure, error.message);
    }
  }
  if (args.json_out == "-") {
    std::cout << doc.dump(2) << std::endl;
    return;
  }
  if (!args.json_out.empty()) {
    if (const Status error = config::WriteFileAtomically(args.json_out, doc.dump(2) + "\n"); !error)
      Fail(kDetect, kExitFailure, error.message);
  }
  PrintSummary(args, request, out);
}

// The survey of every image: the family's tags. A board's tags are refined
// by DetectBoard: the survey's refinement of them (a third of an aprilgrid
// frame's time) would be thrown away.
vision::TagSurveyOptions SurveyOptions(const DetectRequest& request) {
  vision::TagSurveyOptions options;
  options.family = request.family;
  if (const auto& board = request.board)
    for (int id = board->first_id; id < board->first_id + board->cols * board->rows; ++id)
      if (board->AprilgridCorner(id, 0)) options.not_refined.insert(id);
  return options;
}

}  // namespace

void RunDetect(const DetectArgs& args) {
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);
  const DetectRequest request = ParseRequest(args);
  const std::vector<std::string> inputs = CheckInputs(args, request);
  const std::optional<vision::CalibrationBoard>& board = request.board;

  // The lens the board's edges are refined through: --calibration's, else
  // (a board, 3 or more images showing it) one calibrated from the images
  // as calibrate-camera does; it bends a tag's edges (a fisheye's most) but
  // gives no poses, which need a calibration the user stands behind.
  std::optional<vision::Intrinsics> refine_lens = request.intrinsics;
  const vision::TagSurveyOptions survey_options = SurveyOptions(request);
  // The searches (most of the time: the edge models' fits) on their own
  // workers; what they found is reported in the inputs' order.
  const auto find = [&](const cv::Mat& grey) {
    Found found;
    found.survey = SurveyTags(grey, request.camera ? &*request.camera : nullptr, survey_options);
    if (board && found.survey.ok()) {
      // The board's tags as calibrate-camera sees them (vision::DetectBoard:
      // upsampled decoding, the edge model sized for the aprilgrid, the
      // edges through the lens when a calibration is given).
      vision::BoardDetectionOptions board_options;
      if (refine_lens) board_options.lens = *refine_lens;
      found.board = vision::DetectBoard(grey, *board, board_options);
    }
    return found;
  };
  std::vector<Found> found_in_image(inputs.size());
  ParallelFor(inputs.size(), static_cast<unsigned>(args.threads), [&](size_t i) {
    if (!IsVideo(inputs[i])) found_in_image[i] = find(media::ReadGreyImage(inputs[i]).grey);
  });
  json lens = args.calibration.empty() ? json{{"source", "none"}, {"edges", "straight"}}
                                       : json{{"source", "calibration"}, {"file", args.calibration}};
  if (args.straight_edges && args.calibration.empty()) lens["why"] = "--straight-edges";
  if (board && !request.intrinsics && !args.straight_edges) {
    std::vector<bool> done;
    lens = LensFromTheImages(inputs, &found_in_image, *board, args.threads, &refine_lens, &done);
    if (refine_lens) {
      // The other images' boards through the lens too (the tags off the board
      // are the survey's, which no lens changes).
      vision::BoardDetectionOptions through;
      through.lens = *refine_lens;
      ParallelFor(inputs.size(), static_cast<unsigned>(args.threads), [&](size_t i) {
        if (IsVideo(inputs[i]) || done[i] || !found_in_image[i].survey.ok()) return;
        found_in_image[i].board = vision::DetectBoard(media::ReadGreyImage(inputs[i]).grey, *board, through);
      });
    }
  }
  DetectOutput out;
  for (size_t n = 0; n < inputs.size(); ++n) {
    const std::string& path = inputs[n];
    if (IsVideo(path)) {
      media::VideoReader reader;
      const Status opened = reader.Open(path);
      if (!opened.ok()) Fail(kDetect, kExitBadInput, path + ": " + opened.message);
      cv::Mat grey;
      for (int i = 0; reader.Read(&grey); ++i) {
        if (i == 0) CheckImageSize(args, request, path, grey);
        AddImage(args, request, Frame{path, i, grey, {}}, find(grey), &out);
      }
    } else {
      media::GreyImage image = media::ReadGreyImage(path);
      AddImage(args, request, Frame{path, -1, std::move(image.grey), std::move(image.conversion)},
               std::move(found_in_image[n]), &out);
    }
  }
  if (out.frames == 0) Fail(kDetect, kExitBadInput, "no frames in " + inputs.front());
  if (board && out.board_views == 0) {
    Fail(kDetect, kExitBadInput,
         "--board " + args.board + ": no image of " + std::to_string(out.frames) + " shows 4 or more of its " +
             request.family + " tags (ids " + std::to_string(board->first_id) + "-" +
             std::to_string(board->first_id + board->cols * board->rows - 1) + "); nothing written");
  }
  WriteOutputs(args, request, out, lens);
}

void RegisterDetectCommand(CLI::App& app) {
  auto args = std::make_shared<DetectArgs>();
  CLI::App* cmd = app.add_subcommand(
      "detect",
      "Every tag in each image: id, 4 corners (OpenCV pixels, from the printed bitmap's bottom-left corner,\n"
      "counter-clockwise), each corner's sigma; with --calibration the tag's (or board's) pose in the camera\n"
      "frame with its covariance. The tool to reach for when a tag is not found: --annotate draws the tags\n"
      "found and the quads refused.");
  cmd->add_option("inputs", args->inputs, "Images (any format OpenCV reads), videos (.mp4 .avi .mkv .mov .webm), or directories of images")
      ->required();
  cmd->add_option("--tag", args->tag,
                  "FAMILY:ID:SIZE_MM[:HEIGHT_MM]: the family to look for (tag36h11, or tag36h11b2 for a\n"
                  "Kalibr-style 2-bit border); SIZE_MM (outer black edge) gives every tag's pose");
  cmd->add_option("--board", args->board,
                  "aprilgrid:COLSxROWS:TAG_MM:SPACING[:FIRST_ID] or a Kalibr target.yaml");
  cmd->add_option("--calibration", args->calibration, "Camera file (calibrate-camera's): poses and covariances");
  cmd->add_option("--json", args->json_out, "Write everything as JSON to this file ('-': stdout)");
  cmd->add_option("--annotate", args->annotate_dir, "Write one annotated PNG per image into this directory");
  cmd->add_flag("--straight-edges", args->straight_edges,
               "With --board and no --calibration: refine the edges as straight lines instead of through a\n"
               "lens calibrated from the images (faster; right only for a lens that bends little)");
  cmd->add_option("--threads", args->threads, "Worker threads for the images (default: one per core)")
      ->check(CLI::Range(0, kMaxCount));
  cmd->callback([args]() { RunDetect(*args); });
}

}  // namespace odocal::app
