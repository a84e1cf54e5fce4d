// The floor length reference (vision/floor_reference.h): floor-tag centres
// against the exact projection of the rendered tags' centres, the camera's
// height against the rendering camera, on images formed by models the
// estimator does not invert (disk PSF, tone curve, Bayer, MJPEG, a print
// scaled by 1 %).
#include "odocal/vision/floor_reference.h"

#include <cmath>
#include <cstdio>
#include <functional>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/vision/image_formation.h"
#include "odocal/vision/renderer.h"
#include "vision_fixtures.h"

namespace odocal::vision {
namespace {

using calibration::Pose2;
using ::testing::HasSubstr;

struct PlacedTag {
  int id;
  double x_mm, y_mm, yaw_deg;
};
// Four 80 mm tags near the corners of the small camera's view of the floor
// (47 px, cells of 5.8 px: a webcam's blur needs them that large).
const std::vector<PlacedTag> kTags = {
    {1, -400.0, 250.0, 0.0}, {2, 400.0, 250.0, 20.0}, {3, 400.0, -250.0, 45.0}, {4, -400.0, -250.0, -10.0}};
constexpr double kStatedSizeMm = 80.0;

FloorReference Reference(double tape_sigma_mm = 0.3) {
  FloorReference r;
  for (const PlacedTag& t : kTags) r.tags.push_back({t.id, kStatedSizeMm});
  for (size_t i = 0; i < kTags.size(); ++i) {
    const PlacedTag& a = kTags[i];
    const PlacedTag& b = kTags[(i + 1) % kTags.size()];
    r.distances.push_back({a.id, b.id, std::hypot(b.x_mm - a.x_mm, b.y_mm - a.y_mm), tape_sigma_mm});
  }
  return r;
}

// The exact distorted pixel of a floor tag's centre.
cv::Point2d TrueCentre(const CameraModel& camera, const PlacedTag& t) {
  const auto px = camera.ProjectWorld(Eigen::Vector3d(t.x_mm * 1e-3, t.y_mm * 1e-3, 0.0));
  return {px->x(), px->y()};
}

// Every tag seen exactly where `camera` projects its centre, with this sigma.
std::vector<FloorTagSighting> ExactSightings(const CameraModel& camera, double sigma_px) {
  std::vector<FloorTagSighting> seen;
  for (const PlacedTag& t : kTags) {
    FloorTagSighting s;
    s.id = t.id;
    s.frames_seen = s.frames_used = 5;
    s.centre_px = TrueCentre(camera, t);
    s.sigma_centre_px = sigma_px;
    seen.push_back(s);
  }
  return seen;
}

std::vector<cv::Mat> RenderFrames(const CameraModel& camera, const RenderOptions& base, double print_scale,
                                  int n) {
  RenderOptions o = base;
  for (const PlacedTag& t : kTags) {
    FloorTagPlacement p;
    p.id = t.id;
    p.size_mm = kStatedSizeMm * print_scale;
    p.T_world_tag = Pose2::FromXYHeading(t.x_mm * 1e-3, t.y_mm * 1e-3, t.yaw_deg * M_PI / 180.0);
    o.floor_tags.push_back(p);
  }
  std::vector<cv::Mat> frames;
  TagSpec robot_tag = testing::StandardTag();
  robot_tag.size_mm = 60.0;
  for (int k = 0; k < n; ++k) {
    o.seed = 100 + k;  // fresh noise each frame (the floor texture changes too: harmless)
    auto created = Renderer::Create(camera, robot_tag, o);
    EXPECT_TRUE(created.ok()) << created.message;
    frames.push_back(created.renderer->Render(Pose2::FromXYHeading(0.0, 0.0, 0.3)).image);
  }
  return frames;
}

RenderOptions Webcam() {
  RenderOptions o;
  o.formation = *ImageFormationPreset("webcam");
  o.formation.rolling_shutter_s = 0.0;  // static scene
  o.formation.codec = {CodecOptions::Kind::kMjpeg, 23, 80};
  return o;
}

TEST(FloorReference, CentresAreUnbiasedWhateverTheImageModelAndPrintScale) {
  const CameraModel camera = testing::SmallCamera();
  const std::vector<std::pair<std::string, RenderOptions>> formations = {
      {"renderer (gaussian 0.8 px, noise 2)", testing::StandardRender()}, {"webcam, MJPEG 80", Webcam()}};
  for (const auto& [name, options] : formations) {
    // A print 1 % large: the centres must not care.
    const std::vector<FloorTagSighting> seen =
        ObserveFloorTags(RenderFrames(camera, options, 1.01, 4), camera.intrinsics(), Reference());
    ASSERT_EQ(seen.size(), kTags.size());
    for (size_t i = 0; i < kTags.size(); ++i) {
      SCOPED_TRACE(name + ", tag " + std::to_string(kTags[i].id));
      ASSERT_TRUE(seen[i].usable()) << ::testing::PrintToString(ToStrings(seen[i].flags));
      EXPECT_EQ(seen[i].frames_used, 4);
      const cv::Point2d truth = TrueCentre(camera, kTags[i]);
      // Within 2.5 of the stated sigma per axis (0.05 px floor: 0.09 mm on this floor).
      const double error = cv::norm(seen[i].centre_px - truth);
      EXPECT_LT(error, 2.5 * std::sqrt(2.0) * seen[i].sigma_centre_px) << seen[i].centre_px << " vs " << truth;
      std::printf("%s tag %d: centre error %.4f px, stated sigma %.4f px\n", name.c_str(), kTags[i].id, error,
                  seen[i].sigma_centre_px);
      EXPECT_GE(seen[i].sigma_centre_px, kCentreFloorPx);
      EXPECT_LT(seen[i].sigma_centre_px, 0.08);
      EXPECT_NEAR(seen[i].median_quality.side_px, 47.0 * 1.01, 4.0);
    }
  }
}

// Sightings at the exact projections: the height comes out exactly, from any
// trial height, and a tape sigma propagates 1:1 into the relative height sigma.
TEST(FloorReference, HeightFromTheTapeIsExactOnExactCentres) {
  const CameraMount truth_mount{100.0, -50.0, 1200.0, 1.5, 3.0, 10.0};
  const CameraModel truth(testing::SmallCamera().intrinsics(), truth_mount);
  const std::vector<FloorTagSighting> seen = ExactSightings(truth, 0.0);
  for (const double trial_mm : {900.0, 1200.0, 1900.0}) {
    CameraMount trial = truth_mount;
    trial.height_mm = trial_mm;
    const FloorScaleResult r = EstimateFloorScale(CameraModel(truth.intrinsics(), trial), seen, Reference(0.3), 0.0, 0.0);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_NEAR(r.camera_height_mm, 1200.0, 1e-6) << "trial " << trial_mm;
    EXPECT_EQ(r.pairs.size(), 4u);
    for (const auto& p : r.pairs) EXPECT_NEAR(p.seen_mm, p.tape_mm, 1e-6);
    // Four pairs of ~550-800 mm at 0.3 mm each: each pair's relative sigma
    // 0.3 / D; their inverse-variance mean.
    double info = 0.0;
    for (const auto& d : Reference(0.3).distances) info += std::pow(d.mm / (0.3 * 1200.0), 2);
    EXPECT_NEAR(r.sigma_camera_height_mm, 1.0 / std::sqrt(info), 1e-6);
    EXPECT_NEAR(r.variance_share_tape, 1.0, 1e-9);
    EXPECT_FALSE(r.inconsistent);
  }
  // The tilt's sigma enters: a 0.1 deg roll sigma adds to the height's.
  const FloorScaleResult tilted = EstimateFloorScale(truth, seen, Reference(0.3), 0.1, 0.1);
  const FloorScaleResult level = EstimateFloorScale(truth, seen, Reference(0.3), 0.0, 0.0);
  EXPECT_GT(tilted.sigma_camera_height_mm, level.sigma_camera_height_mm);
  EXPECT_GT(tilted.variance_share_tilt, 0.0);
}

TEST(FloorReference, RenderedFloorTagsGiveTheCameraHeight) {
  const CameraModel truth = testing::SmallCamera();
  const std::vector<FloorTagSighting> seen =
      ObserveFloorTags(RenderFrames(truth, Webcam(), 1.005, 4), truth.intrinsics(), Reference());
  CameraMount guess = truth.mount();
  guess.height_mm = 1150.0;  // what a tag printed 4 % large would have said
  const FloorScaleResult r = EstimateFloorScale(CameraModel(truth.intrinsics(), guess), seen, Reference(0.3), 0.0, 0.0);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_LT(r.sigma_camera_height_mm, 0.8);
  EXPECT_GT(r.sigma_camera_height_mm, 0.25);  // 4 pairs at 0.3 mm: ~0.27 mm, plus the centres
  EXPECT_NEAR(r.camera_height_mm, 1200.0, 3.0 * r.sigma_camera_height_mm);
  EXPECT_FALSE(r.inconsistent) << r.chi_square;
}

TEST(FloorReference, DisagreeingDistancesAreReportedNotAveraged) {
  const CameraModel truth = testing::SmallCamera();
  const std::vector<FloorTagSighting> seen = ExactSightings(truth, kCentreFloorPx);
  FloorReference misread = Reference(0.3);
  misread.distances[1].mm += 5.0;  // a tape read 5 mm long
  EXPECT_TRUE(EstimateFloorScale(truth, seen, misread, 0.0, 0.0).inconsistent);
  EXPECT_FALSE(EstimateFloorScale(truth, seen, Reference(0.3), 0.0, 0.0).inconsistent);
}

TEST(FloorReference, UnseenOrDuplicatedTagsAreNamed) {
  const CameraModel camera = testing::SmallCamera();
  FloorReference r = Reference();
  r.tags.push_back({9, kStatedSizeMm});  // not on the floor
  r.distances = {{1, 9, 500.0, 0.3}};
  const std::vector<FloorTagSighting> seen =
      ObserveFloorTags(RenderFrames(camera, testing::StandardRender(), 1.0, 2), camera.intrinsics(), r);
  ASSERT_EQ(seen.size(), 5u);
  EXPECT_THAT(seen[4].flags, ::testing::ElementsAre(ObservationFlag::kNotSeen));
  EXPECT_STREQ(ToString(seen[4].flags[0]), "not_seen");
  const FloorScaleResult result = EstimateFloorScale(camera, seen, r, 0.0, 0.0);
  EXPECT_FALSE(result.ok());
  EXPECT_THAT(result.message, HasSubstr("1-9"));
}

TEST(FloorReference, IsValidNamesTheProblem) {
  std::string why;
  FloorReference r = Reference();
  EXPECT_TRUE(r.IsValid(&why)) << why;
  for (const auto& [edit, expected] :
       std::vector<std::pair<std::function<void(FloorReference*)>, std::string>>{
           {[](FloorReference* f) { f->tags.resize(1); }, "at least two tags"},
           {[](FloorReference* f) { f->distances.clear(); }, "at least one measured distance"},
           {[](FloorReference* f) { f->distances[0].id_b = 7; }, "names a tag not in"},
           {[](FloorReference* f) { f->distances[0].sigma_mm = 0.0; }, "sigma_mm must be positive"},
           {[](FloorReference* f) { f->tags[1].id = f->tags[0].id; }, "listed twice"}}) {
    FloorReference bad = Reference();
    edit(&bad);
    EXPECT_FALSE(bad.IsValid(&why));
    EXPECT_THAT(why, HasSubstr(expected));
  }
}

}  // namespace
}  // namespace odocal::vision
