// The registry of candidate effects (calibration/effect_registry.h), walked:
// every Effect is registered once, under the name ToString gives it; its
// parameters are its own (the effect block's indices each owned by exactly
// one effect), named one by one, the tested ones among them; it says which
// runs tell it apart and what to do about it; what it needs of a session is
// said in words exactly when the session lacks it.
#include "odocal/calibration/effect_registry.h"

#include <algorithm>
#include <set>

#include <gtest/gtest.h>

#include "odocal/calibration/measured_session.h"

namespace odocal::calibration {
namespace {

TEST(EffectRegistry, EveryEffectOnceInOrderUnderItsName) {
  const auto& effects = Effects();
  ASSERT_EQ(effects.size(), kAllEffects.size());
  std::set<std::string_view> names;
  for (size_t i = 0; i < effects.size(); ++i) {
    EXPECT_EQ(effects[i].effect, kAllEffects[i]) << i;
    EXPECT_EQ(effects[i].name, ToString(kAllEffects[i]));
    EXPECT_TRUE(names.insert(effects[i].name).second) << effects[i].name << " twice";
    EXPECT_EQ(&Describe(kAllEffects[i]), &effects[i]);
    EXPECT_EQ(EffectNamed(effects[i].name), kAllEffects[i]);
  }
  EXPECT_FALSE(EffectNamed("warp_drive"));
}

TEST(EffectRegistry, EachParameterOfTheEffectBlockBelongsToOneEffect) {
  std::vector<int> owners(EffectParams::kSize, 0);
  for (const EffectDescriptor& d : Effects()) {
    ASSERT_FALSE(d.params.empty()) << d.name;
    EXPECT_EQ(d.param_names.size(), d.params.size()) << d.name;
    ASSERT_FALSE(d.tested.empty()) << d.name;
    for (int i : d.params) {
      ASSERT_GE(i, 0);
      ASSERT_LT(i, EffectParams::kSize);
      ++owners[static_cast<size_t>(i)];
    }
    for (int i : d.tested)
      EXPECT_NE(std::find(d.params.begin(), d.params.end(), i), d.params.end()) << d.name << " tests another's";
    EXPECT_EQ(EffectParamIndices(d.effect), d.params);
    EXPECT_EQ(EffectTestedIndices(d.effect), d.tested);
    EXPECT_EQ(EffectParamNames(d.effect).size(), d.params.size());
  }
  for (int i = 0; i < EffectParams::kSize; ++i) EXPECT_EQ(owners[static_cast<size_t>(i)], 1) << "index " << i;
}

TEST(EffectRegistry, EachSaysWhichRunsTellItApartAndWhatToDo) {
  for (const EffectDescriptor& d : Effects()) {
    EXPECT_GT(d.distinguishing_runs.size(), 20u) << d.name;
    EXPECT_GT(d.advice.size(), 20u) << d.name;
    EXPECT_EQ(DistinguishingRuns(d.effect), d.distinguishing_runs);
  }
}

TEST(EffectRegistry, WhatASessionLacksIsSaidOnlyWhenItLacksIt) {
  MeasuredSession bare;  // no camera geometry, no runs
  MeasuredSession seen;
  seen.camera = FloorCamera{};
  MeasuredRun run;
  CameraRecord frame;
  frame.valid = true;
  frame.image_row_fraction = 0.4;
  run.camera.push_back(frame);
  run.telemetry.push_back({0.0, 1234, 5678, {}});  // counts from power-on: the wheels' angle
  seen.runs.push_back(run);
  for (const EffectDescriptor& d : Effects()) {
    const std::string lacks = MissingInput(bare, d.effect);
    if (d.missing_input) {
      EXPECT_FALSE(lacks.empty()) << d.name << " needs something a bare session lacks";
    } else {
      EXPECT_TRUE(lacks.empty()) << d.name;
    }
    EXPECT_EQ(MissingInput(seen, d.effect), "") << d.name;
  }
  EXPECT_NE(MissingInput(bare, Effect::kLensDistortion).find("floor geometry"), std::string::npos);
  EXPECT_NE(MissingInput(bare, Effect::kRollingShutter).find("image row"), std::string::npos);
  // Counts that restart at every run (odocal's link) give no wheel angle.
  MeasuredSession restarted = seen;
  restarted.runs[0].telemetry[0].left_ticks = restarted.runs[0].telemetry[0].right_ticks = 0;
  EXPECT_EQ(MissingInput(restarted, Effect::kEccentricWheel), "") << "one run: its counts since power-on";
  restarted.runs.push_back(restarted.runs[0]);
  EXPECT_NE(MissingInput(restarted, Effect::kEccentricWheel).find("start at 0"), std::string::npos);
}

}  // namespace
}  // namespace odocal::calibration
