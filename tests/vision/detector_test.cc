// TagDetector / TagTracker / RefineTagCorners against rendered ground truth.
//
// What is measured: detected corner minus the renderer's true corner (both in
// OpenCV's pixel convention), over many poses spread across the image at the
// issue's standard condition. The mean is the bias (convention errors show up
// here as 0.5 px), the RMS the spread.
#include <cmath>
#include <cstdio>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/renderer.h"
#include "vision_fixtures.h"

namespace odocal::vision {
namespace {

using calibration::Pose2;

struct Stats {
  double mean_x = 0, mean_y = 0, rms = 0;
  int n = 0;
};

std::unique_ptr<TagDetector> MakeDetector(const DetectorOptions& o = {}) {
  auto d = TagDetector::Create(o);
  EXPECT_TRUE(d.ok()) << d.message;
  return std::move(d.detector);
}

class StandardCondition : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto r = Renderer::Create(testing::StandardCamera(), testing::StandardTag(), testing::StandardRender());
    ASSERT_TRUE(r.ok()) << r.message;
    renderer_ = r.renderer.release();
    // Poses spread over the whole view (the camera sees x in about
    // [-1.2, 1.2] m and y in [-1.6, -0.4] m at the tag's height).
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> ux(-1.15, 1.15), uy(-1.55, -0.45), uh(-M_PI, M_PI);
    while (frames_->size() < 24) {
      const RenderedFrame f = renderer_->Render(Pose2::FromXYHeading(ux(rng), uy(rng), uh(rng)));
      if (f.tag_visible) frames_->push_back(f);
    }
  }
  static void TearDownTestSuite() {
    delete renderer_;
    frames_->clear();
  }

  // Corner errors of `detector` (optionally refined) over the frames.
  static Stats Measure(TagDetector* detector, int refine_mode, const CameraModel* camera,
                       double x_min = -1e9, double x_max = 1e9) {
    Stats s;
    double sq = 0;
    for (const auto& f : *frames_) {
      if (f.corners_px[0].x < x_min || f.corners_px[0].x >= x_max) continue;
      const FindResult found = detector->Find(f.image, 5, testing::AroundCorners(f.corners_px, 40));
      EXPECT_EQ(found.status, DetectStatus::kOk) << found.message;
      if (!found.detection) continue;
      auto corners = found.detection->corners_px;
      if (refine_mode) {
        const auto refined = RefineTagCorners(f.image, corners, camera);
        EXPECT_TRUE(refined.ok()) << refined.message;
        corners = refined.corners_px;
      }
      for (int k = 0; k < 4; ++k) {
        const cv::Point2d e = corners[k] - f.corners_px[k];
        s.mean_x += e.x;
        s.mean_y += e.y;
        sq += e.dot(e);
        ++s.n;
      }
    }
    if (s.n > 0) {
      s.mean_x /= s.n;
      s.mean_y /= s.n;
      s.rms = std::sqrt(sq / s.n);
    }
    return s;
  }

  static Renderer* renderer_;
  static std::vector<RenderedFrame>* frames_;
};
Renderer* StandardCondition::renderer_ = nullptr;
std::vector<RenderedFrame>* StandardCondition::frames_ = new std::vector<RenderedFrame>();

TEST_F(StandardCondition, LibraryCornersAfterConversionAreUnbiased) {
  DetectorOptions full_resolution;
  full_resolution.quad_decimate = 1.0f;
  auto detector = MakeDetector(full_resolution);
  const Stats s = Measure(detector.get(), 0, nullptr);
  std::printf("libapriltag (decimate 1) corners - truth: mean (%.4f, %.4f) px, rms %.4f px, %d corners\n", s.mean_x,
              s.mean_y, s.rms, s.n);
  ASSERT_GE(s.n, 80);
  // A wrong convention would show as 0.5 (or 1.0) px here.
  EXPECT_LT(std::abs(s.mean_x), 0.02);
  EXPECT_LT(std::abs(s.mean_y), 0.02);
  EXPECT_LT(s.rms, 0.1);
}

TEST_F(StandardCondition, ConversionAlsoHoldsWithDecimation) {
  DetectorOptions o;
  o.quad_decimate = 2.0f;
  auto detector = MakeDetector(o);
  const Stats s = Measure(detector.get(), 0, nullptr);
  std::printf("decimate 2: mean (%.4f, %.4f) px, rms %.4f px\n", s.mean_x, s.mean_y, s.rms);
  EXPECT_LT(std::abs(s.mean_x), 0.03);
  EXPECT_LT(std::abs(s.mean_y), 0.03);
}

TEST_F(StandardCondition, RefinedCornersAreUnbiasedAndTighterAcrossTheImage) {
  auto detector = MakeDetector();
  const CameraModel camera = testing::StandardCamera();
  const Stats lib = Measure(detector.get(), 0, nullptr);
  const Stats refined = Measure(detector.get(), 1, &camera);
  std::printf("refined corners - truth: mean (%.4f, %.4f) px, rms %.4f px\n", refined.mean_x,
              refined.mean_y, refined.rms);
  EXPECT_LT(std::abs(refined.mean_x), 0.01);
  EXPECT_LT(std::abs(refined.mean_y), 0.01);
  EXPECT_LT(refined.rms, 0.03);
  EXPECT_LT(refined.rms, 0.6 * lib.rms);  // it must earn its place
  // No bias in either half of the image (distortion grows outwards).
  for (const auto& [x0, x1] : {std::pair{0.0, 960.0}, std::pair{960.0, 1920.0}}) {
    const Stats half = Measure(detector.get(), 1, &camera, x0, x1);
    EXPECT_GE(half.n, 20);
    EXPECT_LT(std::abs(half.mean_x), 0.02) << x0;
    EXPECT_LT(std::abs(half.mean_y), 0.02) << x0;
  }
}

TEST_F(StandardCondition, RoiDetectionMatchesFullFrame) {
  auto detector = MakeDetector();
  const RenderedFrame& f = frames_->front();
  const FindResult full = detector->Find(f.image, 5);
  const FindResult roi = detector->Find(f.image, 5, testing::AroundCorners(f.corners_px, 30));
  ASSERT_EQ(full.status, DetectStatus::kOk);
  ASSERT_EQ(roi.status, DetectStatus::kOk);
  for (int k = 0; k < 4; ++k) {
    EXPECT_LT(cv::norm(full.detection->corners_px[k] - roi.detection->corners_px[k]), 0.05);
    // Corner k is the true corner k (order of TagCornersInTag).
    EXPECT_LT(cv::norm(roi.detection->corners_px[k] - f.corners_px[k]), 0.3);
  }
}

TEST(Tracker, FollowsInRoiLosesAndReacquires) {
  auto r = Renderer::Create(testing::SmallCamera(), testing::StandardTag(), testing::StandardRender());
  ASSERT_TRUE(r.ok());
  auto detector = MakeDetector();
  TagTracker tracker(detector.get(), 5);
  int roi_frames = 0;
  for (int i = 0; i < 8; ++i) {
    // 0.6 m/s at 30 fps: 2 cm per frame.
    const RenderedFrame f = r.renderer->Render(Pose2::FromXYHeading(-0.1 + 0.02 * i, 0.0, 0.05 * i));
    const TrackResult t = tracker.Track(f.image);
    ASSERT_EQ(t.find.status, DetectStatus::kOk) << i << ": " << t.find.message;
    EXPECT_EQ(t.used_roi, i > 0) << i;
    roi_frames += t.used_roi;
    if (t.used_roi) {
      EXPECT_LT(t.roi.area(), f.image.total() / 4);
    }
    EXPECT_LT(cv::norm(t.find.detection->corners_px[0] - f.corners_px[0]), 0.3);
  }
  EXPECT_EQ(roi_frames, 7);
  // Out of view: a full-frame search that finds nothing, then reacquisition.
  const TrackResult lost = tracker.Track(r.renderer->Render(Pose2::FromXYHeading(3.0, 0.0, 0.0)).image);
  EXPECT_EQ(lost.find.status, DetectStatus::kNotFound);
  EXPECT_FALSE(lost.used_roi);
  EXPECT_FALSE(lost.find.message.empty());
  const TrackResult back = tracker.Track(r.renderer->Render(Pose2::FromXYHeading(0.05, 0.02, 1.0)).image);
  EXPECT_EQ(back.find.status, DetectStatus::kOk);
  EXPECT_FALSE(back.used_roi);
}

TEST(DetectorBadInput, WrongIdWrongFamilyNotInViewDuplicateAndEmpty) {
  auto r = Renderer::Create(testing::SmallCamera(), testing::StandardTag(), testing::StandardRender());
  ASSERT_TRUE(r.ok());
  const RenderedFrame f = r.renderer->Render(Pose2::FromXYHeading(0.0, 0.0, 0.3));
  auto detector = MakeDetector();

  const FindResult wrong_id = detector->Find(f.image, 7);
  EXPECT_EQ(wrong_id.status, DetectStatus::kWrongId);
  EXPECT_THAT(wrong_id.message, ::testing::HasSubstr("5")) << wrong_id.message;
  EXPECT_FALSE(wrong_id.detection);

  DetectorOptions other_family;
  other_family.family = "tag25h9";
  auto d25 = MakeDetector(other_family);
  EXPECT_EQ(d25->Find(f.image, 5).status, DetectStatus::kNotFound);

  const RenderedFrame away = r.renderer->Render(Pose2::FromXYHeading(0.0, 2.0, 0.0));
  const FindResult none = detector->Find(away.image, 5);
  EXPECT_EQ(none.status, DetectStatus::kNotFound);
  EXPECT_FALSE(none.message.empty());

  // Two copies of the same tag in one frame.
  cv::Mat twice = f.image.clone();
  const cv::Rect src = testing::AroundCorners(f.corners_px, 12);
  f.image(src).copyTo(twice(src + cv::Point(-src.x + 10, -src.y + 10)));
  EXPECT_EQ(detector->Find(twice, 5).status, DetectStatus::kDuplicateId);

  EXPECT_EQ(detector->Detect(cv::Mat()).status, DetectStatus::kBadInput);
  EXPECT_EQ(detector->Detect(cv::Mat(100, 100, CV_32F)).status, DetectStatus::kBadInput);
  EXPECT_EQ(detector->Detect(f.image, cv::Rect(5000, 5000, 50, 50)).status, DetectStatus::kBadInput);

  DetectorOptions bad;
  bad.family = "tag36h12";
  const auto created = TagDetector::Create(bad);
  EXPECT_FALSE(created.ok());
  EXPECT_THAT(created.message, ::testing::HasSubstr("family"));
  bad = DetectorOptions{};
  bad.quad_decimate = 0.5f;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_FALSE(why.empty());
}

TEST(CornerRefine, LeavesTinyTagsAlone) {
  cv::Mat im(100, 100, CV_8U, cv::Scalar(128));
  const std::array<cv::Point2d, 4> tiny{cv::Point2d(10, 10), cv::Point2d(20, 10), cv::Point2d(20, 20),
                                        cv::Point2d(10, 20)};
  const auto r = RefineTagCorners(im, tiny, nullptr);
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.message.empty());
  EXPECT_EQ(r.corners_px[2], tiny[2]);
}

}  // namespace
}  // namespace odocal::vision
