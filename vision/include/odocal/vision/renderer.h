// Renderer: the virtual overhead camera. Turns the robot's true
// pose into the 8-bit grey frame a real camera would record, with exact
// ground truth: the tag's true corner pixels and planar pose.
//
// Frames: world and robot are REP-103 (see camera_model.h, tag.h); pixels
// follow OpenCV (pixel centres at integers, pixel (u, v) covers
// [u-0.5, u+0.5] x [v-0.5, v+0.5]).
//
// Scene: a textured floor (z = 0, seeded value noise, static) with any floor
// tags (RenderOptions::floor_tags) printed on it, the robot as a
// flat grey disc whose top is the tag plane (z = tag height), a white plate
// carrying the tag bitmap from libapriltag's apriltag_to_image.
//
// Image formation, in order: geometry rendered with area-correct
// anti-aliasing (every pixel whose four corners do not fall in the same
// tag cell / region is integrated with 16 x 16 stratified samples; the
// others are uniform and need one look-up), averaged over sub-frame poses
// for motion blur, Gaussian optical blur, additive Gaussian sensor noise,
// rounding to 8 bits.
//
// Video files (H.264 writing, reading back) are in video.h.
//
// Speed: the floor is rendered and blurred once; a frame redraws only the
// window around the robot (plus the blur margin). Sensor noise outside that
// window is read at a random offset from a pre-drawn pool (fresh, seeded
// noise inside it), which is indistinguishable for detection and saves
// drawing two million normal deviates a frame.
#ifndef ODOCAL_VISION_RENDERER_H_
#define ODOCAL_VISION_RENDERER_H_

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/base/status.h"
#include "odocal/calibration/pose2.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/image_formation.h"
#include "odocal/vision/tag.h"

namespace odocal::vision {

// A tag printed on paper lying on the floor (z = 0): a length reference
// (floor_reference.h). Drawn into the static floor with the same
// area-correct anti-aliasing as the robot's tag, under the same optics and
// sensor; the robot's body hides it when it drives over it.
struct FloorTagPlacement {
  std::string family = "tag36h11";
  int id = 0;
  double size_mm = 80.0;  // as printed
  calibration::Pose2 T_world_tag;
  double paper_margin_mm = 10.0;  // white paper beyond the tag's own white border
};

struct RenderOptions {
  double noise_sigma = 2.0;     // grey levels, additive Gaussian
  double blur_sigma_px = 0.8;   // optical blur; 0 = none
  double exposure_s = 0.0;      // for RenderExposure(); 0 = no motion blur
  int max_motion_substeps = 64; // cap on sub-frame poses per exposure
  double motion_step_px = 0.25; // sub-frame poses at most this far apart in the image
  uint64_t seed = 1;            // floor texture and noise
  double body_radius_mm = 150.0;
  double plate_margin_mm = 10.0;  // white plate beyond the tag's own white border
  // Grey levels (before noise).
  double tag_black = 30.0;
  double tag_white = 220.0;
  // Paper bow: the robot tag's paper bulges toward the camera, cylindrically
  // about the tag's y axis: z = tag_bow_mm (1 - (x / half plate)^2) over the
  // plate (its middle line highest, its x ends on the plate's plane). The
  // truth corners are the lifted ones; the truth pose stays the tag's.
  double tag_bow_mm = 0.0;
  double body_grey = 70.0;
  double floor_mean = 120.0;
  double floor_contrast = 40.0;  // peak deviation of the floor texture
  int edge_supersample = 16;     // samples per axis in edge pixels
  // The changing window is formed at this multiple of the resolution (blur
  // at that scale, then area-averaged), so that the optical blur is close to
  // a continuous one: see RenderPoses.
  int optical_oversample = 2;
  // A real camera's image formation (image_formation.h): PSF model, rolling
  // shutter, Bayer, tone curve, shading, Poisson-Gaussian noise, sharpening,
  // MJPEG. Default: none of it (the renderer above, unchanged).
  ImageFormationOptions formation;
  // Tags lying on the floor (none by default).
  std::vector<FloorTagPlacement> floor_tags;

  bool IsValid(std::string* why) const;
};

struct RenderedFrame {
  cv::Mat image;  // CV_8UC1, owned by this frame
  // Truth at the middle of the exposure. With a rolling shutter each row is
  // exposed at its own time: the truth is then the pose at the frame's
  // mid-exposure time, which is the middle row's (row (H - 1) / 2).
  calibration::Pose2 T_world_robot;
  calibration::Pose2 T_world_tag;
  // The black border's outer corners, detector order (TagCornersInTag), OpenCV
  // pixel convention, with lens distortion.
  std::array<cv::Point2d, 4> corners_px{};
  // All four corners inside the image with a one-cell margin.
  bool tag_visible = false;
  int motion_substeps = 1;
};

// Status-carrying factory result, like every odocal estimator.
class Renderer;
struct RendererResult {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;
  std::unique_ptr<Renderer> renderer;
};

class Renderer {
 public:
  static RendererResult Create(const CameraModel& camera, const TagSpec& tag,
                               const RenderOptions& options);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // A frame of the robot standing still at T_world_robot.
  RenderedFrame Render(const calibration::Pose2& T_world_robot);
  // A frame exposed from t_mid_s - exposure_s/2 to t_mid_s + exposure_s/2
  // while the robot follows `trajectory` (time in seconds -> T_world_robot);
  // enough sub-frame poses are averaged that consecutive ones move at most
  // options.motion_step_px. Truth is the pose at t_mid_s. With a rolling
  // shutter, row v is exposed around t_mid_s + (v / (H - 1) - 1/2) * read-out
  // time; the moving window is rendered in bands of rows whose images move at
  // most motion_step_px from one band to the next.
  RenderedFrame RenderExposure(const std::function<calibration::Pose2(double)>& trajectory,
                               double t_mid_s);
  // Lower level: average of the given sub-frame poses, truth `T_world_robot_truth`.
  RenderedFrame RenderPoses(const std::vector<calibration::Pose2>& exposure_poses,
                            const calibration::Pose2& T_world_robot_truth);

  // True corners of the tag when the robot is at T_world_robot (detector order,
  // OpenCV convention); nullopt when behind the camera.
  std::optional<std::array<cv::Point2d, 4>> TrueCorners(
      const calibration::Pose2& T_world_robot) const;

  const CameraModel& camera() const;
  const TagSpec& tag() const;
  const RenderOptions& options() const;
  // The blurred, noise-free floor (CV_32F); for tests and debugging.
  const cv::Mat& background() const;

 private:
  // Rows from bands[i].first up to the next band's first row are exposed
  // over bands[i].second (rolling shutter); one band = a global shutter.
  RenderedFrame RenderBands(const std::vector<std::pair<int, std::vector<calibration::Pose2>>>& bands,
                            const calibration::Pose2& T_world_robot_truth);
  struct Impl;
  explicit Renderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_RENDERER_H_
