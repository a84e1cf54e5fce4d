// Shared scene set-ups for the vision tests: the standard condition
// and a small, fast camera.
#ifndef ODOCAL_TESTS_VISION_VISION_FIXTURES_H_
#define ODOCAL_TESTS_VISION_VISION_FIXTURES_H_

#include <algorithm>
#include <array>

#include <opencv2/core.hpp>

#include "odocal/vision/camera_calibration.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/renderer.h"
#include "odocal/vision/tag.h"

namespace odocal::vision::testing {

// 1920x1080, fx = fy = 1400, distortion [-0.12, 0.05, 0, 0, 0], 2000 mm high,
// pitch 3 deg (the standard scenario keys).
inline Intrinsics StandardIntrinsics() {
  return Intrinsics{1920, 1080, 1400.0, 1400.0, 960.0, 540.0, {-0.12, 0.05, 0.0, 0.0, 0.0}};
}
inline CameraMount StandardMount() { return CameraMount{0.0, -1000.0, 2000.0, 0.0, 3.0, 0.0}; }
inline CameraModel StandardCamera() { return CameraModel(StandardIntrinsics(), StandardMount()); }

inline TagSpec StandardTag() {
  TagSpec tag;
  tag.family = "tag36h11";
  tag.id = 5;
  tag.size_mm = 80.0;
  tag.height_mm = 150.0;
  return tag;
}

// Kalibr's own sample target: an aprilgrid of 6 x 6 tag36h11b2, 88 mm tags,
// gaps 0.3 of a tag (the real D435i data set's board).
inline CalibrationBoard KalibrBoard() {
  CalibrationBoard board;
  board.type = CalibrationBoard::Type::kAprilgrid;
  board.cols = board.rows = 6;
  board.square_m = 0.088;
  board.spacing = 0.3;
  return board;
}

inline RenderOptions StandardRender() {
  RenderOptions o;
  o.noise_sigma = 2.0;
  o.blur_sigma_px = 0.8;
  return o;
}

// 640x480 with the standard focal length scaled down: a quick camera.
inline CameraModel SmallCamera() {
  return CameraModel(Intrinsics{640, 480, 700.0, 700.0, 320.0, 240.0, {-0.12, 0.05, 0.0, 0.0, 0.0}},
                     CameraMount{0.0, 0.0, 1200.0, 0.0, 2.0, 0.0});
}

// TUM-VI's 512x512 190-degree fisheye (its published equidistant
// intrinsics, rounded): the wide lens of the aprilgrid tests.
inline Intrinsics TumViLikeFisheye() {
  Intrinsics lens{512, 512, 190.98, 190.97, 254.93, 256.90, {0.00348, 0.000715, -0.00205, 0.000203, 0.0}};
  lens.lens = LensModel::kEquidistant;
  return lens;
}

// The pixel box around four corners, `margin` px wider all round (a
// detector's region of interest, a crop).
inline cv::Rect AroundCorners(const std::array<cv::Point2d, 4>& c, int margin) {
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (const auto& p : c) {
    x0 = std::min(x0, p.x), y0 = std::min(y0, p.y), x1 = std::max(x1, p.x), y1 = std::max(y1, p.y);
  }
  return cv::Rect(cvFloor(x0) - margin, cvFloor(y0) - margin, cvCeil(x1 - x0) + 2 * margin,
                  cvCeil(y1 - y0) + 2 * margin);
}

}  // namespace odocal::vision::testing

#endif  // ODOCAL_TESTS_VISION_VISION_FIXTURES_H_
