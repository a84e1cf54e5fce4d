// odocal setup-check --camera DEVICE|VIDEO --calibration camera.yaml
//     --tag FAMILY:ID:SIZE_MM[:HEIGHT_MM] --out DIR
//
// Before a session, from a few seconds of the camera with the robot standing
// still (measure/setup_check.h): is the tag found and how large, the images'
// quality, the pose noise at rest and what a rest and a return error will be
// good to, the floor the camera sees with the planned squares drawn in it,
// and the predicted sigma of Ed and Eb. DIR/setup_check.json and an
// annotated DIR/setup_check.png; exit 0 when the setup can measure the plan,
// 1 when it cannot (tag not found, squares out of view, bad images), 2 for
// bad input.
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "cli_util.h"
#include "commands.h"
#include "odocal/base/units.h"
#include "odocal/config/camera_file.h"
#include "odocal/config/files.h"
#include "odocal/measure/setup_check.h"
#include "odocal/media/frame_source.h"
#include "odocal/media/image_file.h"
#include "odocal/media/video.h"

namespace odocal::app {
namespace {

struct SetupCheckArgs : CameraTagArgs {
  double seconds = 3.0;
  double square_mm = 1000.0;
  int runs = 3;
  double track_mm = 300.0;
  double rest_s = 1.0;
  std::string out;
};

constexpr const char* kSetupCheck = "setup-check";

// A video file: its frames with their own times (index / fps, or the
// timestamps file beside it); a device: live frames for `seconds`.
std::vector<measure::SetupFrame> Grab(const std::string& camera, double seconds) {
  std::vector<measure::SetupFrame> frames;
  if (std::filesystem::is_regular_file(camera)) {
    media::VideoReader reader;
    const Status opened = reader.Open(camera);
    if (!opened.ok()) Fail(kSetupCheck, kExitBadInput, opened.message);
    const double fps = reader.fps() > 0.0 ? reader.fps() : 30.0;
    cv::Mat grey;
    for (int k = 0; reader.Read(&grey); ++k) {
      const double t = k / fps;
      if (t > seconds) break;
      frames.push_back({grey.clone(), t});
    }
    if (frames.empty()) Fail(kSetupCheck, kExitBadInput, camera + ": no frame could be read");
    return frames;
  }
  Result<std::unique_ptr<media::CaptureSource>> opened = media::CaptureSource::Open(camera);
  if (!opened) Fail(kSetupCheck, kExitBadInput, "--camera " + camera + ": " + opened.message);
  media::CaptureSource& source = **opened;
  double t0 = -1.0;
  while (true) {
    Result<media::CameraFrame> frame = source.Grab();
    if (!frame) {
      if (frames.empty()) Fail(kSetupCheck, kExitFailure, source.Describe() + ": " + frame.message);
      break;
    }
    if (t0 < 0.0) t0 = frame->t_s;
    if (frame->t_s - t0 > seconds) break;
    frames.push_back({frame->grey, frame->t_s - t0});
  }
  return frames;
}

std::vector<cv::Point> ToImage(const vision::CameraModel& camera, const std::vector<Eigen::Vector2d>& floor,
                               double height_m) {
  std::vector<cv::Point> out;
  for (const auto& p : floor)
    if (const auto px = camera.ProjectWorld(Eigen::Vector3d(p.x(), p.y(), height_m)))
      out.emplace_back(static_cast<int>(std::lround(px->x())), static_cast<int>(std::lround(px->y())));
  return out;
}

void WritePng(const measure::SetupCheckResult& r, const measure::SetupCheckOptions& o, const std::string& path) {
  cv::Mat image;
  cv::cvtColor(r.last_frame, image, cv::COLOR_GRAY2BGR);
  const vision::CameraModel camera(o.intrinsics, r.mount);
  const double h = o.tag.height_m();
  cv::polylines(image, std::vector<std::vector<cv::Point>>{ToImage(camera, r.view_polygon, h)}, true,
                cv::Scalar(200, 200, 0), 2);
  const cv::Scalar square_colour = r.squares_fit ? cv::Scalar(0, 200, 0) : cv::Scalar(0, 0, 255);
  for (const auto& square : r.squares)
    cv::polylines(image, std::vector<std::vector<cv::Point>>{ToImage(camera, square, h)}, true, square_colour, 2);
  if (r.last_corners) {
    std::vector<cv::Point> outline;
    for (const auto& c : *r.last_corners)
      outline.emplace_back(static_cast<int>(std::lround(c.x)), static_cast<int>(std::lround(c.y)));
    cv::polylines(image, std::vector<std::vector<cv::Point>>{outline}, true, cv::Scalar(0, 140, 255), 2);
  }
  std::vector<std::string> lines;
  char buf[200];
  std::snprintf(buf, sizeof(buf), "tag %.0f px; return error sigma %.3f mm, %.4f deg", r.quality.side_px,
                r.return_sigma_position_m * kMToMm, r.return_sigma_heading_rad * kRadToDeg);
  lines.push_back(buf);
  std::snprintf(buf, sizeof(buf), "%.0f mm squares %s; Ed +-%.1e, Eb +-%.1e", o.square_side_m * kMToMm,
                r.squares_fit ? "fit" : "DO NOT FIT", r.sigma_Ed, r.sigma_Eb);
  lines.push_back(buf);
  for (const std::string& w : r.warnings) lines.push_back("! " + w.substr(0, 90));
  int y = 24;
  for (const std::string& line : lines) {
    cv::putText(image, line, cv::Point(10, y), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 3);
    cv::putText(image, line, cv::Point(10, y), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(255, 255, 255), 1);
    y += 22;
  }
  if (const Status written = media::WriteImage(path, image); !written.ok())
    Fail(kSetupCheck, kExitFailure, written.message);
}

nlohmann::json ToJson(const measure::SetupCheckResult& r, const measure::SetupCheckOptions& o,
                      const SetupCheckArgs& args) {
  auto polygon = [](const std::vector<Eigen::Vector2d>& ps) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& p : ps) a.push_back({p.x() * kMToMm, p.y() * kMToMm});
    return a;
  };
  nlohmann::json j = {
      {"camera", args.camera},
      {"frames", {{"read", r.frames}, {"tag_found", r.frames_found}, {"refined", r.frames_refined}, {"fps", r.fps}}},
      {"tag", {{"family", o.tag.family}, {"id", o.tag.id}, {"size_mm", o.tag.size_mm}, {"height_mm", o.tag.height_mm}}},
      {"ok", r.ok()},
      {"warnings", r.warnings}};
  if (!r.ok()) {
    j["message"] = r.message;
    return j;
  }
  j["quality"] = {{"side_px", r.quality.side_px},
                  {"cell_px", r.quality.cell_px},
                  {"contrast_grey", r.quality.contrast_grey},
                  {"blur_sigma_px", r.quality.blur_sigma_px},
                  {"saturated_fraction", r.quality.saturated_fraction},
                  {"grid_angle_deg", r.grid_angle_deg},
                  {"flags", vision::ToStrings(r.quality_flags)}};
  j["camera_mount"] = {{"x_mm", r.mount.x_mm},         {"y_mm", r.mount.y_mm},
                       {"height_mm", r.mount.height_mm}, {"roll_deg", r.mount.roll_deg},
                       {"pitch_deg", r.mount.pitch_deg}, {"yaw_deg", r.mount.yaw_deg},
                       {"from", r.mount_from_tag_size ? "tag_size" : "mount_guess"},
                       {"tilt_fitted", r.plane_from_tag}};
  if (r.edge_shift.ok())
    j["edge_shift"] = {{"shift_px", r.edge_shift.shift_px},
                       {"sigma_px", r.edge_shift.sigma_px},
                       {"views", r.edge_shift.views},
                       {"scale_error_removed", r.edge_shift.RelativeScaleError()}};
  j["noise"] = {{"frame_position_mm", r.frame_sigma_position_m * kMToMm},
                {"frame_heading_deg", r.frame_sigma_heading_rad * kRadToDeg},
                {"shared_position_mm", r.shared_sigma_position_m * kMToMm},
                {"shared_heading_deg", r.shared_sigma_heading_rad * kRadToDeg}};
  j["predicted"] = {{"rest_s", o.rest_s},
                    {"rest_position_mm", r.rest_sigma_position_m * kMToMm},
                    {"rest_heading_deg", r.rest_sigma_heading_rad * kRadToDeg},
                    {"return_error_position_mm", r.return_sigma_position_m * kMToMm},
                    {"return_error_heading_deg", r.return_sigma_heading_rad * kRadToDeg},
                    {"runs_per_direction", o.runs_per_direction},
                    {"square_side_mm", o.square_side_m * kMToMm},
                    {"sigma_Ed", r.sigma_Ed},
                    {"sigma_Eb", r.sigma_Eb}};
  j["floor"] = {{"view_polygon_mm", polygon(r.view_polygon)},
                {"view_width_mm", r.view_width_m * kMToMm},
                {"view_depth_mm", r.view_depth_m * kMToMm},
                {"square_cw_mm", polygon(r.squares[0])},
                {"square_ccw_mm", polygon(r.squares[1])},
                {"squares_fit", r.squares_fit},
                {"squares_min_tag_side_px", r.squares_min_tag_side_px > 0.0 ? nlohmann::json(r.squares_min_tag_side_px)
                                                                         : nlohmann::json(nullptr)},
                {"squares_min_tag_side_at_mm",
                 r.squares_min_tag_side_px > 0.0
                     ? nlohmann::json{r.squares_min_tag_side_at.x() * kMToMm, r.squares_min_tag_side_at.y() * kMToMm}
                     : nlohmann::json(nullptr)},
                {"squares_tag_too_small", r.squares_tag_too_small}};
  return j;
}

void RunSetupCheck(const SetupCheckArgs& args) {
  measure::SetupCheckOptions o;
  o.tag = ParseTagOption(kSetupCheck, "--tag", args.tag);
  if (!args.mount.empty()) o.mount_guess = ParseMountOption(kSetupCheck, "--mount-guess", args.mount);
  const auto file = config::ReadCameraFile(args.calibration);
  if (!file) Fail(kSetupCheck, kExitBadInput, file.message);
  o.intrinsics = file->intrinsics;
  if (!(args.seconds > 0.0)) Fail(kSetupCheck, kExitBadInput, "--seconds must be positive");
  if (!(args.square_mm > 0.0)) Fail(kSetupCheck, kExitBadInput, "--square-mm must be positive");
  if (args.runs < 1) Fail(kSetupCheck, kExitBadInput, "--runs must be at least 1");
  o.square_side_m = args.square_mm * kMmToM;
  o.runs_per_direction = args.runs;
  o.track_m = args.track_mm * kMmToM;
  o.rest_s = args.rest_s;
  const std::vector<measure::SetupFrame> frames = Grab(args.camera, args.seconds);
  if (const Status e = config::EnsureDirectory(args.out); !e) Fail(kSetupCheck, kExitFailure, e.message);
  const measure::SetupCheckResult r = measure::CheckSetup(frames, o);
  const nlohmann::json j = ToJson(r, o, args);
  if (const Status e = config::WriteFileAtomically(args.out + "/setup_check.json", j.dump(2) + "\n"); !e)
    Fail(kSetupCheck, kExitFailure, e.message);
  if (!r.ok()) {
    for (const std::string& w : r.warnings) std::printf("warning: %s\n", w.c_str());
    Fail(kSetupCheck, kExitFailure, r.message + " (" + args.out + "/setup_check.json)");
  }
  WritePng(r, o, args.out + "/setup_check.png");
  std::printf("tag %s id %d: found in %d of %d frames (%.1f fps), %.0f px across (cell %.1f px), contrast %.0f, "
              "blur %.2f px\n",
              o.tag.family.c_str(), o.tag.id, r.frames_found, r.frames, r.fps, r.quality.side_px,
              r.quality.cell_px, r.quality.contrast_grey, r.quality.blur_sigma_px);
  std::printf("camera: %.0f mm above the floor, roll %.2f deg, pitch %.2f deg (%s%s)\n", r.mount.height_mm,
              r.mount.roll_deg, r.mount.pitch_deg,
              r.mount_from_tag_size ? "from the tag's apparent size" : "from the mount guess",
              r.plane_from_tag ? ", tilt fitted to the still tag" : "");
  if (r.edge_shift.ok())
    std::printf("the tag's edges lie %.3f ± %.3f px %s the print (tone curve, blur, ink: %.2f %% of the scale, "
                "removed)\n",
                std::abs(r.edge_shift.shift_px), r.edge_shift.sigma_px,
                r.edge_shift.shift_px >= 0.0 ? "outside" : "inside", 100.0 * std::abs(r.edge_shift.RelativeScaleError()));
  std::printf("noise at rest: %.3f mm, %.4f deg per frame; %.3f mm, %.4f deg shared by every frame\n",
              r.frame_sigma_position_m * kMToMm, r.frame_sigma_heading_rad * kRadToDeg, r.shared_sigma_position_m * kMToMm,
              r.shared_sigma_heading_rad * kRadToDeg);
  std::printf("predicted: a %.1f s rest to %.3f mm, %.4f deg; a return error to %.3f mm, %.4f deg (1 sigma)\n",
              o.rest_s, r.rest_sigma_position_m * kMToMm, r.rest_sigma_heading_rad * kRadToDeg,
              r.return_sigma_position_m * kMToMm, r.return_sigma_heading_rad * kRadToDeg);
  std::printf("floor in view at the tag's height: %.0f x %.0f mm; the %.0f mm squares %s\n", r.view_width_m * kMToMm,
              r.view_depth_m * kMToMm, o.square_side_m * kMToMm,
              r.squares_fit ? "fit (cw and ccw from here)" : "do NOT fit from here");
  if (r.squares_min_tag_side_px > 0.0)
    std::printf("the tag at the squares' corners: %.0f px across at the smallest\n", r.squares_min_tag_side_px);
  std::printf("UMBMark with %d cw + %d ccw: Ed to +-%.2e, Eb to +-%.2e (1 sigma, from the camera alone)\n", o.runs_per_direction,
              o.runs_per_direction, r.sigma_Ed, r.sigma_Eb);
  for (const std::string& w : r.warnings) std::printf("warning: %s\n", w.c_str());
  std::printf("wrote %s/setup_check.json and setup_check.png\n", args.out.c_str());
  if (!r.squares_fit || r.squares_tag_too_small || !r.quality_flags.empty())
    Fail(kSetupCheck, kExitFailure, "this setup cannot measure the plan as it stands (warnings above)");
}

}  // namespace

void RegisterSetupCheckCommand(CLI::App& app) {
  auto args = std::make_shared<SetupCheckArgs>();
  CLI::App* cmd = app.add_subcommand(
      "setup-check",
      "Before a session: from a few seconds of the camera with the robot still, is the tag found, how large,\n"
      "how noisy at rest, does the planned square fit in view, and how well will the return errors, Ed and Eb\n"
      "be measured. Writes DIR/setup_check.json and an annotated DIR/setup_check.png");
  AddCameraTagOptions(cmd, "--camera", args.get());
  cmd->add_option("--seconds", args->seconds, "How much of the camera to look at")->default_val(3.0);
  cmd->add_option("--square-mm", args->square_mm, "The planned UMBMark squares' side")->default_val(1000.0);
  cmd->add_option("--runs", args->runs, "Squares per direction in the plan")->default_val(3);
  cmd->add_option("--track-mm", args->track_mm, "The robot's nominal track")->default_val(300.0);
  cmd->add_option("--rest-s", args->rest_s, "How long each rest of the plan is")->default_val(1.0);
  cmd->add_option("--out", args->out, "Output directory (created)")->required();
  cmd->callback([args]() { RunSetupCheck(*args); });
}

}  // namespace odocal::app
