#include "odocal/calibration/replay.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>

namespace odocal::calibration {
namespace {

struct Frame {
  double t_s = 0.0;
  Pose2 z;
  double sigma_p = 0.0;
  double sigma_h = 0.0;
  double row_fraction = 0.0;  // CameraRecord::image_row_fraction (NaN: unknown)
};

// The start pose whose prediction best matches the anchor frames (whitened
// least squares by Gauss-Newton with a numeric Jacobian: 3 parameters, a few
// hundred residuals; the model is smooth in the start pose).
Pose2 AnchorStart(const MeasuredRun& run, const WheelParams& believed, const ReplayModel& model,
                  const std::optional<FloorCamera>& camera, const ReplayOptions& options,
                  const std::vector<Frame>& anchor) {
  std::vector<double> stamps, rows;
  for (const Frame& f : anchor) {
    stamps.push_back(f.t_s);
    rows.push_back(f.row_fraction);
  }
  auto predict = [&](const Eigen::Vector3d& s) {
    return PredictMeasuredPoses(run, believed, model.scales, model.effects, camera,
                                Pose2::FromXYHeading(s[0], s[1], s[2]), stamps,
                                options.left_direction0, options.right_direction0, rows);
  };
  auto residuals = [&](const Eigen::Vector3d& s) {
    const std::vector<Pose2> p = predict(s);
    Eigen::VectorXd r(3 * anchor.size());
    for (size_t j = 0; j < anchor.size(); ++j) {
      r[3 * j] = (p[j].x() - anchor[j].z.x()) / anchor[j].sigma_p;
      r[3 * j + 1] = (p[j].y() - anchor[j].z.y()) / anchor[j].sigma_p;
      r[3 * j + 2] = WrapAngle(p[j].heading() - anchor[j].z.heading()) / anchor[j].sigma_h;
    }
    return r;
  };
  // Initial guess: the first anchor frame, with the motion the model predicts
  // up to it (from an identity start) undone.
  const std::vector<Pose2> relative = predict(Eigen::Vector3d::Zero());
  const Pose2 guess = anchor.front().z * relative.front().inverse();
  Eigen::Vector3d s(guess.x(), guess.y(), guess.heading());
  for (int iteration = 0; iteration < 20; ++iteration) {
    const Eigen::VectorXd r = residuals(s);
    Eigen::MatrixXd J(r.size(), 3);
    for (int c = 0; c < 3; ++c) {
      constexpr double kStep = 1e-6;  // metres, radians
      Eigen::Vector3d plus = s, minus = s;
      plus[c] += kStep;
      minus[c] -= kStep;
      J.col(c) = (residuals(plus) - residuals(minus)) / (2.0 * kStep);
    }
    const Eigen::Vector3d step = (J.transpose() * J).ldlt().solve(-J.transpose() * r);
    if (!step.allFinite()) break;
    s += step;
    if (step.head<2>().norm() < 1e-10 && std::abs(step[2]) < 1e-10) break;
  }
  return Pose2::FromXYHeading(s[0], s[1], s[2]);
}

// The mean of poses (heading: the circular mean).
Pose2 MeanPose(const std::vector<Pose2>& poses) {
  double x = 0.0, y = 0.0, c = 0.0, s = 0.0;
  for (const Pose2& p : poses) {
    x += p.x();
    y += p.y();
    c += std::cos(p.heading());
    s += std::sin(p.heading());
  }
  const double n = static_cast<double>(poses.size());
  return Pose2::FromXYHeading(x / n, y / n, std::atan2(s, c));
}

}  // namespace

bool ReplayOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (anchor_frames < 1) return fail("anchor_frames must be at least 1");
  if (max_anchor_frames < 1) return fail("max_anchor_frames must be at least 1");
  if (!(default_position_sigma_m > 0.0)) return fail("default_position_sigma_m must be positive");
  if (!(default_heading_sigma_rad > 0.0)) return fail("default_heading_sigma_rad must be positive");
  if (std::abs(left_direction0) != 1 || std::abs(right_direction0) != 1)
    return fail("shaft directions must be +1 or -1");
  return true;
}

namespace {

// ReplayRun's steps, in order.

// When the wheels first and last moved (telemetry clock; nullopt: never),
// and how far they travelled.
struct WheelMotion {
  std::optional<double> first_motion_s, last_motion_s;
  double distance_m = 0.0;
};

// The wheels' first and last motion, and the distance, from the ticks.
WheelMotion FindWheelMotion(const MeasuredRun& run, const WheelParams& believed) {
  WheelMotion motion;
  const double left_m_per_tick = believed.LeftMetresPerTick();
  const double right_m_per_tick = believed.RightMetresPerTick();
  for (size_t k = 1; k < run.telemetry.size(); ++k) {
    const std::int64_t dl = run.telemetry[k].left_ticks - run.telemetry[k - 1].left_ticks;
    const std::int64_t dr = run.telemetry[k].right_ticks - run.telemetry[k - 1].right_ticks;
    if (dl == 0 && dr == 0) continue;
    if (!motion.first_motion_s) motion.first_motion_s = run.telemetry[k - 1].t_s;
    motion.last_motion_s = run.telemetry[k].t_s;
    // Wheel travel, so that a spin in place counts as distance too.
    motion.distance_m += 0.5 * (std::abs(static_cast<double>(dl)) * left_m_per_tick +
                                std::abs(static_cast<double>(dr)) * right_m_per_tick);
  }
  return motion;
}

// The run's valid camera frames in time order, each with its sigmas (the
// options' defaults where the record has none).
std::vector<Frame> ValidFrames(const MeasuredRun& run, const ReplayOptions& options) {
  std::vector<Frame> frames;
  for (const CameraRecord& f : run.camera) {
    if (!f.valid) continue;
    frames.push_back({f.t_s, f.T_world_robot,
                      f.sigma_position_m > 0.0 ? f.sigma_position_m : options.default_position_sigma_m,
                      f.sigma_heading_rad > 0.0 ? f.sigma_heading_rad
                                                : options.default_heading_sigma_rad,
                      f.image_row_fraction});
  }
  std::sort(frames.begin(), frames.end(),
            [](const Frame& a, const Frame& b) { return a.t_s < b.t_s; });
  return frames;
}

// The frames that anchor the start ([begin, end) of the frames), or why
// there are none.
struct AnchorRange {
  size_t begin = 0, end = 0;
  std::string error;  // empty: found
};

// The anchor: the frames that show the robot still before the wheels first
// moved (the last max_anchor_frames of them), else the first anchor_frames;
// at least one frame must follow it.
AnchorRange FindAnchor(const std::vector<Frame>& frames, double first_motion_s, const ReplayModel& model,
                       const ReplayOptions& options) {
  // A frame stamped s shows the robot at telemetry time s + latency (and
  // for a rolling shutter + (row fraction - 1/2) readout).
  auto shown_s = [&](const Frame& f) { return model.effects.TelemetryTimeOf(f.t_s, f.row_fraction); };
  size_t n_still = 0;
  while (n_still < frames.size() && shown_s(frames[n_still]) <= first_motion_s) ++n_still;
  AnchorRange range;
  if (n_still > 0) {
    range.end = n_still;
    range.begin = n_still - std::min<size_t>(n_still, options.max_anchor_frames);
  } else {
    range.end = std::min<size_t>(frames.size(), options.anchor_frames);
    if (range.end < static_cast<size_t>(options.anchor_frames)) {
      range.error = "only " + std::to_string(frames.size()) + " valid frames, fewer than the " +
                    std::to_string(options.anchor_frames) + " that anchor the start";
      return range;
    }
  }
  if (range.end >= frames.size()) range.error = "no valid frame after the start's anchor";
  return range;
}

// The replay's errors: the RMS position error over the predicted frames, and
// the end pose's error (the mean of the frames after the wheels last moved,
// or without an end rest the last valid frame).
void ScoreReplay(const ReplayModel& model, const std::vector<double>& rows, double last_motion_s, RunReplay* out) {
  const std::vector<double>& stamps = out->t_s;
  double sum_sq = 0.0;
  std::vector<Pose2> final_measured, final_predicted;
  for (size_t j = 0; j < stamps.size(); ++j) {
    sum_sq += (out->predicted[j].translation() - out->measured[j].translation()).squaredNorm();
    if (model.effects.TelemetryTimeOf(stamps[j], rows[j]) >= last_motion_s) {
      final_measured.push_back(out->measured[j]);
      final_predicted.push_back(out->predicted[j]);
    }
  }
  out->rms_position_error_m = std::sqrt(sum_sq / static_cast<double>(stamps.size()));
  if (final_measured.empty()) {  // no end rest: the last valid frame
    final_measured.push_back(out->measured.back());
    final_predicted.push_back(out->predicted.back());
  }
  const Pose2 measured_end = MeanPose(final_measured);
  const Pose2 predicted_end = MeanPose(final_predicted);
  out->final_position_error_m = (predicted_end.translation() - measured_end.translation()).norm();
  out->final_heading_error_rad = WrapAngle(predicted_end.heading() - measured_end.heading());
}

}  // namespace

RunReplay ReplayRun(const MeasuredRun& run, const WheelParams& believed, const ReplayModel& model,
                    const std::optional<FloorCamera>& camera, const ReplayOptions& options) {
  RunReplay out;
  auto fail = [&](const std::string& why, StatusCode code = StatusCode::kFailed) {
    out.status = code;
    out.message = run.name + ": " + why;
    return out;
  };
  std::string why;
  if (!options.IsValid(&why)) return fail("replay options: " + why, StatusCode::kInvalidArgument);
  if (!believed.IsValid(&why)) return fail("believed parameters: " + why, StatusCode::kInvalidArgument);
  if (run.telemetry.size() < 2) return fail("fewer than 2 telemetry samples");

  const WheelMotion motion = FindWheelMotion(run, believed);
  out.distance_m = motion.distance_m;
  if (!motion.first_motion_s) return fail("the wheels never moved");

  const std::vector<Frame> frames = ValidFrames(run, options);
  const AnchorRange range = FindAnchor(frames, *motion.first_motion_s, model, options);
  if (!range.error.empty()) return fail(range.error);
  const std::vector<Frame> anchor(frames.begin() + range.begin, frames.begin() + range.end);
  out.start = AnchorStart(run, believed, model, camera, options, anchor);

  std::vector<double> stamps, rows;
  for (size_t j = range.end; j < frames.size(); ++j) {
    stamps.push_back(frames[j].t_s);
    rows.push_back(frames[j].row_fraction);
    out.measured.push_back(frames[j].z);
  }
  out.t_s = stamps;
  out.predicted = PredictMeasuredPoses(run, believed, model.scales, model.effects, camera,
                                       out.start, stamps, options.left_direction0,
                                       options.right_direction0, rows);
  ScoreReplay(model, rows, *motion.last_motion_s, &out);
  out.status = StatusCode::kOk;
  return out;
}

}  // namespace odocal::calibration
