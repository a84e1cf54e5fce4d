// The record made from a run's report (record.h), its JSON round trip, the digest that keys it
// (digest.h) and ISO 8601 time (base/utc_time.h). The reports here carry the keys the commands
// write (docs/formats.md); the values are chosen so each derived number has a hand-computed truth.
#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/records/digest.h"
#include "odocal/records/record.h"

namespace odocal::records {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;

json Wheels(double l, double r, double t) {
  return {{"left_wheel_diameter_mm", l}, {"right_wheel_diameter_mm", r}, {"track_mm", t}, {"ticks_per_rev", 2048}};
}

RecordContext Context() {
  RecordContext c;
  c.robot = "R-7";
  c.time_utc = "2026-03-01T10:00:00Z";
  c.host = "line-2";
  c.folder = "/tmp/run";
  c.digest = "abc";
  return c;
}

TEST(RecordFromReport, ABatchTakesTheChosenEstimatorsEdAndEbAndPropagatesTheirSigmasClaimingNoScaleItDidNotMeasure) {
  const json report = {{"nominal", Wheels(72.0, 72.0, 300.0)},
                       {"corrected", Wheels(71.9, 72.1, 301.5)},
                       {"corrected_from", "umbmark"},
                       {"umbmark",
                        {{"emax_syst_mm", 12.5},
                         {"estimate", {{"Ed", 1.0028}, {"Eb", 1.005}, {"sigma_Ed", 2e-4}, {"sigma_Eb", 1e-3}}}}}};
  const Result<Record> r = RecordFromReport(RunKind::kBatch, report, Context());
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r->robot, "R-7");
  EXPECT_EQ(r->host, "line-2");
  ASSERT_TRUE(r->before && r->after && r->ed && r->eb && r->emax_syst_before_mm);
  EXPECT_NEAR(r->before->track_mm.value, 300.0, 1e-12);
  EXPECT_NEAR(r->after->left_wheel_diameter_mm.value, 71.9, 1e-12);
  EXPECT_NEAR(r->ed->value, 1.0028, 1e-12);
  EXPECT_NEAR(*r->eb->sigma, 1e-3, 1e-15);
  EXPECT_NEAR(r->emax_syst_before_mm->value, 12.5, 1e-12);
  EXPECT_FALSE(r->emax_syst_after_mm) << "batch does not drive the robot again";
  // The track: dB / B = dEb / Eb. The diameters: UMBMark kept the believed scale, whose sigma no
  // one stated: none is claimed.
  EXPECT_NEAR(*r->after->track_mm.sigma, 301.5 * 1e-3 / 1.005, 1e-9);
  EXPECT_FALSE(r->after->left_wheel_diameter_mm.sigma);
  EXPECT_FALSE(r->after->MeanWheelDiameterMm().sigma);

  // With CVRA's scale from straights (its sigma stated): D_L = 2 s / (Ed + 1), so
  // dD_L / D_L = dEd / (Ed + 1) with the scale's relative sigma beside it.
  json with_scale = report;
  with_scale["cvra"]["scale"] = {{"scale", 0.9995}, {"sigma_total", 3e-4}};
  const Result<Record> s = RecordFromReport(RunKind::kBatch, with_scale, Context());
  const double rel = std::hypot(2e-4 / 2.0028, 3e-4);
  EXPECT_NEAR(*s->after->left_wheel_diameter_mm.sigma, 71.9 * rel, 1e-9);
  EXPECT_NEAR(*s->after->right_wheel_diameter_mm.sigma, 72.1 * rel, 1e-9);
  const Estimate mean = s->after->MeanWheelDiameterMm();
  EXPECT_NEAR(mean.value, 72.0, 1e-12);
  EXPECT_NEAR(*mean.sigma, 0.5 * std::hypot(71.9, 72.1) * rel, 1e-9);
}

TEST(RecordFromReport, ATrajectoryFitsSigmaIsTheRunsDisagreementWhenThatIsLarger) {
  // OptiOdom's squares (report.json notes "trust sigma_between_runs"): Ed's runs disagree 7x.
  const json report = {{"nominal", Wheels(72.0, 72.0, 300.0)},
                       {"corrected", Wheels(71.8, 72.0, 300.0)},
                       {"corrected_from", "trajectory"},
                       {"trajectory_fit",
                        {{"Ed", {{"value", 0.9989}, {"sigma", 2.3e-5}, {"sigma_between_runs", 1.67e-4}}},
                         {"Es", {{"value", 0.9962}, {"sigma", 2.7e-5}, {"sigma_between_runs", 0.0}}},
                         {"Eb", {{"value", 1.0035}, {"sigma", 5.4e-5}, {"sigma_between_runs", 3.7e-4}}}}}};
  const Result<Record> r = RecordFromReport(RunKind::kBatch, report, Context());
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_NEAR(*r->ed->sigma, 1.67e-4, 1e-12);
  EXPECT_NEAR(*r->eb->sigma, 3.7e-4, 1e-12);
  const double rel = std::hypot(1.67e-4 / 1.9989, 2.7e-5 / 0.9962);  // Es: the model's (the runs agree)
  EXPECT_NEAR(*r->after->left_wheel_diameter_mm.sigma, 71.8 * rel, 1e-9);
}

TEST(RecordFromReport, ATrajectoryExportAddsTheDistanceScalesSigmaToBothWheels) {
  const json report = {{"nominal", Wheels(72.0, 72.0, 300.0)},
                       {"corrected", Wheels(71.8, 72.0, 300.0)},
                       {"corrected_from", "trajectory"},
                       {"trajectory_fit",
                        {{"Ed", {{"value", 1.0}, {"sigma", 4e-4}}},
                         {"Es", {{"value", 0.998}, {"sigma", 3e-4}}},
                         {"Eb", {{"value", 1.0}, {"sigma", 2e-3}}}}}};
  const Result<Record> r = RecordFromReport(RunKind::kBatch, report, Context());
  ASSERT_TRUE(r.ok()) << r.message;
  const double rel = std::hypot(4e-4 / 2.0, 3e-4 / 0.998);
  EXPECT_NEAR(*r->after->left_wheel_diameter_mm.sigma, 71.8 * rel, 1e-9);
  EXPECT_NEAR(*r->after->track_mm.sigma, 300.0 * 2e-3, 1e-9);
}

TEST(RecordFromReport, AStationsAfterIsTheLastRoundDrivenWithTheKeptSet) {
  const json report = {
      {"robot_name", "odo-sim-1"},
      {"status", "converged"},
      {"robot_params_initial", Wheels(72, 72, 300)},
      {"robot_params_final", Wheels(71.9, 72.1, 301)},
      {"findings", {"turn slip at fast turns"}},
      {"iterations",
       {{{"params_used", Wheels(72, 72, 300)},
         {"emax_syst_mm", 40.0},
         {"emax_syst_sigma_mm", 1.5},
         {"estimate", {{"Ed", 1.003}, {"Eb", 1.004}, {"sigma_Ed", 1e-4}, {"sigma_Eb", 2e-4}}}},
        {{"params_used", Wheels(71.9, 72.1, 301)}, {"emax_syst_mm", 1.2}, {"emax_syst_sigma_mm", 0.4}}}}};
  RecordContext c = Context();
  c.robot.clear();  // the link names the robot
  const Result<Record> r = RecordFromReport(RunKind::kStation, report, c);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r->robot, "odo-sim-1");
  EXPECT_EQ(r->status, "converged");
  ASSERT_TRUE(r->emax_syst_before_mm && r->emax_syst_after_mm);
  EXPECT_NEAR(r->emax_syst_before_mm->value, 40.0, 1e-12);
  EXPECT_NEAR(*r->emax_syst_after_mm->sigma, 0.4, 1e-12);
  EXPECT_THAT(r->findings, ::testing::ElementsAre("turn slip at fast turns"));
  // Squares alone: the distance scale was not measured, so no sigma is claimed for the diameters.
  EXPECT_NEAR(*r->after->track_mm.sigma, 301.0 * 2e-4 / 1.004, 1e-9);
  EXPECT_FALSE(r->after->left_wheel_diameter_mm.sigma);
}

TEST(RecordFromReport, ExplainsFinalParametersAndItsEffectsAreTheRecord) {
  json parameters;
  parameters["Ed"] = {{"value", 1.0014}, {"sigma", 1e-4}};
  parameters["Eb"] = {{"value", 0.9967}, {"sigma", 5e-4}};
  json report = {{"believed", Wheels(72, 72, 300)}, {"corrected", Wheels(72.1, 72.2, 299)}};
  report["effects_added"] = {"turn_slip", "wheel_slip"};
  report["final"]["parameters"] = parameters;
  const Result<Record> r = RecordFromReport(RunKind::kExplain, report, Context());
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_NEAR(r->ed->value, 1.0014, 1e-12);
  EXPECT_THAT(r->findings, ::testing::ElementsAre("turn_slip", "wheel_slip"));
}

TEST(RecordJson, ARecordReadBackIsTheSameRecordAndMissingSigmasStayMissing) {
  const json report = {{"nominal", Wheels(72.0, 72.0, 300.0)},
                       {"corrected", Wheels(71.9, 72.1, 301.5)},
                       {"umbmark", {{"emax_syst_mm", 12.5}, {"estimate", {{"Ed", 1.0028}, {"Eb", 1.005}}}}}};
  Record r = *RecordFromReport(RunKind::kBatch, report, Context());
  r.distance_km = 812.5;
  r.verdict = Verdict::kFail;
  r.failed_limits = {"E_max,syst after not measured"};
  const Result<Record> back = RecordFromJson(json::parse(ToJson(r).dump()));
  ASSERT_TRUE(back.ok()) << back.message;
  EXPECT_EQ(ToJson(*back), ToJson(r));
  EXPECT_FALSE(back->ed->sigma) << "UMBMark from one run a direction has no sigma; none is invented";
  EXPECT_FALSE(back->after->track_mm.sigma);
}

TEST(RecordJson, ABrokenRecordNamesItsKey) {
  json j = ToJson(*RecordFromReport(RunKind::kBatch, {{"nominal", Wheels(72, 72, 300)}}, Context()));
  j.erase("digest");
  EXPECT_THAT(RecordFromJson(j).message, HasSubstr("digest"));
  j["digest"] = "d";
  j["kind"] = "tape";
  EXPECT_THAT(RecordFromJson(j).message, HasSubstr("tape"));
  j["kind"] = "batch";
  j["time_utc"] = "yesterday";
  EXPECT_THAT(RecordFromJson(j).message, HasSubstr("time_utc"));
  j["time_utc"] = "2026-03-01";
  j["params_before"]["track_mm"] = "wide";
  EXPECT_THAT(RecordFromJson(j).message, HasSubstr("params_before.track_mm"));
}

TEST(RecordFile, WrittenAndReadBackFromTheRunFolder) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "odocal_record_file_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const Record r = *RecordFromReport(RunKind::kCheck, {{"nominal", Wheels(72, 72, 300)}}, Context());
  ASSERT_TRUE(WriteRecordFile(r, dir.string()).ok());
  const Result<Record> back = ReadRecordFile(dir.string());
  ASSERT_TRUE(back.ok()) << back.message;
  EXPECT_EQ(back->kind, RunKind::kCheck);
  std::filesystem::remove(dir / "record.json");
  EXPECT_THAT(ReadRecordFile(dir.string()).message, HasSubstr("record.json"));
  std::filesystem::remove_all(dir);
}

TEST(Digest, TheSameContentAnywhereIsTheSameDigestAndOneByteChangesIt) {
  const std::filesystem::path a = std::filesystem::temp_directory_path() / "odocal_digest_a";
  const std::filesystem::path b = std::filesystem::temp_directory_path() / "odocal_digest_b";
  for (const auto& d : {a, b}) {
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    std::ofstream(d / "session.yaml") << "robot: {}\n";
    std::ofstream(d / "run01.csv") << "t_s,x_mm\n0,1\n";
  }
  const auto files = [](const std::filesystem::path& d) {
    return std::vector<std::string>{(d / "session.yaml").string(), (d / "run01.csv").string()};
  };
  const Result<std::string> da = DigestFiles("batch", files(a)), db = DigestFiles("batch", files(b));
  ASSERT_TRUE(da.ok() && db.ok());
  EXPECT_EQ(*da, *db) << "a session copied elsewhere is the same session";
  EXPECT_EQ(da->size(), 64u);
  EXPECT_NE(*DigestFiles("check", files(a)), *da) << "another command on the same session is another record";
  std::ofstream(b / "run01.csv") << "t_s,x_mm\n0,2\n";
  EXPECT_NE(*DigestFiles("batch", files(b)), *da);
  EXPECT_THAT(DigestFiles("batch", {(a / "missing.csv").string()}).message, HasSubstr("missing.csv"));
  // The known SHA-256 of "abc" (FIPS 180-2, appendix B.1).
  EXPECT_EQ(DigestText("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  std::filesystem::remove_all(a);
  std::filesystem::remove_all(b);
}

TEST(UtcTime, IsoTimesWithZonesAndDatesParseToTheSameInstant) {
  const std::optional<double> t = ParseUtc("2026-11-27T18:40:00Z");
  ASSERT_TRUE(t);
  EXPECT_NEAR(*t, 1795804800.0, 0.5);  // date -d 2026-11-27T18:40:00Z +%s
  EXPECT_NEAR(*ParseUtc("2026-11-27T19:40:00+01:00"), *t, 1e-9);
  EXPECT_NEAR(*ParseUtc("2026-11-27T18:40:00.5Z"), *t + 0.5, 1e-9);
  EXPECT_NEAR(*ParseUtc("2026-11-27"), *t - (18 * 3600 + 40 * 60), 1e-9);
  EXPECT_EQ(FormatUtc(*t), "2026-11-27T18:40:00Z");
  for (const char* bad : {"", "yesterday", "2026-13-01", "2026-11-27T25:00:00Z", "2026-11-27T18:40", "2026-11-27Tx"})
    EXPECT_FALSE(ParseUtc(bad)) << bad;
}

}  // namespace
}  // namespace odocal::records
