// IsValid of measure's options: the defaults pass; a field out of range fails, and `why` names it,
// the nested options (tracking, plane, rests, pose log, quality gate) with their own words.
// EstimatorChoiceOptions' own test is in estimator_choice_test.cc.
#include <limits>

#include <gtest/gtest.h>

#include "odocal/measure/measure.h"
#include "odocal/measure/pose_log.h"
#include "odocal/test_util/options_checks.h"

namespace odocal::measure {
namespace {

using test_util::ExpectValidAndEachEditRejected;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(PoseLogOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<PoseLogOptions>(
      {}, {{[](PoseLogOptions* o) { o->rest.window_s = 0.0; }, "window_s"},
           {[](PoseLogOptions* o) { o->rest_search_fraction = 0.0; }, "rest_search_fraction"},
           {[](PoseLogOptions* o) { o->rest_search_fraction = 1.5; }, "rest_search_fraction"},
           {[](PoseLogOptions* o) { o->default_sigma_position_m = 0.0; }, "default frame sigmas"},
           {[](PoseLogOptions* o) { o->default_sigma_heading_rad = kNaN; }, "default frame sigmas"},
           {[](PoseLogOptions* o) { o->min_unit_ratio = 0.0; }, "unit ratio bounds"},
           {[](PoseLogOptions* o) { o->max_unit_ratio = o->min_unit_ratio; }, "unit ratio bounds"},
           {[](PoseLogOptions* o) { o->jump_speed_factor = 1.0; }, "jump speed factor"},
           {[](PoseLogOptions* o) { o->jump_speed_floor_m_s = 0.0; }, "jump speed"},
           {[](PoseLogOptions* o) { o->max_clock_offset_s = -1.0; }, "max_clock_offset_s"}});
}

TEST(MeasureOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<MeasureOptions>(
      {}, {{[](MeasureOptions* o) { o->max_plane_views = 0; }, "max_plane_views"},
           {[](MeasureOptions* o) { o->min_view_separation_px = -1.0; }, "min_view_separation_px"},
           {[](MeasureOptions* o) { o->border_margin_px = kNaN; }, "border_margin_px"},
           {[](MeasureOptions* o) { o->systematic_floor.position_m = -1e-3; }, "systematic_floor"},
           {[](MeasureOptions* o) { o->systematic_floor.heading_rad = -1e-3; }, "systematic_floor"},
           {[](MeasureOptions* o) { o->systematic_scale_sigma = -1e-4; }, "systematic_scale_sigma"},
           {[](MeasureOptions* o) { o->tag_print_sigma = -1e-3; }, "tag_print_sigma"},
           {[](MeasureOptions* o) { o->floor_frames_per_video = 0; }, "floor_frames_per_video"},
           {[](MeasureOptions* o) { o->floor_max_videos = 0; }, "floor_max_videos"},
           {[](MeasureOptions* o) { o->rest_search_fraction = 0.0; }, "rest_search_fraction"},
           {[](MeasureOptions* o) { o->flag_gap_s = 0.0; }, "flag_gap_s"},
           // The nested options with their own words.
           {[](MeasureOptions* o) { o->track.queue_frames = 0; }, "queue_frames"},
           {[](MeasureOptions* o) { o->plane.min_views = 0; }, "camera-plane options"},
           {[](MeasureOptions* o) { o->rest.min_duration_s = -1.0; }, "min_duration_s"},
           {[](MeasureOptions* o) { o->pose_log.max_clock_offset_s = -1.0; }, "max_clock_offset_s"},
           {[](MeasureOptions* o) { o->quality_gate.max_blur_cells = 0.0; }, "quality gate"}});
}

}  // namespace
}  // namespace odocal::measure
