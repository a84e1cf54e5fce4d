// IsValid of calibration's options and parameter structs: the defaults (or, for a value with no
// meaningful default, a typical one) pass; a field out of range fails, and `why` names it.
// UmbmarkInput's own test is in umbmark_test.cc.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "odocal/calibration/bland_altman.h"
#include "odocal/calibration/explain.h"
#include "odocal/calibration/procedures.h"
#include "odocal/calibration/replay.h"
#include "odocal/calibration/rest.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/calibration/seen_turning.h"
#include "odocal/calibration/trajectory_fit.h"
#include "odocal/calibration/umbmark.h"
#include "odocal/test_util/options_checks.h"
#include "odocal/test_util/robots.h"

namespace odocal::calibration {
namespace {

using test_util::BadEdit;
using test_util::ExpectValidAndEachEditRejected;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(BlandAltmanOptions, DefaultsAreValidAndConfidencesLieBetweenAHalfAndOne) {
  ExpectValidAndEachEditRejected<BlandAltmanOptions>(
      {}, {{[](BlandAltmanOptions* o) { o->confidence = 0.5; }, "confidence must be in (0.5, 1)"},
           {[](BlandAltmanOptions* o) { o->confidence = 1.0; }, "confidence"},
           {[](BlandAltmanOptions* o) { o->outlier_confidence = 0.4; }, "outlier_confidence"},
           {[](BlandAltmanOptions* o) { o->outlier_confidence = kNaN; }, "outlier_confidence"}});
}

TEST(ExplainOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<ExplainOptions>(
      {}, {{[](ExplainOptions* o) { o->min_explained_m = -1e-3; }, "min_explained_m"},
           {[](ExplainOptions* o) { o->min_score = kNaN; }, "min_score"},
           {[](ExplainOptions* o) { o->threads = -1; }, "threads"},
           {[](ExplainOptions* o) { o->max_effects = -1; }, "max_effects"},
           {[](ExplainOptions* o) { o->wald_alpha = 0.0; }, "wald_alpha"},
           {[](ExplainOptions* o) { o->alias_tolerance = 1.0; }, "alias_tolerance"},
           {[](ExplainOptions* o) { o->k_folds = 1; }, "k_folds"},
           {[](ExplainOptions* o) { o->max_leave_one_out_runs = 1; }, "max_leave_one_out_runs"},
           {[](ExplainOptions* o) { o->cv_min_relative_gain = 1.0; }, "cv_min_relative_gain"},
           {[](ExplainOptions* o) { o->cv_min_gain_m = -1e-6; }, "cv_min_gain_m"},
           {[](ExplainOptions* o) { o->unexplained_alpha = 1.0; }, "unexplained options"},
           {[](ExplainOptions* o) { o->unexplained_local_ratio = 0.5; }, "unexplained options"},
           {[](ExplainOptions* o) { o->unexplained_min_frames = 0; }, "unexplained options"},
           // The nested options are checked with their own words.
           {[](ExplainOptions* o) { o->fit.irls_rounds = 0; }, "irls_rounds"},
           {[](ExplainOptions* o) { o->replay.anchor_frames = 0; }, "anchor_frames"}});
}

TEST(ReplayOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<ReplayOptions>(
      {}, {{[](ReplayOptions* o) { o->anchor_frames = 0; }, "anchor_frames must be at least 1"},
           {[](ReplayOptions* o) { o->max_anchor_frames = 0; }, "max_anchor_frames"},
           {[](ReplayOptions* o) { o->default_position_sigma_m = 0.0; }, "default_position_sigma_m"},
           {[](ReplayOptions* o) { o->default_heading_sigma_rad = -1.0; }, "default_heading_sigma_rad"},
           {[](ReplayOptions* o) { o->left_direction0 = 0; }, "shaft directions"},
           {[](ReplayOptions* o) { o->right_direction0 = 2; }, "shaft directions"}});
}

TEST(RestOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<RestOptions>({},
                                              {{[](RestOptions* o) { o->window_s = 0.0; }, "window_s must be positive"},
                                               {[](RestOptions* o) { o->position_tolerance_m = -1e-3; }, "position_tolerance_m"},
                                               {[](RestOptions* o) { o->position_tolerance_m = kNaN; }, "position_tolerance_m"},
                                               {[](RestOptions* o) { o->heading_tolerance_rad = -1e-3; }, "heading_tolerance_rad"},
                                               {[](RestOptions* o) { o->heading_tolerance_rad = kNaN; }, "heading_tolerance_rad"},
                                               {[](RestOptions* o) { o->min_duration_s = -1.0; }, "min_duration_s"},
                                               {[](RestOptions* o) { o->max_gap_s = kNaN; }, "max_gap_s"}});
}

TEST(SeenTurningOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<SeenTurningOptions>(
      {}, {{[](SeenTurningOptions* o) { o->max_turn_rate_rad_s = 0.0; }, "max_turn_rate_rad_s"},
           {[](SeenTurningOptions* o) { o->max_turn_rate_rad_s = INFINITY; }, "max_turn_rate_rad_s"},
           {[](SeenTurningOptions* o) { o->heading_margin_rad = M_PI; }, "heading_margin_rad"},
           {[](SeenTurningOptions* o) { o->heading_margin_rad = -0.1; }, "heading_margin_rad"}});
}

TEST(TrajectoryFitOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<TrajectoryFitOptions>(
      {}, {{[](TrajectoryFitOptions* o) { o->default_position_sigma_m = 0.0; }, "default_position_sigma_m"},
           {[](TrajectoryFitOptions* o) { o->default_heading_sigma_rad = 0.0; }, "default_heading_sigma_rad"},
           {[](TrajectoryFitOptions* o) { o->wheel_sigma_m_per_sqrt_m = -1e-3; }, "wheel_sigma_m_per_sqrt_m"},
           {[](TrajectoryFitOptions* o) { o->huber_threshold = -1.0; }, "huber_threshold"},
           {[](TrajectoryFitOptions* o) { o->irls_rounds = 0; }, "irls_rounds"},
           {[](TrajectoryFitOptions* o) { o->solver.max_iterations = 0; }, "max_iterations"},
           {[](TrajectoryFitOptions* o) { o->rank_tolerance = 1.0; }, "rank_tolerance"},
           {[](TrajectoryFitOptions* o) { o->min_frames_per_run = 1; }, "min_frames_per_run"},
           {[](TrajectoryFitOptions* o) { o->wheel_noise_draws = -1; }, "wheel_noise_draws"},
           {[](TrajectoryFitOptions* o) { o->base_prior_sigma = -1.0; }, "base_prior_sigma"},
           {[](TrajectoryFitOptions* o) { o->max_ratio_sigma = 0.0; }, "max_ratio_sigma"},
           {[](TrajectoryFitOptions* o) {
              o->effects = {Effect::kTagOffset, Effect::kTagOffset};
            },
            "twice"}});
}

TEST(UmbmarkOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<UmbmarkOptions>(
      {}, {{[](UmbmarkOptions* o) { o->mean_scale = 0.0; }, "mean_scale"},
           {[](UmbmarkOptions* o) { o->mean_scale = INFINITY; }, "mean_scale"},
           {[](UmbmarkOptions* o) { o->default_position_sigma_m = 0.0; }, "default sigmas"},
           {[](UmbmarkOptions* o) { o->default_heading_sigma_rad = -1.0; }, "default sigmas"},
           {[](UmbmarkOptions* o) { o->min_position_sigma_m = 0.0; }, "sigma floors"},
           {[](UmbmarkOptions* o) { o->min_heading_sigma_rad = kNaN; }, "sigma floors"},
           {[](UmbmarkOptions* o) { o->solver.num_threads = 0; }, "num_threads"}});
}

// A value type, no default worth the name: the test robot's parameters, named as scenario files
// spell them.
TEST(WheelParams, TheTestRobotIsValidAndEachBadFieldIsNamedAsTheScenarioSpellsIt) {
  WheelParams none;
  std::string why;
  EXPECT_FALSE(none.IsValid(&why)) << "all zero";
  ExpectValidAndEachEditRejected<WheelParams>(
      test_util::NominalParams(),
      {{[](WheelParams* p) { p->left_wheel_diameter_m = 0.0; }, "left_wheel_diameter_mm"},
       {[](WheelParams* p) { p->right_wheel_diameter_m = -0.07; }, "right_wheel_diameter_mm"},
       {[](WheelParams* p) { p->track_m = kNaN; }, "track_mm"},
       {[](WheelParams* p) { p->ticks_per_rev = INFINITY; }, "ticks_per_rev"}});
}

// Each procedure checks its own size; the rest apply to all.
TEST(RunSpec, EachProcedureIsValidAndEachBadSizeIsNamedAsTheScenarioSpellsIt) {
  ExpectValidAndEachEditRejected<RunSpec>(RunSpec::Umbmark(Direction::kCw, 2.0),
                                          {{[](RunSpec* r) { r->side_m = 0.0; }, "side_mm"},
                                           {[](RunSpec* r) { r->reference = Reference::kWall; }, "reference"},
                                           {[](RunSpec* r) { r->speed_m_s = 0.0; }, "speed_mm_s"},
                                           {[](RunSpec* r) { r->turn_rate_rad_s = -1.0; }, "turn_rate_deg_s"}});
  ExpectValidAndEachEditRejected<RunSpec>(RunSpec::Straight(-1.0),  // backwards is a straight too
                                          {{[](RunSpec* r) { r->distance_m = 0.0; }, "distance_mm"}});
  ExpectValidAndEachEditRejected<RunSpec>(RunSpec::Spin(2, Direction::kCcw),
                                          {{[](RunSpec* r) { r->turns = 0; }, "turns"}});
  ExpectValidAndEachEditRejected<RunSpec>(
      RunSpec::OutAndBack(1.0, 2),
      {{[](RunSpec* r) { r->distance_m = -1.0; }, "distance_mm"}, {[](RunSpec* r) { r->repeats = 0; }, "repeats"}});
  ExpectValidAndEachEditRejected<RunSpec>(
      RunSpec::Circle(0.4, 1, Direction::kCw),
      {{[](RunSpec* r) { r->radius_m = 0.0; }, "radius_mm"}, {[](RunSpec* r) { r->turns = -1; }, "turns"}});
}

}  // namespace
}  // namespace odocal::calibration
