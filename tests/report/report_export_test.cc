// report.html next to every report.json (batch, demo, validate: the validate
// one is checked in validate_cli_test), and the parameter exports read back.
#include <cstdio>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "odocal/report/exports.h"
#include "odocal/report/html_report.h"
#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

using test_util::RunCommand;

using test_util::Odocal;

using test_util::ReadJson;
using test_util::Slurp;

void ExpectSelfContained(const std::string& html) {
  EXPECT_THAT(html, ::testing::HasSubstr("<!DOCTYPE html>"));
  EXPECT_THAT(html, ::testing::HasSubstr("</html>"));
  EXPECT_THAT(html, ::testing::Not(::testing::HasSubstr("<script")));
  EXPECT_THAT(html, ::testing::Not(::testing::HasSubstr("<link")));
  EXPECT_THAT(html, ::testing::Not(::testing::HasSubstr("<img")));
  EXPECT_THAT(html, ::testing::Not(::testing::HasSubstr("https://")));
}

TEST(ReportHtml, DrawsWhatTheJsonHas) {
  const nlohmann::json report = {
      {"session", "a<b>&c"},
      {"umbmark",
       {{"return_errors", {{"cw", {{{"x_mm", -10.0}, {"y_mm", 5.0}}}}, {"ccw", {{{"x_mm", 8.0}, {"y_mm", 4.0}}}}}},
        {"x_cg_cw_mm", -10.0}, {"y_cg_cw_mm", 5.0}, {"x_cg_ccw_mm", 8.0}, {"y_cg_ccw_mm", 4.0},
        {"emax_syst_mm", 11.18}, {"n_cw", 1}, {"n_ccw", 1}}},
      {"iterations", {{{"emax_syst_mm", 12.0}}, {{"emax_syst_mm", 0.2}}}},
      {"trajectories", {{{"name", "r1"}, {"points_mm", {{0.0, 0.0}, {100.0, 0.0}, {100.0, 100.0}}}}}},
  };
  const std::string html = report::ReportHtml(report, "test");
  ExpectSelfContained(html);
  EXPECT_THAT(html, ::testing::HasSubstr("class='umbmark'"));
  EXPECT_THAT(html, ::testing::HasSubstr("class='convergence'"));
  EXPECT_THAT(html, ::testing::HasSubstr("class='trajectories'"));
  EXPECT_THAT(html, ::testing::Not(::testing::HasSubstr("class='bland-altman'")));
  EXPECT_THAT(html, ::testing::HasSubstr("a&lt;b&gt;&amp;c"));
  EXPECT_THAT(html, ::testing::Not(::testing::HasSubstr("a<b>")));
  EXPECT_THAT(html, ::testing::HasSubstr("11.18"));
  EXPECT_THAT(html, ::testing::HasSubstr("<polyline"));
}

// A station's round that pushed nothing ("pushed": null) says so instead of
// an empty "Pushed:" table; one that pushed lists what.
TEST(ReportHtml, AnIterationThatPushedNothingSaysSo) {
  const nlohmann::json umbmark = {{"return_errors", {{"cw", {{{"x_mm", -1.0}, {"y_mm", 2.0}}}}}},
                                  {"emax_syst_mm", 2.2}};
  const nlohmann::json report = {
      {"iterations",
       {{{"emax_syst_mm", 12.0}, {"umbmark", umbmark}, {"pushed", {{"track_mm", 301.5}}}},
        {{"emax_syst_mm", 0.2}, {"umbmark", umbmark}, {"pushed", nullptr}}}}};
  const std::string html = report::ReportHtml(report, "test");
  EXPECT_THAT(html, ::testing::HasSubstr("<p>Pushed:</p><table class='kv'><tr><th>track_mm</th><td>301.5"));
  EXPECT_THAT(html, ::testing::HasSubstr("<p>Nothing pushed.</p>"));
  EXPECT_THAT(html, ::testing::Not(::testing::HasSubstr("<p>Pushed:</p><table class='kv'></table>")));
}

TEST(ReportHtml, BatchOnTheSampleSessionWithExports) {
  const std::string dir = test_util::MakeTempDir("odocal_report_batch_");
  const auto r = RunCommand(Odocal("batch " + test_util::SourceDir() +
                                   "/sample_data/session/session.yaml --out " + dir +
                                   " --export ros2 " + dir + "/ros2.yaml --export firmware " + dir +
                                   "/firmware.yaml"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string html = Slurp(dir + "/report.html");
  ExpectSelfContained(html);
  EXPECT_THAT(html, ::testing::HasSubstr("class='umbmark'"));
  EXPECT_THAT(html, ::testing::HasSubstr("class='trajectories'"));
  EXPECT_THAT(html, ::testing::HasSubstr("E_max,syst"));
  const nlohmann::json report = ReadJson(dir + "/report.json");
  ASSERT_EQ(report["umbmark"]["return_errors"]["cw"].size(), 1u);
  ASSERT_EQ(report["trajectories"].size(), report["runs"].size());
  EXPECT_GT(report["trajectories"][0]["points_mm"].size(), 20u);

  const YAML::Node ros2 = YAML::LoadFile(dir + "/ros2.yaml");
  const YAML::Node p = ros2["diff_drive_controller"]["ros__parameters"];
  ASSERT_TRUE(p.IsMap());
  EXPECT_EQ(p.size(), 3u);
  for (const char* k : {"wheel_separation_multiplier", "left_wheel_radius_multiplier",
                        "right_wheel_radius_multiplier"})
    EXPECT_NEAR(p[k].as<double>(), report["ros2"][k].get<double>(), 1e-8) << k;
  const YAML::Node fw = YAML::LoadFile(dir + "/firmware.yaml");
  for (const char* k : {"left_wheel_diameter_mm", "right_wheel_diameter_mm", "track_mm"})
    EXPECT_NEAR(fw[k].as<double>(), report["corrected"][k].get<double>(), 1e-6) << k;
  EXPECT_EQ(fw["ticks_per_rev"].as<int>(), report["corrected"]["ticks_per_rev"].get<int>());
  EXPECT_EQ(fw.size(), 4u);
}

TEST(ReportHtml, DemoDrawsConvergenceAndExports) {
  const std::string dir = test_util::MakeTempDir("odocal_report_demo_");
  const auto r = RunCommand(Odocal("demo --scenario " + test_util::SourceDir() +
                                   "/sample_data/scenarios/demo.yaml --out " + dir +
                                   " --export firmware " + dir + "/fw.yaml --export ros2 " + dir +
                                   "/ros2.yaml"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string html = Slurp(dir + "/report.html");
  ExpectSelfContained(html);
  EXPECT_THAT(html, ::testing::HasSubstr("class='convergence'"));
  EXPECT_THAT(html, ::testing::HasSubstr("class='umbmark'"));
  const nlohmann::json report = ReadJson(dir + "/report.json");
  const YAML::Node fw = YAML::LoadFile(dir + "/fw.yaml");
  for (const char* k : {"left_wheel_diameter_mm", "right_wheel_diameter_mm", "track_mm"})
    EXPECT_NEAR(fw[k].as<double>(), report["robot_params_final"][k].get<double>(), 1e-6) << k;
  const YAML::Node p = YAML::LoadFile(dir + "/ros2.yaml")["diff_drive_controller"]["ros__parameters"];
  EXPECT_NEAR(p["wheel_separation_multiplier"].as<double>(),
              report["ros2"]["wheel_separation_multiplier"].get<double>(), 1e-8);
}

TEST(Export, UmbmarkExportsWhenDiametersAreGiven) {
  const std::string dir = test_util::MakeTempDir("odocal_export_umbmark_");
  const std::string runs =
      "umbmark --side-mm 2000 --track-mm 300 --cw=-125.8,-143.8 --cw=-124.9,-141.2 "
      "--ccw 139.2,-121.8 --ccw 140.1,-119.7 ";
  const auto ok = RunCommand(Odocal(runs + "--left-diameter-mm 70 --right-diameter-mm 70 "
                                           "--ticks-per-rev 2048 --json --export ros2 " + dir +
                                           "/r.yaml --export firmware " + dir + "/f.yaml"));
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  const nlohmann::json doc = nlohmann::json::parse(ok.out);
  const YAML::Node fw = YAML::LoadFile(dir + "/f.yaml");
  EXPECT_NEAR(fw["track_mm"].as<double>(), doc["corrected"]["track_mm"].get<double>(), 1e-6);
  EXPECT_EQ(fw["ticks_per_rev"].as<int>(), 2048);
  const YAML::Node p = YAML::LoadFile(dir + "/r.yaml")["diff_drive_controller"]["ros__parameters"];
  EXPECT_NEAR(p["left_wheel_radius_multiplier"].as<double>(),
              doc["ros2"]["left_wheel_radius_multiplier"].get<double>(), 1e-8);
  EXPECT_GT(std::abs(p["wheel_separation_multiplier"].as<double>() - 1.0), 1e-5);

  const auto no_wheels = RunCommand(Odocal(runs + "--export ros2 " + dir + "/x.yaml"));
  EXPECT_EQ(no_wheels.exit_code, 2);
  EXPECT_THAT(no_wheels.err, ::testing::HasSubstr("--export needs the nominal wheels")) << no_wheels.err;
  const auto bad_kind = RunCommand(Odocal(runs + "--left-diameter-mm 70 --right-diameter-mm 70 "
                                                 "--export urdf " + dir + "/x.yaml"));
  EXPECT_EQ(bad_kind.exit_code, 2);
  EXPECT_THAT(bad_kind.err, ::testing::HasSubstr("--export urdf: unknown kind")) << bad_kind.err;
}

TEST(Export, YamlRoundTripsThroughAParser) {
  calibration::WheelParams nominal, corrected;
  nominal.left_wheel_diameter_m = nominal.right_wheel_diameter_m = 0.07;
  nominal.track_m = 0.3;
  nominal.ticks_per_rev = 4096;
  corrected = nominal;
  corrected.left_wheel_diameter_m = 0.0699123456789;
  corrected.right_wheel_diameter_m = 0.0700876543211;
  corrected.track_m = 0.303123456789;
  const YAML::Node fw = YAML::Load(report::FirmwareExportYaml(corrected));
  EXPECT_NEAR(fw["left_wheel_diameter_mm"].as<double>(), 69.9123456789, 1e-6);
  EXPECT_NEAR(fw["right_wheel_diameter_mm"].as<double>(), 70.0876543211, 1e-6);
  EXPECT_NEAR(fw["track_mm"].as<double>(), 303.123456789, 1e-6);
  EXPECT_EQ(fw["ticks_per_rev"].as<int>(), 4096);
  const YAML::Node p = YAML::Load(report::Ros2ExportYaml(nominal, corrected))["diff_drive_controller"]["ros__parameters"];
  EXPECT_NEAR(p["wheel_separation_multiplier"].as<double>(), 303.123456789 / 300.0, 1e-8);
  EXPECT_NEAR(p["left_wheel_radius_multiplier"].as<double>(), 69.9123456789 / 70.0, 1e-8);
  EXPECT_NEAR(p["right_wheel_radius_multiplier"].as<double>(), 70.0876543211 / 70.0, 1e-8);
}

}  // namespace
}  // namespace odocal
