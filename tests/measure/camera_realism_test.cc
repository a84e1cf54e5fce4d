// Real cameras in the measurement: the scenario's camera image-formation keys, and rests
// whose images cannot support a number get a fatal flag and no value.
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "odocal/config/scenario.h"
#include "odocal/measure/measure.h"
#include "odocal/report/measurement_json.h"
#include "odocal/test_util/test_util.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/renderer.h"

namespace odocal {
namespace {

std::string WriteTemp(const std::string& text) {
  const std::string dir = test_util::MakeTempDir("odocal_realism_");
  const std::string path = dir + "/s.yaml";
  std::ofstream(path) << text;
  return path;
}

std::string ScenarioText(const std::string& camera_extra) {
  return R"(seed: 3
robot:
  nominal: {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0, ticks_per_rev: 2048}
  true:    {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0}
runs:
  - {procedure: straight, distance_mm: 500}
tag: {family: tag36h11, id: 5, size_mm: 80, height_mm: 150}
camera:
  width: 640
  height: 480
  fx: 700
  fy: 700
  cx: 320
  cy: 240
  pose: {height_mm: 1200}
)" + camera_extra;
}

TEST(CameraScenario, WithoutProfileKeysNothingChanges) {
  std::string error;
  const auto s = config::LoadScenario(WriteTemp(ScenarioText("")));
  ASSERT_TRUE(s && s->camera) << error;
  EXPECT_FALSE(s->camera->render.formation.HasSensorChain());
  EXPECT_FALSE(s->camera->render.formation.psf.has_value());
  // Stored near-losslessly: intra-coded CRF 18, ultrafast (bench/codec).
  EXPECT_EQ(s->camera->crf, 18);
  EXPECT_EQ(s->camera->x264_preset, "ultrafast");
  EXPECT_EQ(s->camera->keyint, 1);
  EXPECT_NEAR(s->camera->tag_print_scale, 1.0, 1e-12);
}

// `crf: N` is a camera that records H.264 itself, as `codec: {h264: N}`:
// inter-coded like such a camera, not the simulator's intra-coded store.
TEST(CameraScenario, ACrfIsACameraThatCodesH264Itself) {
  for (const std::string extra : {"  crf: 23\n", "  codec: {h264: 23}\n"}) {
    const auto s = config::LoadScenario(WriteTemp(ScenarioText(extra)));
    ASSERT_TRUE(s && s->camera) << extra;
    EXPECT_EQ(s->camera->crf, 23) << extra;
    EXPECT_EQ(s->camera->x264_preset, "veryfast") << extra;
    EXPECT_EQ(s->camera->keyint, 0) << extra;
  }
}

TEST(CameraScenario, ProfileThenOverrides) {
  std::string error;
  const auto s = config::LoadScenario(WriteTemp(ScenarioText(R"(  profile: webcam
  psf: {model: disk+gaussian, radius_px: 1.2, sigma_px: 0.5}
  rolling_shutter_ms: 25
  gamma: 2.4
  noise: {read_e: 4, full_well_e: 6000}
  codec: {mjpeg: 70}
  tag: {print_scale: 1.0042, black_level: 0.08, white_level: 0.9}
)")));
  ASSERT_TRUE(s && s->camera) << s.message;
  const vision::ImageFormationOptions& f = s->camera->render.formation;
  ASSERT_TRUE(f.psf);
  EXPECT_EQ(f.psf->model, vision::PsfOptions::Model::kDiskGaussian);
  EXPECT_NEAR(f.psf->radius_px, 1.2, 1e-12);
  EXPECT_NEAR(f.rolling_shutter_s, 0.025, 1e-12);
  EXPECT_TRUE(f.bayer);  // from the profile
  EXPECT_NEAR(f.gamma, 2.4, 1e-12);
  ASSERT_TRUE(f.noise);
  EXPECT_NEAR(f.noise->full_well_e, 6000.0, 1e-9);
  EXPECT_EQ(f.codec.kind, vision::CodecOptions::Kind::kMjpeg);
  EXPECT_EQ(f.codec.quality, 70);
  EXPECT_EQ(s->camera->crf, 0) << "MJPEG frames are stored losslessly, not coded twice";
  EXPECT_NEAR(s->camera->tag_print_scale, 1.0042, 1e-12);
  EXPECT_NEAR(s->camera->render.tag_black, 0.08 * 255.0, 1e-9);

  const auto h264 = config::LoadScenario(WriteTemp(ScenarioText("  profile: phone\n")));
  ASSERT_TRUE(h264) << h264.message;
  EXPECT_EQ(h264->camera->crf, 28);
}

TEST(CameraScenario, BadProfileKeysAreNamed) {
  for (const auto& [extra, expected] : std::vector<std::pair<std::string, std::string>>{
           {"  profile: dslr\n", "camera.profile: unknown 'dslr'"},
           {"  psf: {model: airy}\n", "camera.psf.model: unknown 'airy'"},
           {"  psf: {model: disk}\n", "psf.radius_px"},
           {"  bayer: bggr\n", "camera.bayer: expected rggb or none"},
           {"  codec: {h265: 20}\n", "camera.codec.h265: unknown key"},
           {"  profile: webcam\n  crf: 12\n", "camera.crf: give the codec once"},
           {"  tag: {print_scale: 3}\n", "camera.tag.print_scale"},
           {"  gamma: 0\n", "gamma must be in"}}) {
    std::string error;
    error = test_util::ErrorOf(config::LoadScenario(WriteTemp(ScenarioText(extra))));
    EXPECT_THAT(error, ::testing::HasSubstr(expected)) << error;
  }
}

// Rest frames as the tracker keeps them (crop = the whole small frame).
std::vector<vision::FrameObservation> RestFrames(const vision::ImageFormationOptions& formation,
                                                 const vision::CameraModel& camera,
                                                 const vision::TagSpec& tag, int n) {
  vision::RenderOptions o;
  o.formation = formation;
  auto renderer = vision::Renderer::Create(camera, tag, o).renderer;
  auto detector = vision::TagDetector::Create(vision::DetectorOptions{}).detector;
  std::vector<vision::FrameObservation> frames;
  for (int k = 0; k < n; ++k) {
    const vision::RenderedFrame f = renderer->Render(calibration::Pose2::FromXYHeading(0.03, 0.02, 0.4));
    vision::FrameObservation obs;
    obs.index = k;
    obs.t_s = k / 30.0;
    const vision::FindResult found = detector->Find(f.image, tag.id);
    if (found.status == vision::DetectStatus::kOk) obs.corners_px = found.detection->corners_px;
    obs.crop = f.image;
    frames.push_back(obs);
  }
  return frames;
}

TEST(RestQuality, GoodImagesMeasureAndReportTheirQuality) {
  const vision::CameraModel camera(vision::Intrinsics{640, 480, 700, 700, 320, 240, {0, 0, 0, 0, 0}},
                                   vision::CameraMount{0, 0, 1200, 0, 0, 0});
  vision::TagSpec tag;
  tag.id = 5;
  tag.size_mm = 80;
  tag.height_mm = 150;
  vision::ImageFormationOptions webcam = *vision::ImageFormationPreset("webcam");
  webcam.codec = {vision::CodecOptions::Kind::kMjpeg, 23, 80};
  measure::RestQuality q;
  const auto rest = measure::MeasureRestExactly(RestFrames(webcam, camera, tag, 6), -1, 1, camera, tag, &q);
  ASSERT_TRUE(rest);
  EXPECT_NEAR(rest->mean.x(), 0.03, 0.3e-3);
  EXPECT_EQ(q.frames, 6);
  EXPECT_EQ(q.usable, 6);
  EXPECT_TRUE(q.flags.empty());
  EXPECT_NEAR(q.median.side_px, 700.0 * 80.0 / 1050.0, 1.0);
  EXPECT_GT(q.median.contrast_grey, 80.0);
  // The fitted tone exponent is reported, not asserted: on a 53 px tag with
  // a sharp lens it is weakly determined (0.9-2.7 for a true 2.2, measured),
  // and an error in it moves all four edges alike (docs/vision.md).
  EXPECT_GE(q.median.gamma, 0.3);
  const nlohmann::json j = report::RestQualityJson(q);
  EXPECT_EQ(j["per_frame"].size(), 6u);
  EXPECT_TRUE(j.contains("blur_sigma_px"));
}

TEST(RestQuality, OverexposedRestHasAFatalFlagAndNoNumber) {
  const vision::CameraModel camera(vision::Intrinsics{640, 480, 700, 700, 320, 240, {0, 0, 0, 0, 0}},
                                   vision::CameraMount{0, 0, 1200, 0, 0, 0});
  vision::TagSpec tag;
  tag.id = 5;
  tag.size_mm = 80;
  tag.height_mm = 150;
  vision::ImageFormationOptions over;
  over.gain = 2.5;
  over.noise = vision::SensorNoiseOptions{3.0, 20000.0};
  measure::RestQuality q;
  const auto rest = measure::MeasureRestExactly(RestFrames(over, camera, tag, 4), -1, 1, camera, tag, &q);
  EXPECT_FALSE(rest);
  ASSERT_FALSE(q.flags.empty());
  EXPECT_EQ(q.flags.front(), vision::ObservationFlag::kOverexposed);
  EXPECT_TRUE(measure::IsFatalFlag("image_quality:end_rest:overexposed"));
}

}  // namespace
}  // namespace odocal
