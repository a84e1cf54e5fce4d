// odocal check's work on a simulated session (stand-in camera): the true set
// replays the runs far better than the nominal one; a run with too few frames
// and a set that needs a camera geometry the session lacks are listed with
// their reasons, never with a number; the summary is over the runs replayed.
#include "odocal/report/check_report.h"

#include <cstdio>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "explain_fixtures.h"

namespace odocal::testing {
namespace {

using calibration::Direction;
using calibration::RunSpec;

TEST(CheckReport, ListsRunsAndSetsThatCannotBeReplayedWithTheirReason) {
  const std::vector<RunSpec> plan = {RunSpec::Umbmark(Direction::kCw, 1.0),
                                     RunSpec::Umbmark(Direction::kCcw, 1.0)};
  SessionUnderTest s = MakeSession(plan, {}, 5);
  ASSERT_EQ(s.session.runs.size(), 2u);
  // A third run the camera saw in three frames only, all in motion.
  calibration::MeasuredRun sparse = s.session.runs[0];
  sparse.name = "sparse";
  const size_t n = sparse.camera.size();
  for (size_t i = 0; i < n; ++i)
    if (i != n / 2 && i != n / 2 + 1 && i != n / 2 + 2) sparse.camera[i].valid = false;
  s.session.runs.push_back(sparse);
  s.session.camera.reset();

  const config::Scenario scenario = MakeScenario(plan, {}, 5);
  config::ReplaySet truth;
  truth.name = "truth";
  truth.kind = config::ParamFileKind::kFirmware;
  truth.model.scales = calibration::WheelScalesFrom(scenario.robot.nominal, scenario.robot.truth);
  config::ReplaySet lens = truth;
  lens.name = "lens";
  lens.kind = config::ParamFileKind::kExplain;
  lens.effects = {calibration::Effect::kLensDistortion};
  lens.model.effects.values[calibration::EffectParams::kK1] = 0.01;

  const report::CheckResult result = report::RunCheck(s.session, {config::NominalReplaySet(), truth, lens});
  EXPECT_EQ(result.Replayed(), 4);  // nominal and truth on the two squares
  const nlohmann::json j = report::CheckJson("simulated", s.session, result);
  ASSERT_EQ(j["runs"].size(), 3u);
  for (int k = 0; k < 2; ++k) {
    const nlohmann::json& run = j["runs"][k];
    const double nominal = run["results"][0]["final_position_error_mm"];
    const double true_set = run["results"][1]["final_position_error_mm"];
    std::printf("[figure] %s: nominal final %.3f mm, truth %.3f mm\n",
                run["name"].get<std::string>().c_str(), nominal, true_set);
    EXPECT_LT(true_set, nominal / 3.0);
    EXPECT_FALSE(run["results"][2]["ok"].get<bool>());
    EXPECT_THAT(run["results"][2]["reason"].get<std::string>(), ::testing::HasSubstr("lens"));
  }
  for (const nlohmann::json& r : j["runs"][2]["results"]) {
    EXPECT_FALSE(r["ok"].get<bool>());
    EXPECT_FALSE(r.contains("final_position_error_mm"));
    EXPECT_EQ(r["reason"].get<std::string>().rfind("sparse: ", 0), 0u) << r["reason"];
  }
  EXPECT_THAT(j["runs"][2]["results"][0]["reason"].get<std::string>(),
              ::testing::HasSubstr("valid frames"))
      << j["runs"][2]["results"][0]["reason"];
  EXPECT_EQ(j["not_replayed"].size(), 5u);  // sparse x 3 sets, lens x 2 squares

  // Summaries over the runs each set replayed.
  EXPECT_EQ(j["summary"][0]["runs"], 2);
  EXPECT_EQ(j["summary"][0]["not_replayed"], 1);
  const double a = j["runs"][0]["results"][1]["rms_error_mm"],
               b = j["runs"][1]["results"][1]["rms_error_mm"];
  EXPECT_NEAR(j["summary"][1]["rms_error_mm"]["mean"].get<double>(), 0.5 * (a + b), 1e-12);
  EXPECT_NEAR(j["summary"][1]["rms_error_mm"]["max"].get<double>(), std::max(a, b), 1e-12);
  EXPECT_EQ(j["summary"][2]["runs"], 0);
  EXPECT_TRUE(j["summary"][2]["final_position_error_mm"]["max"].is_null());

  const std::string table = report::CheckTable(j);
  EXPECT_THAT(table, ::testing::HasSubstr("sparse  nominal  not replayed")) << table;
  const std::string page = report::CheckHtml(j);
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_THAT(page, ::testing::HasSubstr("not replayed: sparse"));
  EXPECT_THAT(page, ::testing::Not(::testing::HasSubstr("src=")));
}

}  // namespace
}  // namespace odocal::testing
