// The station file: its keys load into typed values (the floor reference with
// the session file's keys), and a malformed one is named by file, line and key.
#include "odocal/config/station_file.h"

#include <fstream>
#include <string>
#include <tuple>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

const char* kStation = R"(robot: {port: /dev/ttyUSB0, baud: 115200}
camera: {device: "0", calibration: camera.yaml, mount_guess: {x_mm: 0, y_mm: -1000, height_mm: 2000}}
tag: {family: tag36h11, id: 5, size_mm: 80, size_sigma_mm: 0.05, height_mm: 150}
floor_reference:
  tags: [{id: 1, size_mm: 80}, {id: 2, size_mm: 80}, {id: 3, size_mm: 60}]
  distances:
    - {between: [1, 2], mm: 1040.5, sigma_mm: 0.3}
    - {between: [2, 3], mm: 742.1}
  tag_height_sigma_mm: 0.8
plan: {side_mm: 2000, runs_per_direction: 3}
)";

TEST(StationFile, LoadsAFloorReference) {
  const std::string dir = test_util::MakeTempDir("odocal_station_file_");
  std::ofstream(dir + "/station.yaml") << kStation;
  const auto c = config::LoadStationConfig(dir + "/station.yaml");
  ASSERT_TRUE(c) << c.message;
  ASSERT_TRUE(c->tag_size_sigma_mm);
  EXPECT_NEAR(*c->tag_size_sigma_mm, 0.05, 1e-12);
  ASSERT_TRUE(c->floor_reference);
  const vision::FloorReference& r = *c->floor_reference;
  EXPECT_EQ(r.family, "tag36h11");
  ASSERT_EQ(r.tags.size(), 3u);
  EXPECT_NEAR(r.tags[2].size_mm, 60.0, 1e-12);
  ASSERT_EQ(r.distances.size(), 2u);
  EXPECT_EQ(r.distances[0].id_a, 1);
  EXPECT_EQ(r.distances[0].id_b, 2);
  EXPECT_NEAR(r.distances[0].mm, 1040.5, 1e-9);
  EXPECT_NEAR(r.distances[1].sigma_mm, 0.5, 1e-12) << "a tape read to the millimetre by default";
  EXPECT_NEAR(r.tag_height_sigma_mm, 0.8, 1e-12);
  std::string why;
  EXPECT_TRUE(r.IsValid(&why)) << why;
}

TEST(StationFile, WithoutAFloorReferenceThereIsNone) {
  const std::string dir = test_util::MakeTempDir("odocal_station_file_none_");
  std::string text = kStation;
  text.erase(text.find("floor_reference:"), text.find("plan:") - text.find("floor_reference:"));
  std::ofstream(dir + "/station.yaml") << text;
  const auto c = config::LoadStationConfig(dir + "/station.yaml");
  ASSERT_TRUE(c) << c.message;
  EXPECT_FALSE(c->floor_reference);
}

TEST(StationFile, ABadFloorReferenceIsNamed) {
  const std::string dir = test_util::MakeTempDir("odocal_station_file_bad_");
  for (const auto& [from, to, expected] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"between: [2, 3]", "between: [2, 9]",
            "station.yaml:8: floor_reference.distances[1].between: tag 9 is not in floor_reference.tags"},
           {"mm: 742.1", "mm: -742.1", "floor_reference.distances[1].mm"},
           {"sigma_mm: 0.3", "sigma_mm: 0", "floor_reference.distances[0].sigma_mm"},
           {"{id: 3, size_mm: 60}", "{id: 2, size_mm: 60}", "floor_reference.tags[2].id: tag 2 listed twice"},
           {"{id: 3, size_mm: 60}", "{id: 3}", "floor_reference.tags[2].size_mm"},
           {"tag_height_sigma_mm: 0.8", "tag_height: 0.8", "floor_reference.tag_height: unknown key"},
           {"  tags: [", "  tagz: [", "floor_reference.tagz: unknown key"},
           {"size_sigma_mm: 0.05", "size_sigma_mm: -1", "tag.size_sigma_mm: must not be negative"}}) {
    std::string text = kStation;
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    std::ofstream(dir + "/station.yaml") << text;
    const std::string error = test_util::ErrorOf(config::LoadStationConfig(dir + "/station.yaml"));
    EXPECT_THAT(error, ::testing::HasSubstr(expected)) << from << " -> " << to;
  }
}

TEST(StationFile, TheLinesLimitsLoadAndABadOneIsNamed) {
  const std::string dir = test_util::MakeTempDir("odocal_station_limits_");
  std::ofstream(dir + "/station.yaml") << kStation << "limits: {emax_syst_after_mm: 2, ed: 0.5%, eb: 0.02}\n";
  const auto c = config::LoadStationConfig(dir + "/station.yaml");
  ASSERT_TRUE(c) << c.message;
  ASSERT_TRUE(c->limits.emax_syst_after_mm && c->limits.ed_tolerance && c->limits.eb_tolerance);
  EXPECT_NEAR(*c->limits.emax_syst_after_mm, 2.0, 1e-12);
  EXPECT_NEAR(*c->limits.ed_tolerance, 0.005, 1e-12);
  EXPECT_NEAR(*c->limits.eb_tolerance, 0.02, 1e-12);
  EXPECT_FALSE(c->limits.emax_syst_before_mm);

  std::ofstream(dir + "/bad.yaml") << kStation << "limits: {emax_syst_after: 2}\n";
  const auto bad = config::LoadStationConfig(dir + "/bad.yaml");
  ASSERT_FALSE(bad);
  EXPECT_THAT(bad.message, ::testing::HasSubstr("bad.yaml"));
  EXPECT_THAT(bad.message, ::testing::HasSubstr("emax_syst_after"));
}

}  // namespace
}  // namespace odocal
