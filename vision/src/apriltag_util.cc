#include "apriltag_util.h"

#include <cstdlib>
#include <cstring>

#include <apriltag/tag16h5.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagCircle21h7.h>
#include <apriltag/tagStandard41h12.h>

namespace odocal::vision::internal {

namespace {

// The same family with a black border `border_bits` cells wide instead of
// one: libapriltag's own layout, widened. Its decoder samples the bits at
// (bit_x + 0.5) / width_at_border across the outer black square and checks
// the border at 0.5 cell inside and outside its edge, so moving every bit one
// cell inwards and widening width_at_border (and total_width, the bitmap with
// its one-cell white quiet zone) by 2 per extra ring is all a wider border
// takes. Kalibr's aprilgrid tags are tag36h11 with a 2-bit border (the codes
// and bit positions of AprilTag 2 and 3's tag36h11 are the same bitmap).
// Only for families with the black border outside (not reversed_border).
apriltag_family_t* Widen(apriltag_family_t* f, int border_bits, const std::string& name) {
  const int extra = border_bits - 1;
  for (uint32_t i = 0; i < f->nbits; ++i) {
    f->bit_x[i] += extra;
    f->bit_y[i] += extra;
  }
  f->width_at_border += 2 * extra;
  f->total_width += 2 * extra;
  std::free(f->name);  // the family's destroy frees the name: keep it malloc'ed
  f->name = strdup(name.c_str());
  return f;
}

}  // namespace

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
  // "<family>b2": the classic families (black border outside) with a 2-bit
  // black border, e.g. tag36h11b2 = Kalibr's tags.
  static const Entry kWidenable[] = {
      {"tag36h11b2", tag36h11_create, tag36h11_destroy},
      {"tag25h9b2", tag25h9_create, tag25h9_destroy},
      {"tag16h5b2", tag16h5_create, tag16h5_destroy},
  };
  for (const auto& e : kWidenable) {
    if (name == e.name) return FamilyPtr(Widen(e.create(), 2, name), FamilyDeleter{e.destroy});
  }
  return FamilyPtr(nullptr, FamilyDeleter{});
}

}  // namespace odocal::vision::internal
