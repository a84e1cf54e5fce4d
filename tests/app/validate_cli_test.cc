// odocal validate end to end on the committed sample session (real H.264
// videos): manual numbers made from the renderer's truth plus a known bias and
// scatter come back as that bias and those limits of agreement; bad CSV files
// fail with one line naming the file and the line.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "odocal/config/manual_csv.h"
#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

using test_util::RunCommand;

using test_util::Odocal;
std::string SamplePath() { return test_util::SourceDir() + "/sample_data/session/session.yaml"; }

using test_util::ReadJson;
using test_util::Slurp;

struct Put {
  double bias, sd;
};

TEST(ValidateCli, RecoversTheBiasAndLimitsPutIntoTheTape) {
  const nlohmann::json truth =
      ReadJson(test_util::SourceDir() + "/sample_data/session_truth/truth.json");
  const std::string dir = test_util::MakeTempDir("odocal_validate_");
  // Twelve readings a run (operators with the same tape habit).
  const Put x{1.5, 2.0}, y{-0.8, 1.5}, theta{0.3, 0.4};
  std::mt19937 rng(4711);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::ofstream csv(dir + "/manual.csv");
  csv << "# made from truth.json + bias (1.5, -0.8 mm, 0.3 deg) + N(0, (2.0, 1.5 mm, 0.4 deg))\n";
  csv << "run,x_mm,y_mm,theta_deg\n";
  int readings = 0;
  for (const auto& run : truth["runs"]) {
    const auto& e = run["true_return_error"];
    for (int k = 0; k < 12; ++k, ++readings)
      csv << run["name"].get<std::string>() << "," << e["x_mm"].get<double>() + x.bias + x.sd * unit(rng)
          << "," << e["y_mm"].get<double>() + y.bias + y.sd * unit(rng) << ","
          << e["theta_deg"].get<double>() + theta.bias + theta.sd * unit(rng) << "\n";
  }
  csv.close();
  ASSERT_GE(readings, 24);
  // 18 interval checks below: at 99.9 % each, all hold with probability 98 %
  // (at 95 % about one would miss by construction).
  const auto r = RunCommand(Odocal("validate --confidence 0.999 --manual " + dir + "/manual.csv " +
                                   SamplePath() + " --out " + dir + "/out"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::printf("%s", r.out.c_str());
  const nlohmann::json report = ReadJson(dir + "/out/report.json");
  ASSERT_EQ(report["axes"].size(), 3u);
  const double z = 3.290526731;  // normal quantile of 0.9995
  for (const auto& a : report["axes"]) {
    const std::string axis = a["axis"];
    const Put put = axis == "x" ? x : axis == "y" ? y : theta;
    EXPECT_EQ(a["n"].get<int>(), readings) << axis;
    const double bias = a["bias"], sd = a["sd"];
    std::printf("%s: put in bias %.2f sd %.2f; reported bias %.3f [%.3f, %.3f], sd %.3f, limits "
                "%.3f [%.3f, %.3f] to %.3f [%.3f, %.3f]\n",
                axis.c_str(), put.bias, put.sd, bias, a["bias_ci"][0].get<double>(),
                a["bias_ci"][1].get<double>(), sd, a["lower_limit"].get<double>(),
                a["lower_limit_ci"][0].get<double>(), a["lower_limit_ci"][1].get<double>(),
                a["upper_limit"].get<double>(), a["upper_limit_ci"][0].get<double>(),
                a["upper_limit_ci"][1].get<double>());
    // The camera's own error (tens of micrometres, hundredths of a degree)
    // is negligible against the tape's.
    EXPECT_LE(a["bias_ci"][0].get<double>(), put.bias) << axis;
    EXPECT_GE(a["bias_ci"][1].get<double>(), put.bias) << axis;
    EXPECT_LE(a["lower_limit_ci"][0].get<double>(), put.bias - z * put.sd) << axis;
    EXPECT_GE(a["lower_limit_ci"][1].get<double>(), put.bias - z * put.sd) << axis;
    EXPECT_LE(a["upper_limit_ci"][0].get<double>(), put.bias + z * put.sd) << axis;
    EXPECT_GE(a["upper_limit_ci"][1].get<double>(), put.bias + z * put.sd) << axis;
    // And the intervals are narrow enough to mean something: the bias's is
    // 2 t sd / sqrt(n) (1.5 sd at n = 24, t = 3.77), a limit's 2 t sd
    // sqrt(1/n + z^2 / (2 (n - 1))) (4.0 sd at n = 24).
    EXPECT_LT(a["bias_ci"][1].get<double>() - a["bias_ci"][0].get<double>(), 2.0 * put.sd) << axis;
    EXPECT_LT(a["lower_limit_ci"][1].get<double>() - a["lower_limit_ci"][0].get<double>(), 6.0 * put.sd)
        << axis;
    EXPECT_LT(a["upper_limit_ci"][1].get<double>() - a["upper_limit_ci"][0].get<double>(), 6.0 * put.sd)
        << axis;
    EXPECT_NEAR(a["z"].get<double>(), z, 1e-6);
    EXPECT_LT(a["camera_sigma_max"].get<double>(), 0.1 * put.sd) << axis;
  }
  const std::string verdict = report["verdict"]["text"];
  EXPECT_THAT(verdict, ::testing::HasSubstr("good for UMBMark when E_max,syst is above")) << verdict;
  // |bias| + z sd of the worse axis, x: 1.5 + 3.29 * 2 = 8.1 mm.
  EXPECT_NEAR(report["verdict"]["error_bound_mm"].get<double>(), 1.5 + z * 2.0, 2.0);

  const std::string html = Slurp(dir + "/out/report.html");
  EXPECT_THAT(html, ::testing::HasSubstr("<svg"));
  EXPECT_THAT(html, ::testing::HasSubstr("class='bland-altman'"));
  EXPECT_THAT(html, ::testing::HasSubstr("class='trajectories'"));
  EXPECT_EQ(html.find("http://"), html.find("http://www.w3.org/2000/svg"));  // no external assets
  EXPECT_THAT(html, ::testing::Not(::testing::HasSubstr("<script")));
}

TEST(ValidateCli, AWildReadingIsFlaggedAsAnOutlier) {
  const nlohmann::json truth =
      ReadJson(test_util::SourceDir() + "/sample_data/session_truth/truth.json");
  const std::string dir = test_util::MakeTempDir("odocal_validate_outlier_");
  std::mt19937 rng(99);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::ofstream csv(dir + "/manual.csv");
  csv << "run,x_mm,y_mm\n";
  int line = 1;
  int wild_line = 0;
  for (const auto& run : truth["runs"]) {
    const auto& e = run["true_return_error"];
    for (int k = 0; k < 3; ++k) {
      ++line;
      const bool wild = wild_line == 0 && k == 1;  // a misread: 25 mm off in x
      if (wild) wild_line = line;
      csv << run["name"].get<std::string>() << "," << e["x_mm"].get<double>() + noise(rng) + (wild ? 25.0 : 0.0)
          << "," << e["y_mm"].get<double>() + noise(rng) << "\n";
    }
  }
  csv.close();
  const auto r = RunCommand(Odocal("validate --manual " + dir + "/manual.csv " + SamplePath() +
                                   " --out " + dir + "/out"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = ReadJson(dir + "/out/report.json");
  ASSERT_EQ(report["axes"].size(), 2u);  // no theta column
  const auto& ax = report["axes"][0];
  ASSERT_EQ(ax["axis"], "x");
  ASSERT_EQ(ax["outliers"].size(), 1u);
  EXPECT_EQ(ax["outliers"][0]["line"].get<int>(), wild_line);
  EXPECT_EQ(report["axes"][1]["outliers"].size(), 0u);
}

// Bad input: one line on stderr naming the file (and the line), exit 2.
struct BadCsv {
  std::string name;
  std::string contents;  // empty name of file: missing
  std::string expected;  // in the error line
};

TEST(ValidateCli, BadCsvFailsWithOneClearLine) {
  const std::string dir = test_util::MakeTempDir("odocal_validate_bad_");
  const std::vector<BadCsv> cases = {
      {"missing", "", "manual.csv: cannot open"},
      {"empty", "\n# nothing\n", "manual.csv: empty"},
      {"header_only", "run,x_mm,y_mm\n", "no readings"},
      {"missing_column", "run,x_mm\nrun01_umbmark_cw,1\n", "manual.csv:1: header: missing column 'y_mm'"},
      {"unknown_run", "run,x_mm,y_mm\nrun01_umbmark_cw,1,2\nrun99,1,2\n",
       "manual.csv:3: run 'run99' is not in"},
      {"non_numeric", "run,x_mm,y_mm\nrun01_umbmark_cw,1,2\nrun01_umbmark_cw,1,two\n",
       "manual.csv:3: y_mm: 'two' is not a finite number"},
      {"wrong_unit", "run,x_cm,y_cm\nrun01_umbmark_cw,1,2\n",
       "manual.csv:1: header: unknown column 'x_cm'; odocal reads x_mm (millimetres)"},
      {"wrong_theta_unit", "run,x_mm,y_mm,theta_rad\n", "unknown column 'theta_rad'; odocal reads theta_deg"},
      {"short_line", "run,x_mm,y_mm\n\nrun01_umbmark_cw,1\n", "manual.csv:3: 2 cells, the header has 3"},
  };
  for (const BadCsv& c : cases) {
    const std::string sub = dir + "/" + c.name;
    std::filesystem::create_directories(sub);
    if (c.name != "missing") std::ofstream(sub + "/manual.csv") << c.contents;
    const auto r = RunCommand(Odocal("validate --manual " + sub + "/manual.csv " + SamplePath() +
                                     " --out " + sub + "/out"));
    EXPECT_EQ(r.exit_code, 2) << c.name << ": " << r.err;
    EXPECT_THAT(r.err, ::testing::HasSubstr(c.expected)) << c.name << ": " << r.err;
    EXPECT_THAT(r.err, ::testing::HasSubstr(sub + "/manual.csv")) << c.name << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.name << ": " << r.err;
    EXPECT_FALSE(std::filesystem::exists(sub + "/out/report.json")) << c.name;
  }
}

TEST(ValidateCli, TooFewReadingsForStatisticsFail) {
  const std::string dir = test_util::MakeTempDir("odocal_validate_few_");
  std::ofstream(dir + "/manual.csv") << "run,x_mm,y_mm\nrun01_umbmark_cw,-9,-10\nrun02_umbmark_ccw,-8,9\n";
  const auto r = RunCommand(Odocal("validate --manual " + dir + "/manual.csv " + SamplePath() +
                                   " --out " + dir + "/out"));
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("fewer than 3 readings")) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/out/report.json"));
}

TEST(ValidateCsv, ReadsOptionalThetaCommentsAndColumnOrder) {
  const std::string dir = test_util::MakeTempDir("odocal_manual_csv_");
  std::ofstream(dir + "/m.csv") << "# comment\ny_mm, run ,x_mm,theta_deg\n-2.5,a,1e1,\n3,b,-4,0.25\n";
  const auto r = config::ReadManualCsv(dir + "/m.csv");
  ASSERT_TRUE(r) << r.message;
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[0].run, "a");
  EXPECT_EQ((*r)[0].line, 3);
  EXPECT_NEAR((*r)[0].x_mm, 10.0, 1e-12);
  EXPECT_NEAR((*r)[0].y_mm, -2.5, 1e-12);
  EXPECT_FALSE((*r)[0].theta_deg.has_value());
  ASSERT_TRUE((*r)[1].theta_deg.has_value());
  EXPECT_NEAR(*(*r)[1].theta_deg, 0.25, 1e-12);
}

}  // namespace
}  // namespace odocal
