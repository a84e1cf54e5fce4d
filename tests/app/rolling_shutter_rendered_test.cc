// A rolling shutter on rendered video: the real binary renders a small
// session (640x480, 10 fps, one out-and-back of 16 s whose tag crosses the
// image's rows 0.16 to 0.83) with the renderer's rolling shutter, measures it
// from the H.264 video (`explain SESSION.yaml`: each frame's image row from
// the tag's corners) and explains it. The readout is the camera's
// `rolling_shutter_ms` (the physical one) or the scenario's hidden
// `{name: rolling_shutter, ms}` (rendered as the camera's); explain recovers
// it either way, and does not name it when the shutter is global.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

using test_util::CommandResult;
using test_util::Odocal;
using test_util::ReadJson;
using test_util::RunCommand;

// A whole-field camera 1.85 m over the tag; the robot drives 1.2 m along the
// image's columns and back (its rows change, at 400 mm/s).
std::string ScenarioText(const std::string& effects, const std::string& camera_extra) {
  return R"(seed: 5
robot:
  nominal: {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0, ticks_per_rev: 2048}
  true:    {left_wheel_diameter_mm: 69.95, right_wheel_diameter_mm: 70.06, track_mm: 303.0}
  start_pose: {x_mm: 0, y_mm: -600, heading_deg: 90}
  speed_mm_s: 400
  turn_rate_deg_s: 90
  rest_s: 1.0
  noise: {wheel_mm_per_sqrt_m: 0.05}
runs:
  - {procedure: out_and_back, distance_mm: 1200, repeats: 1}
effects: )" + effects + R"(
tag: {family: tag36h11, id: 5, size_mm: 100, height_mm: 150, offset_mm: {x: 0, y: 0}}
camera:
  width: 640
  height: 480
  fx: 450
  fy: 450
  cx: 320
  cy: 240
  distortion: [0, 0, 0, 0, 0]
  pose: {x_mm: 0, y_mm: 0, height_mm: 2000, roll_deg: 0, pitch_deg: 3, yaw_deg: 0}
  fps: 10
  noise_sigma: 2.0
  blur_sigma_px: 0.8
  exposure_ms: 4
)" + camera_extra;
}

nlohmann::json SimulateAndExplain(const std::string& name, const std::string& scenario) {
  const std::string dir = test_util::MakeTempDir("odocal_rs_" + name + "_");
  std::ofstream(dir + "/scenario.yaml") << scenario;
  const CommandResult sim =
      RunCommand(Odocal("simulate --scenario " + dir + "/scenario.yaml --out " + dir + "/sim"));
  EXPECT_EQ(sim.exit_code, 0) << sim.err;
  const CommandResult ex =
      RunCommand(Odocal("explain " + dir + "/sim/session.yaml --out " + dir + "/explain"));
  EXPECT_EQ(ex.exit_code, 0) << ex.err;
  std::printf("%s", ex.out.c_str());
  return ReadJson(dir + "/explain/explain.json");
}

// The first step names rolling_shutter with an interval that holds 20 ms and
// measures it (within +/-20 %).
void ExpectReadoutRecovered(const nlohmann::json& j, const std::string& label) {
  ASSERT_TRUE(j.contains("steps")) << label;
  ASSERT_FALSE(j["steps"].empty()) << label << ": nothing named";
  const nlohmann::json& step = j["steps"][0];
  ASSERT_EQ(step["effect"], "rolling_shutter") << label << " " << step.dump();
  const nlohmann::json& iv = step["interval95"]["ms"];
  ASSERT_TRUE(iv.is_array()) << label << " " << step.dump();
  std::printf("[figure] rendered rolling shutter (%s): %.3f ms [%.3f, %.3f] (truth 20)\n",
              label.c_str(), step["params"]["ms"].get<double>(), iv[0].get<double>(),
              iv[1].get<double>());
  EXPECT_LE(iv[0].get<double>(), 20.0) << label;
  EXPECT_GE(iv[1].get<double>(), 20.0) << label;
  EXPECT_LT(iv[1].get<double>() - iv[0].get<double>(), 0.4 * 20.0) << label;
  // It closes most of the gap the shutter opened (the rest is the rendered
  // camera's own systematic in motion, ~0.2 mm on this run with a global shutter).
  EXPECT_LT(j["gap_after_mm"].get<double>(), 0.5 * j["gap_before_mm"].get<double>()) << label;
}

TEST(RollingShutterRendered, TheCamerasReadoutIsNamedAndRecovered) {
  ExpectReadoutRecovered(SimulateAndExplain("camera", ScenarioText("[]", "  rolling_shutter_ms: 20\n")),
                         "camera.rolling_shutter_ms");
}

TEST(RollingShutterRendered, TheHiddenEffectIsRenderedAsTheCamerasAndRecovered) {
  ExpectReadoutRecovered(
      SimulateAndExplain("effect", ScenarioText("[{name: rolling_shutter, ms: 20}]", "")),
      "effects: rolling_shutter");
}

TEST(RollingShutterRendered, AGlobalShutterIsNotNamedOne) {
  const nlohmann::json j = SimulateAndExplain("global", ScenarioText("[]", ""));
  ASSERT_TRUE(j.contains("effects_added"));
  for (const auto& e : j["effects_added"]) EXPECT_NE(e, "rolling_shutter") << j["effects_added"].dump();
}

}  // namespace
}  // namespace odocal
