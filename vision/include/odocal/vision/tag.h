// TagSpec: the AprilTag mounted on the robot, and its geometry.
//
// Frames:
//   robot  REP-103: x forward, y left, z up; origin on the floor.
//   tag    planar, origin at the tag centre, x along the printed bitmap's
//          columns (left to right), y up the printed bitmap (bottom to top),
//          z out of the printed face (up, towards the overhead camera). With
//          yaw_deg = 0 the tag's x is the robot's forward direction.
// The tag lies flat (face up) at height_mm above the floor; T_robot_tag is its
// planar pose in the robot frame. `size_mm` is the black border's outer edge
// (AprilTag's "tag size"), as in the scenario file.
#ifndef ODOCAL_VISION_TAG_H_
#define ODOCAL_VISION_TAG_H_

#include <array>
#include <iosfwd>
#include <string>

#include <Eigen/Core>

#include "odocal/base/units.h"
#include "odocal/calibration/pose2.h"

namespace odocal::vision {

struct TagSpec {
  std::string family = "tag36h11";
  int id = 0;
  double size_mm = 80.0;     // black border edge
  double height_mm = 150.0;  // tag face above the floor
  double offset_x_mm = 0.0;  // tag centre in the robot frame
  double offset_y_mm = 0.0;
  double yaw_deg = 0.0;      // tag x relative to robot x

  bool IsValid(std::string* why) const;
  double size_m() const { return size_mm * kMmToM; }
  double height_m() const { return height_mm * kMmToM; }
  calibration::Pose2 T_robot_tag() const;
};

// The black border's outer corners in the tag frame (metres), in the order
// the detector reports them (libapriltag's p[0..3], counter-clockwise in the
// image): (-s/2, -s/2), (s/2, -s/2), (s/2, s/2), (-s/2, s/2) — i.e. starting
// at the bottom-left of the printed bitmap. Verified against the detector on
// rendered frames (tests/vision/detector_test.cc).
std::array<Eigen::Vector2d, 4> TagCornersInTag(double size_m);

// Whether libapriltag knows the family (tag36h11, tag25h9, tag16h5,
// tagStandard41h12, ...), or it is one of those classic families with a 2-bit
// black border: tag36h11b2 (Kalibr's aprilgrid tags), tag25h9b2, tag16h5b2.
// Same codes, same ids, same decoder; only the border is one cell wider all
// round, and `size_mm` is still the outer edge of the black border.
bool IsKnownTagFamily(const std::string& family);

// Cells across the black border's outer edge: 8 for tag36h11, 10 for
// tag36h11b2 (CornerRefineOptions::width_at_border); 0 for an unknown family.
int TagWidthAtBorder(const std::string& family);

std::ostream& operator<<(std::ostream& os, const TagSpec& tag);

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_TAG_H_
