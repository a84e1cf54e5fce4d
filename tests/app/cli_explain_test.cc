// odocal explain end to end: the real binary on the files `odocal simulate`
// writes (through the stand-in camera), robot-side effects hidden in the
// scenario.
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

using test_util::RunCommand;

using test_util::Odocal;

using test_util::ReadJson;

TEST(CliExplain, NamesTheHiddenEffectsAndWritesTheReports) {
  const std::string sim = test_util::MakeTempDir("odocal_explain_sim_");
  const std::string out = test_util::MakeTempDir("odocal_explain_out_");
  const std::string scenario =
      test_util::SourceDir() + "/sample_data/scenarios/explain_drift_slip.yaml";
  ASSERT_EQ(RunCommand(Odocal("simulate --scenario " + scenario + " --out " + sim)).exit_code, 0);
  const auto r = RunCommand(Odocal("explain " + sim + " --out " + out));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::printf("%s", r.out.c_str());
  const nlohmann::json j = ReadJson(out + "/explain.json");
  for (const char* key : {"gap_before_mm", "steps", "gap_after_mm", "effects_added"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["effects_added"], nlohmann::json({"carpet_drift", "turn_slip"}));
  ASSERT_EQ(j["steps"].size(), 2u);
  for (const auto& step : j["steps"]) {
    for (const char* key : {"effect", "params", "gap_after_mm", "score", "cross_validation"})
      EXPECT_TRUE(step.contains(key)) << key;
    // Each named effect predicts the runs it was not fitted on better.
    const auto& cv = step["cross_validation"];
    EXPECT_EQ(cv["method"], "leave_one_run_out");
    EXPECT_EQ(cv["folds"], 5);
    EXPECT_LT(cv["heldout_rms_after_mm"].get<double>(),
              0.9 * cv["heldout_rms_before_mm"].get<double>());
  }
  // Parameters keyed as the scenario keys them, in its units.
  EXPECT_NEAR(j["steps"][0]["params"]["rate_mm_per_m"].get<double>(), 10.0, 0.5);
  EXPECT_NEAR(j["steps"][0]["params"]["grain_deg"].get<double>(), 30.0, 3.0);
  EXPECT_NEAR(j["steps"][1]["params"]["fraction_at_1rad_s"].get<double>(), 0.03, 0.002);
  EXPECT_LT(j["gap_after_mm"].get<double>(), j["gap_before_mm"].get<double>() / 3.0);
  // Both named: nothing structured remains.
  EXPECT_EQ(j["unexplained"], nlohmann::json::array());
  EXPECT_FALSE(j["remainder"]["significant"].get<bool>());
  // The truth it never read: Ed = 70.06 / 69.95, Eb = 303 / 300, within 3
  // of their own sigmas (this seed draws Eb at about 2 sigma)...
  const auto& p = j["final"]["parameters"];
  EXPECT_NEAR(p["Eb"]["value"].get<double>(), 1.01, 3.0 * p["Eb"]["sigma"].get<double>());
  EXPECT_NEAR(p["Ed"]["value"].get<double>(), 70.06 / 69.95, 3.0 * p["Ed"]["sigma"].get<double>());
  // ...and sigmas that say something: this scenario and seed give 95 %
  // half-widths of 4.7e-5 (Ed) and 3.6e-4 (Eb) (docs/explain.md), sigmas of
  // 2.4e-5 and 1.8e-4. Twice that would mean the fit lost three quarters of
  // its information, and 3 sigma would no longer test it.
  EXPECT_LT(p["Ed"]["sigma"].get<double>(), 5e-5);
  EXPECT_LT(p["Eb"]["sigma"].get<double>(), 4e-4);
  std::ifstream html(out + "/explain.html");
  std::stringstream page;
  page << html.rdbuf();
  EXPECT_EQ(page.str().rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_GE(static_cast<int>(page.str().find("<svg")), 0);
  EXPECT_THAT(page.str(), ::testing::Not(::testing::HasSubstr("src="))) << "self-contained";
}

TEST(CliExplain, BadInputIsOneClearLine) {
  const std::string out = test_util::MakeTempDir("odocal_explain_bad_");
  auto r = RunCommand(Odocal("explain /nonexistent/dir --out " + out));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr("odocal explain: /nonexistent/dir")) << r.err;
  r = RunCommand(Odocal("explain " + out + " --out " + out));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr("truth.json")) << r.err;
  r = RunCommand(Odocal("explain " + out + " --out " + out + " --camera-centre-mm 1"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr("--camera-centre-mm")) << r.err;
}

}  // namespace
}  // namespace odocal
