#include "odocal/simulation/stand_in_camera.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include <nlohmann/json.hpp>

#include "odocal/base/units.h"
#include "odocal/calibration/rest.h"

namespace odocal::simulation {

using calibration::RunFlag;
using calibration::RunFlagKind;

namespace {

using calibration::Pose2;

std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream ss(line);
  std::string f;
  while (std::getline(ss, f, ',')) fields.push_back(f);
  return fields;
}

bool ReadCsv(const std::string& path, size_t n_fields, std::vector<std::vector<double>>* rows,
             std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = path + ": cannot read";
    return false;
  }
  std::string line;
  std::getline(in, line);  // header
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty()) continue;
    const std::vector<std::string> fields = SplitCsvLine(line);
    if (fields.size() != n_fields) {
      *error = path + ":" + std::to_string(line_no) + ": expected " + std::to_string(n_fields) +
               " fields";
      return false;
    }
    std::vector<double> row;
    for (const std::string& f : fields) {
      char* end = nullptr;
      const double v = std::strtod(f.c_str(), &end);
      if (end == f.c_str() || !std::isfinite(v)) {
        *error = path + ":" + std::to_string(line_no) + ": not a number: '" + f + "'";
        return false;
      }
      row.push_back(v);
    }
    rows->push_back(row);
  }
  return true;
}

// The image row, as a fraction v / (H - 1), at which `camera` (a pinhole with
// vertical field `vertical_fov_rad`, the middle row on its axis) sees the
// tag-plane point p.
double RowFraction(const calibration::FloorCamera& camera, double vertical_fov_rad,
                   const Eigen::Vector2d& p) {
  const Eigen::Vector3d c =
      camera.R_camera_world * (Eigen::Vector3d(p.x(), p.y(), 0.0) - camera.centre_m);
  return 0.5 + (c.y() / c.z()) / (2.0 * std::tan(vertical_fov_rad / 2.0));
}

}  // namespace

calibration::Pose2 TruthAt(const SimulatedRunRecord& run, double t) {
  const std::vector<double>& ts = run.truth_t_s;
  if (t <= ts.front()) return run.truth_poses.front();
  if (t >= ts.back()) return run.truth_poses.back();
  const size_t k = static_cast<size_t>(std::upper_bound(ts.begin(), ts.end(), t) - ts.begin()) - 1;
  const double u = (t - ts[k]) / std::max(ts[k + 1] - ts[k], 1e-12);
  const Pose2& a = run.truth_poses[k];
  const Pose2& b = run.truth_poses[k + 1];
  const double dh = calibration::WrapAngle(b.heading() - a.heading());
  return Pose2::FromXYHeading(a.x() + u * (b.x() - a.x()), a.y() + u * (b.y() - a.y()),
                              a.heading() + u * dh);
}

bool StandInCameraOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(fps > 0.0)) return fail("camera fps must be positive");
  if (!(sigma_position_m > 0.0)) return fail("camera position sigma must be positive");
  if (!(sigma_heading_rad > 0.0)) return fail("camera heading sigma must be positive");
  if (home_radius_m && !(*home_radius_m > 0.0)) return fail("home radius must be positive");
  if (!camera.IsValid()) return fail("camera must be above the tag plane, looking down at it");
  if (!(rolling_shutter_s >= 0.0)) return fail("rolling shutter readout must not be negative");
  if (!(vertical_fov_rad > 0.0 && vertical_fov_rad < M_PI))
    return fail("vertical field of view must be in (0, 180) deg");
  return true;
}

calibration::MeasuredSession MeasureWithStandInCamera(const calibration::WheelParams& believed,
                                                      const std::vector<SimulatedRunRecord>& runs,
                                                      const StandInCameraOptions& options) {
  calibration::MeasuredSession session;
  session.believed = believed;
  session.camera = options.camera;
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double period = 1.0 / options.fps;
  for (const SimulatedRunRecord& run : runs) {
    calibration::MeasuredRun mr;
    mr.name = run.name;
    mr.spec = run.spec;
    mr.telemetry = run.telemetry;
    if (run.telemetry.empty() || run.truth_poses.empty()) {
      mr.flags.push_back(RunFlag::Of(RunFlagKind::kNoTelemetry));
      session.runs.push_back(mr);
      continue;
    }
    // The camera runs continuously on its own frame grid (capture times k / fps).
    const double t0 = run.telemetry.front().t_s, t1 = run.telemetry.back().t_s;
    std::vector<calibration::PoseSample> samples;
    for (double k = std::ceil(t0 / period); k * period <= t1; k += 1.0) {
      const double t_capture = k * period;
      // The tag centre's image row; with a rolling shutter, the row whose
      // exposure time shows the tag there (a fixed point: the tag moves a
      // fraction of a row in the readout's shift).
      const Eigen::Vector2d tag_on_robot(options.tag_x_m, options.tag_y_m);
      Pose2 truth = TruthAt(run, t_capture);
      double row = RowFraction(options.camera, options.vertical_fov_rad, truth * tag_on_robot);
      if (options.rolling_shutter_s > 0.0)
        for (int iteration = 0; iteration < 3; ++iteration) {
          truth = TruthAt(run, t_capture + (row - 0.5) * options.rolling_shutter_s);
          row = RowFraction(options.camera, options.vertical_fov_rad, truth * tag_on_robot);
        }
      calibration::CameraRecord f;
      f.image_row_fraction = row;
      f.t_s = t_capture - options.latency_s;
      f.sigma_position_m = options.sigma_position_m;
      f.sigma_heading_rad = options.sigma_heading_rad;
      f.valid = !options.home_radius_m ||
                (truth.translation() - options.home_centre_m).norm() <= *options.home_radius_m;
      // What the camera sees: the tag (wherever it really is on the robot)...
      Eigen::Vector2d p = truth * tag_on_robot;
      // ...through a lens whose k1 is off by k1_delta.
      calibration::SeenThroughLens(options.camera, p.x(), p.y(), options.k1_delta, 0.0, 0.0, &p.x(),
                                   &p.y());
      const double nx = normal(rng), ny = normal(rng), nh = normal(rng);
      f.T_world_robot = Pose2::FromXYHeading(p.x() + options.sigma_position_m * nx,
                                             p.y() + options.sigma_position_m * ny,
                                             truth.heading() + options.tracker_yaw_rad +
                                                 options.sigma_heading_rad * nh);
      mr.camera.push_back(f);
      samples.push_back({f.t_s, f.T_world_robot, f.valid});
    }
    // The rests before and after the run, as the camera pipeline finds them.
    const calibration::RestSummary rests = calibration::FindRests(samples);
    if (!rests.rests.empty() && rests.rests.front().t_begin_s <= samples.front().t_s + 0.2)
      mr.start_rest = rests.rests.front();
    else
      mr.flags.push_back(RunFlag::Of(RunFlagKind::kNoStartRest));
    if (!rests.rests.empty() && rests.rests.back().t_end_s >= samples.back().t_s - 0.2 &&
        (!mr.start_rest || rests.rests.size() > 1))
      mr.end_rest = rests.rests.back();
    else
      mr.flags.push_back(RunFlag::Of(RunFlagKind::kNoEndRest));
    if (mr.start_rest && mr.end_rest)
      mr.return_error = calibration::Between(*mr.start_rest, *mr.end_rest);
    session.runs.push_back(mr);
  }
  return session;
}

std::vector<SimulatedRunRecord> SimulatedRunRecordsOf(const SimulationResult& result) {
  std::vector<SimulatedRunRecord> runs;
  for (size_t i = 0; i < result.runs.size(); ++i) {
    const sim::RunRecord& r = result.runs[i];
    SimulatedRunRecord run;
    run.name = result.run_names[i];
    run.spec = r.spec;
    for (const sim::TelemetrySample& s : r.telemetry)
      run.telemetry.push_back({s.t_s, s.left_ticks, s.right_ticks, s.odometry});
    for (const sim::TruthSample& s : r.trajectory) {
      if (!run.truth_t_s.empty() && s.t_s <= run.truth_t_s.back()) continue;
      run.truth_t_s.push_back(s.t_s);
      run.truth_poses.push_back(s.T_world_robot);
    }
    runs.push_back(std::move(run));
  }
  return runs;
}

Result<calibration::MeasuredSession> LoadSimulatedSession(const std::string& dir, const StandInCameraOptions& options) {
  using R = Result<calibration::MeasuredSession>;
  std::string why;
  if (!options.IsValid(&why)) return R::Error(StatusCode::kInvalidArgument, why);
  const std::string truth_path = dir + "/truth.json";
  std::ifstream in(truth_path);
  if (!in)
    return R::Error(StatusCode::kNotFound,
                    truth_path + ": cannot read (expected an `odocal simulate --out` directory)");
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    return R::Error(StatusCode::kBadFile, truth_path + ": not JSON: " + e.what());
  }
  calibration::WheelParams believed;
  std::vector<SimulatedRunRecord> runs;
  try {
    // Only the nominal parameters and the plan: never `truth`, true poses or effects.
    const nlohmann::json& nominal = doc.at("robot").at("nominal");
    believed.left_wheel_diameter_m = nominal.at("left_wheel_diameter_mm").get<double>() * kMmToM;
    believed.right_wheel_diameter_m = nominal.at("right_wheel_diameter_mm").get<double>() * kMmToM;
    believed.track_m = nominal.at("track_mm").get<double>() * kMmToM;
    believed.ticks_per_rev = nominal.at("ticks_per_rev").get<double>();
    for (const nlohmann::json& j : doc.at("runs")) {
      SimulatedRunRecord run;
      run.name = j.at("name").get<std::string>();
      const auto procedure = calibration::ParseProcedure(j.at("procedure").get<std::string>());
      if (!procedure) throw std::runtime_error("runs[].procedure: unknown");
      run.spec.procedure = *procedure;
      if (j.contains("direction"))
        run.spec.direction =
            calibration::ParseDirection(j["direction"].get<std::string>()).value_or(
                calibration::Direction::kCw);
      if (j.contains("reference"))
        run.spec.reference =
            calibration::ParseReference(j["reference"].get<std::string>()).value_or(
                calibration::Reference::kCamera);
      run.spec.side_m = j.value("side_mm", 0.0) * kMmToM;
      run.spec.distance_m = j.value("distance_mm", 0.0) * kMmToM;
      run.spec.turns = j.value("turns", 0);
      run.spec.repeats = j.value("repeats", 1);
      std::vector<std::vector<double>> rows;
      const std::string telemetry = dir + "/" + j.at("telemetry").get<std::string>();
      if (!ReadCsv(telemetry, 7, &rows, &why)) return R::Error(StatusCode::kBadFile, why);
      for (const auto& r : rows)
        run.telemetry.push_back({r[0], static_cast<std::int64_t>(std::llround(r[1])),
                                 static_cast<std::int64_t>(std::llround(r[2])),
                                 Pose2::FromXYHeading(r[3] * kMmToM, r[4] * kMmToM, r[5] * kDegToRad)});
      rows.clear();
      // The true trajectory feeds only the stand-in camera.
      const std::string trajectory = dir + "/" + j.at("trajectory").get<std::string>();
      if (!ReadCsv(trajectory, 4, &rows, &why)) return R::Error(StatusCode::kBadFile, why);
      for (const auto& r : rows) {
        if (!run.truth_t_s.empty() && r[0] <= run.truth_t_s.back()) continue;
        run.truth_t_s.push_back(r[0]);
        run.truth_poses.push_back(Pose2::FromXYHeading(r[1] * kMmToM, r[2] * kMmToM, r[3] * kDegToRad));
      }
      runs.push_back(std::move(run));
    }
  } catch (const std::exception& e) {
    return R::Error(StatusCode::kBadFile, truth_path + ": " + e.what());
  }
  if (!believed.IsValid(&why)) return R::Error(StatusCode::kBadFile, truth_path + ": robot.nominal." + why);
  return R::Ok(MeasureWithStandInCamera(believed, runs, options));
}

}  // namespace odocal::simulation
