// odocal check end to end on the committed sample session (real H.264 videos,
// a robot with Ed ~ 1.0016 and Eb 1.01 whose squares do not close): the set
// `odocal batch --export firmware` corrected must replay the runs far better
// than the nominal one, and the renderer's true set (written here as a
// firmware file) at the session's noise level; the same correction as ROS 2
// multipliers gives the same errors, and explain's fit (explain.json) holds
// too. Runs that cannot be replayed are listed with their reason; bad input
// fails with one line naming the file.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "odocal/config/session.h"
#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

using test_util::Odocal;
using test_util::RunCommand;

std::string SamplePath() { return test_util::SourceDir() + "/sample_data/session/session.yaml"; }

using test_util::ReadJson;
using test_util::Slurp;

// The result of `set` for `run` in check.json.
const nlohmann::json& Result(const nlohmann::json& run, const std::string& set) {
  for (const nlohmann::json& r : run["results"])
    if (r["set"] == set) return r;
  ADD_FAILURE() << "no result for set " << set << " in run " << run["name"];
  static const nlohmann::json kNone;
  return kNone;
}

// The true parameters of the sample session in the firmware export's names.
std::string TruthFirmwareYaml() {
  const nlohmann::json truth =
      ReadJson(test_util::SourceDir() + "/sample_data/session_truth/truth.json");
  const nlohmann::json& t = truth["robot"]["true"];
  std::ostringstream os;
  os.precision(10);
  os << "# the renderer's true parameters (sample_data/session_truth/truth.json)\n"
     << "left_wheel_diameter_mm: " << t["left_wheel_diameter_mm"].get<double>() << "\n"
     << "right_wheel_diameter_mm: " << t["right_wheel_diameter_mm"].get<double>() << "\n"
     << "track_mm: " << t["track_mm"].get<double>() << "\n"
     << "ticks_per_rev: " << t["ticks_per_rev"].get<double>() << "\n";
  return os.str();
}

TEST(CheckCli, CorrectedSetHoldsAndTheTrueSetIsAtTheNoiseLevel) {
  const std::string dir = test_util::MakeTempDir("odocal_check_");
  auto r = RunCommand(Odocal("batch " + SamplePath() + " --out " + dir + "/batch --export firmware " +
                             dir + "/corrected.yaml --export ros2 " + dir + "/ros2.yaml"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // explain's whole-trajectory fit of the same session, read from its explain.json.
  r = RunCommand(Odocal("explain " + SamplePath() + " --out " + dir + "/explain"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ofstream(dir + "/truth.yaml") << TruthFirmwareYaml();
  r = RunCommand(Odocal("check " + SamplePath() + " --params " + dir + "/corrected.yaml --params " +
                        dir + "/ros2.yaml --params truth=" + dir + "/truth.yaml --params fit=" +
                        dir + "/explain/explain.json --out " + dir + "/check"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::printf("%s", r.out.c_str());
  EXPECT_THAT(r.out, ::testing::HasSubstr("nominal"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("truth"));

  const nlohmann::json j = ReadJson(dir + "/check/check.json");
  ASSERT_EQ(j["sets"].size(), 5u);
  EXPECT_EQ(j["sets"][0]["name"], "nominal");
  EXPECT_EQ(j["sets"][1]["name"], "corrected");
  EXPECT_EQ(j["sets"][1]["kind"], "firmware");
  EXPECT_EQ(j["sets"][2]["kind"], "ros2");
  EXPECT_EQ(j["sets"][4]["kind"], "explain");
  EXPECT_TRUE(j["not_replayed"].empty()) << j["not_replayed"].dump();
  ASSERT_EQ(j["runs"].size(), 2u);
  for (const nlohmann::json& run : j["runs"]) {
    const std::string name = run["name"];
    const nlohmann::json &nominal = Result(run, "nominal"), &corrected = Result(run, "corrected"),
                         &ros2 = Result(run, "ros2"), &truth = Result(run, "truth"),
                         &fit = Result(run, "fit");
    for (const nlohmann::json* res : {&nominal, &corrected, &ros2, &truth, &fit})
      ASSERT_TRUE((*res)["ok"].get<bool>()) << name << ": " << res->dump();
    const double e_nominal = nominal["final_position_error_mm"];
    const double e_corrected = corrected["final_position_error_mm"];
    const double e_truth = truth["final_position_error_mm"];
    std::printf("[figure] %s final error: nominal %.3f mm %.3f deg, corrected %.3f mm %.4f deg, "
                "truth %.3f mm %.4f deg\n",
                name.c_str(), e_nominal, nominal["final_heading_error_deg"].get<double>(),
                e_corrected, corrected["final_heading_error_deg"].get<double>(), e_truth,
                truth["final_heading_error_deg"].get<double>());
    // The nominal robot misses by centimetres on a 300 mm square (the
    // squares do not close: ~10 mm return errors, ~3.5 deg).
    EXPECT_GT(e_nominal, 5.0) << name;
    EXPECT_GT(std::abs(nominal["final_heading_error_deg"].get<double>()), 2.0) << name;
    EXPECT_LT(e_corrected, e_nominal / 10.0) << name;
    EXPECT_LT(corrected["rms_error_mm"].get<double>(), nominal["rms_error_mm"].get<double>() / 10.0)
        << name;
    // The same correction written as ROS 2 multipliers replays the same
    // (the files carry 9 significant digits).
    EXPECT_NEAR(ros2["final_position_error_mm"].get<double>(), e_corrected, 1e-3) << name;
    EXPECT_LT(fit["final_position_error_mm"].get<double>(), e_nominal / 10.0) << name;
    // Truth at the session's noise level: the camera measures return errors
    // within ~0.02 mm, and the wheels' own noise (0.05 mm/sqrt(m), which no
    // parameter set predicts) walks the heading by ~0.3 mrad over a 2.1 m
    // square through the 300 mm track: a few tenths of a millimetre.
    EXPECT_LT(e_truth, 0.6) << name;
    EXPECT_LT(std::abs(truth["final_heading_error_deg"].get<double>()), 0.05) << name;
    EXPECT_LT(truth["rms_error_mm"].get<double>(), 0.5) << name;
    // Distance: the 4 x 300 mm legs plus the wheels' travel in 4 spins of 90 deg.
    EXPECT_NEAR(run["distance_mm"].get<double>(), 1200.0 + 4.0 * 0.25 * M_PI * 300.0, 20.0) << name;
    EXPECT_NEAR(nominal["final_error_percent"].get<double>(),
                100.0 * e_nominal / run["distance_mm"].get<double>(), 1e-9);
    EXPECT_GT(run["measured_mm"].size(), 100u);
    EXPECT_GT(truth["predicted_mm"].size(), 100u);
  }
  // The summary is the max and mean over the runs.
  for (size_t s = 0; s < j["summary"].size(); ++s) {
    const nlohmann::json& summary = j["summary"][s];
    EXPECT_EQ(summary["runs"], 2);
    const double a = j["runs"][0]["results"][s]["final_position_error_mm"];
    const double b = j["runs"][1]["results"][s]["final_position_error_mm"];
    EXPECT_NEAR(summary["final_position_error_mm"]["max"].get<double>(), std::max(a, b), 1e-9);
    EXPECT_NEAR(summary["final_position_error_mm"]["mean"].get<double>(), 0.5 * (a + b), 1e-9);
  }

  const std::string page = Slurp(dir + "/check/report.html");
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  // A trajectory plot per run and the bar chart.
  size_t svgs = 0;
  for (size_t at = page.find("<svg"); at != std::string::npos; at = page.find("<svg", at + 1)) ++svgs;
  EXPECT_EQ(svgs, 3u);
  EXPECT_THAT(page, ::testing::Not(::testing::HasSubstr("src="))) << "self-contained";
  EXPECT_THAT(page, ::testing::Not(::testing::HasSubstr("<script")));
  for (const char* set : {"nominal", "corrected", "ros2", "truth", "fit"})
    EXPECT_THAT(page, ::testing::HasSubstr(set)) << set;
}

TEST(CheckCli, RunWithoutTelemetryIsListedWithItsReason) {
  const std::string dir = test_util::MakeTempDir("odocal_check_notelemetry_");
  auto session = config::LoadSession(SamplePath());
  ASSERT_TRUE(session) << session.message;
  ASSERT_EQ(session->runs.size(), 2u);
  session->runs[1].telemetry.clear();
  session->camera_file = dir + "/camera.yaml";
  ASSERT_TRUE(config::WriteSession(*session, dir + "/session.yaml").ok());
  std::ofstream(dir + "/truth.yaml") << TruthFirmwareYaml();
  const auto r = RunCommand(Odocal("check " + dir + "/session.yaml --params " + dir +
                                   "/truth.yaml --out " + dir + "/check"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("not replayed")) << r.out;
  const nlohmann::json j = ReadJson(dir + "/check/check.json");
  const nlohmann::json& second = j["runs"][1];
  for (const char* set : {"nominal", "truth"}) {
    EXPECT_TRUE(Result(j["runs"][0], set)["ok"].get<bool>()) << set;
    const nlohmann::json& res = Result(second, set);
    EXPECT_FALSE(res["ok"].get<bool>());
    EXPECT_FALSE(res.contains("final_position_error_mm")) << "no silent number";
    EXPECT_THAT(res["reason"].get<std::string>(), ::testing::HasSubstr("no telemetry")) << res;
    EXPECT_THAT(res["reason"].get<std::string>(),
                ::testing::HasSubstr(second["name"].get<std::string>()))
        << res;
  }
  EXPECT_EQ(j["not_replayed"].size(), 2u);
  EXPECT_EQ(j["summary"][1]["runs"], 1);
  EXPECT_EQ(j["summary"][1]["not_replayed"], 1);
  EXPECT_THAT(Slurp(dir + "/check/report.html"), ::testing::HasSubstr("not replayed: "));
}

TEST(CheckCli, BadInputIsOneClearLine) {
  const std::string dir = test_util::MakeTempDir("odocal_check_bad_");
  std::ofstream(dir + "/truth.yaml") << TruthFirmwareYaml();
  std::ofstream(dir + "/other.yaml") << "max_speed_mm_s: 500\n";
  std::ofstream(dir + "/negative.yaml") << "left_wheel_diameter_mm: -70\nright_wheel_diameter_mm: 70\n"
                                           "track_mm: 300\nticks_per_rev: 2048\n";
  std::ofstream(dir + "/file") << "not a directory\n";
  struct Case {
    std::string args;
    int exit_code;
    std::vector<std::string> words;
  };
  const std::string out = " --out " + dir + "/out";
  const Case cases[] = {
      {"/nonexistent/session.yaml --params " + dir + "/truth.yaml" + out, 2,
       {"odocal check: /nonexistent/session.yaml", "no such file"}},
      {SamplePath() + " --params " + dir + "/missing.yaml" + out, 2,
       {"odocal check: " + dir + "/missing.yaml", "no such file"}},
      {SamplePath() + " --params " + dir + out, 2, {"odocal check: " + dir, "directory"}},
      {SamplePath() + " --params " + dir + "/other.yaml" + out, 2,
       {"odocal check: " + dir + "/other.yaml", "max_speed_mm_s", "left_wheel_diameter_mm",
        "diff_drive_controller", "final.parameters"}},
      {SamplePath() + " --params " + dir + "/negative.yaml" + out, 2,
       {"odocal check: " + dir + "/negative.yaml:", "left_wheel_diameter_mm", "positive"}},
      {SamplePath() + " --params " + dir + "/truth.yaml --params " + dir + "/truth.yaml" + out, 2,
       {"'truth'", "NAME=FILE"}},
      {SamplePath() + " --params nominal=" + dir + "/truth.yaml" + out, 2, {"'nominal'"}},
      {SamplePath() + " --params " + dir + "/truth.yaml --out " + dir + "/file/out", 1,
       {"odocal check: ", dir + "/file/out"}},
  };
  for (const Case& c : cases) {
    const auto r = RunCommand(Odocal("check " + c.args));
    EXPECT_EQ(r.exit_code, c.exit_code) << c.args << "\n" << r.err;
    for (const std::string& w : c.words) EXPECT_THAT(r.err, ::testing::HasSubstr(w)) << w << "\n" << r.err;
    // One line, nothing measured.
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/out/check.json"));
}

}  // namespace
}  // namespace odocal
