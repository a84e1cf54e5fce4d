// A look at real data: the OptiOdom differential-drive runs (motion capture as
// the pose source; ../shared/realdata/optiodom/README.md), through the
// trajectory fit, replay and explain. A test-only loader (the importer for
// the CLI is another engineer's work); skipped when the data are absent.
// Prints figures; asserts only what must hold on any robot.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "odocal/calibration/explain.h"
#include "odocal/calibration/replay.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration {
namespace {

// The data sit beside the work trees (../shared from the main tree, ../../shared
// from a worktree under wt/).
std::string Root() {
  for (const char* root : {"../shared/realdata/optiodom/diff/", "../../shared/realdata/optiodom/diff/"})
    if (std::filesystem::exists(root)) return root;
  return "../shared/realdata/optiodom/diff/";
}

std::vector<std::vector<double>> ReadRows(const std::string& path) {
  std::vector<std::vector<double>> rows;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream ss(line);
    std::string f;
    while (std::getline(ss, f, ',')) row.push_back(f.empty() ? NAN : std::stod(f));
    rows.push_back(row);
  }
  return rows;
}

// One set (a folder): believed parameters from its metadata, every run.
std::optional<MeasuredSession> LoadSet(const std::string& set) {
  const std::string dir = Root() + set;
  if (!std::filesystem::exists(dir)) return std::nullopt;
  const std::string stamp = std::filesystem::path(set).filename();
  MeasuredSession session;
  std::ifstream meta(dir + "/" + stamp + "_metadata.csv");
  std::string line;
  while (std::getline(meta, line)) {
    std::stringstream ss(line);
    std::string key, a, b;
    std::getline(ss, key, ',');
    std::getline(ss, a, ',');
    std::getline(ss, b, ',');
    if (key == "Li") session.believed.track_m = std::stod(a);
    if (key == "Di") {
      session.believed.right_wheel_diameter_m = std::stod(a);
      session.believed.left_wheel_diameter_m = std::stod(b);
    }
  }
  session.believed.ticks_per_rev = 64 * 43.7;
  for (int i = 1; i < 100; ++i) {
    char name[64];
    std::snprintf(name, sizeof(name), "%s_run-%02d.csv", stamp.c_str(), i);
    if (!std::filesystem::exists(dir + "/" + name)) break;
    MeasuredRun run;
    run.name = set + "/" + std::to_string(i);
    std::int64_t left = 0, right = 0;
    for (const auto& r : ReadRows(dir + "/" + name)) {
      right += static_cast<std::int64_t>(std::llround(r[4]));
      left += static_cast<std::int64_t>(std::llround(r[5]));
      run.telemetry.push_back({r[0], left, right, Pose2()});
      CameraRecord f;
      f.t_s = r[0];
      f.valid = std::isfinite(r[1]) && std::isfinite(r[2]) && std::isfinite(r[3]);
      if (f.valid) f.T_world_robot = Pose2::FromXYHeading(r[1], r[2], r[3]);
      // Motion capture: 0.05-0.1 mm scatter at rest (measured on the first
      // frames of these runs); heading stated alike.
      f.sigma_position_m = 0.1e-3;
      f.sigma_heading_rad = 0.05 * M_PI / 180.0;
      run.camera.push_back(f);
    }
    session.runs.push_back(run);
  }
  return session;
}

MeasuredSession Merge(const std::vector<MeasuredSession>& sets) {
  MeasuredSession s = sets.front();
  for (size_t i = 1; i < sets.size(); ++i)
    s.runs.insert(s.runs.end(), sets[i].runs.begin(), sets[i].runs.end());
  return s;
}

void PrintReplays(const char* what, const MeasuredSession& s, const TrajectoryFitResult& fit) {
  double sum = 0.0;
  int n = 0;
  for (const MeasuredRun& run : s.runs) {
    const RunReplay r = ReplayRun(run, s.believed, {fit.scales, fit.effects});
    if (!r.ok) {
      std::printf("  %s: %s\n", what, r.message.c_str());
      continue;
    }
    std::printf("[real] %s %-28s final %.2f mm (%.3f %% of %.2f m), heading %.2f deg, RMS %.2f mm\n",
                what, run.name.c_str(), r.final_position_error_m * 1e3,
                100 * r.final_error_fraction(), r.distance_m, r.final_heading_error_rad * 180 / M_PI,
                r.rms_position_error_m * 1e3);
    sum += r.rms_position_error_m * r.rms_position_error_m;
    ++n;
  }
  if (n) std::printf("[real] %s RMS over runs %.2f mm\n", what, std::sqrt(sum / n));
}

TEST(OptiOdomLook, CirclesAgainstAFitOnStraightsAndTurns) {
  const auto ivanjko = LoadSet("ivanjko/250620201618");
  const auto circles = LoadSet("circular/250620202104");
  if (!ivanjko || !circles) GTEST_SKIP() << "OptiOdom data not found under " << Root();
  TrajectoryFitOptions o;
  o.wheel_noise_draws = 4;
  const TrajectoryFitResult on_ivanjko = FitTrajectory(*ivanjko, o);
  ASSERT_TRUE(on_ivanjko.ok()) << on_ivanjko.message;
  std::printf("ivanjko fit:\n%s", on_ivanjko.BriefReport().c_str());
  const TrajectoryFitResult on_circles = FitTrajectory(*circles, o);
  ASSERT_TRUE(on_circles.ok()) << on_circles.message;
  std::printf("circles fit:\n%s", on_circles.BriefReport().c_str());
  PrintReplays("ivanjko-fit on ivanjko", *ivanjko, on_ivanjko);
  PrintReplays("ivanjko-fit on circles", *circles, on_ivanjko);
  PrintReplays("circle-fit on circles", *circles, on_circles);
  const ExplainResult e = Explain(Merge({*ivanjko, *circles}));
  std::printf("explain ivanjko + circles:\n%s", e.BriefReport().c_str());
}

}  // namespace
}  // namespace odocal::calibration
