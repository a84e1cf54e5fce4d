#include "apriltag_util.h"

#include <apriltag/tag16h5.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagCircle21h7.h>
#include <apriltag/tagStandard41h12.h>

namespace odocal::vision::internal {

FamilyPtr CreateFamily(const std::string& name) {
  struct Entry {
    const char* name;
    apriltag_family_t* (*create)();
    void (*destroy)(apriltag_family_t*);
  };
  static const Entry kFamilies[] = {
      {"tag36h11", tag36h11_create, tag36h11_destroy},
      {"tag25h9", tag25h9_create, tag25h9_destroy},
      {"tag16h5", tag16h5_create, tag16h5_destroy},
      {"tagCircle21h7", tagCircle21h7_create, tagCircle21h7_destroy},
      {"tagStandard41h12", tagStandard41h12_create, tagStandard41h12_destroy},
  };
  for (const auto& e : kFamilies) {
    if (name == e.name) return FamilyPtr(e.create(), FamilyDeleter{e.destroy});
  }
  return FamilyPtr(nullptr, FamilyDeleter{});
}

}  // namespace odocal::vision::internal
