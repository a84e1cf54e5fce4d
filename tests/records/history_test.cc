// What history and fleet read from the records, against truths the tests make themselves:
// synthetic robots with a known wear rate, a known repair, a known E_max,syst growth; control
// chart sequences built to break one Western Electric rule each; limits and verdicts by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "odocal/records/history.h"
#include "odocal/records/limits.h"

namespace odocal::records {
namespace {

constexpr double kWeek = 7.0 * 86400.0;
const double kStart = *ParseUtc("2026-01-05T08:00:00Z");

// A calibration whose mean wheel diameter is `diameter` with sigma `sigma_d` (each wheel
// sqrt(2) sigma_d, independent, so the mean's sigma is sigma_d) and whose track is `track`.
Record Calibration(const std::string& robot, double time_s, double diameter, double sigma_d, double track, double sigma_t) {
  Record r;
  r.robot = robot;
  r.kind = RunKind::kBatch;
  r.time_utc = FormatUtc(time_s);
  r.digest = robot + "-" + r.time_utc;
  WheelSet w;
  w.left_wheel_diameter_mm = {diameter, sigma_d * std::sqrt(2.0)};
  w.right_wheel_diameter_mm = {diameter, sigma_d * std::sqrt(2.0)};
  w.track_mm = {track, sigma_t};
  w.ticks_per_rev = 4096;
  r.after = w;
  return r;
}

struct Year {
  double wear_per_week = -0.04;
  double sigma_d = 0.01;
  double sigma_t = 0.3;
  int repair_at = -1;  // the track jumps by repair_mm from this record on
  double repair_mm = 3.0;
};

// A robot calibrated weekly for a year (53 calibrations).
std::vector<Record> WeeklyYear(const Year& y, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<Record> out;
  for (int k = 0; k <= 52; ++k) {
    const double d = 72.0 + y.wear_per_week * k + y.sigma_d * unit(rng);
    double t = 300.0 + y.sigma_t * unit(rng);
    if (y.repair_at >= 0 && k >= y.repair_at) t += y.repair_mm;
    out.push_back(Calibration("R1", kStart + k * kWeek, d, y.sigma_d, t, y.sigma_t));
    out.back().distance_km = 2.0 * k;  // 2 km a week
  }
  return out;
}

HistoryOptions Options() {
  HistoryOptions o;
  o.now_s = kStart;
  return o;
}

TEST(History, WearRateIsFoundWithAnHonestSigma) {
  const Year year;  // -0.04 mm/week, sigma 0.01 mm
  constexpr int kSeeds = 50;
  std::vector<double> values, sigmas;
  int covered = 0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const HistoryAnalysis a = AnalyseHistory("R1", WeeklyYear(year, 1000 + seed), Options());
    EXPECT_TRUE(a.steps.empty()) << "seed " << seed << ": wear alone taken for a step at " << a.steps.front().time_utc;
    ASSERT_TRUE(a.wear_mm_per_week && a.wear_mm_per_week->sigma);
    values.push_back(a.wear_mm_per_week->value);
    sigmas.push_back(*a.wear_mm_per_week->sigma);
    if (std::fabs(a.wear_mm_per_week->value - year.wear_per_week) < 2.0 * *a.wear_mm_per_week->sigma) ++covered;
    // 2 km a week: the same wear per 1000 km is 500 times the weekly one.
    ASSERT_TRUE(a.wear_mm_per_1000km);
    EXPECT_NEAR(a.wear_mm_per_1000km->value, 500.0 * a.wear_mm_per_week->value, 1e-9);
    ASSERT_TRUE(a.track_mm_per_week && a.track_mm_per_week->sigma);
    EXPECT_LT(std::fabs(a.track_mm_per_week->value), 4.0 * *a.track_mm_per_week->sigma);
  }
  double mean = 0, mean_sigma = 0;
  for (int i = 0; i < kSeeds; ++i) mean += values[i] / kSeeds, mean_sigma += sigmas[i] / kSeeds;
  double spread = 0;
  for (double v : values) spread += (v - mean) * (v - mean);
  spread = std::sqrt(spread / (kSeeds - 1));
  // The analytic slope sigma: sigma / sqrt(sum (k - 26)^2) over k = 0..52.
  const double analytic = year.sigma_d / std::sqrt(53.0 * (53.0 * 53.0 - 1.0) / 12.0);
  EXPECT_NEAR(mean_sigma, analytic, 0.3 * analytic);
  EXPECT_GT(mean_sigma, 0.5 * spread);
  EXPECT_LT(mean_sigma, 2.0 * spread);
  EXPECT_GE(covered, 43) << "of " << kSeeds << " within 2 sigma";  // 95 % expected
  EXPECT_NEAR(mean, year.wear_per_week, 3.0 * spread / std::sqrt(kSeeds));
}

TEST(History, WearIsFittedWithUnitWeightsWhenSigmasAreMissing) {
  Year year;
  std::vector<Record> records = WeeklyYear(year, 7);
  for (Record& r : records) {
    r.after->left_wheel_diameter_mm.sigma.reset();
    r.after->right_wheel_diameter_mm.sigma.reset();
    r.after->track_mm.sigma.reset();
  }
  const HistoryAnalysis a = AnalyseHistory("R1", records, Options());
  EXPECT_TRUE(a.steps.empty());
  ASSERT_TRUE(a.wear_mm_per_week && a.wear_mm_per_week->sigma);
  // The residual scatter stands in for the sigmas: the same slope sigma within its own noise.
  const double analytic = year.sigma_d / std::sqrt(53.0 * (53.0 * 53.0 - 1.0) / 12.0);
  EXPECT_NEAR(*a.wear_mm_per_week->sigma, analytic, 0.4 * analytic);
  EXPECT_NEAR(a.wear_mm_per_week->value, year.wear_per_week, 4.0 * analytic);
}

TEST(History, ARepairIsOneStepAtItsRecordAndWearIsNotAStep) {
  constexpr int kSeeds = 50;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    Year year;
    year.wear_per_week = -0.05;  // five of the diameter's sigmas a week
    year.repair_at = 26;
    const HistoryAnalysis a = AnalyseHistory("R1", WeeklyYear(year, 2000 + seed), Options());
    ASSERT_EQ(a.steps.size(), 1u) << "seed " << seed;
    EXPECT_EQ(a.steps[0].index, 26) << "seed " << seed;
    EXPECT_EQ(a.steps[0].parameter, "track_mm");
    EXPECT_NEAR(a.steps[0].change, 3.0, 5.0 * 0.3);
    EXPECT_GT(a.steps[0].z, 4.0);
    EXPECT_EQ(a.track_segment_start, 26);
    EXPECT_EQ(a.segment_start, 0) << "a track repair leaves the wheels' wear trend whole";
    // The trend restarts at the repair: 27 weeks of wear still measured.
    ASSERT_TRUE(a.wear_mm_per_week && a.wear_mm_per_week->sigma);
    EXPECT_NEAR(a.wear_mm_per_week->value, -0.05, 5.0 * *a.wear_mm_per_week->sigma);

    year.repair_at = -1;
    const HistoryAnalysis quiet = AnalyseHistory("R1", WeeklyYear(year, 2000 + seed), Options());
    EXPECT_TRUE(quiet.steps.empty()) << "seed " << seed << ": " << quiet.steps.size() << " steps without a repair, first at "
                                     << quiet.steps.front().index << " " << quiet.steps.front().parameter;
    EXPECT_EQ(quiet.segment_start, 0);
  }
}

TEST(History, ARepairRightAfterTheFirstCalibrationIsFound) {
  // Too few calibrations before it for a trend: the ones after it say where the track went.
  Year year;
  year.repair_at = 1;
  int found = 0;
  for (int seed = 1; seed <= 50; ++seed) {
    const HistoryAnalysis a = AnalyseHistory("R1", WeeklyYear(year, 4000 + seed), Options());
    EXPECT_LE(a.steps.size(), 1u) << "seed " << seed;
    if (a.steps.size() == 1 && a.steps[0].index == 1 && a.steps[0].parameter == "track_mm") ++found;
  }
  EXPECT_GE(found, 45) << "of 50";  // a line extrapolated back from 8 points is weaker than one forward
}

TEST(History, NewestCalibrationOffTheTrendIsAWarningNotAStep) {
  std::vector<Record> records;
  for (int k = 0; k < 10; ++k) records.push_back(Calibration("R1", kStart + k * kWeek, 72.0, 0.01, 300.0, 0.3));
  // 1.2 mm over the line's 0.18 mm extrapolated 9 weeks and the value's 0.3 mm: 3.4 sigma.
  records.back().after->track_mm.value = 301.2;
  const HistoryAnalysis a = AnalyseHistory("R1", records, Options());
  EXPECT_TRUE(a.steps.empty());
  ASSERT_EQ(a.warnings.size(), 1u);
  EXPECT_NE(a.warnings[0].find("track_mm"), std::string::npos) << a.warnings[0];
  EXPECT_NE(a.warnings[0].find("301.2"), std::string::npos) << a.warnings[0];
  EXPECT_NE(a.warnings[0].find("300.00"), std::string::npos) << a.warnings[0];

  records.back().after->track_mm.value = 302.0;  // 5.7 sigma: a step, said once
  const HistoryAnalysis stepped = AnalyseHistory("R1", records, Options());
  ASSERT_EQ(stepped.steps.size(), 1u);
  EXPECT_EQ(stepped.steps[0].index, 9);
  EXPECT_TRUE(stepped.warnings.empty());

  records.back().after->track_mm.value = 300.2;
  EXPECT_TRUE(AnalyseHistory("R1", records, Options()).warnings.empty());
}

// Calibrations every 4 weeks; each leaves E_max,syst at 0.5 mm and finds it grown by
// `rate` mm/week when the robot comes back.
std::vector<Record> Growing(double rate, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<Record> out;
  for (int k = 0; k < 8; ++k) {
    Record r = Calibration("R1", kStart + 4 * k * kWeek, 72.0, 0.01, 300.0, 0.3);
    r.emax_syst_after_mm = Estimate{0.5 + noise * unit(rng), noise > 0 ? std::optional<double>(noise) : std::nullopt};
    if (k > 0)
      r.emax_syst_before_mm = Estimate{0.5 + rate * 4.0 + noise * unit(rng), noise > 0 ? std::optional<double>(noise) : std::nullopt};
    out.push_back(r);
  }
  return out;
}

TEST(History, EmaxGrowthGivesTheLimitCrossingDate) {
  HistoryOptions o = Options();
  o.limits.emax_syst_after_mm = 2.0;
  const std::vector<Record> records = Growing(0.1, 0.0, 1);
  const double last = kStart + 28 * kWeek;
  // (2 - 0.5) mm at 0.1 mm/week: 15 weeks after the last calibration.
  const double crossing = last + 15.0 * kWeek;
  o.now_s = last + 14.0 * kWeek;
  HistoryAnalysis a = AnalyseHistory("R1", records, o);
  ASSERT_TRUE(a.emax_growth_mm_per_week);
  EXPECT_NEAR(a.emax_growth_mm_per_week->value, 0.1, 1e-9);
  ASSERT_TRUE(a.limit_crossing_utc);
  EXPECT_NEAR(*ParseUtc(*a.limit_crossing_utc), crossing, 1.0);
  ASSERT_TRUE(a.due_utc);
  EXPECT_EQ(*a.due_utc, *a.limit_crossing_utc);
  EXPECT_FALSE(a.due);
  o.now_s = last + 16.0 * kWeek;
  EXPECT_TRUE(AnalyseHistory("R1", records, o).due);

  // A shorter interval comes first.
  o.limits.recalibrate_days = 60;
  a = AnalyseHistory("R1", records, o);
  ASSERT_TRUE(a.due_utc);
  EXPECT_NEAR(*ParseUtc(*a.due_utc), last + 60 * 86400.0, 1.0);
  EXPECT_TRUE(a.due);

  // No limit: no crossing; the interval alone.
  o.limits.emax_syst_after_mm.reset();
  a = AnalyseHistory("R1", records, o);
  EXPECT_FALSE(a.limit_crossing_utc);
  EXPECT_NEAR(*ParseUtc(*a.due_utc), last + 60 * 86400.0, 1.0);
}

TEST(History, EmaxGrowthWithNoiseIsWithinItsSigma) {
  HistoryOptions o = Options();
  o.limits.emax_syst_after_mm = 2.0;
  int covered = 0;
  for (int seed = 1; seed <= 50; ++seed) {
    const HistoryAnalysis a = AnalyseHistory("R1", Growing(0.1, 0.05, 3000 + seed), o);
    ASSERT_TRUE(a.emax_growth_mm_per_week && a.emax_growth_mm_per_week->sigma);
    // Seven rates, each (0.05 sqrt 2 / 4) mm/week: their mean to 0.0067 (more when the scatter says so).
    EXPECT_NEAR(*a.emax_growth_mm_per_week->sigma, 0.05 * std::sqrt(2.0) / 4.0 / std::sqrt(7.0), 0.01);
    if (std::fabs(a.emax_growth_mm_per_week->value - 0.1) < 2.0 * *a.emax_growth_mm_per_week->sigma) ++covered;
    ASSERT_TRUE(a.limit_crossing_utc);
    const Record& last = a.records.back();
    const double weeks = (*ParseUtc(*a.limit_crossing_utc) - *ParseUtc(last.time_utc)) / kWeek;
    EXPECT_NEAR(weeks, (2.0 - last.emax_syst_after_mm->value) / a.emax_growth_mm_per_week->value, 1e-3);
    EXPECT_NEAR(weeks, 15.0, 4.0);  // the analytic date, within the rate's noise
  }
  EXPECT_GE(covered, 40);
}

TEST(History, RecordsWithoutACalibratedSetAreListedNotFitted) {
  std::vector<Record> records = WeeklyYear(Year{}, 9);
  Record measured = records[3];
  measured.after.reset();
  measured.time_utc = FormatUtc(kStart + 3.5 * kWeek);
  records.push_back(measured);
  const HistoryAnalysis a = AnalyseHistory("R1", records, Options());
  ASSERT_EQ(a.records.size(), 54u);
  EXPECT_FALSE(a.records[4].after);  // sorted into its place
  EXPECT_TRUE(a.steps.empty());
  ASSERT_TRUE(a.wear_mm_per_week);
  EXPECT_NEAR(a.wear_mm_per_week->value, -0.04, 5.0 * *a.wear_mm_per_week->sigma);
}

TEST(History, JsonHasEveryKeyAndNullsWhereUnknown) {
  const HistoryAnalysis a = AnalyseHistory("R1", {Calibration("R1", kStart, 72.0, 0.01, 300.0, 0.3)}, Options());
  const nlohmann::json j = HistoryJson(a);
  EXPECT_EQ(j["robot"], "R1");
  ASSERT_EQ(j["records"].size(), 1u);
  const nlohmann::json& an = j["analysis"];
  for (const char* key : {"wear_mm_per_week", "wear_mm_per_1000km", "track_mm_per_week", "emax_growth_mm_per_week",
                          "limit_crossing_utc", "due_utc"}) {
    ASSERT_TRUE(an.contains(key)) << key;
    EXPECT_TRUE(an[key].is_null()) << key;
  }
  EXPECT_TRUE(an["steps"].is_array());
  EXPECT_EQ(an["due"], false);

  Year year;
  year.repair_at = 26;
  const HistoryAnalysis b = AnalyseHistory("R1", WeeklyYear(year, 4), Options());
  const nlohmann::json k = HistoryJson(b);
  ASSERT_EQ(k["analysis"]["steps"].size(), 1u);
  EXPECT_EQ(k["analysis"]["steps"][0]["index"], 26);
  EXPECT_TRUE(k["analysis"]["wear_mm_per_week"]["sigma"].is_number());
  const std::string table = HistoryTable(b);
  EXPECT_NE(table.find(" +/- "), std::string::npos) << table;
  EXPECT_NE(table.find("step"), std::string::npos);
  const std::string html = HistoryHtml(b);
  EXPECT_NE(html.find("<svg viewBox="), std::string::npos);
  EXPECT_NE(html.find("max-width:100%"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("http"), std::string::npos);  // nothing fetched
}

// Control charts: mean 0, sigma 1, quiet around it; each rule broken by construction.
std::vector<double> Quiet() {
  std::vector<double> v;
  for (int i = 0; i < 24; ++i) v.push_back((i % 2 ? -1.0 : 1.0) * (0.2 + 0.1 * (i % 3)));
  return v;
}

std::vector<int> Rules(const std::vector<ControlChart::Flag>& flags, int rule) {
  std::vector<int> at;
  for (const auto& f : flags)
    if (f.rule == rule) at.push_back(f.index);
  return at;
}

TEST(WesternElectric, QuietSequenceHasNoFlags) {
  EXPECT_TRUE(WesternElectricFlags(Quiet(), 0.0, 1.0).empty());
  EXPECT_TRUE(WesternElectricFlags({5.0, -5.0, 4.0}, 0.0, 0.0).empty());  // no spread: no chart
}

TEST(WesternElectric, EachRuleFiresOnItsPattern) {
  std::vector<double> v = Quiet();
  v[10] = 3.5;
  auto flags = WesternElectricFlags(v, 0.0, 1.0);
  EXPECT_EQ(Rules(flags, 1), std::vector<int>{10});
  EXPECT_EQ(flags.size(), 1u);
  EXPECT_NE(flags[0].why.find("rule 1"), std::string::npos);

  v = Quiet();
  v[10] = 2.5, v[11] = 0.2, v[12] = 2.4;  // 2 of 3 beyond 2 sigma, none beyond 3
  flags = WesternElectricFlags(v, 0.0, 1.0);
  EXPECT_EQ(Rules(flags, 2), std::vector<int>{12});
  EXPECT_EQ(flags.size(), 1u);
  EXPECT_NE(flags[0].why.find("rule 2"), std::string::npos);
  v[12] = -2.4;  // the other side: no pattern
  EXPECT_TRUE(WesternElectricFlags(v, 0.0, 1.0).empty());

  v = Quiet();
  v[10] = -1.5, v[11] = -1.2, v[12] = -0.3, v[13] = -1.8, v[14] = -1.4;  // 4 of 5 below -1 sigma
  flags = WesternElectricFlags(v, 0.0, 1.0);
  EXPECT_EQ(Rules(flags, 3), std::vector<int>{14});
  EXPECT_EQ(flags.size(), 1u);
  EXPECT_NE(flags[0].why.find("below"), std::string::npos);
  v[13] = -0.8;  // 3 of 5
  EXPECT_TRUE(WesternElectricFlags(v, 0.0, 1.0).empty());

  v = Quiet();
  for (int i = 10; i < 18; ++i) v[i] = 0.4;  // 8 in a row above
  v[18] = -0.3;                               // (v[9] is below too)
  flags = WesternElectricFlags(v, 0.0, 1.0);
  EXPECT_EQ(Rules(flags, 4), std::vector<int>{17});
  EXPECT_EQ(flags.size(), 1u);
  EXPECT_NE(flags[0].why.find("rule 4"), std::string::npos);
  v[17] = -0.4;  // 7 in a row
  EXPECT_TRUE(WesternElectricFlags(v, 0.0, 1.0).empty());
}

TEST(Limits, ParsesKeysFractionsAndPercentages) {
  auto l = ParseLimits("emax_syst_after_mm=2, ed=0.5%,eb = 0.02,emax_syst_before_mm=3.5,recalibrate_days=90");
  ASSERT_TRUE(l.ok()) << l;
  EXPECT_NEAR(*l->emax_syst_after_mm, 2.0, 1e-12);
  EXPECT_NEAR(*l->emax_syst_before_mm, 3.5, 1e-12);
  EXPECT_NEAR(*l->ed_tolerance, 0.005, 1e-12);
  EXPECT_NEAR(*l->eb_tolerance, 0.02, 1e-12);
  EXPECT_NEAR(*l->recalibrate_days, 90.0, 1e-12);
  const std::string d = Describe(*l);
  EXPECT_NE(d.find("E_max,syst after <= 2 mm"), std::string::npos) << d;
  EXPECT_NE(d.find("|Ed - 1| <= 0.5 %"), std::string::npos) << d;

  auto back = LimitsFromJson(LimitsJson(*l));
  ASSERT_TRUE(back.ok()) << back;
  EXPECT_NEAR(*back->ed_tolerance, 0.005, 1e-12);
  EXPECT_NEAR(*back->recalibrate_days, 90.0, 1e-12);
  EXPECT_FALSE(LimitsJson(*l).contains("ed_tolerance"));
  EXPECT_TRUE(LimitsJson(*l).contains("ed"));

  auto empty = ParseLimits("");
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->empty());
  EXPECT_TRUE(LimitsFromJson(LimitsJson(Limits{}))->empty());
}

TEST(Limits, BadInputIsAnErrorNamingTheKey) {
  const std::pair<const char*, const char*> bad[] = {
      {"emax_syst_after_mm=2,speed=3", "speed"},  {"ed=abc", "ed"},        {"eb=-1", "eb"},
      {"emax_syst_after_mm=2%", "emax_syst_after_mm"}, {"recalibrate_days", "recalibrate_days"},
      {"ed=0.5%,ed=1%", "ed"},                    {"emax_syst_before_mm=0", "emax_syst_before_mm"},
      {"recalibrate_days=30d", "recalibrate_days"},
  };
  for (const auto& [text, key] : bad) {
    const auto l = ParseLimits(text);
    ASSERT_FALSE(l.ok()) << text;
    EXPECT_EQ(l.status, StatusCode::kInvalidArgument);
    EXPECT_NE(l.message.find(key), std::string::npos) << text << ": " << l.message;
  }
  auto j = LimitsFromJson({{"ed", 0.005}, {"speed", 1}});
  ASSERT_FALSE(j.ok());
  EXPECT_NE(j.message.find("speed"), std::string::npos);
  j = LimitsFromJson({{"eb", -0.1}});
  ASSERT_FALSE(j.ok());
  EXPECT_NE(j.message.find("eb"), std::string::npos);
}

TEST(Limits, JudgePassFailAndNotMeasured) {
  const Limits limits = *ParseLimits("emax_syst_after_mm=2,ed=0.5%");
  Record r = Calibration("R1", kStart, 72.0, 0.01, 300.0, 0.3);
  r.emax_syst_after_mm = Estimate{2.61, 0.05};
  r.ed = Estimate{1.0062, 0.0004};
  Judge(limits, &r);
  EXPECT_EQ(r.verdict, Verdict::kFail);
  ASSERT_EQ(r.failed_limits.size(), 2u);
  EXPECT_EQ(r.failed_limits[0], "E_max,syst after 2.61 mm > 2 mm");
  EXPECT_EQ(r.failed_limits[1], "|Ed - 1| 0.62 % > 0.5 %");

  r.emax_syst_after_mm = Estimate{1.5, 0.05};
  r.ed = Estimate{0.997, 0.0004};
  Judge(limits, &r);
  EXPECT_EQ(r.verdict, Verdict::kPass);
  EXPECT_TRUE(r.failed_limits.empty());

  // Just over: the digits say it is over.
  r.emax_syst_after_mm = Estimate{2.0004, 0.05};
  Judge(limits, &r);
  EXPECT_EQ(r.verdict, Verdict::kFail);
  ASSERT_EQ(r.failed_limits.size(), 1u);
  EXPECT_EQ(r.failed_limits[0], "E_max,syst after 2.0004 mm > 2 mm");

  r.emax_syst_after_mm.reset();
  Judge(limits, &r);
  EXPECT_EQ(r.verdict, Verdict::kFail);
  ASSERT_EQ(r.failed_limits.size(), 1u);
  EXPECT_EQ(r.failed_limits[0].rfind("E_max,syst after not measured", 0), 0u) << r.failed_limits[0];

  Judge(*ParseLimits("recalibrate_days=30"), &r);  // an interval is no acceptance limit
  EXPECT_EQ(r.verdict, Verdict::kNone);
  EXPECT_TRUE(r.failed_limits.empty());
  Judge(Limits{}, &r);
  EXPECT_EQ(r.verdict, Verdict::kNone);
}

TEST(Fleet, PassRateCausesAndChartsAgainstAHandComputation) {
  const Limits limits = *ParseLimits("emax_syst_after_mm=2,ed=0.5%");
  // Four robots, named out of build order; each calibrated twice. The charts read the first
  // record (the build), the verdict the last.
  struct Robot {
    std::string name;
    double built_day;
    double first_ed, last_ed;
    double first_emax_before;
    std::optional<double> last_emax_after;
  };
  const Robot robots[] = {
      {"delta", 0, 1.002, 1.001, 3.0, 1.0},    // built first; passes
      {"<alpha>", 1, 1.004, 1.002, 4.0, 2.5},  // fails E_max,syst after
      {"charlie", 2, 0.998, 1.009, 2.0, std::nullopt},  // fails E_max,syst after (not measured) and Ed
      {"bravo", 3, 1.010, 0.999, 5.0, 1.2},    // passes
  };
  std::vector<Record> all;
  for (const Robot& r : robots) {
    Record first = Calibration(r.name, kStart + r.built_day * 86400.0, 72.0, 0.01, 300.0, 0.3);
    first.ed = Estimate{r.first_ed, 0.0005};
    first.emax_syst_before_mm = Estimate{r.first_emax_before, 0.1};
    Record last = Calibration(r.name, kStart + (30 + r.built_day) * 86400.0, 71.9, 0.01, 300.0, 0.3);
    last.ed = Estimate{r.last_ed, 0.0005};
    last.emax_syst_before_mm = Estimate{1.0, 0.1};
    if (r.last_emax_after) last.emax_syst_after_mm = Estimate{*r.last_emax_after, 0.1};
    Judge(limits, &last);
    all.push_back(first);
    all.push_back(last);
  }
  HistoryOptions o = Options();
  o.limits = limits;
  o.limits.recalibrate_days = 20;
  o.now_s = kStart + 52 * 86400.0;  // due: those last calibrated by day 32
  const FleetSummary fleet = SummariseFleet(all, o);

  ASSERT_EQ(fleet.robots.size(), 4u);
  EXPECT_EQ(fleet.robots[0].robot, "<alpha>");
  EXPECT_EQ(fleet.robots[3].robot, "delta");
  EXPECT_EQ(fleet.records, 8);
  EXPECT_EQ(fleet.robots[0].calibrations, 2);
  EXPECT_EQ(fleet.judged, 4);
  EXPECT_EQ(fleet.passed, 2);
  // due: last + 20 days <= day 52: delta (30), <alpha> (31), charlie (32); not bravo (33).
  EXPECT_TRUE(fleet.robots[0].due);   // <alpha>
  EXPECT_FALSE(fleet.robots[1].due);  // bravo
  EXPECT_TRUE(fleet.robots[2].due);   // charlie
  EXPECT_TRUE(fleet.robots[3].due);   // delta
  ASSERT_EQ(fleet.causes.size(), 2u);
  EXPECT_EQ(fleet.causes[0], (std::pair<std::string, int>{"E_max,syst after", 2}));
  EXPECT_EQ(fleet.causes[1], (std::pair<std::string, int>{"|Ed - 1|", 1}));

  // Ed and E_max,syst before in build order (delta, <alpha>, charlie, bravo); E_max,syst after
  // from the first record that has it (the last here; charlie has none); Eb nowhere: no chart.
  ASSERT_EQ(fleet.charts.size(), 3u);
  const ControlChart& ed = fleet.charts[0];
  EXPECT_EQ(ed.quantity, "Ed");
  EXPECT_EQ(ed.robots, (std::vector<std::string>{"delta", "<alpha>", "charlie", "bravo"}));
  // mean (1.002 + 1.004 + 0.998 + 1.010) / 4 = 1.0035; moving ranges 0.002, 0.006, 0.012,
  // their mean 0.02 / 3, sigma that over 1.128.
  EXPECT_NEAR(ed.mean, 1.0035, 1e-12);
  EXPECT_NEAR(ed.sigma, 0.02 / 3.0 / 1.128, 1e-12);
  const ControlChart& emax = fleet.charts[1];
  EXPECT_EQ(emax.quantity, "emax_syst_before_mm");
  EXPECT_NEAR(emax.mean, 3.5, 1e-12);
  EXPECT_NEAR(emax.sigma, (1.0 + 2.0 + 3.0) / 3.0 / 1.128, 1e-12);
  const ControlChart& after = fleet.charts[2];
  EXPECT_EQ(after.quantity, "emax_syst_after_mm");
  EXPECT_EQ(after.robots, (std::vector<std::string>{"delta", "<alpha>", "bravo"}));
  EXPECT_NEAR(after.mean, (1.0 + 2.5 + 1.2) / 3.0, 1e-12);
  EXPECT_NEAR(after.sigma, (1.5 + 1.3) / 2.0 / 1.128, 1e-12);

  const nlohmann::json j = FleetJson(fleet);
  EXPECT_NEAR(j["pass_rate"].get<double>(), 0.5, 1e-12);
  EXPECT_EQ(j["causes"][0]["limit"], "E_max,syst after");
  EXPECT_EQ(j["causes"][0]["count"], 2);
  EXPECT_NEAR(j["charts"][0]["ucl"].get<double>(), 1.0035 + 3.0 * ed.sigma, 1e-12);
  EXPECT_EQ(j["robots"][0]["verdict"], "fail");
  EXPECT_TRUE(j["robots"][0]["due_utc"].is_string());
  EXPECT_TRUE(j["robots"][0].contains("wear_mm_per_week"));

  const std::string table = FleetTable(fleet);
  EXPECT_NE(table.find("passed 2 of 4"), std::string::npos) << table;
  const std::string html = FleetHtml(fleet);
  EXPECT_EQ(html.find("<alpha>"), std::string::npos);  // escaped
  EXPECT_NE(html.find("&lt;alpha&gt;"), std::string::npos);
  EXPECT_NE(html.find("class=\"due\""), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
}

TEST(Fleet, ControlChartFlagsAnOutlyingBuild) {
  std::vector<Record> all;
  const double ed[] = {1.001, 0.999, 1.002, 1.000, 0.998, 1.001, 1.000, 1.030, 0.999, 1.001};
  for (int i = 0; i < 10; ++i) {
    Record r = Calibration("robot" + std::to_string(i), kStart + i * 86400.0, 72.0, 0.01, 300.0, 0.3);
    r.ed = Estimate{ed[i], 0.0005};
    r.eb = Estimate{0.999, 0.001};  // every build alike: a chart with sigma 0 must still draw
    all.push_back(r);
  }
  const FleetSummary fleet = SummariseFleet(all, Options());
  ASSERT_EQ(fleet.charts.size(), 2u);
  EXPECT_NEAR(fleet.charts[1].sigma, 0.0, 1e-12);
  EXPECT_TRUE(fleet.charts[1].flags.empty());
  EXPECT_EQ(fleet.judged, 0);
  EXPECT_TRUE(FleetJson(fleet)["pass_rate"].is_null());
  ASSERT_FALSE(fleet.charts[0].flags.empty());
  EXPECT_EQ(fleet.charts[0].flags[0].index, 7);
  EXPECT_EQ(fleet.charts[0].flags[0].rule, 1);
  EXPECT_NE(FleetHtml(fleet).find("class=\"flag\""), std::string::npos);
}

}  // namespace
}  // namespace odocal::records
