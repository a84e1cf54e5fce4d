// batch's --estimator on the command line: the default, auto, on the
// committed sample session (real H.264 videos) with its telemetry removed:
// nothing can be replayed, so nothing is cross-validated; batch keeps
// umbmark, says why on the terminal and in report.json, exits 0 and exports
// what it exported before auto. An unknown name is refused before anything
// is measured. (Auto's choice on cross-validated runs: tests/measure/
// estimator_choice_test.cc on simulated robots, tests/app/realdata_optiodom_test.cc
// on the real one.)
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

namespace fs = std::filesystem;
using test_util::Odocal;
using test_util::RunCommand;
using ::testing::HasSubstr;

TEST(BatchEstimatorCli, AutoWithoutTelemetryKeepsUmbmarkAndSaysWhy) {
  const std::string dir = test_util::MakeTempDir("odocal_batch_auto_");
  fs::copy(test_util::SourceDir() + "/sample_data/session", dir + "/s", fs::copy_options::recursive);
  // The runs without their telemetry keys.
  std::istringstream in(test_util::Slurp(dir + "/s/session.yaml"));
  std::string text, line;
  while (std::getline(in, line)) {
    const size_t at = line.find(", telemetry: ");
    if (at != std::string::npos) {
      const size_t end = line.find(',', at + 2);
      line.erase(at, end - at);
    }
    text += line + "\n";
  }
  ASSERT_THAT(text, ::testing::Not(HasSubstr("telemetry")));
  std::ofstream(dir + "/s/session.yaml") << text;

  const test_util::CommandResult r =
      RunCommand(Odocal("batch " + dir + "/s/session.yaml --out " + dir + "/b --export firmware " + dir + "/fw.yaml"));
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_THAT(r.out, HasSubstr("estimator: umbmark (auto). umbmark (the default before auto): no run has telemetry"));
  const nlohmann::json report = test_util::ReadJson(dir + "/b/report.json");
  ASSERT_TRUE(report.contains("estimator_choice"));
  const nlohmann::json& c = report["estimator_choice"];
  EXPECT_EQ(c["chosen"], "umbmark");
  EXPECT_FALSE(c["cross_validated"].get<bool>());
  EXPECT_THAT(c["why"].get<std::string>(), HasSubstr("telemetry"));
  EXPECT_EQ(report["corrected_from"], "umbmark");
  EXPECT_FALSE(report.contains("trajectory_fit")) << "no telemetry, no trajectory fit";
  for (const nlohmann::json& k : c["candidates"]) EXPECT_TRUE(k["heldout_final_error_mm"].is_null());
  // What was exported is UMBMark's correction, as before auto.
  EXPECT_TRUE(fs::exists(dir + "/fw.yaml"));
  EXPECT_NEAR(report["corrected"]["track_mm"].get<double>(),
              report["umbmark"]["track_mm"].get<double>() * report["umbmark"]["estimate"]["Eb"].get<double>(), 1e-6);
}

TEST(BatchEstimatorCli, AnUnknownEstimatorIsRefused) {
  const std::string dir = test_util::MakeTempDir("odocal_batch_bad_");
  const test_util::CommandResult r = RunCommand(
      Odocal("batch " + test_util::SourceDir() + "/sample_data/session/session.yaml --out " + dir +
             "/b --estimator best"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("--estimator"));
  EXPECT_FALSE(fs::exists(dir + "/b/report.json"));
}

}  // namespace
}  // namespace odocal
