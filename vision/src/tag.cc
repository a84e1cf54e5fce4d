#include "odocal/base/units.h"
#include "odocal/vision/tag.h"

#include <cmath>
#include <ostream>

#include "apriltag_util.h"

namespace odocal::vision {

bool TagSpec::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (!IsKnownTagFamily(family)) return fail("unknown tag family '" + family + "'");
  if (id < 0) return fail("tag id must be >= 0");
  auto fam = internal::CreateFamily(family);
  if (static_cast<uint32_t>(id) >= fam->ncodes) {
    return fail("tag id " + std::to_string(id) + " not in family " + family + " (" +
                std::to_string(fam->ncodes) + " codes)");
  }
  if (!(size_mm > 0.0)) return fail("tag size_mm must be positive");
  if (!(height_mm >= 0.0) || !std::isfinite(height_mm)) return fail("tag height_mm must be >= 0");
  if (!std::isfinite(offset_x_mm) || !std::isfinite(offset_y_mm) || !std::isfinite(yaw_deg)) {
    return fail("tag offset and yaw must be finite");
  }
  return true;
}

calibration::Pose2 TagSpec::T_robot_tag() const {
  return calibration::Pose2::FromXYHeading(offset_x_mm * kMmToM, offset_y_mm * kMmToM,
                                           yaw_deg * kDegToRad);
}

std::array<Eigen::Vector2d, 4> TagCornersInTag(double size_m) {
  const double h = 0.5 * size_m;
  return {Eigen::Vector2d(-h, -h), Eigen::Vector2d(h, -h), Eigen::Vector2d(h, h),
          Eigen::Vector2d(-h, h)};
}

bool IsKnownTagFamily(const std::string& family) {
  return internal::CreateFamily(family) != nullptr;
}

int TagWidthAtBorder(const std::string& family) {
  const auto f = internal::CreateFamily(family);
  return f ? f->width_at_border : 0;
}

std::ostream& operator<<(std::ostream& os, const TagSpec& t) {
  return os << "TagSpec{" << t.family << " id=" << t.id << " size_mm=" << t.size_mm
            << " height_mm=" << t.height_mm << " offset_mm=(" << t.offset_x_mm << ", "
            << t.offset_y_mm << ") yaw_deg=" << t.yaw_deg << "}";
}

}  // namespace odocal::vision
