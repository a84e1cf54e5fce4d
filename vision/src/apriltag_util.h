// Internal: owning wrappers for libapriltag's C objects.
#ifndef ODOCAL_VISION_SRC_APRILTAG_UTIL_H_
#define ODOCAL_VISION_SRC_APRILTAG_UTIL_H_

#include <memory>
#include <string>

#include <apriltag/apriltag.h>
#include <apriltag/common/image_u8.h>

namespace odocal::vision::internal {

// A family plus the matching destroy function (each family has its own).
struct FamilyDeleter {
  void (*destroy)(apriltag_family_t*) = nullptr;
  void operator()(apriltag_family_t* f) const {
    if (f && destroy) destroy(f);
  }
};
using FamilyPtr = std::unique_ptr<apriltag_family_t, FamilyDeleter>;

// nullptr when libapriltag does not know `name`.
FamilyPtr CreateFamily(const std::string& name);

struct DetectorDeleter {
  void operator()(apriltag_detector_t* d) const { apriltag_detector_destroy(d); }
};
using DetectorPtr = std::unique_ptr<apriltag_detector_t, DetectorDeleter>;

struct DetectionsDeleter {
  void operator()(zarray_t* z) const { apriltag_detections_destroy(z); }
};
using DetectionsPtr = std::unique_ptr<zarray_t, DetectionsDeleter>;

struct ImageU8Deleter {
  void operator()(image_u8_t* im) const { image_u8_destroy(im); }
};
using ImageU8Ptr = std::unique_ptr<image_u8_t, ImageU8Deleter>;

}  // namespace odocal::vision::internal

#endif  // ODOCAL_VISION_SRC_APRILTAG_UTIL_H_
