// Real photographs are the referee (docs/vision.md, "Real photographs"):
// odocal's aprilgrid corners beside two peers' on the same frames, judged by
// the target's own layout, with each method's camera calibrated by itself
// from the other frames.
//
//   real_photographs_bench DATA_DIR [--target FILE] [--images DIR] [--peer DIR]
//                          [--model plumb_bob|fisheye] [--refits N] [--seed S] [--variants 0]
//                          [--frames N] [--board-shape fit]
//
// --board-shape fit: every method's camera calibrated with the board's shape
// measured from its own corners on the same frames (calibrate-camera
// --board-shape fit, vision/board_shape.h), and scored on that lifted board.
//
// --frames (default 60; 0: all): a video's thousands of frames are cut to N
// evenly spaced in name order (every measure calibrates once per frame).
//
// The lens model: --model, else a camera file's cam0 dist_model in DATA_DIR
// (yac's radtan / equi4; Kalibr's camchain distortion_model), else chosen
// as calibrate-camera's --model auto chooses (vision::CompareLensModels on
// odocal's first-pass corners); a fisheye is scored through its lens (the
// corners undistorted to the normalised plane for solvePnP, projected back
// through the lens).
//
// DATA_DIR is laid out as Kalibr/yac/EuRoC data sets are: frames in
// --images DIR, else cam0/data, mav0/cam0/data, cam0 or DATA_DIR itself
// (8-bit or deeper, read as calibrate-camera reads them: media::ReadGreyImage),
// a target file (Kalibr target.yaml or a yac camera file with calib_target:,
// the first *.yaml in DATA_DIR that reads as an aprilgrid unless --target), and optionally yac's
// detections, <frame>.csv (ts, rows, cols, size, spacing, kp_x, kp_y, ...,
// tag_id, corner_index): in --peer DIR, else grid0/cam0/data/, else anywhere
// under DATA_DIR.
//
// Methods:
//   odocal          what calibrate-camera uses: DetectBoard (the exact edge
//                   model, the edge shift measured inside the tags
//                   (edge_shift.h), each edge line fitted on through the
//                   corner squares' edges that continue it), then again
//                   through the lens calibrated from those first-pass
//                   corners (a printed straight edge is a curve in the
//                   image); the first pass alone beside it; and (unless
//                   --variants 0) variants: the tags' own edges only, those
//                   with the shift left in, the whole-tag fit
//   yac             the data set's own detections (X-corners, cornerSubPix)
//   aruco           OpenCV's aruco, DICT_APRILTAG_36h11, markerBorderBits 2,
//                   CORNER_REFINE_SUBPIX
// Measures:
//   calibration     each method's corners through calibrate-camera's
//                   CalibrateCamera: RMS, per-view RMS, and the intrinsics'
//                   spread over refits that leave a fifth of the frames out
//   (a) board       per frame, every corner under one rigid board pose
//                   (solvePnP), intrinsics from the other frames: RMS px
//   (b) tag pose    per frame, each tag's pose from its own 4 corners
//                   (IPPE) against the pose the frame's other tags give it:
//                   the error across the line of sight (mm) and about the
//                   tag's normal (deg), RMS over the frame's tags
//   board shape     (b) across the line of sight explained by one lift per
//                   tag off the board's plane (the same for every method's
//                   corners on a board that is not flat), and (b) with each
//                   frame's board shape from the other frames
// (a) and (b) on the tags every method found in that frame (all 4 corners),
// on the frames where each method sees at least 5 tags.
#include <algorithm>
#include <cctype>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/aruco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <yaml-cpp/yaml.h>

#include "odocal/base/format.h"
#include "odocal/config/calib_target.h"
#include "odocal/media/image_file.h"
#include "odocal/vision/board_shape.h"
#include "odocal/vision/camera_calibration.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/edge_shift.h"

namespace fs = std::filesystem;
using namespace odocal;

namespace {

using Key = std::pair<int, int>;                // (tag id, corner k in tag.h's order)
using Corners = std::map<Key, cv::Point2d>;     // one frame, one method

struct Method {
  std::string name;
  std::vector<Corners> frames;  // per frame
};

// yac's corners of one frame (config::ReadYacAprilgridCsv); exits on a bad file.
Corners ReadYac(const fs::path& csv) {
  const auto read = config::ReadYacAprilgridCsv(csv.string());
  if (!read) {
    std::fprintf(stderr, "%s\n", read.message.c_str());
    std::exit(2);
  }
  Corners out;
  for (const config::YacAprilgridCorner& c : *read) out[{c.tag_id, c.corner}] = cv::Point2d(c.x_px, c.y_px);
  return out;
}

Corners Aruco(const cv::Mat& grey, const vision::CalibrationBoard& board) {
  const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_APRILTAG_36h11);
  auto params = cv::aruco::DetectorParameters::create();
  params->markerBorderBits = 2;
  params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_SUBPIX;
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
  cv::aruco::detectMarkers(grey, dict, corners, ids, params);
  Corners out;
  for (size_t i = 0; i < ids.size(); ++i) {
    if (!board.AprilgridCorner(ids[i], 0)) continue;
    // aruco's own order (its marker's top-left first, clockwise); main()
    // maps it to tag.h's.
    for (int k = 0; k < 4; ++k) out[{ids[i], k}] = corners[i][k];
  }
  return out;
}

// The tags with all four corners in every method's frame f.
std::set<int> CommonTags(const std::vector<Method>& methods, size_t f) {
  std::map<int, int> count;
  for (const Method& m : methods) {
    std::map<int, int> corners;
    for (const auto& [key, p] : m.frames[f]) ++corners[key.first];
    for (const auto& [id, n] : corners)
      if (n == 4) ++count[id];
  }
  std::set<int> out;
  for (const auto& [id, n] : count)
    if (n == static_cast<int>(methods.size())) out.insert(id);
  return out;
}

int TagsIn(const Corners& c) {
  std::set<int> ids;
  for (const auto& [key, p] : c) ids.insert(key.first);
  return static_cast<int>(ids.size());
}

// Each tag's lift off the board's plane [m], by id (vision/board_shape.h);
// empty: the board as printed, flat.
using Lifts = std::map<int, double>;

vision::BoardDetection AsDetection(const Corners& c, const vision::CalibrationBoard& board,
                                   const std::set<int>* only = nullptr, const Lifts* lifts = nullptr) {
  vision::BoardDetection d;
  for (const auto& [key, p] : c) {
    if (only && !only->count(key.first)) continue;
    d.object_points.push_back(*board.AprilgridCorner(key.first, key.second));
    if (lifts && lifts->count(key.first)) d.object_points.back().z = static_cast<float>(lifts->at(key.first));
    d.image_points.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  }
  d.found = d.image_points.size() >= 16;
  return d;
}

// The tags whose 4 corners a method found, with their ids (what
// MeasureBoardShape and a lifted calibration need).
vision::BoardDetection AsTagDetection(const Corners& c, const vision::CalibrationBoard& board) {
  vision::BoardDetection d;
  for (const auto& [key, p] : c) {
    if (key.second != 0) continue;
    bool whole = true;
    for (int k = 1; k < 4; ++k) whole = whole && c.count({key.first, k});
    if (!whole) continue;
    d.tag_ids.push_back(key.first);
    for (int k = 0; k < 4; ++k) {
      d.object_points.push_back(*board.AprilgridCorner(key.first, k));
      const cv::Point2d q = c.at({key.first, k});
      d.image_points.emplace_back(static_cast<float>(q.x), static_cast<float>(q.y));
    }
  }
  d.found = d.tag_ids.size() >= 4;
  return d;
}

// A method's camera from the frames `use` marks, and, with `shape` (the
// bench's --board-shape fit), the board's shape measured from the same
// frames and the camera calibrated again with each tag at its lift.
struct Calibrated {
  vision::CameraCalibrationResult result;
  Lifts lifts;
  bool ok() const { return result.ok(); }
};

Calibrated Calibrate(const Method& m, const vision::CalibrationBoard& board, cv::Size size,
                     const std::vector<bool>& use, vision::LensModel lens, bool shape = false) {
  std::vector<vision::BoardDetection> views;
  for (size_t f = 0; f < m.frames.size(); ++f) {
    if (!use[f]) continue;
    vision::BoardDetection d = shape ? AsTagDetection(m.frames[f], board) : AsDetection(m.frames[f], board);
    if (d.found) views.push_back(std::move(d));
  }
  vision::CameraCalibrationOptions options;
  options.lens = lens;
  Calibrated out{vision::CalibrateCamera(views, size, options), {}};
  if (!shape || !out.ok() || board.type != vision::CalibrationBoard::Type::kAprilgrid) return out;
  const vision::BoardShape measured = vision::MeasureBoardShape(views, board, out.result.intrinsics);
  if (!measured.ok()) return out;
  for (const vision::TagLift& t : measured.tags) options.board_lift_m[t.id] = 1e-3 * t.lift_mm;
  options.initial = out.result.intrinsics;
  vision::CameraCalibrationResult lifted = vision::CalibrateCamera(views, size, options);
  if (!lifted.ok()) return out;
  return {std::move(lifted), options.board_lift_m};
}

// solvePnP through any lens: the points undistorted to the normalised plane
// (K = I, no distortion), so that plumb_bob and a fisheye are scored alike.
bool SolvePnPThroughLens(const std::vector<cv::Point3f>& object, const std::vector<cv::Point2f>& image,
                         const vision::CameraModel& camera, cv::Mat& rvec, cv::Mat& tvec, int flags = cv::SOLVEPNP_ITERATIVE) {
  const vision::Intrinsics& in = camera.intrinsics();
  if (in.lens == vision::LensModel::kPlumbBob)  // OpenCV's own, as the figures in docs/vision.md were made
    return cv::solvePnP(object, image, in.CameraMatrix(), in.DistortionCoeffs(), rvec, tvec, false, flags);
  std::vector<cv::Point2d> px(image.begin(), image.end());
  const std::vector<cv::Point2d> n = camera.UndistortToNormalized(px);
  std::vector<cv::Point2f> nf;
  for (const cv::Point2d& p : n) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return false;
    nf.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  }
  return cv::solvePnP(object, nf, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec, false, flags);
}

std::vector<cv::Point2f> ProjectThroughLens(const std::vector<cv::Point3f>& object, const cv::Mat& rvec,
                                            const cv::Mat& tvec, const vision::CameraModel& camera) {
  const vision::Intrinsics& in = camera.intrinsics();
  if (in.lens == vision::LensModel::kPlumbBob) {
    std::vector<cv::Point2f> out;
    cv::projectPoints(object, rvec, tvec, in.CameraMatrix(), in.DistortionCoeffs(), out);
    return out;
  }
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  const cv::Vec3d t(tvec);
  std::vector<cv::Point2f> out;
  for (const cv::Point3f& p : object) {
    const cv::Vec3d c = R * cv::Vec3d(p.x, p.y, p.z) + t;
    const auto px = camera.ProjectCamera(Eigen::Vector3d(c[0], c[1], c[2]));
    out.emplace_back(px ? static_cast<float>(px->x()) : NAN, px ? static_cast<float>(px->y()) : NAN);
  }
  return out;
}

struct FrameScore {
  double board_rms_px = NAN;
  double across_mm = NAN;    // RMS over the frame's tags
  double heading_deg = NAN;  // RMS over the frame's tags
  int flipped = 0;           // tags whose own pose took IPPE's other solution
  std::array<double, 4> parts_px{NAN, NAN, NAN, NAN};  // (a) as moved, grown, turned, bent
  // (b) per tag: the error across the line of sight, and what a tag lifted
  // 1 m off the board along its normal would make of it (the normal's part
  // across the line of sight), both in the camera frame [m].
  struct TagAcross {
    cv::Vec3d across, normal;
  };
  std::map<int, TagAcross> tags;
};

// `lifts`: the board's shape the camera was calibrated with (empty: flat).
FrameScore Score(const Corners& c, const std::set<int>& tags, const vision::CalibrationBoard& board,
                 const vision::Intrinsics& in, const Lifts* lifts = nullptr) {
  FrameScore s;
  const vision::CameraModel camera(in, vision::CameraMount{});
  // (a) one rigid pose for every corner.
  const vision::BoardDetection all = AsDetection(c, board, &tags, lifts);
  cv::Mat rvec, tvec;
  if (!SolvePnPThroughLens(all.object_points, all.image_points, camera, rvec, tvec)) return s;
  const std::vector<cv::Point2f> projected = ProjectThroughLens(all.object_points, rvec, tvec, camera);
  double sq = 0.0;
  for (size_t i = 0; i < projected.size(); ++i) {
    const cv::Point2f e = projected[i] - all.image_points[i];
    sq += e.dot(e);
  }
  s.board_rms_px = std::sqrt(sq / projected.size());
  // Where the board residual is, tag by tag (4 consecutive points each: the
  // map's order): the tag moved (mean), grown (radial), turned (tangential)
  // or bent (the rest); RMS per corner coordinate of each part.
  {
    double t2 = 0.0, r2 = 0.0, a2 = 0.0, rest2 = 0.0;
    int tags_n = 0;
    for (size_t i = 0; i + 3 < projected.size(); i += 4) {
      cv::Point2d mean(0, 0), centre(0, 0);
      std::array<cv::Point2d, 4> r, u;
      for (int k = 0; k < 4; ++k) {
        r[k] = cv::Point2d(all.image_points[i + k] - projected[i + k]);
        centre += 0.25 * cv::Point2d(projected[i + k]);
        mean += 0.25 * r[k];
      }
      double radial = 0.0, turn = 0.0;
      for (int k = 0; k < 4; ++k) {
        u[k] = cv::Point2d(projected[i + k]) - centre;
        u[k] *= 1.0 / cv::norm(u[k]);
        radial += 0.25 * (r[k] - mean).dot(u[k]);
        turn += 0.25 * (r[k] - mean).cross(u[k]);
      }
      for (int k = 0; k < 4; ++k) {
        const cv::Point2d left = r[k] - mean - radial * u[k] - turn * cv::Point2d(u[k].y, -u[k].x);
        rest2 += left.dot(left) / 4.0;
      }
      t2 += mean.dot(mean);
      r2 += radial * radial;
      a2 += turn * turn;
      ++tags_n;
    }
    if (tags_n) {
      s.parts_px = {std::sqrt(t2 / tags_n / 2), std::sqrt(r2 / tags_n / 2), std::sqrt(a2 / tags_n / 2),
                    std::sqrt(rest2 / tags_n / 2)};
    }
  }
  // (b) each tag alone against the others.
  const double side = board.square_m;
  const std::vector<cv::Point3f> square = {{static_cast<float>(-side / 2), static_cast<float>(side / 2), 0},
                                           {static_cast<float>(side / 2), static_cast<float>(side / 2), 0},
                                           {static_cast<float>(side / 2), static_cast<float>(-side / 2), 0},
                                           {static_cast<float>(-side / 2), static_cast<float>(-side / 2), 0}};
  double across2 = 0.0, heading2 = 0.0;
  int n = 0;
  for (int id : tags) {
    std::set<int> others = tags;
    others.erase(id);
    if (others.size() < 4) continue;
    const vision::BoardDetection rest = AsDetection(c, board, &others, lifts);
    cv::Mat rb, tb;
    if (!SolvePnPThroughLens(rest.object_points, rest.image_points, camera, rb, tb)) continue;
    // IPPE_SQUARE's object order: (-s/2, s/2), (s/2, s/2), (s/2, -s/2), (-s/2, -s/2),
    // i.e. top-left, top-right, bottom-right, bottom-left in a y-up square:
    // tag.h's corners 3, 2, 1, 0.
    std::vector<cv::Point2f> own;
    for (int k : {3, 2, 1, 0}) own.emplace_back(static_cast<float>(c.at({id, k}).x), static_cast<float>(c.at({id, k}).y));
    cv::Mat rt, tt;
    if (!SolvePnPThroughLens(square, own, camera, rt, tt, cv::SOLVEPNP_IPPE_SQUARE)) continue;
    // The tag's centre and axes on the board, through the others' pose.
    const cv::Point3f c0 = *board.AprilgridCorner(id, 0), c2 = *board.AprilgridCorner(id, 2);
    const cv::Vec3d centre_board(0.5 * (c0.x + c2.x), 0.5 * (c0.y + c2.y),
                                 lifts && lifts->count(id) ? lifts->at(id) : 0.0);
    cv::Matx33d Rb, Rt;
    cv::Rodrigues(rb, Rb);
    cv::Rodrigues(rt, Rt);
    const cv::Vec3d centre_others = Rb * centre_board + cv::Vec3d(tb);
    const cv::Vec3d centre_own(tt);
    const cv::Vec3d d = centre_own - centre_others;
    const cv::Vec3d v = centre_others * (1.0 / cv::norm(centre_others));
    const cv::Vec3d across = d - v * d.dot(v);
    // The tag's frame has the board's axes (x along the columns, y up the bitmaps).
    const cv::Matx33d R = Rb.t() * Rt;
    // A small tag's own pose can take the other of IPPE's two solutions (its
    // normal tilted the wrong way): counted, not averaged.
    if (R(2, 2) < std::cos(20.0 * M_PI / 180.0)) {
      ++s.flipped;
      continue;
    }
    const double heading = std::atan2(R(1, 0), R(0, 0));
    const cv::Vec3d normal(Rb(0, 2), Rb(1, 2), Rb(2, 2));
    s.tags[id] = {across, normal - v * normal.dot(v)};
    across2 += across.dot(across);
    heading2 += heading * heading;
    ++n;
  }
  if (n) {
    s.across_mm = 1e3 * std::sqrt(across2 / n);
    s.heading_deg = 180.0 / M_PI * std::sqrt(heading2 / n);
  }
  return s;
}

// The lens a yac or Kalibr camera file names (cam0's dist_model /
// distortion_model: radtan, equi4, equidistant, fisheye); nullopt when none.
std::optional<vision::LensModel> LensOfTargetFile(const fs::path& file) {
  try {
    const YAML::Node cam0 = YAML::LoadFile(file.string())["cam0"];
    for (const char* key : {"dist_model", "distortion_model"}) {
      if (!cam0 || !cam0[key]) continue;
      const std::string v = cam0[key].as<std::string>();
      if (v.rfind("equi", 0) == 0 || v == "fisheye") return vision::LensModel::kEquidistant;
      if (v.rfind("radtan", 0) == 0 || v == "plumb_bob") return vision::LensModel::kPlumbBob;
    }
  } catch (const YAML::Exception&) {
    // Not YAML, or no such key: the target file's reader says what is wrong.
  }
  return std::nullopt;
}

double Median(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double StdDev(const std::vector<double>& v) {
  if (v.size() < 2) return NAN;
  double m = 0.0;
  for (double x : v) m += x / v.size();
  double s = 0.0;
  for (double x : v) s += (x - m) * (x - m);
  return std::sqrt(s / (v.size() - 1));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s DATA_DIR [--target FILE] [--images DIR] [--peer DIR] [--model plumb_bob|fisheye] [--refits N] [--seed S] "
                 "[--variants 0] [--frames N] [--board-shape fit]\n", argv[0]);
    return 2;
  }
  const fs::path dir = argv[1];
  fs::path target, peer_dir, image_dir;
  int refits = 10;
  int max_frames = 60;  // --frames; 0: every frame
  unsigned seed = 1;
  bool with_variants = true;  // --variants 0: odocal and the peers only (a quick probe)
  // --board-shape fit: every method's camera calibrated with the board's
  // shape measured from its own corners (calibrate-camera --board-shape
  // fit), and its frames scored on that lifted board.
  bool board_shape_fit = false;
  std::optional<vision::LensModel> model;  // --model; else a camera file's cam0 dist_model, else chosen
  vision::BoardDetectionOptions detect;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--target") target = argv[i + 1];
    else if (a == "--peer") peer_dir = argv[i + 1];
    else if (a == "--images") image_dir = argv[i + 1];
    else if (a == "--refits") refits = std::stoi(argv[i + 1]);
    else if (a == "--frames") max_frames = std::stoi(argv[i + 1]);
    else if (a == "--seed") seed = static_cast<unsigned>(std::stoul(argv[i + 1]));
    else if (a == "--variants") with_variants = std::string(argv[i + 1]) != "0";
    else if (a == "--board-shape") board_shape_fit = std::string(argv[i + 1]) == "fit";
    else if (a == "--model") {
      model = vision::ParseLensModel(argv[i + 1]);
      if (!model) {
        std::fprintf(stderr, "--model %s: plumb_bob or fisheye (equidistant)\n", argv[i + 1]);
        return 2;
      }
    }
    else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return 2;
    }
  }
  // The target: --target, else the first *.yaml in DATA_DIR (by name) that
  // reads as one (a data set may hold a camchain or an IMU file beside it).
  std::vector<fs::path> yamls;
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".yaml" || e.path().extension() == ".yml") yamls.push_back(e.path());
  std::sort(yamls.begin(), yamls.end());
  std::optional<vision::CalibrationBoard> board_read;
  std::string target_error = "no *.yaml target file in " + dir.string() + " (--target FILE)";
  for (const fs::path& candidate : target.empty() ? yamls : std::vector<fs::path>{target}) {
    const auto board_or = config::ReadCalibrationTarget(candidate.string());
    if (board_or) {
      board_read = *board_or;
      target = candidate;
      break;
    }
    target_error = board_or.message;
  }
  if (!board_read) {
    std::fprintf(stderr, "%s\n", target_error.c_str());
    return 2;
  }
  const vision::CalibrationBoard board = *board_read;
  std::string lens_from = model ? "--model" : "";
  for (const fs::path& f : yamls) {
    if (model) break;
    model = LensOfTargetFile(f);
    if (model) lens_from = f.filename().string() + "'s cam0 model";
  }
  // The frames: --images, else cam0/data (Kalibr/yac), mav0/cam0/data (EuRoC), cam0, or DATA_DIR itself.
  std::vector<fs::path> images;
  std::vector<fs::path> folders = {dir / "cam0" / "data", dir / "mav0" / "cam0" / "data", dir / "cam0", dir};
  if (!image_dir.empty()) folders = {image_dir};
  for (const fs::path& folder : folders) {
    if (!fs::is_directory(folder)) continue;
    for (const auto& e : fs::directory_iterator(folder)) {
      std::string ext = e.path().extension().string();
      for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
      if (ext == ".jpg" || ext == ".jpeg" || ext == ".png" || ext == ".bmp" || ext == ".pgm" || ext == ".tif" ||
          ext == ".tiff")
        images.push_back(e.path());
    }
    if (!images.empty()) break;
  }
  std::sort(images.begin(), images.end());
  if (images.empty()) {
    std::fprintf(stderr, "%s: no images in cam0/data, mav0/cam0/data or the directory itself\n", dir.c_str());
    return 2;
  }
  // A video's thousands of frames: every measure below calibrates once per
  // frame (the other frames' intrinsics) and OpenCV's adjustment is dense in
  // the views, so at most --frames of them, evenly spaced in name order.
  const size_t all_frames = images.size();
  if (max_frames > 0 && images.size() > static_cast<size_t>(max_frames)) {
    std::vector<fs::path> spaced;
    for (int i = 0; i < max_frames; ++i) spaced.push_back(images[i * all_frames / static_cast<size_t>(max_frames)]);
    images = std::move(spaced);
  }

  Method odocal{"odocal", {}}, yac{"yac (data set)", {}}, aruco{"OpenCV aruco", {}};
  // yac's detections: grid0/cam0/data/<frame>.csv (the D435i set), else
  // --peer DIR, else any <frame>.csv elsewhere under DATA_DIR (yac's own test
  // data keeps them beside the frames' folder, cam0/<frame>.csv).
  std::map<std::string, fs::path> peer_csv;
  {
    const fs::path preferred = !peer_dir.empty() ? peer_dir : dir / "grid0" / "cam0" / "data";
    std::set<std::string> stems;
    for (const fs::path& p : images) stems.insert(p.stem().string());
    if (fs::is_directory(preferred)) {
      for (const auto& e : fs::directory_iterator(preferred))
        if (e.path().extension() == ".csv" && stems.count(e.path().stem().string()))
          peer_csv[e.path().stem().string()] = e.path();
    } else {
      for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.path().extension() == ".csv" && stems.count(e.path().stem().string()))
          peer_csv[e.path().stem().string()] = e.path();
    }
  }
  const bool have_yac = !peer_csv.empty();
  // odocal's variants: what each part of DetectBoard's aprilgrid refinement
  // is worth.
  struct Variant {
    Method method;
    vision::BoardDetectionOptions options;
  };
  std::vector<Variant> variants;
  if (with_variants) {
    vision::BoardDetectionOptions own = detect, left_in = detect, whole = detect;
    own.aprilgrid_collinear_edges = false;
    left_in.aprilgrid_collinear_edges = false;
    left_in.aprilgrid_edge_shift = false;
    whole.aprilgrid_whole_tag_fit = true;
    variants = {{{"odocal, the tags' own edges", {}}, own},
                {{"odocal, own edges, edge shift left in", {}}, left_in},
                {{"odocal, whole-tag fit", {}}, whole}};
  }
  const auto corners_of = [](const vision::BoardDetection& d) {
    Corners c;
    if (d.found)
      for (size_t t = 0; t < d.tag_ids.size(); ++t)
        for (int k = 0; k < 4; ++k) c[{d.tag_ids[t], k}] = d.image_points[4 * t + k];
    return c;
  };
  cv::Size size;
  std::vector<double> shifts;
  std::vector<cv::Mat> greys;  // every frame, read once (30-100 small frames)
  for (const fs::path& p : images) {
    const cv::Mat grey = media::ReadGreyImage(p.string()).grey;
    if (grey.empty()) {
      std::fprintf(stderr, "%s: cannot be read as an image\n", p.c_str());
      return 2;
    }
    greys.push_back(grey);
    size = grey.size();
    const vision::BoardDetection d = vision::DetectBoard(grey, board, detect);
    if (d.found) shifts.push_back(d.edge_shift_px);
    odocal.frames.push_back(corners_of(d));
    for (Variant& v : variants) v.method.frames.push_back(corners_of(vision::DetectBoard(grey, board, v.options)));
    if (have_yac) {
      const auto it = peer_csv.find(p.stem().string());
      yac.frames.push_back(it == peer_csv.end() ? Corners{} : ReadYac(it->second));
    }
    aruco.frames.push_back(Aruco(grey, board));
  }
  // The lens model, when neither --model nor a camera file names it: both
  // fitted to odocal's first-pass corners, as calibrate-camera --model auto.
  if (!model) {
    const std::vector<bool> all(images.size(), true);
    const auto p = Calibrate(odocal, board, size, all, vision::LensModel::kPlumbBob).result;
    const auto f = Calibrate(odocal, board, size, all, vision::LensModel::kEquidistant).result;
    std::vector<vision::BoardDetection> views;
    for (const Corners& c : odocal.frames)
      if (vision::BoardDetection d = AsDetection(c, board); d.found) views.push_back(std::move(d));
    const vision::LensModelChoice choice = vision::CompareLensModels(views, p, f);
    model = choice.chosen;
    lens_from = Format("chosen as calibrate-camera --model auto: first-pass RMS plumb_bob %.4f, fisheye %.4f px",
                       choice.plumb_bob_rms_px, choice.fisheye_rms_px);
  }
  const vision::LensModel lens_model = *model;
  // odocal again, its tags' edges refined through the lens it calibrated
  // from its own first-pass corners (a straight printed edge is a curve in
  // the image): what `calibrate-camera` does on its second pass, and so
  // odocal's corners. The first pass stays beside it.
  Method first_pass = odocal;
  first_pass.name = "odocal, first pass (edges straight)";
  {
    vision::BoardDetectionOptions through = detect;
    const auto first = Calibrate(odocal, board, size, std::vector<bool>(images.size(), true), lens_model).result;
    if (first.ok()) {
      through.lens = first.intrinsics;
      for (size_t i = 0; i < images.size(); ++i) {
        const vision::BoardDetection d = vision::DetectBoard(greys[i], board, through);
        if (d.found) odocal.frames[i] = corners_of(d);  // else the first pass's, as calibrate-camera keeps it
      }
    } else {
      std::fprintf(stderr, "odocal's first-pass calibration failed (%s): odocal's corners are the first pass's\n",
                   first.message.c_str());
    }
  }
  variants.insert(variants.begin(), Variant{first_pass, detect});
  std::vector<Method> methods = {odocal};
  for (const Variant& v : variants) methods.push_back(v.method);
  const size_t first_peer = methods.size();
  if (have_yac) methods.push_back(yac);
  methods.push_back(aruco);
  const size_t F = images.size();

  std::printf("# Real photographs: %s (%zu frames, %dx%d), %dx%d %s, tag %.1f mm, spacing %.2f\n\n", dir.c_str(), F,
              size.width, size.height, board.cols, board.rows, board.tag_family.c_str(), board.square_m * 1e3,
              board.spacing);
  std::printf("target: %s; lens: %s (%s)\n\n", target.c_str(), vision::LensModelName(lens_model), lens_from.c_str());
  if (images.size() < all_frames)
    std::printf("frames: %zu of the %zu, evenly spaced in name order (--frames; 0 for every frame)\n\n", images.size(),
                all_frames);
  std::sort(shifts.begin(), shifts.end());
  if (!shifts.empty())
    std::printf("odocal's edge shift per view: median %+.3f px, range %+.3f .. %+.3f px (negative: the black looks "
                "thinner than printed)\n\n",
                shifts[shifts.size() / 2], shifts.front(), shifts.back());

  // aruco's corner order against tag.h's, from the data rather than assumed:
  // the rotation of aruco's four corners that lies nearest odocal's.
  {
    auto map = [](int k, int r, int sign) { return ((r + sign * k) % 4 + 4) % 4; };
    double best = 1e18;
    int best_r = 0, best_sign = 1;
    for (int sign : {1, -1})
      for (int r = 0; r < 4; ++r) {
        double sum = 0.0;
        for (size_t f = 0; f < F; ++f)
          for (const auto& [key, p] : aruco.frames[f])
            if (auto it = odocal.frames[f].find({key.first, map(key.second, r, sign)}); it != odocal.frames[f].end())
              sum += cv::norm(p - it->second);
        if (sum < best) best = sum, best_r = r, best_sign = sign;
      }
    for (Corners& c : aruco.frames) {
      Corners turned;
      for (const auto& [key, p] : c) turned[{key.first, map(key.second, best_r, best_sign)}] = p;
      c = turned;
    }
    methods.back() = aruco;
    std::printf("aruco's corner k is tag.h's corner %d %c k (mod 4)\n", best_r, best_sign > 0 ? '+' : '-');
  }
  // Convention check: the peers' corners against odocal's on the tags both found.
  for (size_t m = first_peer; m < methods.size(); ++m) {
    double sum = 0.0;
    int n = 0;
    for (size_t f = 0; f < F; ++f)
      for (const auto& [key, p] : methods[m].frames[f])
        if (auto it = odocal.frames[f].find(key); it != odocal.frames[f].end()) {
          sum += cv::norm(p - it->second);
          ++n;
        }
    std::printf("%s vs odocal: %d corners in common, mean distance %.3f px\n", methods[m].name.c_str(), n,
                n ? sum / n : NAN);
  }

  // Calibration from each method's corners, all frames, and refits.
  std::printf("\n## Calibration from each method's corners (CalibrateCamera, %s)\n\n", vision::LensModelName(lens_model));
  std::printf("| corners | tags found | views | RMS [px] | per-view RMS median / max [px] | fx, fy, cx, cy [px] | "
              "spread over %d refits without a fifth of the frames: fx, fy, cx, cy [px] |\n|---|---|---|---|---|---|---|\n",
              refits);
  std::vector<vision::CameraCalibrationResult> full(methods.size());
  for (size_t m = 0; m < methods.size(); ++m) {
    int tags = 0;
    for (const Corners& c : methods[m].frames) tags += TagsIn(c);
    full[m] = Calibrate(methods[m], board, size, std::vector<bool>(F, true), lens_model, board_shape_fit).result;
    const auto& r = full[m];
    if (!r.ok()) {
      std::printf("| %s | %d | — | %s |\n", methods[m].name.c_str(), tags, r.message.c_str());
      continue;
    }
    std::mt19937 rng(seed);
    std::vector<double> fx, fy, cx, cy;
    for (int k = 0; k < refits; ++k) {
      std::vector<size_t> order(F);
      for (size_t i = 0; i < F; ++i) order[i] = i;
      std::shuffle(order.begin(), order.end(), rng);
      std::vector<bool> use(F, true);
      for (size_t i = 0; i < F / 5; ++i) use[order[i]] = false;
      const auto s = Calibrate(methods[m], board, size, use, lens_model, board_shape_fit).result;
      if (!s.ok()) continue;
      fx.push_back(s.intrinsics.fx);
      fy.push_back(s.intrinsics.fy);
      cx.push_back(s.intrinsics.cx);
      cy.push_back(s.intrinsics.cy);
    }
    std::vector<double> per_view = r.per_view_rms_px;
    std::printf("| %s | %d | %d | %.4f | %.3f / %.3f | %.2f, %.2f, %.2f, %.2f | %.2f, %.2f, %.2f, %.2f |\n",
                methods[m].name.c_str(), tags, r.views, r.rms_reprojection_error_px, Median(per_view),
                *std::max_element(per_view.begin(), per_view.end()), r.intrinsics.fx, r.intrinsics.fy,
                r.intrinsics.cx, r.intrinsics.cy, StdDev(fx), StdDev(fy), StdDev(cx), StdDev(cy));
  }

  // A peer whose corners calibrate no camera (OpenCV aruco finds 1 of the
  // ~1000 tags of 14 px on the D435i frames resampled through a fisheye) is
  // left out of the per-frame comparison, which needs every method's tags.
  for (size_t m = methods.size(); m-- > 1;) {
    if (full[m].ok()) continue;
    std::printf("\n%s is left out of the per-frame comparison: its corners calibrate no camera.\n",
                methods[m].name.c_str());
    methods.erase(methods.begin() + static_cast<long>(m));
    full.erase(full.begin() + static_cast<long>(m));
  }

  // (a) and (b) per frame, intrinsics from the other frames.
  std::vector<std::vector<FrameScore>> scores(methods.size());
  // Per peer m: (odocal's corners with m's intrinsics, m's corners with odocal's).
  std::vector<std::pair<std::vector<FrameScore>, std::vector<FrameScore>>> cross;
  std::vector<size_t> used_frames;
  for (size_t f = 0; f < F; ++f) {
    bool all = true;
    for (const Method& m : methods) all = all && TagsIn(m.frames[f]) >= 5;
    const std::set<int> tags = CommonTags(methods, f);
    if (!all || tags.size() < 5) continue;
    used_frames.push_back(f);
    std::vector<bool> use(F, true);
    use[f] = false;
    std::vector<Calibrated> cals;
    for (size_t m = 0; m < methods.size(); ++m) {
      cals.push_back(Calibrate(methods[m], board, size, use, lens_model, board_shape_fit));
      scores[m].push_back(cals[m].ok() ? Score(methods[m].frames[f], tags, board, cals[m].result.intrinsics,
                                               &cals[m].lifts)
                                       : FrameScore{});
    }
    // Each peer's corners under odocal's camera and odocal's under each
    // peer's: is a difference the corners' or the calibration's?
    cross.resize(methods.size());
    for (size_t m = 1; m < methods.size(); ++m) {
      cross[m].first.push_back(cals[m].ok() ? Score(methods[0].frames[f], tags, board, cals[m].result.intrinsics,
                                                    &cals[m].lifts)
                                            : FrameScore{});
      cross[m].second.push_back(cals[0].ok() ? Score(methods[m].frames[f], tags, board, cals[0].result.intrinsics,
                                                     &cals[0].lifts)
                                             : FrameScore{});
    }
  }
  std::printf("\n## Per frame, intrinsics from the other frames (%zu frames where every method sees >= 5 tags; "
              "the tags all of them found)\n\n",
              used_frames.size());
  std::printf("| corners | (a) board RMS, median / mean over frames [px] | (b) across the line of sight, median / "
              "mean [mm] | (b) about the normal, median / mean [deg] | tags whose own pose flipped (IPPE's other solution) |\n|---|---|---|---|---|\n");
  for (size_t m = 0; m < methods.size(); ++m) {
    std::vector<double> a, b, h;
    for (const FrameScore& s : scores[m]) {
      a.push_back(s.board_rms_px);
      b.push_back(s.across_mm);
      h.push_back(s.heading_deg);
    }
    auto mean = [](const std::vector<double>& v) {
      double s = 0.0;
      int n = 0;
      for (double x : v)
        if (std::isfinite(x)) s += x, ++n;
      return n ? s / n : NAN;
    };
    int flipped = 0;
    for (const FrameScore& s : scores[m]) flipped += s.flipped;
    std::printf("| %s | %.4f / %.4f | %.3f / %.3f | %.4f / %.4f | %d |\n", methods[m].name.c_str(), Median(a),
                mean(a), Median(b), mean(b), Median(h), mean(h), flipped);
  }
  std::printf("\nThe corners or the camera? (a) board RMS, median over frames [px], with the intrinsics swapped:\n\n"
              "| peer | odocal's corners, peer's intrinsics | peer's corners, odocal's intrinsics |\n|---|---|---|\n");
  for (size_t m = 1; m < methods.size(); ++m) {
    std::vector<double> a, b;
    for (const FrameScore& s : cross[m].first) a.push_back(s.board_rms_px);
    for (const FrameScore& s : cross[m].second) b.push_back(s.board_rms_px);
    std::printf("| %s | %.4f | %.4f |\n", methods[m].name.c_str(), Median(a), Median(b));
  }
  std::printf("\n(a) by part, median over frames: RMS per corner coordinate [px] of the residual each tag's four "
              "corners share as a move, a growth (along the diagonals), a turn, and what is left\n\n"
              "| corners | moved | grown | turned | rest |\n|---|---|---|---|---|\n");
  for (size_t m = 0; m < methods.size(); ++m) {
    std::array<std::vector<double>, 4> parts;
    for (const FrameScore& s : scores[m])
      for (int k = 0; k < 4; ++k) parts[k].push_back(s.parts_px[k]);
    std::printf("| %s | %.3f | %.3f | %.3f | %.3f |\n", methods[m].name.c_str(), Median(parts[0]), Median(parts[1]),
                Median(parts[2]), Median(parts[3]));
  }
  // (b) and the board's shape. A tag that sits off the board's plane by h
  // along its normal moves, seen from the others' pose, by h times the
  // normal's part across the line of sight: the same for every method's
  // corners. Fitted per tag from the frames (least squares of the across
  // errors on that direction): on all of them (how much of (b) the shape
  // explains), and leaving the scored frame out (its board measured from
  // the other frames, as its intrinsics are). First order: the others'
  // pose is not refitted to the lifted layout.
  auto lifts = [&](size_t m, std::optional<size_t> leave_out) {
    std::map<int, std::pair<double, double>> sums;  // id -> (sum a.n, sum n.n)
    for (size_t i = 0; i < scores[m].size(); ++i) {
      if (leave_out && i == *leave_out) continue;
      for (const auto& [id, t] : scores[m][i].tags) {
        sums[id].first += t.across.dot(t.normal);
        sums[id].second += t.normal.dot(t.normal);
      }
    }
    std::map<int, double> h;
    for (const auto& [id, s2] : sums)
      if (s2.second > 0.0) h[id] = s2.first / s2.second;
    return h;
  };
  std::vector<std::vector<double>> shaped(methods.size());  // per method and frame: (b) across, board shape from the other frames [mm]
  std::printf("\n(b) and the board's shape: each tag's lift off the board's plane, fitted to the across errors "
              "(one number per tag)\n\n| corners | (b) across the line of sight explained by the tags' lifts, "
              "fitted to every frame | (b) across, each frame's board shape from the other frames: median / mean "
              "[mm] |\n|---|---|---|\n");
  for (size_t m = 0; m < methods.size(); ++m) {
    const std::map<int, double> all = lifts(m, std::nullopt);
    double total = 0.0, left = 0.0;
    for (const FrameScore& fs : scores[m])
      for (const auto& [id, t] : fs.tags) {
        total += t.across.dot(t.across);
        const cv::Vec3d r = t.across - all.at(id) * t.normal;
        left += r.dot(r);
      }
    for (size_t i = 0; i < scores[m].size(); ++i) {
      const std::map<int, double> h = lifts(m, i);
      double sq = 0.0;
      for (const auto& [id, t] : scores[m][i].tags) {
        const auto it = h.find(id);
        const cv::Vec3d r = t.across - (it == h.end() ? 0.0 : it->second) * t.normal;
        sq += r.dot(r);
      }
      shaped[m].push_back(scores[m][i].tags.empty() ? NAN : 1e3 * std::sqrt(sq / scores[m][i].tags.size()));
    }
    double sum = 0.0;
    int n = 0;
    for (double x : shaped[m])
      if (std::isfinite(x)) sum += x, ++n;
    std::printf("| %s | %.0f %% | %.3f / %.3f |\n", methods[m].name.c_str(), total > 0.0 ? 100.0 * (1.0 - left / total) : NAN,
                Median(shaped[m]), n ? sum / n : NAN);
  }
  if (board.type == vision::CalibrationBoard::Type::kAprilgrid) {
    std::printf("\nEach tag's lift [mm] fitted to every frame, by id (row 0 holds ids 0 to %d; '.': not scored):\n\n",
                board.cols - 1);
    for (size_t m = 0; m < methods.size(); ++m) {
      if (m > 0 && methods[m].name.rfind("odocal", 0) == 0) continue;  // odocal's variants
      const std::map<int, double> all = lifts(m, std::nullopt);
      std::printf("%s:\n", methods[m].name.c_str());
      for (int r = 0; r < board.rows; ++r) {
        std::printf("   ");
        for (int c = 0; c < board.cols; ++c) {
          const auto it = all.find(board.first_id + r * board.cols + c);
          if (it == all.end()) std::printf("      .");
          else std::printf(" %+6.2f", 1e3 * it->second);
        }
        std::printf("\n");
      }
    }
  }
  // odocal against each peer and variant, frame by frame.
  for (size_t ref : {size_t{0}}) {
    std::printf("\nFrames where %s is below the peer (of %zu):\n\n| peer | (a) board | (b) across | (b) heading | "
                "(b) across, the board's shape from the other frames |\n|---|---|---|---|---|\n",
                methods[ref].name.c_str(), used_frames.size());
    for (size_t m = 0; m < methods.size(); ++m) {
      if (m == ref) continue;
      int a = 0, b = 0, h = 0, bs = 0;
      for (size_t i = 0; i < used_frames.size(); ++i) {
        a += scores[ref][i].board_rms_px < scores[m][i].board_rms_px;
        b += scores[ref][i].across_mm < scores[m][i].across_mm;
        h += scores[ref][i].heading_deg < scores[m][i].heading_deg;
        bs += shaped[ref][i] < shaped[m][i];
      }
      std::printf("| %s | %d | %d | %d | %d |\n", methods[m].name.c_str(), a, b, h, bs);
    }
  }
  return 0;
}
