// live::TagWatch (odocal watch's pipeline) against rendered truth: a camera
// tilted 4 deg and hung 1400 mm up, guessed level at 1200 mm; after the
// plane's views the page's pose, height and tilt are the renderer's.
#include "odocal/live/tag_watch.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "odocal/calibration/pose2.h"
#include "odocal/vision/renderer.h"

namespace odocal::live {
namespace {

constexpr double kTrueHeightMm = 1400.0, kTruePitchDeg = 4.0;

vision::CameraModel TrueCamera() {
  return vision::CameraModel(vision::Intrinsics{640, 480, 600.0, 600.0, 320.0, 240.0, {-0.1, 0.03, 0.0, 0.0, 0.0}},
                             vision::CameraMount{0.0, 0.0, kTrueHeightMm, 0.0, kTruePitchDeg, 0.0});
}

vision::TagSpec Tag() {
  vision::TagSpec tag;
  tag.family = "tag36h11";
  tag.id = 3;
  tag.size_mm = 100.0;
  tag.height_mm = 120.0;
  return tag;
}

const nlohmann::json* Estimate(const nlohmann::json& state, const std::string& name) {
  for (const nlohmann::json& e : state["estimates"])
    if (e["name"] == name) return &e;
  return nullptr;
}

TEST(TagWatch, FitsTheCameraOnceAndMeasuresTheTagOnItsPlane) {
  const vision::TagSpec tag = Tag();
  vision::RenderOptions o;
  o.noise_sigma = 1.0;
  o.blur_sigma_px = 0.7;
  auto rendered = vision::Renderer::Create(TrueCamera(), tag, o);
  ASSERT_TRUE(rendered.ok()) << rendered.message;
  LiveState state;
  const vision::CameraMount guess{0.0, 0.0, 1200.0, 0.0, 0.0, 0.0};  // level, 200 mm low
  auto watch = TagWatch::Create(tag, TrueCamera().intrinsics(), guess, &state);
  ASSERT_TRUE(watch) << watch.message;
  // The tag drives a slow arc through the view: 40 frames, more than the plane's 30.
  calibration::Pose2 last;
  for (int i = 0; i < 40; ++i) {
    last = calibration::Pose2::FromXYHeading(-0.25 + 0.0125 * i, 0.1 * std::sin(0.08 * i), 0.02 * i);
    const vision::RenderedFrame frame = rendered.renderer->Render(last);
    ASSERT_TRUE(frame.tag_visible) << i;
    (*watch)->OnFrame(frame.image, i / 30.0);
  }
  EXPECT_EQ((*watch)->frames(), 40);
  EXPECT_EQ((*watch)->found(), 40);
  const nlohmann::json s = state.StateJson();
  const nlohmann::json* height = Estimate(s, "camera height");
  const nlohmann::json* pitch = Estimate(s, "camera pitch");
  ASSERT_NE(height, nullptr) << s.dump();
  ASSERT_NE(pitch, nullptr) << "the plane was not fitted: " << s.dump();
  EXPECT_NEAR(height->at("value").get<double>(), kTrueHeightMm, 1.0);
  EXPECT_NEAR(pitch->at("value").get<double>(), kTruePitchDeg, 0.05);
  EXPECT_GT(height->at("sigma").get<double>(), 0.0);
  // The last frame's pose, measured on the fitted plane.
  ASSERT_TRUE(s.contains("pose") && !s["pose"].is_null()) << s.dump();
  std::printf(
      "[figure] height %.2f mm (sigma %.2f), pitch %.3f deg, last pose %.2f %.2f mm %.3f deg (truth %.2f %.2f, %.3f)\n",
      height->at("value").get<double>(), height->at("sigma").get<double>(), pitch->at("value").get<double>(),
      s["pose"]["x_mm"].get<double>(), s["pose"]["y_mm"].get<double>(), s["pose"]["heading_deg"].get<double>(),
      last.x() * 1e3, last.y() * 1e3, last.heading() * 180.0 / M_PI);
  EXPECT_NEAR(s["pose"]["x_mm"].get<double>(), last.x() * 1e3, 1.0);
  EXPECT_NEAR(s["pose"]["y_mm"].get<double>(), last.y() * 1e3, 1.0);
  EXPECT_NEAR(s["pose"]["heading_deg"].get<double>(), last.heading() * 180.0 / M_PI, 0.05);
}

TEST(TagWatch, AnotherTagInViewIsSaidAndNoPoseIsMade) {
  vision::TagSpec shown = Tag();
  auto rendered = vision::Renderer::Create(TrueCamera(), shown, {});
  ASSERT_TRUE(rendered.ok()) << rendered.message;
  vision::TagSpec asked = shown;
  asked.id = 4;
  LiveState state;
  auto watch = TagWatch::Create(asked, TrueCamera().intrinsics(), std::nullopt, &state);
  ASSERT_TRUE(watch) << watch.message;
  for (int i = 0; i < 3; ++i)
    (*watch)->OnFrame(rendered.renderer->Render(calibration::Pose2::FromXYHeading(0.0, 0.0, 0.0)).image, i / 30.0);
  EXPECT_EQ((*watch)->found(), 0);
  const nlohmann::json s = state.StateJson();
  EXPECT_NE(s.dump().find("not id 4"), std::string::npos) << s.dump();
}

TEST(TagWatch, AnUnknownFamilyIsRefused) {
  vision::TagSpec tag = Tag();
  tag.family = "tag99h1";
  LiveState state;
  auto watch = TagWatch::Create(tag, TrueCamera().intrinsics(), std::nullopt, &state);
  EXPECT_FALSE(watch);
  EXPECT_EQ(watch.status, StatusCode::kInvalidArgument);
  EXPECT_FALSE(watch.message.empty());
}

}  // namespace
}  // namespace odocal::live
