// StationOptions::IsValid (rig/station/station.h): the defaults pass; a field out of range fails,
// and `why` names it, the nested options (tracking, plane, the floor tags' quality gate) with
// their own words.
#include <chrono>
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "odocal/station/station.h"
#include "odocal/test_util/options_checks.h"

namespace odocal::station {
namespace {

using namespace std::chrono_literals;
using test_util::ExpectValidAndEachEditRejected;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(StationOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<StationOptions>(
      {}, {{[](StationOptions* o) { o->max_rounds = 1; }, "max_rounds"},
           {[](StationOptions* o) { o->rest_frames = 1; }, "rest_frames"},
           {[](StationOptions* o) { o->min_rest_found_fraction = 0.0; }, "min_rest_found_fraction"},
           {[](StationOptions* o) { o->min_rest_found_fraction = 1.5; }, "min_rest_found_fraction"},
           {[](StationOptions* o) { o->rest_flush_frames = -1; }, "rest_flush_frames"},
           {[](StationOptions* o) { o->settle_s = -0.5; }, "settle_s"},
           {[](StationOptions* o) { o->settle_s = kNaN; }, "settle_s"},
           {[](StationOptions* o) { o->max_plane_views = 0; }, "max_plane_views"},
           {[](StationOptions* o) { o->edge_shift_frames = -1; }, "edge_shift_frames"},
           {[](StationOptions* o) { o->min_view_separation_px = kNaN; }, "min_view_separation_px"},
           {[](StationOptions* o) { o->motion_threshold_px = 0.0; }, "motion_threshold_px"},
           {[](StationOptions* o) { o->still_px = -0.1; }, "still_px"},
           {[](StationOptions* o) { o->still_s = 0.0; }, "still_s"},
           {[](StationOptions* o) { o->start_timeout = 0ms; }, "start_timeout"},
           {[](StationOptions* o) { o->turn_slip_sigmas = kNaN; }, "turn_slip_sigmas"},
           {[](StationOptions* o) { o->run_timeout = 0ms; }, "run_timeout"},
           {[](StationOptions* o) { o->poll_interval = -1ms; }, "poll_interval"},
           {[](StationOptions* o) { o->converge_sigmas = 0.0; }, "converge_sigmas"},
           {[](StationOptions* o) { o->floor_frames = 0; }, "floor_frames"},
           {[](StationOptions* o) { o->max_turn_rate_rad_s = INFINITY; }, "max_turn_rate_rad_s"},
           {[](StationOptions* o) { o->heading_check_rad = M_PI; }, "heading_check_rad"},
           {[](StationOptions* o) { o->camera_scale.systematic_scale_sigma = -1e-4; }, "systematic_scale_sigma"},
           {[](StationOptions* o) { o->camera_scale.tag_print_sigma = kNaN; }, "tag_print_sigma"},
           // The nested options with their own words.
           {[](StationOptions* o) { o->camera_scale.quality_gate.min_contrast_grey = -1.0; }, "quality gate"},
           {[](StationOptions* o) { o->track.reacquire_every = 0; }, "reacquire_every"},
           {[](StationOptions* o) { o->plane.huber_px = -1.0; }, "camera-plane options"}});
}

}  // namespace
}  // namespace odocal::station
