// Parameter files for `odocal check`: each kind, written by the code that
// writes it for real (exports.h, explain_report.h), comes back as the scales
// and effects it holds relative to the session's nominal set; bad files fail
// with one line naming the file and the key.
#include "odocal/config/param_files.h"

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "odocal/calibration/explain.h"
#include "odocal/report/explain_report.h"
#include "odocal/report/exports.h"
#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

using calibration::EffectParams;
using calibration::WheelParams;

WheelParams Nominal() {
  WheelParams p;
  p.left_wheel_diameter_m = 0.070;
  p.right_wheel_diameter_m = 0.070;
  p.track_m = 0.300;
  p.ticks_per_rev = 2048;
  return p;
}

WheelParams Corrected() {
  WheelParams p = Nominal();
  p.left_wheel_diameter_m = 0.06995;
  p.right_wheel_diameter_m = 0.07006;
  p.track_m = 0.303;
  return p;
}

std::string Write(const std::string& name, const std::string& text) {
  static const std::string dir = test_util::MakeTempDir("odocal_param_files_");
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

std::optional<config::ReplaySet> Read(const std::string& path, std::string* error,
                             const WheelParams& believed = Nominal()) {
  const Result<config::ParamSpec> spec = config::ParseParamSpec(path);
  if (!spec) {
    *error = spec.message;
    return std::nullopt;
  }
  Result<config::ReplaySet> set = config::ReadReplaySet(*spec, believed);
  if (!set) {
    *error = set.message;
    return std::nullopt;
  }
  return std::move(*set.value);
}

// `tol`: the exports write 9 significant digits.
void ExpectScales(const config::ReplaySet& set, double r_left, double r_right, double eb,
                  double tol = 1e-8) {
  EXPECT_NEAR(set.model.scales.r_left, r_left, tol);
  EXPECT_NEAR(set.model.scales.r_right, r_right, tol);
  EXPECT_NEAR(set.model.scales.Eb, eb, tol);
}

TEST(ParamFiles, FirmwareExportGivesTheRatiosToTheNominalSet) {
  std::string error;
  const auto set = Read(Write("firmware.yaml", report::FirmwareExportYaml(Corrected())), &error);
  ASSERT_TRUE(set) << error;
  EXPECT_EQ(set->kind, config::ParamFileKind::kFirmware);
  EXPECT_EQ(set->name, "firmware");
  ExpectScales(*set, 69.95 / 70.0, 70.06 / 70.0, 303.0 / 300.0);
  for (double v : set->model.effects.values) EXPECT_NEAR(v, 0.0, 1e-15);
  const WheelParams back = set->Equivalent(Nominal());
  EXPECT_THAT(back, test_util::IsNearWheelParams(Corrected(), 1e-9));  // 1e-12 m
}

TEST(ParamFiles, FirmwareTicksPerRevCountsInTheMetresPerTick) {
  // Twice the ticks for the same wheel: each tick is half as far.
  WheelParams p = Nominal();
  p.ticks_per_rev = 4096;
  std::string error;
  const auto set = Read(Write("ticks.yaml", report::FirmwareExportYaml(p)), &error);
  ASSERT_TRUE(set) << error;
  ExpectScales(*set, 0.5, 0.5, 1.0);
  // A fractional gear ratio stays fractional (64 x 43.7 = 2796.8).
  p = Nominal();
  p.ticks_per_rev = 2796.8;
  const auto geared = Read(Write("geared.yaml", report::FirmwareExportYaml(p)), &error);
  ASSERT_TRUE(geared) << error;
  EXPECT_NEAR(geared->model.scales.r_left, 2048.0 / 2796.8, 1e-12);
}

TEST(ParamFiles, Ros2MultipliersAreTheScales) {
  std::string error;
  const auto set = Read(Write("ros2.yaml", report::Ros2ExportYaml(Nominal(), Corrected())), &error);
  ASSERT_TRUE(set) << error;
  EXPECT_EQ(set->kind, config::ParamFileKind::kRos2);
  ExpectScales(*set, 69.95 / 70.0, 70.06 / 70.0, 303.0 / 300.0);
}

TEST(ParamFiles, Ros2FileWithOtherControllerParametersIsAccepted) {
  std::string error;
  const auto set = Read(Write("controller.yaml",
                              "diff_drive_controller:\n"
                              "  ros__parameters:\n"
                              "    wheel_radius: 0.035\n"
                              "    wheel_separation: 0.3\n"
                              "    wheel_separation_multiplier: 1.01\n"
                              "    left_wheel_radius_multiplier: 0.999\n"
                              "    right_wheel_radius_multiplier: 1.001\n"),
                        &error);
  ASSERT_TRUE(set) << error;
  ExpectScales(*set, 0.999, 1.001, 1.01);
}

// An explain.json as odocal explain writes it, from a result whose final fit
// holds these parameters (named as FitTrajectory names them).
// `fitted_on` is the session's believed set (explain.json states it).
std::string ExplainJsonText(double ed, double es, double eb, const WheelParams& fitted_on) {
  calibration::ExplainResult r;
  r.status = odocal::StatusCode::kOk;
  auto add = [&](const std::string& name, double value) {
    calibration::ParameterEstimate p;
    p.name = name;
    p.value = value;
    p.sigma = 1e-4;
    r.final_fit.parameters.push_back(p);
  };
  add("Ed", ed);
  add("Es", es);
  add("Eb", eb);
  add("turn_gain", eb / es);
  add("carpet_drift.grain_rad", 30.0 * M_PI / 180.0);
  add("carpet_drift.rate_m_per_m", 0.01);
  add("turn_slip.fraction_at_1rad_s", 0.03);
  add("tag_offset.x_m", 0.030);
  add("tag_offset.y_m", -0.015);
  for (auto e : {calibration::Effect::kCarpetDrift, calibration::Effect::kTurnSlip,
                 calibration::Effect::kTagOffset}) {
    calibration::ExplainStep s;
    s.effect = e;
    r.steps.push_back(s);
  }
  calibration::MeasuredSession session;
  session.believed = fitted_on;
  return report::ExplainJson(session, r).dump(2);
}

TEST(ParamFiles, ExplainJsonGivesTheFinalFitsScalesAndEffects) {
  // Unequal nominal wheels, so that Es weighs them: r_l = 0.999, r_r = 1.002.
  WheelParams believed = Nominal();
  believed.right_wheel_diameter_m = 0.071;
  const double rl = 0.999, rr = 1.002, dl = 0.070, dr = 0.071;
  const double es = (rl * dl + rr * dr) / (dl + dr);
  std::string error;
  const auto set =
      Read(Write("explain.json", ExplainJsonText(rr / rl, es, 1.012, believed)), &error, believed);
  ASSERT_TRUE(set) << error;
  EXPECT_EQ(set->kind, config::ParamFileKind::kExplain);
  EXPECT_EQ(set->name, "explain");
  ExpectScales(*set, rl, rr, 1.012);
  ASSERT_EQ(set->effects.size(), 3u);
  const EffectParams& fx = set->model.effects;
  EXPECT_NEAR(fx.drift_rate_m_per_m(), 0.01, 1e-12);
  EXPECT_NEAR(fx.drift_grain_rad(), 30.0 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(fx.slip_fraction_at_1rad_s(), 0.03, 1e-12);
  EXPECT_NEAR(fx.tag_x_m(), 0.030, 1e-12);
  EXPECT_NEAR(fx.tag_y_m(), -0.015, 1e-12);
  EXPECT_NEAR(fx.latency_s(), 0.0, 1e-15);  // not named: off
}

// The same robot recorded believing other parameters: the physical set the
// fit stands for is re-expressed relative to this session's beliefs.
TEST(ParamFiles, ExplainJsonFromOtherBeliefsGivesTheSamePhysicalRobot) {
  WheelParams fitted_on = Nominal();
  fitted_on.track_m *= 1.025;  // believed 2.5 % wider, wheels 1.2 % larger
  fitted_on.left_wheel_diameter_m *= 1.012;
  fitted_on.right_wheel_diameter_m *= 1.012;
  const double rl = 0.990, rr = 0.992, eb = 0.98;
  const double es = (rl * fitted_on.left_wheel_diameter_m + rr * fitted_on.right_wheel_diameter_m) /
                    (fitted_on.left_wheel_diameter_m + fitted_on.right_wheel_diameter_m);
  std::string error;
  const WheelParams here = Nominal();
  const auto set =
      Read(Write("explain_other.json", ExplainJsonText(rr / rl, es, eb, fitted_on)), &error, here);
  ASSERT_TRUE(set) << error;
  // Physical travel per tick and track, whichever beliefs they are written against.
  EXPECT_NEAR(here.LeftMetresPerTick() * set->model.scales.r_left,
              fitted_on.LeftMetresPerTick() * rl, 1e-15);
  EXPECT_NEAR(here.RightMetresPerTick() * set->model.scales.r_right,
              fitted_on.RightMetresPerTick() * rr, 1e-15);
  EXPECT_NEAR(here.track_m * set->model.scales.Eb, fitted_on.track_m * eb, 1e-12);
}

TEST(ParamFiles, NameEqualsFileNamesTheSet) {
  std::string error;
  const std::string path = Write("firmware2.yaml", report::FirmwareExportYaml(Corrected()));
  const auto spec = config::ParseParamSpec("corrected=" + path);
  ASSERT_TRUE(spec) << spec.message;
  EXPECT_EQ(spec->name, "corrected");
  EXPECT_EQ(spec->path, path);
  // A path with '=' after a directory is a path, named by its stem.
  const auto plain = config::ParseParamSpec("out/a=b/set.yaml");
  ASSERT_TRUE(plain);
  EXPECT_EQ(plain->path, "out/a=b/set.yaml");
  EXPECT_EQ(plain->name, "set");
  error = test_util::ErrorOf(config::ParseParamSpec("name="));
  EXPECT_THAT(error, ::testing::HasSubstr("name=")) << error;
}

void ExpectFails(const std::string& path, const std::vector<std::string>& words) {
  std::string error;
  EXPECT_FALSE(Read(path, &error)) << path;
  EXPECT_EQ(error.rfind(path, 0), 0u) << "names the file first: " << error;
  for (const std::string& w : words) EXPECT_THAT(error, ::testing::HasSubstr(w)) << error;
}

TEST(ParamFiles, BadFilesNameTheFileAndTheKey) {
  ExpectFails("/nonexistent/params.yaml", {"no such file"});
  ExpectFails(Write("unknown.yaml", "wheel: 70\nspeed: 2\n"),
              {"no parameter set", "wheel", "left_wheel_diameter_mm", "diff_drive_controller"});
  ExpectFails(Write("list.yaml", "- 1\n- 2\n"), {"no parameter set"});
  ExpectFails(Write("broken.yaml", "a: [1, 2\n"), {"not valid YAML"});
  ExpectFails(Write("negative.yaml",
                    "left_wheel_diameter_mm: -70\nright_wheel_diameter_mm: 70\n"
                    "track_mm: 300\nticks_per_rev: 2048\n"),
              {"left_wheel_diameter_mm", "positive"});
  ExpectFails(Write("missing.yaml",
                    "left_wheel_diameter_mm: 70\nright_wheel_diameter_mm: 70\nticks_per_rev: 2048\n"),
              {"track_mm", "missing"});
  ExpectFails(Write("typo.yaml",
                    "left_wheel_diameter_mm: 70\nright_wheel_diameter_mm: 70\n"
                    "track_mm: 300\nticks_per_rev: 2048\ntrack_mm_: 301\n"),
              {"track_mm_"});
  ExpectFails(Write("ros2_missing.yaml",
                    "diff_drive_controller:\n  ros__parameters:\n"
                    "    wheel_separation_multiplier: 1.01\n    left_wheel_radius_multiplier: 1\n"),
              {"right_wheel_radius_multiplier", "missing"});
  ExpectFails(Write("ros2_zero.yaml",
                    "diff_drive_controller:\n  ros__parameters:\n"
                    "    wheel_separation_multiplier: 0\n    left_wheel_radius_multiplier: 1\n"
                    "    right_wheel_radius_multiplier: 1\n"),
              {"wheel_separation_multiplier", "positive"});
  ExpectFails(Write("ros2_no_params.yaml", "diff_drive_controller:\n  update_rate: 50\n"),
              {"ros__parameters", "missing"});
  ExpectFails(Write("explain_no_es.json", R"({"final": {"parameters": {"Ed": {"value": 1.0},
              "Eb": {"value": 1.0}}}, "effects_added": []})"),
              {"final.parameters.Es", "missing"});
  ExpectFails(Write("explain_negative.json", R"({"final": {"parameters": {"Ed": {"value": 1.0},
              "Es": {"value": -1.0}, "Eb": {"value": 1.0}}}, "effects_added": []})"),
              {"final.parameters.Es.value", "positive"});
  ExpectFails(Write("explain_effect.json", R"({"final": {"parameters": {"Ed": {"value": 1.0},
              "Es": {"value": 1.0}, "Eb": {"value": 1.0}}}, "effects_added": ["turn_slip"]})"),
              {"turn_slip.fraction_at_1rad_s", "missing"});
  ExpectFails(Write("explain_unknown.json", R"({"final": {"parameters": {"Ed": {"value": 1.0},
              "Es": {"value": 1.0}, "Eb": {"value": 1.0}}}, "effects_added": ["gremlins"]})"),
              {"effects_added", "gremlins"});
}

}  // namespace
}  // namespace odocal
