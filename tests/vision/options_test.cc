// IsValid of vision's options structs that no other test checks: the defaults (for a board
// pattern, a chessboard's) pass; a field out of range fails, and `why` names it where the
// implementation does (a few say only which group of options is out of range).
// Tested elsewhere: TagSpec (kalibr_tag_test), Intrinsics (camera_model_test, fisheye_test),
// FloorReference (floor_reference_test), CalibrationBoard and BoardDetectionOptions
// (camera_calibration_test).
#include <cmath>
#include <limits>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "odocal/test_util/options_checks.h"
#include "odocal/vision/board_render.h"
#include "odocal/vision/board_shape.h"
#include "odocal/vision/camera_calibration.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/edge_quality.h"
#include "odocal/vision/edge_shift.h"
#include "odocal/vision/image_formation.h"
#include "odocal/vision/planar_pose.h"
#include "odocal/vision/renderer.h"
#include "odocal/vision/tag_observer.h"
#include "odocal/vision/tag_survey.h"

namespace odocal::vision {
namespace {

using test_util::ExpectValidAndEachEditRejected;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(DetectorOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<DetectorOptions>(
      {}, {{[](DetectorOptions* o) { o->family = "tag99h1"; }, "unknown tag family 'tag99h1'"},
           {[](DetectorOptions* o) { o->quad_decimate = 0.5f; }, "quad_decimate"},
           {[](DetectorOptions* o) { o->quad_sigma = -1.0f; }, "quad_sigma"},
           {[](DetectorOptions* o) { o->decode_sharpening = -0.25; }, "decode_sharpening"},
           {[](DetectorOptions* o) { o->nthreads = 0; }, "nthreads"},
           {[](DetectorOptions* o) { o->max_hamming = 4; }, "max_hamming"}});
}

TEST(BoardShapeOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<BoardShapeOptions>(
      {}, {{[](BoardShapeOptions* o) { o->min_sightings = 3; }, "min_sightings"},
           {[](BoardShapeOptions* o) { o->flat_mm = -0.1; }, "flat_mm"},
           {[](BoardShapeOptions* o) { o->flat_mm = kNaN; }, "flat_mm"}});
}

TEST(TrackerOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<TrackerOptions>(
      {}, {{[](TrackerOptions* o) { o->roi_margin_sides = -0.5; }, "ROI margins"},
           {[](TrackerOptions* o) { o->roi_min_margin_px = -1; }, "ROI margins"},
           {[](TrackerOptions* o) { o->small_tag_px = kNaN; }, "small_tag_px"},
           {[](TrackerOptions* o) { o->full_resolution_every = -1; }, "full_resolution_every"}});
}

TEST(CornerRefineOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<CornerRefineOptions>(
      {}, {{[](CornerRefineOptions* o) { o->sample_step_px = 0.0; }, "sample_step_px"},
           {[](CornerRefineOptions* o) { o->end_margin = 0.5; }, "end_margin"},
           {[](CornerRefineOptions* o) { o->max_half_width_px = 0.5; }, "max_half_width_px"},
           {[](CornerRefineOptions* o) { o->min_cell_px = 0.0; }, "min_cell_px"},
           {[](CornerRefineOptions* o) { o->width_at_border = 2; }, "width_at_border"},
           {[](CornerRefineOptions* o) { o->model_free_settled_px = -1.0; }, "model_free_settled_px"},
           {[](CornerRefineOptions* o) { o->edge_model_solver.max_iterations = 0; }, "edge_model_solver"},
           {[](CornerRefineOptions* o) { o->model_free_solver.num_threads = 0; }, "model_free_solver"}});
}

TEST(VideoTrackOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<VideoTrackOptions>(
      {}, {{[](VideoTrackOptions* o) { o->reacquire_every = 0; }, "reacquire_every"},
           {[](VideoTrackOptions* o) { o->duplicate_check_every = -1; }, "duplicate_check_every"},
           {[](VideoTrackOptions* o) { o->queue_frames = 0; }, "queue_frames"},
           // The nested options with their own words.
           {[](VideoTrackOptions* o) { o->detector.nthreads = 0; }, "nthreads"},
           {[](VideoTrackOptions* o) { o->tracker.small_tag_px = -1.0; }, "small_tag_px"},
           {[](VideoTrackOptions* o) { o->refine.width_at_border = 0; }, "corner refinement"}});
}

TEST(QualityGate, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<QualityGate>(
      {}, {{[](QualityGate* g) { g->min_contrast_grey = -1.0; }, "quality gate: min_contrast_grey"},
           {[](QualityGate* g) { g->max_blur_cells = 0.0; }, "max_blur_cells"},
           {[](QualityGate* g) { g->max_saturated_fraction = 1.5; }, "max_saturated_fraction"},
           {[](QualityGate* g) { g->max_relative_residual = kNaN; }, "max_relative_residual"}});
}

TEST(EdgeShiftOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<EdgeShiftOptions>(
      {}, {{[](EdgeShiftOptions* o) { o->margin_cells = 2.5; }, "edge shift options: margin_cells"},
           {[](EdgeShiftOptions* o) { o->corner_cells = -1.0; }, "corner_cells"},
           {[](EdgeShiftOptions* o) { o->min_cell_px = 0.0; }, "min_cell_px"},
           {[](EdgeShiftOptions* o) { o->max_blur_cells = kNaN; }, "max_blur_cells"},
           {[](EdgeShiftOptions* o) { o->max_pixels = 99.0; }, "max_pixels"},
           {[](EdgeShiftOptions* o) { o->solver.max_iterations = 0; }, "max_iterations"}});
}

TEST(CameraPlaneOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<CameraPlaneOptions>(
      {}, {{[](CameraPlaneOptions* o) { o->solver.max_iterations = 0; }, "camera-plane options: solver"},
           {[](CameraPlaneOptions* o) { o->huber_px = -1.0; }, "huber_px"},
           {[](CameraPlaneOptions* o) { o->min_views = 0; }, "min_views"},
           {[](CameraPlaneOptions* o) { o->rolling_shutter_probe_s = 0.0; }, "rolling_shutter_probe_s"},
           {[](CameraPlaneOptions* o) { o->rolling_shutter_min_shear_px = kNaN; }, "rolling_shutter_min_shear_px"}});
}

TEST(TagSurveyOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<TagSurveyOptions>(
      {}, {{[](TagSurveyOptions* o) { o->family = "qr"; }, "unknown tag family 'qr'"},
           {[](TagSurveyOptions* o) { o->quad_decimate = 0.0f; }, "quad_decimate"},
           {[](TagSurveyOptions* o) { o->max_hamming = -1; }, "max_hamming"},
           {[](TagSurveyOptions* o) { o->min_rejected_contrast = -1.0; }, "min_rejected_contrast"}});
}

TEST(CameraCalibrationOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<CameraCalibrationOptions>(
      {}, {{[](CameraCalibrationOptions* o) { o->min_views = 2; }, "min_views must be >= 3"},
           {[](CameraCalibrationOptions* o) { o->threads = -1; }, "threads"},
           {[](CameraCalibrationOptions* o) { o->board_lift_m[3] = 1e-3; }, "board_lift_m needs initial"},
           {[](CameraCalibrationOptions* o) {
              o->board_lift_m[3] = NAN;
              o->initial = Intrinsics{640, 480, 600.0, 600.0, 320.0, 240.0};
            },
            "tag 3's lift"}});
}

TEST(ImageFormationOptions, EachPartsOptionsNameTheirField) {
  ExpectValidAndEachEditRejected<PsfOptions>(
      {}, {{[](PsfOptions* o) { o->sigma_px = -0.1; }, "psf.sigma_px"},
           {[](PsfOptions* o) { o->sigma_px = 21.0; }, "psf.sigma_px"},
           // A disk needs its radius (none by default).
           {[](PsfOptions* o) { o->model = PsfOptions::Model::kDisk; }, "psf.radius_px"},
           {[](PsfOptions* o) {
              o->model = PsfOptions::Model::kDiskGaussian;
              o->radius_px = 1.0;
              o->sigma_px = kNaN;
            },
            "psf.sigma_px"}});
  ExpectValidAndEachEditRejected<SensorNoiseOptions>(
      {}, {{[](SensorNoiseOptions* o) { o->read_e = -1.0; }, "noise.read_e"},
           {[](SensorNoiseOptions* o) { o->full_well_e = 99.0; }, "noise.full_well_e"}});
  ExpectValidAndEachEditRejected<CodecOptions>(
      {}, {{[](CodecOptions* o) { o->crf = 52; }, "crf"}, {[](CodecOptions* o) { o->quality = 0; }, "quality"}});
}

TEST(ImageFormationOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<ImageFormationOptions>(
      {}, {{[](ImageFormationOptions* o) { o->rolling_shutter_s = 1.5; }, "rolling_shutter_ms"},
           {[](ImageFormationOptions* o) { o->gamma = 0.1; }, "gamma"},
           {[](ImageFormationOptions* o) { o->vignetting = 1.0; }, "vignetting"},
           {[](ImageFormationOptions* o) { o->light_gradient = -1.0; }, "light_gradient"},
           {[](ImageFormationOptions* o) { o->gain = 0.0; }, "gain"},
           {[](ImageFormationOptions* o) { o->sharpen = 6.0; }, "sharpen must"},
           {[](ImageFormationOptions* o) { o->sharpen_sigma_px = 0.0; }, "sharpen_sigma_px"},
           // The parts, when present, with their own words.
           {[](ImageFormationOptions* o) { o->psf = PsfOptions{.sigma_px = -1.0}; }, "psf.sigma_px"},
           {[](ImageFormationOptions* o) { o->noise = SensorNoiseOptions{.read_e = -1.0}; }, "noise.read_e"},
           {[](ImageFormationOptions* o) { o->codec.quality = 101; }, "quality"}});
}

TEST(RenderOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<RenderOptions>(
      {}, {{[](RenderOptions* o) { o->noise_sigma = -1.0; }, "noise_sigma"},
           {[](RenderOptions* o) { o->blur_sigma_px = 20.5; }, "blur_sigma_px"},
           {[](RenderOptions* o) { o->exposure_s = kNaN; }, "exposure_s"},
           {[](RenderOptions* o) { o->max_motion_substeps = 0; }, "max_motion_substeps"},
           {[](RenderOptions* o) { o->motion_step_px = 0.0; }, "motion_step_px"},
           {[](RenderOptions* o) { o->body_radius_mm = -1.0; }, "body_radius_mm"},
           {[](RenderOptions* o) { o->plate_margin_mm = -1.0; }, "plate_margin_mm"},
           {[](RenderOptions* o) { o->edge_supersample = 65; }, "edge_supersample"},
           {[](RenderOptions* o) { o->optical_oversample = 0; }, "optical_oversample"},
           {[](RenderOptions* o) { o->tag_bow_mm = 51.0; }, "bow_mm"},
           {[](RenderOptions* o) { o->formation.gamma = 9.0; }, "gamma"}});
}

TEST(BoardRenderOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<BoardRenderOptions>(
      {}, {{[](BoardRenderOptions* o) { o->noise_sigma = -1.0; }, "noise_sigma"},
           {[](BoardRenderOptions* o) { o->blur_sigma_px = kNaN; }, "blur_sigma_px"},
           {[](BoardRenderOptions* o) { o->supersample = 0; }, "supersample"}});
}

TEST(BoardPattern, AChessboardIsValidAndEachBadFieldIsNamed) {
  std::string why;
  EXPECT_FALSE(BoardPattern{}.IsValid(&why)) << "no cells";
  ExpectValidAndEachEditRejected<BoardPattern>(
      BoardPattern::Chessboard(7, 5, 0.025),
      {{[](BoardPattern* p) { p->cells = cv::Mat(); }, "cells"},
       {[](BoardPattern* p) { p->cells = cv::Mat(6, 8, CV_32FC1, cv::Scalar(0)); }, "CV_8UC1"},
       {[](BoardPattern* p) { p->cell_m = 0.0; }, "cell size"},
       {[](BoardPattern* p) { p->margin_m = -0.01; }, "margin"}});
}

}  // namespace
}  // namespace odocal::vision
