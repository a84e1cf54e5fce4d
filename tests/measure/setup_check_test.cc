// setup-check's floor geometry through a wide lens: the tag's size in the
// image at the squares' corners, against the tag rendered there and found by
// the detector, and the warning when a fisheye's rim shrinks it.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/calibration/pose2.h"
#include "odocal/measure/setup_check.h"
#include "odocal/vision/renderer.h"
#include "odocal/vision/tag_survey.h"

namespace odocal::measure {
namespace {

using calibration::Pose2;
using ::testing::HasSubstr;

// A 1600x1200 fisheye 1.2 m over the floor (as tests/vision/fisheye_test.cc's).
vision::Intrinsics Fisheye() {
  vision::Intrinsics in{1600, 1200, 560.0, 561.0, 801.5, 598.25, {-0.02, 0.004, -0.0015, 0.0002, 0.0}};
  in.lens = vision::LensModel::kEquidistant;
  return in;
}

vision::TagSpec Tag() {
  vision::TagSpec tag;
  tag.family = "tag36h11";
  tag.id = 5;
  tag.size_mm = 80.0;
  tag.height_mm = 150.0;
  return tag;
}

// The robot's poses at the squares' corners, arriving and leaving (cw, ccw).
std::vector<Pose2> SquareCorners(const Pose2& start, double side_m) {
  std::vector<Pose2> out;
  for (const double turn : {-M_PI / 2, M_PI / 2}) {
    Pose2 pose = start;
    for (int side = 0; side < 4; ++side) {
      pose = pose * Pose2::FromXYHeading(side_m, 0.0, 0.0);
      out.push_back(pose);
      pose = pose * Pose2::FromXYHeading(0.0, 0.0, turn);
      out.push_back(pose);
    }
  }
  return out;
}

double ShortestSide(const std::array<cv::Point2d, 4>& c) {
  double side = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 4; ++k) side = std::min(side, cv::norm(c[(k + 1) % 4] - c[k]));
  return side;
}

TEST(SetupCheck, SaysWhereAWideLensShrinksTheTagAtTheSquaresCorners) {
  vision::RenderOptions render;
  render.noise_sigma = 2.0;
  render.blur_sigma_px = 0.8;
  render.seed = 3;
  SetupCheckOptions options;
  options.intrinsics = Fisheye();
  options.tag = Tag();
  options.monte_carlo_draws = 50;
  // Squares out to 50-55 degrees off the axis, a small one near it, and the
  // camera 2 m up, where the same squares shrink the tag under 16 px.
  struct Case {
    double height_mm;
    Pose2 start;
    double side_m;
    bool warned;
  };
  for (const Case& c : {Case{1200.0, Pose2::FromXYHeading(-0.6, -0.3, 0.35), 1.3, true},
                        Case{1200.0, Pose2::FromXYHeading(-0.2, -0.15, 0.35), 0.4, false},
                        Case{2000.0, Pose2::FromXYHeading(-0.6, -0.3, 0.35), 1.3, true}}) {
    const Pose2& start = c.start;
    const double side_m = c.side_m;
    SCOPED_TRACE(::testing::Message() << c.height_mm << " mm up, " << side_m << " m squares");
    const vision::CameraMount mount{0.0, 0.0, c.height_mm, 0.0, 1.5, 0.0};
    const vision::CameraModel camera(Fisheye(), mount);
    auto r = vision::Renderer::Create(camera, Tag(), render);
    ASSERT_TRUE(r.ok()) << r.message;
    options.mount_guess = mount;
    std::vector<SetupFrame> frames;
    for (int i = 0; i < 6; ++i) frames.push_back({r.renderer->Render(start).image, i / 30.0});
    options.square_side_m = side_m;
    const SetupCheckResult check = CheckSetup(frames, options);
    ASSERT_TRUE(check.ok()) << check.message;
    ASSERT_TRUE(check.squares_fit) << ::testing::PrintToString(check.warnings);
    // The truth: the tag rendered at every corner of the squares and found
    // there by libapriltag at full resolution, in a window around it; under
    // 16 px its bits may not decode, and its outline is then the quad the
    // library refused.
    double truth = std::numeric_limits<double>::infinity();
    Pose2 where;
    std::vector<std::pair<Pose2, double>> sides;  // each corner visited, the tag's side found there
    vision::TagSurveyOptions survey;
    survey.refine = false;
    for (const Pose2& at : SquareCorners(start, side_m)) {
      const auto centre = camera.ProjectWorld(Eigen::Vector3d(at.x(), at.y(), Tag().height_m()));
      ASSERT_TRUE(centre.has_value());
      const cv::Mat image = r.renderer->Render(at).image;
      const cv::Rect window = cv::Rect(static_cast<int>(centre->x()) - 100, static_cast<int>(centre->y()) - 100, 200, 200) &
                              cv::Rect(0, 0, image.cols, image.rows);
      const vision::TagSurvey found = vision::SurveyTags(image(window).clone(), nullptr, survey);
      ASSERT_TRUE(found.ok());
      std::vector<std::array<cv::Point2d, 4>> outlines;
      for (const auto& t : found.tags) outlines.push_back(t.corners_px);
      if (outlines.empty())
        for (const auto& q : found.rejected) outlines.push_back(q.corners_px);
      ASSERT_EQ(outlines.size(), 1u) << at.x() << ", " << at.y() << " in " << window;
      const double side = ShortestSide(outlines[0]);
      sides.emplace_back(at, side);
      if (side < truth) truth = side, where = at;
    }
    std::printf("figures: %.0f mm up, %.1f m squares: the tag at the smallest %.2f px (rendered and found: %.2f px) at (%.0f, %.0f) mm; "
                "%.1f px where it stands\n",
                c.height_mm, side_m, check.squares_min_tag_side_px, truth, where.x() * 1e3, where.y() * 1e3, check.quality.side_px);
    EXPECT_NEAR(check.squares_min_tag_side_px, truth, 0.03 * truth);
    // Where: a corner where the tag is as small as the smallest within the
    // truth's own scatter (libapriltag's unrefined quads: up to 0.4 px
    // between two visits of one corner; two corners of a square can tie).
    const bool at_a_smallest = std::any_of(sides.begin(), sides.end(), [&](const auto& s) {
      return s.second <= truth * 1.03 && (check.squares_min_tag_side_at - s.first.translation()).norm() < 0.01;
    });
    EXPECT_TRUE(at_a_smallest) << "said (" << check.squares_min_tag_side_at.transpose() << ") m; smallest at ("
                               << where.translation().transpose() << ") m";
    // tag36h11: 8 cells at the border.
    EXPECT_EQ(check.squares_tag_too_small, truth < 8 * kTooSmallTagCellPx) << truth;
    const bool warned = std::any_of(check.warnings.begin(), check.warnings.end(), [](const std::string& w) {
      return w.find("px across (") != std::string::npos;
    });
    // 50-55 degrees off the axis the fisheye halves the tag's size across
    // the line of sight.
    EXPECT_EQ(truth < 8 * kSmallTagCellPx, c.warned) << truth;
    EXPECT_EQ(warned, c.warned) << ::testing::PrintToString(check.warnings);
  }
}

}  // namespace
}  // namespace odocal::measure
