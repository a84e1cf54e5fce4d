// LiveState (rig/live): what the page is told, from frames and the producer's calls.
#include "odocal/live/live_state.h"

#include <chrono>
#include <cmath>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace odocal::live {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;

// A tag-like square: black border, a few white cells, on white paper, side
// `side_px` centred at (cx, cy), axis-aligned; its outer corners in the
// detector's order.
struct Drawn {
  cv::Mat grey;
  TagOutline corners;
};
Drawn DrawTag(cv::Size size, double cx, double cy, double side_px) {
  Drawn d;
  d.grey = cv::Mat(size, CV_8UC1, cv::Scalar(200));
  const double h = side_px / 2.0;
  // Pixel centres at integers: the square covers [cx - h, cx + h] in
  // continuous coordinates, i.e. pixel edges at c -+ h.
  const cv::Rect outer(static_cast<int>(std::lround(cx - h + 0.5)), static_cast<int>(std::lround(cy - h + 0.5)),
                       static_cast<int>(std::lround(side_px)), static_cast<int>(std::lround(side_px)));
  d.grey(outer).setTo(30);
  const double cell = side_px / 8.0;
  for (int i = 2; i < 6; i += 2)
    for (int j = 1; j < 7; j += 3)
      d.grey(cv::Rect(outer.x + static_cast<int>(i * cell), outer.y + static_cast<int>(j * cell),
                      static_cast<int>(cell), static_cast<int>(cell)))
          .setTo(200);
  d.corners = {cv::Point2d(cx - h, cy + h), cv::Point2d(cx + h, cy + h), cv::Point2d(cx + h, cy - h),
               cv::Point2d(cx - h, cy - h)};
  return d;
}

LivePose PoseAt(double x_mm, double y_mm, double heading_deg = 0.0) {
  LivePose p;
  p.x_mm = x_mm;
  p.y_mm = y_mm;
  p.heading_deg = heading_deg;
  p.sigma_x_mm = 0.02;
  p.sigma_y_mm = 0.03;
  p.sigma_heading_deg = 0.01;
  return p;
}

std::vector<std::string> WarningKeys(const json& j) {
  std::vector<std::string> keys;
  for (const json& w : j["warnings"]) keys.push_back(w["key"]);
  return keys;
}

TEST(LiveState, BeforeTheFirstFrameThereIsNothingToShowAndNoWarning) {
  LiveState state;
  const json j = state.StateJson();
  EXPECT_EQ(j["version"], 1);
  EXPECT_TRUE(j["frame"].is_null());
  EXPECT_TRUE(j["pose"].is_null());
  EXPECT_TRUE(j["progress"].is_null());
  EXPECT_TRUE(j["trajectory_mm"].empty());
  EXPECT_TRUE(j["estimates"].empty());
  EXPECT_TRUE(j["warnings"].empty());
  EXPECT_FALSE(j["tag"]["seen"]);
  EXPECT_FALSE(state.FrameJpeg().has_value());
  EXPECT_EQ(state.frame_seq(), 0);
}

TEST(LiveState, FrameTagAndPoseAreReported) {
  LiveState state;
  state.SetSource("clip.mp4");
  const Drawn d = DrawTag({640, 480}, 320, 240, 64);
  state.OnFrame(d.grey, 0.5, d.corners, PoseAt(12.5, -3.25, 30.0));
  const json j = state.StateJson();
  EXPECT_EQ(j["source"], "clip.mp4");
  EXPECT_EQ(j["frame"]["seq"], 1);
  EXPECT_DOUBLE_EQ(j["frame"]["t_s"].get<double>(), 0.5);
  EXPECT_EQ(j["frame"]["width"], 640);
  EXPECT_EQ(j["frame"]["height"], 480);
  EXPECT_TRUE(j["tag"]["seen"]);
  EXPECT_NEAR(j["tag"]["side_px"].get<double>(), 64.0, 0.05);
  ASSERT_EQ(j["tag"]["corners_px"].size(), 4u);
  EXPECT_NEAR(j["tag"]["corners_px"][0][0].get<double>(), 288.0, 1e-9);
  EXPECT_NEAR(j["tag"]["corners_px"][0][1].get<double>(), 272.0, 1e-9);
  EXPECT_NEAR(j["pose"]["x_mm"].get<double>(), 12.5, 1e-9);
  EXPECT_NEAR(j["pose"]["y_mm"].get<double>(), -3.25, 1e-9);
  EXPECT_NEAR(j["pose"]["heading_deg"].get<double>(), 30.0, 1e-9);
  EXPECT_NEAR(j["pose"]["sigma_y_mm"].get<double>(), 0.03, 1e-12);
  EXPECT_TRUE(j["pose"]["current"]);
  EXPECT_TRUE(j["warnings"].empty()) << j["warnings"].dump();

  // A frame without the tag: the last pose stays, no longer current.
  state.OnFrame(d.grey, 0.6, std::nullopt, std::nullopt);
  const json k = state.StateJson();
  EXPECT_FALSE(k["tag"]["seen"]);
  EXPECT_TRUE(k["tag"]["corners_px"].is_null());
  EXPECT_EQ(k["tag"]["frames_since_seen"], 1);
  EXPECT_FALSE(k["pose"]["current"]);
  EXPECT_DOUBLE_EQ(k["pose"]["t_s"].get<double>(), 0.5);
}

TEST(LiveState, TrajectoryKeepsPointsAStepApartAndTheLatest) {
  LiveOptions o;
  o.trajectory_step_mm = 2.0;
  LiveState state(o);
  const cv::Mat grey(120, 160, CV_8UC1, cv::Scalar(128));
  for (int i = 0; i <= 100; ++i) state.OnFrame(grey, i * 0.1, std::nullopt, PoseAt(0.5 * i, 0.0));
  const json t = state.StateJson()["trajectory_mm"];
  // 0, 2, 4, ..., 50 mm: 26 points; the 0.5 mm steps in between are dropped.
  ASSERT_EQ(t.size(), 26u);
  EXPECT_DOUBLE_EQ(t[0][0].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(t[25][0].get<double>(), 50.0);
  for (size_t i = 1; i < t.size(); ++i) EXPECT_NEAR(t[i][0].get<double>() - t[i - 1][0].get<double>(), 2.0, 1e-9);
  state.ClearTrajectory();
  EXPECT_TRUE(state.StateJson()["trajectory_mm"].empty());
  // Replaced (a new camera model): the same thinning.
  state.SetTrajectory({{0, 0}, {1, 0}, {3, 0}, {3, 5}});
  EXPECT_EQ(state.StateJson()["trajectory_mm"], json::parse("[[0.0,0.0],[3.0,0.0],[3.0,5.0]]"));
}

TEST(LiveState, ALongTrajectoryIsThinnedNotCut) {
  LiveOptions o;
  o.trajectory_step_mm = 1.0;
  o.max_trajectory_points = 100;
  LiveState state(o);
  const cv::Mat grey(120, 160, CV_8UC1, cv::Scalar(128));
  // A circle of radius 500 mm driven three times, 1 mm a frame.
  const int n = static_cast<int>(3 * 2 * M_PI * 500);
  for (int i = 0; i < n; ++i) {
    const double a = i / 500.0;
    state.OnFrame(grey, i * 0.01, std::nullopt, PoseAt(500 * std::cos(a), 500 * std::sin(a)));
  }
  const json t = state.StateJson()["trajectory_mm"];
  EXPECT_LE(t.size(), 100u);
  EXPECT_GE(t.size(), 50u);
  // The start stays, and the path is whole: no gap longer than a few of its steps.
  EXPECT_NEAR(t[0][0].get<double>(), 500.0, 0.05);
  EXPECT_NEAR(t[0][1].get<double>(), 0.0, 0.05);
  double longest = 0.0;
  for (size_t i = 1; i < t.size(); ++i)
    longest = std::max(longest, std::hypot(t[i][0].get<double>() - t[i - 1][0].get<double>(),
                                           t[i][1].get<double>() - t[i - 1][1].get<double>()));
  EXPECT_LT(longest, 3 * (n / static_cast<double>(t.size())));
}

TEST(LiveState, ProgressAndEstimatesAsSet) {
  LiveState state;
  state.SetProgress(3, 8, "UMBMark cw, 1000 mm", "round 1: 4 cw + 4 ccw");
  state.SetEstimate("Ed", 1.0012, 0.0003, "");
  state.SetEstimate("Eb", 0.9978, 0.0005, "");
  state.SetEstimate("E_max,syst", 12.3, 0.8, "mm");
  state.SetEstimate("Ed", 1.0010, 0.0002, "");  // replaces, keeps its place
  const json j = state.StateJson();
  EXPECT_EQ(j["progress"]["run_index"], 3);
  EXPECT_EQ(j["progress"]["run_total"], 8);
  EXPECT_EQ(j["progress"]["run_label"], "UMBMark cw, 1000 mm");
  EXPECT_EQ(j["progress"]["plan_label"], "round 1: 4 cw + 4 ccw");
  ASSERT_EQ(j["estimates"].size(), 3u);
  EXPECT_EQ(j["estimates"][0]["name"], "Ed");
  EXPECT_DOUBLE_EQ(j["estimates"][0]["value"].get<double>(), 1.0010);
  EXPECT_DOUBLE_EQ(j["estimates"][0]["sigma"].get<double>(), 0.0002);
  EXPECT_EQ(j["estimates"][1]["name"], "Eb");
  EXPECT_EQ(j["estimates"][2]["name"], "E_max,syst");
  EXPECT_EQ(j["estimates"][2]["unit"], "mm");
}

TEST(LiveState, TagLostAfterNFramesWithoutIt) {
  LiveOptions o;
  o.lost_after_frames = 5;
  LiveState state(o);
  const Drawn d = DrawTag({320, 240}, 160, 120, 48);
  state.OnFrame(d.grey, 0.0, d.corners, std::nullopt);
  for (int i = 1; i <= 4; ++i) state.OnFrame(d.grey, i * 0.1, std::nullopt, std::nullopt);
  EXPECT_THAT(WarningKeys(state.StateJson()), ::testing::IsEmpty());
  state.OnFrame(d.grey, 0.5, std::nullopt, std::nullopt);
  const json j = state.StateJson();
  ASSERT_THAT(WarningKeys(j), ::testing::ElementsAre("tag_lost"));
  EXPECT_THAT(j["warnings"][0]["text"].get<std::string>(), HasSubstr("last 5 frames"));
  // Seen again: gone.
  state.OnFrame(d.grey, 0.6, d.corners, std::nullopt);
  EXPECT_THAT(WarningKeys(state.StateJson()), ::testing::IsEmpty());

  LiveState never(o);
  for (int i = 0; i < 5; ++i) never.OnFrame(d.grey, i * 0.1, std::nullopt, std::nullopt);
  const json n = never.StateJson();
  ASSERT_THAT(WarningKeys(n), ::testing::ElementsAre("tag_lost"));
  EXPECT_THAT(n["warnings"][0]["text"].get<std::string>(), HasSubstr("not found"));
}

TEST(LiveState, TooSmallBelowTheSizeTheRefinementNeeds) {
  EXPECT_DOUBLE_EQ(LiveOptions{}.min_side_px, 16.0);  // 2 px cells x 8 cells
  LiveState state;
  const Drawn small = DrawTag({320, 240}, 160, 120, 14);
  state.OnFrame(small.grey, 0.0, small.corners, std::nullopt);
  const json j = state.StateJson();
  ASSERT_THAT(WarningKeys(j), ::testing::ElementsAre("too_small"));
  EXPECT_THAT(j["warnings"][0]["text"].get<std::string>(), HasSubstr("14 px"));
  const Drawn fine = DrawTag({320, 240}, 160, 120, 40);
  state.OnFrame(fine.grey, 0.1, fine.corners, std::nullopt);
  EXPECT_THAT(WarningKeys(state.StateJson()), ::testing::IsEmpty());
}

TEST(LiveState, SharpnessIgnoresExposureAndFallsWithBlur) {
  const Drawn d = DrawTag({320, 240}, 160, 120, 64);
  cv::Mat soft;
  cv::GaussianBlur(d.grey, soft, cv::Size(), 0.7);
  const std::optional<double> sharp = TagSharpness(soft, d.corners);
  ASSERT_TRUE(sharp.has_value());
  cv::Mat dim;
  soft.convertTo(dim, CV_8U, 0.5, 20.0);  // half the light
  EXPECT_NEAR(*TagSharpness(dim, d.corners) / *sharp, 1.0, 0.05);
  cv::Mat blurred;
  cv::GaussianBlur(d.grey, blurred, cv::Size(), 2.5);
  EXPECT_LT(*TagSharpness(blurred, d.corners), 0.3 * *sharp);
  // A box mostly outside the image, or without contrast: no number.
  TagOutline off = d.corners;
  for (cv::Point2d& c : off) c -= cv::Point2d(150, 110);
  EXPECT_FALSE(TagSharpness(d.grey, off).has_value());
  EXPECT_FALSE(TagSharpness(cv::Mat(240, 320, CV_8UC1, cv::Scalar(90)), d.corners).has_value());
}

TEST(LiveState, BlurAgainstTheSessionsSharpFrames) {
  LiveOptions o;
  o.blur_min_frames = 10;
  LiveState state(o);
  const Drawn d = DrawTag({320, 240}, 160, 120, 64);
  cv::Mat sharp, blurred;
  cv::GaussianBlur(d.grey, sharp, cv::Size(), 0.7);
  cv::GaussianBlur(d.grey, blurred, cv::Size(), 2.5);
  // Blurred before there is a reference: no judgement yet.
  for (int i = 0; i < 5; ++i) state.OnFrame(blurred, i * 0.1, d.corners, std::nullopt);
  EXPECT_THAT(WarningKeys(state.StateJson()), ::testing::IsEmpty());
  for (int i = 0; i < 20; ++i) state.OnFrame(sharp, 1 + i * 0.1, d.corners, std::nullopt);
  EXPECT_THAT(WarningKeys(state.StateJson()), ::testing::IsEmpty());
  state.OnFrame(blurred, 3.0, d.corners, std::nullopt);
  const json j = state.StateJson();
  ASSERT_THAT(WarningKeys(j), ::testing::ElementsAre("blur"));
  EXPECT_THAT(j["warnings"][0]["text"].get<std::string>(), HasSubstr("% as sharp"));
  EXPECT_GT(j["tag"]["sharpness_reference"].get<double>(), j["tag"]["sharpness"].get<double>());
  state.OnFrame(sharp, 3.1, d.corners, std::nullopt);
  EXPECT_THAT(WarningKeys(state.StateJson()), ::testing::IsEmpty());
}

TEST(LiveState, TheProducersOwnWarningsByKey) {
  LiveState state;
  state.SetWarning("link", "robot link: no answer");
  state.SetWarning("source_ended", "the video ended");
  state.SetWarning("link", "robot link: no answer for 3 s");
  json j = state.StateJson();
  ASSERT_THAT(WarningKeys(j), ::testing::ElementsAre("link", "source_ended"));
  EXPECT_EQ(j["warnings"][0]["text"], "robot link: no answer for 3 s");
  state.ClearWarning("link");
  EXPECT_THAT(WarningKeys(state.StateJson()), ::testing::ElementsAre("source_ended"));
}

TEST(LiveState, FrameJpegIsScaledForThePageWithTheOutlineDrawn) {
  LiveState state;  // image_max_width_px 960
  const Drawn d = DrawTag({1920, 1080}, 1000, 500, 120);
  state.OnFrame(d.grey, 0.0, d.corners, std::nullopt);
  const std::optional<LiveJpeg> jpeg = state.FrameJpeg();
  ASSERT_TRUE(jpeg.has_value());
  EXPECT_EQ(jpeg->seq, 1);
  const cv::Mat image = cv::imdecode(*jpeg->bytes, cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 960);
  EXPECT_EQ(image.rows, 540);
  EXPECT_EQ(jpeg->width, 960);
  const json j = state.StateJson();
  EXPECT_EQ(j["frame"]["jpeg_width"], 960);
  EXPECT_EQ(j["frame"]["jpeg_height"], 540);
  // Magenta on each side's middle (scaled by 1/2), nowhere far from the tag.
  auto magenta = [&](cv::Point p) {
    const cv::Vec3b v = image.at<cv::Vec3b>(p);
    return v[0] > 180 && v[2] > 180 && v[1] < 90;
  };
  for (int i = 0; i < 4; ++i) {
    const cv::Point2d m = 0.5 * (d.corners[i] + d.corners[(i + 1) % 4]);
    const cv::Point shown(static_cast<int>(std::lround((m.x + 0.5) / 2 - 0.5)),
                          static_cast<int>(std::lround((m.y + 0.5) / 2 - 0.5)));
    bool near = false;
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) near = near || magenta(shown + cv::Point(dx, dy));
    EXPECT_TRUE(near) << "side " << i;
  }
  EXPECT_FALSE(magenta({100, 100}));
  // Encoded once per frame.
  EXPECT_EQ(state.FrameJpeg()->bytes, jpeg->bytes);
  state.OnFrame(d.grey, 0.1, std::nullopt, std::nullopt);
  EXPECT_EQ(state.FrameJpeg()->seq, 2);
}

TEST(LiveState, WaitForFrameWakesOnANewFrame) {
  LiveState state;
  EXPECT_FALSE(state.WaitForFrame(0, std::chrono::milliseconds(20)));
  const cv::Mat grey(48, 64, CV_8UC1, cv::Scalar(0));
  std::thread producer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    state.OnFrame(grey, 0.0, std::nullopt, std::nullopt);
  });
  EXPECT_TRUE(state.WaitForFrame(0, std::chrono::seconds(5)));
  producer.join();
  EXPECT_FALSE(state.WaitForFrame(1, std::chrono::milliseconds(10)));
}

TEST(LiveState, OptionsAreChecked) {
  std::string why;
  EXPECT_TRUE(LiveOptions{}.IsValid(&why)) << why;
  LiveOptions o;
  o.blur_ratio = 1.5;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_THAT(why, HasSubstr("blur_ratio"));
  o = LiveOptions{};
  o.lost_after_frames = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_THAT(why, HasSubstr("lost_after_frames"));
}

}  // namespace
}  // namespace odocal::live
