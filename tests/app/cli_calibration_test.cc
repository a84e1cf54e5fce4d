// End to end: the real odocal binary on real files.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

using test_util::CommandResult;
using test_util::RunCommand;

using test_util::Odocal;

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string ScenarioPath(const std::string& name) {
  return test_util::SourceDir() + "/sample_data/scenarios/" + name;
}

std::string WriteScenario(const std::string& text) {
  const std::string path = test_util::MakeTempDir("odocal_cli_") + "/s.yaml";
  std::ofstream(path) << text;
  return path;
}

const char* kUmbmarkScenario = R"(seed: 3
robot:
  nominal: {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0, ticks_per_rev: 2048}
  true:    {left_wheel_diameter_mm: 69.9, right_wheel_diameter_mm: 70.1, track_mm: 306.0}
  speed_mm_s: 500
  turn_rate_deg_s: 120
  rest_s: 0.2
  noise: {wheel_mm_per_sqrt_m: 0}
runs:
  - {procedure: umbmark, direction: cw, side_mm: 1500}
  - {procedure: umbmark, direction: ccw, side_mm: 1500}
)";

TEST(CliSimulate, WritesTruthAndTelemetryByteForByte) {
  const std::string scenario = WriteScenario(kUmbmarkScenario);
  const std::string a = test_util::MakeTempDir("odocal_sim_a_");
  const std::string b = test_util::MakeTempDir("odocal_sim_b_");
  ASSERT_EQ(RunCommand(Odocal("simulate --scenario " + scenario + " --out " + a)).exit_code, 0);
  const CommandResult r = RunCommand(Odocal("simulate --scenario " + scenario + " --out " + b));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const auto& entry : std::filesystem::directory_iterator(a)) {
    const std::string name = entry.path().filename();
    EXPECT_EQ(ReadFile(a + "/" + name), ReadFile(b + "/" + name)) << name;
  }
  const nlohmann::json truth = nlohmann::json::parse(ReadFile(a + "/truth.json"));
  // Ed = (70.1/69.9) / 1, Eb = 306/300, Es = 1.
  EXPECT_NEAR(truth["truth"]["Ed"].get<double>(), 70.1 / 69.9, 1e-12);
  EXPECT_NEAR(truth["truth"]["Eb"].get<double>(), 1.02, 1e-12);
  EXPECT_NEAR(truth["truth"]["Es"].get<double>(), 1.0, 1e-12);
  ASSERT_EQ(truth["runs"].size(), 2u);
  const nlohmann::json& run = truth["runs"][0];
  EXPECT_EQ(run["procedure"], "umbmark");
  EXPECT_EQ(run["direction"], "cw");
  for (const char* key : {"true_start", "true_end", "odometry_end"}) {
    ASSERT_TRUE(run.contains(key)) << key;
    EXPECT_TRUE(run[key].contains("heading_deg")) << key;
  }
  // The return error is the true end in the true start frame; start is the origin here.
  EXPECT_NEAR(run["true_return_error"]["x_mm"].get<double>(), run["true_end"]["x_mm"].get<double>(), 1e-9);
  EXPECT_TRUE(std::filesystem::exists(a + "/" + run["telemetry"].get<std::string>()));
  // The second run starts where the first ended.
  EXPECT_NEAR(truth["runs"][1]["true_start"]["x_mm"].get<double>(),
              run["true_end"]["x_mm"].get<double>(), 1e-9);
}

TEST(CliUmbmark, SimulatedReturnErrorsGiveTheTruthBack) {
  const std::string scenario = WriteScenario(kUmbmarkScenario);
  const std::string dir = test_util::MakeTempDir("odocal_sim_");
  ASSERT_EQ(RunCommand(Odocal("simulate --scenario " + scenario + " --out " + dir)).exit_code, 0);
  const nlohmann::json truth = nlohmann::json::parse(ReadFile(dir + "/truth.json"));
  auto run_arg = [](const nlohmann::json& run) {
    const auto& e = run["true_return_error"];
    std::ostringstream os;
    os.precision(17);
    os << "--" << run["direction"].get<std::string>() << "=" << e["x_mm"].get<double>() << ","
       << e["y_mm"].get<double>() << "," << e["theta_deg"].get<double>();
    return os.str();
  };
  const CommandResult r =
      RunCommand(Odocal("umbmark --side-mm 1500 --track-mm 300 --json " + run_arg(truth["runs"][0]) +
                        " " + run_arg(truth["runs"][1])));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  for (const char* key : {"x_cg_cw_mm", "y_cg_cw_mm", "x_cg_ccw_mm", "y_cg_ccw_mm", "emax_syst_mm"})
    EXPECT_TRUE(j.contains(key)) << key;
  for (const char* fo : {"first_order_x", "first_order_y"})
    for (const char* key : {"alpha_deg", "beta_deg", "R_mm", "Ed", "Eb", "c_left", "c_right"})
      EXPECT_TRUE(j[fo].contains(key)) << fo << "." << key;
  for (const char* key : {"Ed", "Eb", "track_corrected_mm", "turn_scale", "c_left", "c_right"})
    EXPECT_TRUE(j["estimate"].contains(key)) << key;
  EXPECT_NEAR(j["estimate"]["Ed"].get<double>(), truth["truth"]["Ed"].get<double>(), 1e-5);
  EXPECT_NEAR(j["estimate"]["Eb"].get<double>(), truth["truth"]["Eb"].get<double>(), 1e-4);
  EXPECT_NEAR(j["estimate"]["track_corrected_mm"].get<double>(), 306.0, 0.03);
  EXPECT_THAT(j["quality"]["uncertainty"].get<std::string>(), ::testing::HasSubstr("none"));
}

TEST(CliUmbmark, RepeatedRunsPrintUncertaintyAndTheTableReadsWell) {
  const CommandResult r = RunCommand(Odocal(
      "umbmark --side-mm 2000 --track-mm 300 --cw=-120,-140 --cw=-124,-139 --cw=-121,-143 "
      "--ccw 139,-121 --ccw 141,-119 --ccw 138,-124 --left-diameter-mm 70 --right-diameter-mm 70 "
      "--ticks-per-rev 2048"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("E_max,syst")) << r.out;
  EXPECT_THAT(r.out, ::testing::HasSubstr("1-sigma")) << r.out;
  EXPECT_THAT(r.out, ::testing::HasSubstr("corrected parameters")) << r.out;
  EXPECT_THAT(r.out, ::testing::HasSubstr("wheel_separation_multiplier")) << r.out;
}

struct BadArgs {
  std::string name;  // the test's name
  std::string args;
  std::string expected;
};

void PrintTo(const BadArgs& c, std::ostream* os) { *os << "umbmark " << c.args; }

class CliUmbmarkErrors : public ::testing::TestWithParam<BadArgs> {};

TEST_P(CliUmbmarkErrors, OneClearLineAndNonZeroExit) {
  const CommandResult r = RunCommand(Odocal("umbmark " + GetParam().args));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, ::testing::HasSubstr(GetParam().expected)) << r.err;
  EXPECT_TRUE(r.out.empty()) << "no number without its quality: " << r.out;
}

INSTANTIATE_TEST_SUITE_P(
    BadInput, CliUmbmarkErrors,
    ::testing::Values(
        BadArgs{"ZeroSide", "--side-mm 0 --track-mm 300 --cw 1,2 --ccw 1,2", "side-mm"},
        BadArgs{"NegativeSide", "--side-mm -5 --track-mm 300 --cw 1,2 --ccw 1,2", "side-mm"},
        BadArgs{"ZeroTrack", "--side-mm 2000 --track-mm 0 --cw 1,2 --ccw 1,2", "track-mm"},
        BadArgs{"SideNotANumber", "--side-mm nan --track-mm 300 --cw 1,2 --ccw 1,2", "side-mm"},
        BadArgs{"CwNotANumber", "--side-mm 2000 --track-mm 300 --cw nan,2 --ccw 1,2", "--cw #1"},
        BadArgs{"UnequalCwAndCcw", "--side-mm 2000 --track-mm 300 --cw 1,2 --cw 3,4 --ccw 1,2", "cw/ccw"},
        BadArgs{"NoCw", "--side-mm 2000 --track-mm 300 --ccw 1,2", "--cw"},
        BadArgs{"CwWithOneValue", "--side-mm 2000 --track-mm 300 --cw 1 --ccw 1,2", "--cw #1"},
        BadArgs{"CwWithFourValues", "--side-mm 2000 --track-mm 300 --cw 1,2,3,4 --ccw 1,2", "--cw #1"},
        BadArgs{"ErrorsTooLargeForTheModel", "--side-mm 2000 --track-mm 300 --cw=-40000,0 --ccw 40000,0", "beta"}),
    [](const ::testing::TestParamInfo<BadArgs>& info) { return info.param.name; });

TEST(CliCvra, ThreeProceduresPrintTheirFactorsWithQuality) {
  CommandResult r = RunCommand(Odocal(
      "cvra ratio --reference wall --distance-mm 6000 --heading-deg 0.2 --heading-deg 0.22 "
      "--track-mm 300 --json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  nlohmann::json j = nlohmann::json::parse(r.out);
  // Ed = (D - delta b / 2) / (D + delta b / 2) for each run, then the mean.
  auto ed = [](double deg) {
    const double half = deg * M_PI / 180.0 * 300.0 / 2.0;
    return (6000.0 - half) / (6000.0 + half);
  };
  EXPECT_NEAR(j["Ed"].get<double>(), 0.5 * (ed(0.2) + ed(0.22)), 1e-12);
  EXPECT_FALSE(j["sigma_Ed"].is_null());
  EXPECT_EQ(j["n"], 2);

  r = RunCommand(Odocal("cvra scale --asked-mm 2000 --real-mm 2004 --json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j["diameter_factor"].get<double>(), 1.002, 1e-12);
  EXPECT_NEAR(j["ticks_per_mm_factor"].get<double>(), 1.0 / 1.002, 1e-12);
  EXPECT_TRUE(j["sigma_scale"].is_null());
  EXPECT_THAT(j["quality"].get<std::string>(), ::testing::HasSubstr("none"));

  r = RunCommand(Odocal("cvra track --reference wall --turns 10 --heading-deg 36 --track-mm 300"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // g = 1 + delta / (2 pi N) = 1 + 0.1 / 10.
  EXPECT_THAT(r.out, ::testing::HasSubstr("track_factor = 1.01")) << r.out;
  EXPECT_THAT(r.out, ::testing::HasSubstr("track_corrected_mm = 303")) << r.out;
}

TEST(CliCvra, BadInputNamesTheFlag) {
  CommandResult r = RunCommand(Odocal("cvra ratio --reference floor --distance-mm 1 --heading-deg 1 --track-mm 300"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, ::testing::HasSubstr("--reference")) << r.err;
  r = RunCommand(Odocal("cvra scale --asked-mm 2000"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, ::testing::HasSubstr("--real-mm or --end")) << r.err;
  r = RunCommand(Odocal("cvra track --reference camera --turns 0 --heading-deg 1"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, ::testing::HasSubstr("--turns")) << r.err;
}

TEST(CliSimulate, BadScenarioIsOneLineAndWritesNothing) {
  const std::string scenario = WriteScenario("seed: 1\nrobot: {}\nruns: []\n");
  const std::string out = test_util::MakeTempDir("odocal_out_") + "/sub";
  const CommandResult r = RunCommand(Odocal("simulate --scenario " + scenario + " --out " + out));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr("robot.nominal: missing")) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(CliDemo, TheMainJobImprovesEmaxFiftyTimes) {
  const std::string out = test_util::MakeTempDir("odocal_demo_");
  const CommandResult r =
      RunCommand(Odocal("demo --scenario " + ScenarioPath("demo.yaml") + " --out " + out));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = nlohmann::json::parse(ReadFile(out + "/report.json"));
  EXPECT_GT(report["improvement"].get<double>(), 50.0) << r.out;
  EXPECT_THAT(r.out, ::testing::HasSubstr("report: "));
  ASSERT_EQ(report["iterations"].size(), 2u);
  EXPECT_TRUE(report["iterations"][0]["pushed"].contains("track_mm"));
}

}  // namespace
}  // namespace odocal
