// The equidistant (Kannala-Brandt) lens: odocal's projection against
// OpenCV's cv::fisheye (an independent implementation of the same model),
// its inverse to machine precision across the field, and the whole chain on
// rendered frames of a fisheye camera 1.2 m over the floor (wide enough to
// see a 2 m square): detection, edge refinement through the curved image,
// planar pose, all against the renderer's truth.
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "odocal/base/units.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/edge_quality.h"
#include "odocal/vision/planar_pose.h"
#include "odocal/vision/renderer.h"
#include "odocal/vision/tag_survey.h"
#include "vision_fixtures.h"

namespace odocal::vision {
namespace {

using calibration::Pose2;
using calibration::WrapAngle;

// A 1600x1200 fisheye, 1.2 m over the floor: 61 deg from the axis at the
// top and bottom edges, the floor 1.9 m either side at the tag's height.
Intrinsics Fisheye() {
  Intrinsics in{1600, 1200, 560.0, 561.0, 801.5, 598.25, {-0.02, 0.004, -0.0015, 0.0002, 0.0}};
  in.lens = LensModel::kEquidistant;
  return in;
}
CameraMount FisheyeMount() { return CameraMount{0.0, 0.0, 1200.0, 0.0, 1.5, 0.0}; }

TEST(FisheyeLens, ProjectsAsOpenCvsFisheyeModelAndInvertsToMachinePrecision) {
  const CameraModel camera(Fisheye(), CameraMount{});
  std::mt19937 rng(24);
  std::uniform_real_distribution<double> angle(0.0, 1.3), azimuth(-M_PI, M_PI);
  std::vector<cv::Point3d> points;
  for (int i = 0; i < 500; ++i) {
    const double theta = angle(rng), phi = azimuth(rng);
    points.emplace_back(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
  }
  std::vector<cv::Point2d> opencv;
  cv::fisheye::projectPoints(points, opencv, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), Fisheye().CameraMatrix(),
                             Fisheye().DistortionCoeffs());
  double worst_px = 0.0, worst_inverse = 0.0;
  for (size_t i = 0; i < points.size(); ++i) {
    const auto px = camera.ProjectCamera(Eigen::Vector3d(points[i].x, points[i].y, points[i].z));
    ASSERT_TRUE(px);
    worst_px = std::max(worst_px, std::hypot(px->x() - opencv[i].x, px->y() - opencv[i].y));
    const Eigen::Vector3d ray = camera.UnprojectToRay(*px);
    worst_inverse = std::max(worst_inverse, std::hypot(ray.x() - points[i].x / points[i].z,
                                                       ray.y() - points[i].y / points[i].z));
  }
  std::printf("figures: |odocal - cv::fisheye| <= %.2e px; inverse <= %.2e (normalised) over 500 rays to 74 deg\n",
              worst_px, worst_inverse);
  EXPECT_LT(worst_px, 1e-6);
  EXPECT_LT(worst_inverse, 1e-9);
  // The file form cv::fisheye takes: four coefficients.
  EXPECT_EQ(Fisheye().DistortionCoeffs().cols, 4);
  std::string why;
  Intrinsics five = Fisheye();
  five.distortion[4] = 0.1;
  EXPECT_FALSE(five.IsValid(&why));
  EXPECT_THAT(why, ::testing::HasSubstr("four coefficients"));
  const auto five_coefficients =
      Intrinsics::FromCv(Fisheye().CameraMatrix(), cv::Mat::zeros(1, 5, CV_64F), 1600, 1200, LensModel::kEquidistant);
  EXPECT_FALSE(five_coefficients);
  EXPECT_THAT(five_coefficients.message, ::testing::HasSubstr("exactly 4 coefficients"));
  EXPECT_EQ(ParseLensModel("pinhole-equi"), LensModel::kEquidistant);
  EXPECT_EQ(ParseLensModel("radtan"), LensModel::kPlumbBob);
  EXPECT_FALSE(ParseLensModel("kannala"));
}

// Rendered through the fisheye at the centre and 0.8-0.9 m out (40-41 deg
// off the axis; an 80 mm tag: 43 px across at the centre, 28 x 36 px there),
// measured as a rest is (the half-level lines, then the model-free fit):
// averaged over noisy frames, the tag's position is within 0.05 mm and its
// heading within three standard errors (and 0.015 deg) of the truth. Before
// the refiners took each pixel as a unit square in the image rather than in
// the undistorted plane, the heading 0.7 m out was 0.043 deg off (7 sigma).
// Further out (50 deg and more) this tag is small across the view's radius:
// the next test.
// `detect --calibration` gives each tag's and the board's pose through
// EstimateObjectPose. With a fisheye camera file it fitted the points as
// plumb_bob (k1..k4 read as k1 k2 p1 p2): a board 50 degrees off the axis of
// a 190-degree lens came out 16 px RMS off. Points projected through the lens
// (cv::fisheye, independent of odocal's projection) with 0.02 px of noise:
// the pose within its stated sigmas and the residual the noise's.
TEST(FisheyeLens, ObjectPoseThroughTheLens) {
  Intrinsics lens{512, 512, 190.98, 190.97, 254.93, 256.90, {0.00348, 0.000715, -0.00205, 0.000203, 0.0}};
  lens.lens = LensModel::kEquidistant;
  std::vector<cv::Point3d> board;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) board.emplace_back(0.1144 * c, 0.1144 * r, 0.0);
  const cv::Vec3d rvec(0.3, -0.5, 0.2), tvec(0.35, 0.1, 0.45);  // ~40-60 degrees off the axis
  std::vector<cv::Point2d> pixels;
  cv::fisheye::projectPoints(board, pixels, rvec, tvec, lens.CameraMatrix(), lens.DistortionCoeffs());
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.02);
  for (cv::Point2d& p : pixels) p += cv::Point2d(noise(rng), noise(rng));
  const ObjectPose pose = EstimateObjectPose(lens, board, pixels, std::vector<double>(board.size(), 0.02));
  ASSERT_TRUE(pose.ok()) << pose.message;
  EXPECT_LT(pose.rms_residual_px, 0.04);
  const Eigen::Vector3d t = pose.T_camera_object.translation();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(t[k], tvec[k], 4.0 * std::sqrt(pose.covariance(3 + k, 3 + k))) << k;
  const Eigen::AngleAxisd aa(pose.T_camera_object.linear());
  const Eigen::Vector3d r = aa.angle() * aa.axis();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(r[k], rvec[k], 4.0 * std::sqrt(pose.covariance(k, k))) << k;
  // The pose's sigmas are those of 0.02 px corners: micrometres here.
  EXPECT_LT(std::sqrt(pose.covariance(5, 5)), 1e-4);
}

TEST(FisheyeLens, RenderedTagPoseIsUnbiasedAcrossTheField) {
  const CameraModel camera(Fisheye(), FisheyeMount());
  RenderOptions options = testing::StandardRender();
  auto r = Renderer::Create(camera, testing::StandardTag(), options);
  ASSERT_TRUE(r.ok()) << r.message;
  auto d = TagDetector::Create(DetectorOptions{});
  ASSERT_TRUE(d.ok());
  const Pose2 truths[] = {Pose2::FromXYHeading(0.01, 0.02, 0.3), Pose2::FromXYHeading(0.7, -0.35, -1.9),
                          Pose2::FromXYHeading(-0.75, 0.5, 2.6)};
  for (const Pose2& truth : truths) {
    TagTracker tracker(d.detector.get(), 5);
    constexpr int kFrames = 12;
    std::vector<double> ex, ey, eh;
    for (int i = 0; i < kFrames; ++i) {
      const RenderedFrame f = r.renderer->Render(truth);
      const TrackResult t = tracker.Track(f.image);
      ASSERT_EQ(t.find.status, DetectStatus::kOk) << ::testing::PrintToString(truth);
      // As a rest is measured (measure::MeasureRestExactly): the half-level
      // lines, then the exact model-free fit through the lens.
      const auto half = RefineTagCorners(f.image, t.find.detection->corners_px, &camera);
      ASSERT_TRUE(half.ok()) << half.message << " at " << ::testing::PrintToString(truth);
      const auto refined = RefineTagCornersModelFree(f.image, half.corners_px, &camera);
      ASSERT_TRUE(refined.ok()) << refined.message << " at " << ::testing::PrintToString(truth);
      const PlanarPoseResult p = MeasureTagPose(camera, testing::StandardTag(), refined.corners_px);
      ASSERT_TRUE(p.ok()) << p.message;
      ex.push_back((p.T_world_robot.x() - truth.x()) * 1e3);
      ey.push_back((p.T_world_robot.y() - truth.y()) * 1e3);
      eh.push_back(WrapAngle(p.T_world_robot.heading() - truth.heading()) * kRadToDeg);
    }
    auto mean_and_se = [](const std::vector<double>& v) {
      double m = 0.0, s = 0.0;
      for (double x : v) m += x / v.size();
      for (double x : v) s += (x - m) * (x - m) / (v.size() - 1);
      return std::pair<double, double>(m, std::sqrt(s / v.size()));
    };
    const auto [mx, sx] = mean_and_se(ex);
    const auto [my, sy] = mean_and_se(ey);
    const auto [mh, sh] = mean_and_se(eh);
    std::printf("figures: fisheye, tag at %s: mean error (%.4f +- %.4f, %.4f +- %.4f) mm, %.5f +- %.5f deg "
                "over %d frames\n",
                ::testing::PrintToString(truth).c_str(), mx, sx, my, sy, mh, sh, kFrames);
    EXPECT_LT(std::abs(mx), 0.05);
    EXPECT_LT(std::abs(my), 0.05);
    EXPECT_LT(std::abs(mh), std::max(3.0 * sh, 0.005));
    EXPECT_LT(std::abs(mh), 0.015);
  }
}


// Further out the tag shrinks across the view's radius: 50-55 deg off the
// axis (1.3-1.5 m from the point under the camera) the 80 mm tag is 14-18
// px across that way, 2-3 px a cell. At the detector's decimation 2 its
// cells fall apart and libapriltag finds nothing; the tracker looks for it at
// full resolution, and rests are measured as any other. What a rest there
// gives: its place within 0.25-0.5 mm (outwards: the small cells' edges lean
// a tenth of a pixel), a return error (the end rest against the start rest,
// 25 mm and 4 deg apart, as UMBMark's are) unbiased within its noise: the
// bias is shared by the two rests.
TEST(FisheyeLens, ASmallTagAtTheRimIsFoundAtFullResolutionAndMeasured) {
  const CameraModel camera(Fisheye(), FisheyeMount());
  auto r = Renderer::Create(camera, testing::StandardTag(), testing::StandardRender());
  ASSERT_TRUE(r.ok()) << r.message;
  auto d = TagDetector::Create(DetectorOptions{});
  ASSERT_TRUE(d.ok());
  // A rest's mean pose over a second of frames (the tracker and refiners as
  // measure's), with the standard error of its position [m] and heading.
  struct Rest {
    Pose2 mean;
    double se_m = 0.0, se_rad = 0.0;
    int frames = 0;
  };
  const auto rest = [&](const Pose2& truth) -> std::optional<Rest> {
    TagTracker tracker(d.detector.get(), 5);
    std::vector<double> xs, ys, hs;
    constexpr int kFrames = 30;
    for (int i = 0; i < kFrames; ++i) {
      const RenderedFrame f = r.renderer->Render(truth);
      const TrackResult t = tracker.Track(f.image);
      EXPECT_EQ(t.find.status, DetectStatus::kOk) << ::testing::PrintToString(truth) << " frame " << i;
      if (t.find.status != DetectStatus::kOk) return std::nullopt;
      // A frame whose edges cannot be fitted is left out of the rest, as
      // measure leaves it out.
      const auto half = RefineTagCorners(f.image, t.find.detection->corners_px, &camera);
      if (!half.ok()) continue;
      const auto refined = RefineTagCornersModelFree(f.image, half.corners_px, &camera);
      if (!refined.ok()) continue;
      const PlanarPoseResult p = MeasureTagPose(camera, testing::StandardTag(), refined.corners_px);
      if (!p.ok()) continue;
      xs.push_back(p.T_world_robot.x());
      ys.push_back(p.T_world_robot.y());
      hs.push_back(truth.heading() + WrapAngle(p.T_world_robot.heading() - truth.heading()));
    }
    EXPECT_GE(xs.size(), 2u * kFrames / 3) << "frames measured at " << ::testing::PrintToString(truth);
    if (xs.size() < 3) return std::nullopt;
    const auto mean_and_se = [](const std::vector<double>& v) {
      double m = 0.0, s = 0.0;
      for (double x : v) m += x / v.size();
      for (double x : v) s += (x - m) * (x - m) / (v.size() - 1);
      return std::pair<double, double>(m, std::sqrt(s / v.size()));
    };
    const auto [mx, sx] = mean_and_se(xs);
    const auto [my, sy] = mean_and_se(ys);
    const auto [mh, sh] = mean_and_se(hs);
    return Rest{Pose2::FromXYHeading(mx, my, mh), std::hypot(sx, sy), sh, static_cast<int>(xs.size())};
  };
  const Pose2 step = Pose2::FromXYHeading(0.020, -0.015, 4.0 * kDegToRad);
  for (const Pose2& start : {Pose2::FromXYHeading(-1.25, -0.35, 0.2), Pose2::FromXYHeading(0.3, 1.45, -2.2)}) {
    TrackerOptions decimated_only;
    decimated_only.small_tag_px = 0.0;
    decimated_only.full_resolution_every = 0;
    TagTracker old_tracker(d.detector.get(), 5, decimated_only);
    EXPECT_NE(old_tracker.Track(r.renderer->Render(start).image).find.status, DetectStatus::kOk)
        << "found at decimation 2: this test no longer tests the full-resolution search";
    const Pose2 end = start * step;
    const auto a = rest(start), b = rest(end);
    ASSERT_TRUE(a && b);
    const double place_mm = std::hypot(a->mean.x() - start.x(), a->mean.y() - start.y()) * kMToMm;
    const Pose2 measured = a->mean.inverse() * b->mean;
    const double return_mm = std::hypot(measured.x() - step.x(), measured.y() - step.y()) * kMToMm;
    const double return_deg = std::abs(WrapAngle(measured.heading() - step.heading())) * kRadToDeg;
    const double se_mm = std::hypot(a->se_m, b->se_m) * kMToMm;
    const double se_deg = std::hypot(a->se_rad, b->se_rad) * kRadToDeg;
    std::printf("[figure] fisheye rim, rest at %s: place %.3f mm off; return error off by %.4f mm (se %.4f), "
                "%.4f deg (se %.4f); %d and %d of 30 frames measured\n",
                ::testing::PrintToString(start).c_str(), place_mm, return_mm, se_mm, return_deg, se_deg, a->frames,
                b->frames);
    EXPECT_LT(place_mm, 1.0);
    EXPECT_LT(return_mm, std::max(4.0 * se_mm, 0.02));
    EXPECT_LT(return_deg, std::max(4.0 * se_deg, 0.005));
  }
}

// detect's per-corner sigma through a fisheye: the edges are fitted on the
// undistorted plane, where a pixel near the field's edge is up to 1.5 times
// as wide; the sigma is stated in the image's pixels, and must be the
// corners' scatter there over frames with fresh noise (the same pose).
TEST(FisheyeLens, CornerSigmaIsInTheImagesPixels) {
  const CameraModel camera(Fisheye(), FisheyeMount());
  RenderOptions options = testing::StandardRender();
  options.noise_sigma = 4.0;
  auto r = Renderer::Create(camera, testing::StandardTag(), options);
  ASSERT_TRUE(r.ok()) << r.message;
  TagSurveyOptions survey;
  survey.quad_decimate = 2.0f;  // the refinement is on the full image anyway
  survey.collect_rejected = false;
  constexpr int kFrames = 16;
  double scatter2 = 0.0, stated2 = 0.0;
  int dof = 0, n = 0;
  for (const Pose2& truth : {Pose2::FromXYHeading(0.75, -0.45, 0.4), Pose2::FromXYHeading(-0.8, 0.5, -2.2)}) {
    std::array<std::vector<cv::Point2d>, 4> corners;
    for (int i = 0; i < kFrames; ++i) {
      const RenderedFrame f = r.renderer->Render(truth);
      const TagSurvey s = SurveyTags(f.image, &camera, survey);
      ASSERT_TRUE(s.ok()) << s.message;
      ASSERT_EQ(s.tags.size(), 1u);
      ASSERT_TRUE(s.tags[0].refined) << s.tags[0].refine_message;
      for (int k = 0; k < 4; ++k) {
        corners[k].push_back(s.tags[0].corners_px[k]);
        stated2 += std::pow(s.tags[0].corner_sigma_px[k], 2);
        ++n;
      }
    }
    for (const auto& c : corners) {
      cv::Point2d mean(0, 0);
      for (const cv::Point2d& p : c) mean += p * (1.0 / c.size());
      for (const cv::Point2d& p : c) scatter2 += (p - mean).dot(p - mean) / 2.0;  // per axis
      dof += static_cast<int>(c.size()) - 1;
    }
  }
  const double scatter = std::sqrt(scatter2 / dof), stated = std::sqrt(stated2 / n);
  std::printf("figures: fisheye corners near the field's edge: scatter %.4f px per axis, stated sigma %.4f px (%d "
              "corners)\n",
              scatter, stated, n);
  EXPECT_NEAR(stated / scatter, 1.0, 0.3);
}

}  // namespace
}  // namespace odocal::vision
