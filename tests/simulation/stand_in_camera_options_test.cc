// StandInCameraOptions::IsValid (rig/simulation/stand_in_camera.h): the defaults pass; a field out
// of range fails, and `why` names what is wrong.
#include <limits>

#include <gtest/gtest.h>

#include "odocal/simulation/stand_in_camera.h"
#include "odocal/test_util/options_checks.h"

namespace odocal::simulation {
namespace {

using test_util::ExpectValidAndEachEditRejected;

TEST(StandInCameraOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  StandInCameraOptions home;
  home.home_radius_m = 0.5;
  EXPECT_TRUE(home.IsValid(nullptr)) << "a camera over the start area";
  ExpectValidAndEachEditRejected<StandInCameraOptions>(
      {}, {{[](StandInCameraOptions* o) { o->fps = 0.0; }, "camera fps"},
           {[](StandInCameraOptions* o) { o->sigma_position_m = 0.0; }, "position sigma"},
           {[](StandInCameraOptions* o) { o->sigma_heading_rad = -1.0; }, "heading sigma"},
           {[](StandInCameraOptions* o) { o->home_radius_m = 0.0; }, "home radius"},
           {[](StandInCameraOptions* o) { o->camera.centre_m.z() = -1.0; }, "above the tag plane"},
           {[](StandInCameraOptions* o) { o->rolling_shutter_s = -0.01; }, "rolling shutter"},
           {[](StandInCameraOptions* o) { o->vertical_fov_rad = M_PI; }, "vertical field of view"},
           {[](StandInCameraOptions* o) { o->vertical_fov_rad = std::numeric_limits<double>::quiet_NaN(); },
            "vertical field of view"}});
}

}  // namespace
}  // namespace odocal::simulation
