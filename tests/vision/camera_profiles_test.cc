// Images odocal did not design: the camera simulator's parts, the
// PSF- and tone-free corner refinement measured on images formed by PSFs and
// tone curves it does not invert, and bad frames that must be flagged.
// Small images (640x480), so each test takes a few seconds.
#include <cmath>
#include <cstdio>
#include <numeric>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "odocal/base/units.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/edge_quality.h"
#include "odocal/vision/image_formation.h"
#include "odocal/vision/planar_pose.h"
#include "odocal/vision/renderer.h"
#include "vision_fixtures.h"

namespace odocal::vision {
namespace {

using calibration::Pose2;
using calibration::WrapAngle;

std::unique_ptr<Renderer> MakeRenderer(const ImageFormationOptions& formation, uint64_t seed = 1,
                                       const TagSpec& tag = testing::StandardTag()) {
  RenderOptions o = testing::StandardRender();
  o.seed = seed;
  o.formation = formation;
  auto r = Renderer::Create(testing::SmallCamera(), tag, o);
  EXPECT_TRUE(r.ok()) << r.message;
  return std::move(r.renderer);
}

struct Measured {
  bool usable = false;  // measured, and no quality flag
  bool ok() const { return usable; }
  std::string why;
  Pose2 pose;
  TagImageQuality quality;
  std::vector<ObservationFlag> flags;
};

// Detection, the per-frame refinement, then the PSF- and tone-free one.
Measured Measure(const cv::Mat& image, const CameraModel& camera, const TagSpec& tag) {
  Measured m;
  auto detector = TagDetector::Create(DetectorOptions{}).detector;
  const FindResult found = detector->Find(image, tag.id);
  if (found.status != DetectStatus::kOk) {
    m.why = ToString(found.status);
    return m;
  }
  const CornerRefineResult coarse = RefineTagCorners(image, found.detection->corners_px, &camera);
  if (!coarse.ok()) {
    m.why = coarse.message;
    return m;
  }
  const ModelFreeRefineResult fine = RefineTagCornersModelFree(image, coarse.corners_px, &camera);
  m.quality = fine.quality;
  if (!fine.ok()) {
    m.why = fine.message;
    return m;
  }
  m.flags = QualityFlags(fine.quality);
  const PlanarPoseResult pose = MeasureTagPose(camera, tag, fine.corners_px);
  m.usable = pose.ok() && m.flags.empty();
  m.pose = pose.T_world_robot;
  if (!m.flags.empty()) m.why = ToString(m.flags.front());
  return m;
}

// Places and headings over the small camera's view; two with the edges
// parallel to the pixel grid, where a wrong edge model is phase-biased.
std::vector<Pose2> Places() {
  return {Pose2::FromXYHeading(0.0, 0.0, 0.0),      Pose2::FromXYHeading(0.12, -0.08, M_PI / 2),
          Pose2::FromXYHeading(-0.15, 0.10, 0.61),  Pose2::FromXYHeading(0.20, 0.12, -1.9),
          Pose2::FromXYHeading(-0.22, -0.12, 2.7),  Pose2::FromXYHeading(0.05, 0.18, -0.33)};
}

TEST(CameraProfiles, PresetsAreValidAndOffMeansUnchanged) {
  for (const std::string& name : ImageFormationPresetNames()) {
    const auto preset = ImageFormationPreset(name);
    ASSERT_TRUE(preset) << name;
    std::string why;
    EXPECT_TRUE(preset->IsValid(&why)) << name << ": " << why;
    EXPECT_TRUE(preset->HasSensorChain()) << name;
  }
  EXPECT_FALSE(ImageFormationPreset("dslr"));
  EXPECT_FALSE(ImageFormationOptions{}.HasSensorChain());
  // Default formation: byte for byte the renderer of before (same seed).
  auto plain = MakeRenderer({});
  RenderOptions o = testing::StandardRender();
  auto reference = Renderer::Create(testing::SmallCamera(), testing::StandardTag(), o).renderer;
  const Pose2 pose = Pose2::FromXYHeading(0.03, -0.02, 0.4);
  EXPECT_EQ(cv::norm(plain->Render(pose).image, reference->Render(pose).image, cv::NORM_INF), 0.0);
}

TEST(CameraProfiles, EqualWidthPsfsHaveEqualSecondMoments) {
  const PsfOptions gauss{PsfOptions::Model::kGaussian, 0.0, 0.8};
  const PsfOptions disk{PsfOptions::Model::kDisk, 1.6, 0.0};
  const PsfOptions both{PsfOptions::Model::kDiskGaussian, 1.2, std::sqrt(0.64 - 0.36)};
  for (const PsfOptions& psf : {gauss, disk, both}) {
    EXPECT_NEAR(psf.EquivalentSigma(), 0.8, 1e-12);
    // The kernel itself: blur a point at 2x and measure its variance.
    cv::Mat point = cv::Mat::zeros(41, 41, CV_32F);
    point.at<float>(20, 20) = 1.0f;
    cv::Mat blurred;
    ApplyPsf(point, &blurred, psf, 2);
    double sum = 0.0, var = 0.0;
    for (int v = 0; v < 41; ++v)
      for (int u = 0; u < 41; ++u) {
        sum += blurred.at<float>(v, u);
        var += blurred.at<float>(v, u) * (u - 20) * (u - 20);
      }
    EXPECT_NEAR(sum, 1.0, 1e-4) << ToString(psf.model);
    // In fine pixels (2 per image pixel); the disk's area sampling adds 1/12
    // of a fine pixel squared, the hat-integrated Gaussian 1/6 (raster.h):
    // a few hundredths of a pixel of width.
    const double extra = (psf.model != PsfOptions::Model::kGaussian ? 1.0 / 12 : 0.0) +
                         (psf.model != PsfOptions::Model::kDisk ? 1.0 / 6 : 0.0);
    // The disk sampled on the grid is not exactly r^2 / 4 (measured 0.004 px wider).
    EXPECT_NEAR(std::sqrt(var / sum) / 2.0, std::sqrt(0.64 + extra / 4.0), 0.006) << ToString(psf.model);
  }
}

// The test: the same scene formed by a Gaussian, a disk and a
// disk+Gaussian PSF of equal width, through a gamma 2.2 tone curve, Bayer
// demosaicing, vignetting and an uneven light -- none of which the
// estimator models exactly. The pose bias must not depend on the PSF.
TEST(CameraProfiles, PoseBiasDoesNotDependOnThePsfModel) {
  const CameraModel camera = testing::SmallCamera();
  const TagSpec tag = testing::StandardTag();
  ImageFormationOptions base;
  base.bayer = true;
  base.gamma = 2.2;
  base.vignetting = 0.3;
  base.light_gradient = 0.15;
  base.noise = SensorNoiseOptions{3.0, 20000.0};
  const std::vector<PsfOptions> psfs = {{PsfOptions::Model::kGaussian, 0.0, 0.8},
                                        {PsfOptions::Model::kDisk, 1.6, 0.0},
                                        {PsfOptions::Model::kDiskGaussian, 1.2, std::sqrt(0.64 - 0.36)}};
  constexpr int kFrames = 3;
  std::vector<Eigen::Vector3d> bias;  // mean (x mm, y mm, heading deg) error per PSF
  std::vector<std::vector<Eigen::Vector3d>> per_place(psfs.size());
  for (size_t i = 0; i < psfs.size(); ++i) {
    ImageFormationOptions f = base;
    f.psf = psfs[i];
    auto renderer = MakeRenderer(f, 7);  // the same seed: the same noise for every PSF
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Pose2& pose : Places()) {
      Eigen::Vector3d rest = Eigen::Vector3d::Zero();
      for (int k = 0; k < kFrames; ++k) {
        const Measured m = Measure(renderer->Render(pose).image, camera, tag);
        ASSERT_TRUE(m.ok()) << ToString(psfs[i].model) << ": " << m.why;
        rest += Eigen::Vector3d((m.pose.x() - pose.x()) * 1e3, (m.pose.y() - pose.y()) * 1e3,
                                WrapAngle(m.pose.heading() - pose.heading()) * kRadToDeg) /
                kFrames;
      }
      per_place[i].push_back(rest);
      sum += rest / static_cast<double>(Places().size());
    }
    bias.push_back(sum);
  }
  for (size_t i = 0; i < psfs.size(); ++i) {
    std::printf("  %-14s bias x %+.4f mm, y %+.4f mm, heading %+.5f deg\n", ToString(psfs[i].model),
                bias[i].x(), bias[i].y(), bias[i].z());
    for (size_t j = i + 1; j < psfs.size(); ++j) {
      const Eigen::Vector3d d = bias[i] - bias[j];
      EXPECT_LT(std::hypot(d.x(), d.y()), 0.01)
          << ToString(psfs[i].model) << " vs " << ToString(psfs[j].model) << ": " << d.transpose();
      EXPECT_LT(std::abs(d.z()), 0.003) << ToString(psfs[i].model) << " vs " << ToString(psfs[j].model);
    }
    // And small in itself: a tenth of the 1.5 mm pixel is 0.15 mm.
    EXPECT_LT(std::hypot(bias[i].x(), bias[i].y()), 0.02) << ToString(psfs[i].model);
  }
}

TEST(CameraProfiles, RollingShutterTruthIsTheFramesMidExposure) {
  ImageFormationOptions f;
  f.rolling_shutter_s = 0.030;
  auto renderer = MakeRenderer(f);
  auto global = MakeRenderer({});
  // 1 m/s along world +y, which is image up: the rows that hold the tag
  // (below the middle row) are read out later than the frame's mid-time.
  const Pose2 start = Pose2::FromXYHeading(0.02, -0.15, 0.3);
  const auto trajectory = [&](double t) { return Pose2::FromXYHeading(start.x(), start.y() + 1.0 * t, 0.3); };
  const RenderedFrame rs = renderer->RenderExposure(trajectory, 0.0);
  const RenderedFrame gs = global->RenderExposure(trajectory, 0.0);
  EXPECT_NEAR(rs.T_world_robot.y(), start.y(), 1e-12);  // truth: mid-exposure
  const CameraModel camera = testing::SmallCamera();
  const Measured mr = Measure(rs.image, camera, testing::StandardTag());
  const Measured mg = Measure(gs.image, camera, testing::StandardTag());
  ASSERT_TRUE(mr.ok() && mg.ok()) << mr.why << " / " << mg.why;
  const cv::Point2d centre = (rs.corners_px[0] + rs.corners_px[1] + rs.corners_px[2] + rs.corners_px[3]) * 0.25;
  const double t_rows = (centre.y / (480 - 1) - 0.5) * f.rolling_shutter_s;
  EXPECT_GT(t_rows, 0.005);
  // The global shutter sees the mid-time pose; the rolling shutter the pose
  // at its rows' time (within the skew of the tag across its own rows).
  EXPECT_NEAR(mg.pose.y(), start.y(), 0.5e-3);
  EXPECT_NEAR(mr.pose.y(), start.y() + t_rows, 1.0e-3);
}

// Bad frames: each gives a flag or no detection, never a silent number.
// Paper bow (`camera.tag.bow_mm`): a bowed print is a raised tag. Its corners
// rise by 0.56 bow (at x = size/2 of a 60 mm half-plate), its middle line by
// the whole bow, so the measured tag sits between those heights: seen from
// the camera centre C at height H, a tag raised by z is displaced by
// (p - C) z / (H - h - z) on the plane of the stated height h. The fitted
// effective rise must lie between the two, and the radial model must explain
// the displacement. Noise-free, so the figures are the bow's alone.
TEST(CameraProfiles, PaperBowActsAsARaisedTag) {
  const TagSpec tag = testing::StandardTag();
  const CameraModel camera = testing::SmallCamera();
  RenderOptions flat_options = testing::StandardRender();
  flat_options.noise_sigma = 0.0;
  RenderOptions bowed_options = flat_options;
  bowed_options.tag_bow_mm = 2.0;
  auto flat = Renderer::Create(camera, tag, flat_options).renderer;
  auto bowed = Renderer::Create(camera, tag, bowed_options).renderer;
  ASSERT_TRUE(flat && bowed);
  const Eigen::Vector2d centre = camera.T_world_camera().translation().head<2>();
  const double above_tag_m = camera.T_world_camera().translation().z() - tag.height_m();
  double num = 0.0, den = 0.0;
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> shifts;  // (u, displacement)
  for (const Pose2& place : Places()) {
    const Measured f = Measure(flat->Render(place).image, camera, tag);
    const Measured b = Measure(bowed->Render(place).image, camera, tag);
    ASSERT_TRUE(f.ok() && b.ok()) << f.why << " / " << b.why;
    // The bowed tag's corners, lifted, are what the renderer says is true.
    const auto lifted = bowed->TrueCorners(place);
    const auto level = flat->TrueCorners(place);
    ASSERT_TRUE(lifted && level);
    EXPECT_GT(cv::norm((*lifted)[0] - (*level)[0]), 1e-3);
    // The displacement the bow adds, against the radial model per metre of rise.
    const Eigen::Vector2d d = b.pose.translation() - f.pose.translation();
    const Eigen::Vector2d u = (place.translation() - centre) / above_tag_m;
    num += d.dot(u);
    den += u.dot(u);
    shifts.push_back({u, d});
  }
  const double rise_mm = num / den * 1e3;
  std::printf("paper bow 2 mm: effective rise %.3f mm\n", rise_mm);
  EXPECT_GT(rise_mm, 0.5 * 2.0);
  EXPECT_LT(rise_mm, 1.05 * 2.0);
  // What is not radial comes from the bow's one axis (the edges along the
  // tag's x curve, those along y do not): up to 0.09 mm here, measured.
  for (const auto& [u, d] : shifts) {
    std::printf("  displacement %.3f mm, beyond the raised-tag model %.3f mm\n", d.norm() * 1e3,
                (d - u * rise_mm * 1e-3).norm() * 1e3);
    EXPECT_LT((d - u * rise_mm * 1e-3).norm() * 1e3, 0.12);
  }
}

TEST(CameraProfiles, BadFramesAreFlaggedNotMeasured) {
  const CameraModel camera = testing::SmallCamera();
  const TagSpec tag = testing::StandardTag();
  const Pose2 pose = Pose2::FromXYHeading(0.04, 0.03, 0.5);
  ImageFormationOptions good;
  good.gamma = 2.2;
  good.noise = SensorNoiseOptions{3.0, 20000.0};
  good.psf = PsfOptions{PsfOptions::Model::kDisk, 1.0, 0.0};
  {
    const Measured m = Measure(MakeRenderer(good)->Render(pose).image, camera, tag);
    EXPECT_TRUE(m.ok()) << m.why;
    EXPECT_GT(m.quality.contrast_grey, 100.0);
    EXPECT_NEAR(m.quality.blur_sigma_px, 0.5, 0.25);  // a 1 px disk: sigma 0.5
    EXPECT_NEAR(m.quality.side_px, 700.0 * 80.0 / (1200.0 - 150.0), 1.0);  // f * size / distance
  }
  {
    ImageFormationOptions over = good;
    over.gain = 2.5;  // the white plate clips
    const Measured m = Measure(MakeRenderer(over)->Render(pose).image, camera, tag);
    EXPECT_FALSE(m.ok());
    EXPECT_EQ(m.why, "overexposed");
  }
  {
    ImageFormationOptions blurred = good;
    blurred.psf = PsfOptions{PsfOptions::Model::kDisk, 3.5, 0.0};
    const Measured m = Measure(MakeRenderer(blurred)->Render(pose).image, camera, tag);
    EXPECT_FALSE(m.ok());
    if (!m.flags.empty()) {
      EXPECT_EQ(m.why, "defocused");
    }
  }
  {
    // A cable across one edge of the tag.
    RenderedFrame f = MakeRenderer(good)->Render(pose);
    const cv::Point2d a = (f.corners_px[0] * 0.6 + f.corners_px[1] * 0.4);
    cv::line(f.image, a + cv::Point2d(-6, -6), a + cv::Point2d(6, 6), cv::Scalar(90), 3);
    const Measured m = Measure(f.image, camera, tag);
    EXPECT_FALSE(m.ok()) << "occluded edge measured as if clean";
  }
  {
    // A second tag with the same id.
    auto renderer = MakeRenderer(good);
    RenderedFrame f = renderer->Render(pose);
    const RenderedFrame other = renderer->Render(Pose2::FromXYHeading(-0.2, -0.1, 1.0));
    cv::Rect box = cv::boundingRect(std::vector<cv::Point>{
        other.corners_px[0], other.corners_px[1], other.corners_px[2], other.corners_px[3]});
    box.x -= 10, box.y -= 10, box.width += 20, box.height += 20;
    other.image(box).copyTo(f.image(box));
    auto detector = TagDetector::Create(DetectorOptions{}).detector;
    EXPECT_EQ(detector->Find(f.image, tag.id).status, DetectStatus::kDuplicateId);
    EXPECT_FALSE(Measure(f.image, camera, tag).ok());
  }
}

}  // namespace
}  // namespace odocal::vision
