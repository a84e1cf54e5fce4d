#include "odocal/measure/estimate_session.h"

#include <algorithm>
#include <cmath>

#include "odocal/base/units.h"
#include "odocal/calibration/corrections.h"
#include "odocal/calibration/cvra.h"
#include "odocal/calibration/explain.h"
#include "odocal/calibration/statistics.h"

namespace odocal::measure {
namespace {

// The robot's own belief of where the run ended, in its start frame, from the
// odometry it reported (identity without telemetry, or when it reported
// none). A real robot's controller stops within a tolerance of the planned
// end (the OptiOdom robot: ~5 mm and 1-2 deg short of closing its squares),
// so a return error is true - this belief, not true - plan (UMBMark's
// epsilon = x_abs - x_calc); the CVRA estimators need the true displacement
// itself, the return error plus this belief.
calibration::Pose2 OdometryEnd(const calibration::MeasuredRun& m) {
  if (m.telemetry.size() < 2) return calibration::Pose2::Identity();
  return m.telemetry.front().odometry.inverse() * m.telemetry.back().odometry;
}

// Collects one CVRA quantity run by run.
struct CvraCollector {
  std::vector<double> values;
  std::vector<std::string> runs;

  void Add(const calibration::CvraResult& r, const std::string& run) {
    if (!r.ok()) return;
    values.push_back(r.value);
    runs.push_back(run);
  }
  std::optional<PooledCvra> Pooled() const {
    if (values.empty()) return std::nullopt;
    return PooledCvra{values, runs, calibration::Mean(values), calibration::StandardError(values)};
  }
};

}  // namespace

SessionEstimate EstimateSession(const std::vector<SessionMeasurement>& sessions) {
  SessionEstimate e;
  const calibration::WheelParams& nominal = sessions.front().session.nominal;
  calibration::UmbmarkInput input;
  input.track_m = nominal.track_m;
  CvraCollector ratios, scales, tracks;
  for (const SessionMeasurement& sm : sessions) {
    for (const RunMeasurement& rm : sm.runs) {
      const calibration::MeasuredRun& m = rm.measured;
      if (!UsableReturnError(m)) continue;
      // true - odometry in the start frame, and the true displacement.
      const calibration::Pose2& error = m.return_error->pose;
      const double ex = error.x(), ey = error.y(), eh = error.heading();
      const calibration::Pose2 odometry = OdometryEnd(m);
      const calibration::Pose2 p = calibration::Pose2::FromXYHeading(
          ex + odometry.x(), ey + odometry.y(), calibration::WrapAngle(eh + odometry.heading()));
      const calibration::RunSpec& spec = m.spec;
      switch (spec.procedure) {
        case calibration::Procedure::kUmbmark: {
          if (!input.AddRun(spec, error)) e.notes.push_back(m.name + ": square of another side, not pooled");
          break;
        }
        case calibration::Procedure::kOutAndBack: {
          if (spec.reference == calibration::Reference::kWall) {
            e.notes.push_back(m.name + ": wall-referenced; the camera cannot see the wall's correction");
            break;
          }
          const double travel = 2.0 * spec.distance_m * spec.repeats;
          ratios.Add(calibration::WheelRatioFromCamera(travel, eh, nominal.track_m), m.name);
          break;
        }
        case calibration::Procedure::kStraight:
          scales.Add(calibration::ScaleFromStraight(m.telemetry.size() < 2 ? spec.distance_m : odometry.x(),
                                                    p.x(), p.y(), p.heading()),
                     m.name);
          break;
        case calibration::Procedure::kSpin: {
          const double planned =
              (spec.direction == calibration::Direction::kCcw ? 1.0 : -1.0) * 2.0 * M_PI * spec.turns;
          // What odometry turned: the plan, corrected by where it stopped.
          const double believed = planned + calibration::WrapAngle(odometry.heading() - planned);
          tracks.Add(calibration::TrackFromCamera(believed, eh), m.name);
          break;
        }
        case calibration::Procedure::kRecorded:
        case calibration::Procedure::kCircle:
          // No closed-form UMBMark/CVRA model of these paths: such runs serve
          // the trajectory fit (explain) and the report only.
          break;
      }
    }
  }
  if (!input.cw.empty() || !input.ccw.empty()) {
    // Unequal counts (a flagged run dropped): pair the first n of each.
    const size_t n = std::min(input.cw.size(), input.ccw.size());
    if (input.cw.size() != input.ccw.size()) {
      e.notes.push_back("umbmark: " + std::to_string(input.cw.size()) + " cw and " +
                        std::to_string(input.ccw.size()) + " ccw usable runs; using " +
                        std::to_string(n) + " of each");
      input.cw.resize(n);
      input.ccw.resize(n);
    }
    if (n > 0) {
      const calibration::UmbmarkSummary s = calibration::EstimateUmbmark(input);
      if (s.ok()) {
        e.umbmark_input = input;
        e.umbmark = s;
      } else {
        e.notes.push_back("umbmark: " + s.message);
      }
    }
  }
  e.ratio = ratios.Pooled();
  e.scale = scales.Pooled();
  if (e.scale)
    for (const SessionMeasurement& sm : sessions)
      e.scale->camera_scale_sigma = std::max(e.scale->camera_scale_sigma, sm.camera_scale_sigma);
  e.track = tracks.Pooled();
  return e;
}

calibration::WheelParams CorrectedParams(const calibration::WheelParams& nominal,
                                         const SessionEstimate& e) {
  const auto mean = [](const std::optional<PooledCvra>& c) {
    return c ? std::optional<double>(c->mean) : std::nullopt;
  };
  if (e.umbmark) {
    calibration::WheelParams p =
        calibration::ApplyUmbmarkCorrection(nominal, e.umbmark->coupled.Ed, e.umbmark->coupled.Eb);
    return calibration::ApplyCvra(p, std::nullopt, mean(e.scale), std::nullopt);
  }
  return calibration::ApplyCvra(nominal, mean(e.ratio), mean(e.scale), mean(e.track));
}

calibration::MeasuredSession PoolTrajectoryRuns(const std::vector<SessionMeasurement>& sessions,
                                                std::vector<std::string>* notes,
                                                std::vector<std::pair<size_t, size_t>>* origin) {
  calibration::MeasuredSession pooled;
  if (origin) origin->clear();
  bool first = true;
  for (size_t s = 0; s < sessions.size(); ++s) {
    const SessionMeasurement& sm = sessions[s];
    calibration::MeasuredSession ms = sm.ToMeasuredSession();
    if (first) {
      pooled.believed = ms.believed;
      pooled.camera_scale_sigma = ms.camera_scale_sigma;
      first = false;
    } else if (std::abs(ms.believed.left_wheel_diameter_m - pooled.believed.left_wheel_diameter_m) > 1e-12 ||
               std::abs(ms.believed.right_wheel_diameter_m - pooled.believed.right_wheel_diameter_m) > 1e-12 ||
               std::abs(ms.believed.track_m - pooled.believed.track_m) > 1e-12 ||
               std::abs(ms.believed.ticks_per_rev - pooled.believed.ticks_per_rev) > 1e-9) {
      notes->push_back("trajectory_fit: " + sm.session.path +
                       " was recorded with other believed parameters; fitted without it");
      continue;
    }
    pooled.camera_scale_sigma = std::max(pooled.camera_scale_sigma, ms.camera_scale_sigma);
    for (size_t r = 0; r < ms.runs.size(); ++r) {
      if (ms.runs[r].telemetry.empty()) continue;
      pooled.runs.push_back(std::move(ms.runs[r]));
      if (origin) origin->emplace_back(s, r);
    }
  }
  return pooled;
}

calibration::TrajectoryFitOptions SessionTrajectoryFitOptions() {
  // The pose source's clock offset against the robot's is fitted with the
  // parameters: a real pose source has one (the OptiOdom rows' poses lead
  // their ticks by up to ~56 ms), and left out the scales absorb what they
  // can of it (the track of the OptiOdom Ivanjko paths moved by 0.1-0.3 %
  // when it was fitted; the squares' by < 0.01 %). Fitting a zero offset
  // costs a little variance.
  calibration::TrajectoryFitOptions options;
  options.effects = {calibration::Effect::kCameraLatency};
  return options;
}

bool DeterminesWheels(const calibration::TrajectoryFitResult& fit) {
  if (!fit.ok()) return false;
  for (const char* key : {"Ed", "Es", "Eb", "turn_gain"}) {
    const calibration::ParameterEstimate* p = fit.Find(key);
    if (p && !p->identifiable) return false;
  }
  return true;
}

// Unlike UMBMark the trajectory fit uses every frame and measures the
// distance scale Es as well, which a pose source with true lengths (motion
// capture, a camera with a length reference) supports.
std::optional<calibration::TrajectoryFitResult> FitSessionTrajectories(
    const std::vector<SessionMeasurement>& sessions, std::vector<std::string>* notes,
    std::vector<calibration::RunLeftOut>* left_out) {
  if (left_out) left_out->clear();
  const calibration::MeasuredSession pooled = PoolTrajectoryRuns(sessions, notes);
  if (pooled.runs.empty()) return std::nullopt;  // no telemetry: nothing to fit
  const calibration::TrajectoryFitOptions options = SessionTrajectoryFitOptions();
  calibration::TrajectoryFitResult fit = calibration::FitTrajectory(pooled, options);
  if (!fit.ok()) {
    notes->push_back("trajectory_fit: " + fit.message);
    return std::nullopt;
  }
  // What the runs' disagreement says of each parameter: on a real robot
  // the model's sigmas are several times too small (docs/realdata.md,
  // "How sure"), and this is the check a reader needs.
  if (const int failed = calibration::AddRunJackknife(pooled, &fit, 0, left_out); failed > 0) {
    notes->push_back("trajectory_fit: " + std::to_string(failed) + " of the refits without one run did not " +
                     "converge; no sigma_between_runs");
  } else if (fit.jackknife_runs == 0) {
    notes->push_back("trajectory_fit: fewer than 3 runs; the sigmas are the model's alone, and nothing "
                     "checks them against the runs' disagreement (a real robot's runs disagree several "
                     "times more than its model's sigmas say)");
  } else {
    std::string wider;
    for (const calibration::ParameterEstimate& p : fit.parameters) {
      // Above 3: the jackknife reads high by itself when runs differ in
      // kind (2-2.7x on a simulated squares + spins + out-and-back plan with
      // the model right), and the OptiOdom sets are 5.5-15x.
      if (!(p.sigma_between_runs > 3.0 * p.sigma) || p.name == "turn_gain") continue;
      char item[120];
      std::snprintf(item, sizeof(item), "%s%s %.1fx", wider.empty() ? "" : ", ", p.name.c_str(),
                    p.sigma_between_runs / p.sigma);
      wider += item;
    }
    if (!wider.empty())
      notes->push_back("trajectory_fit: the " + std::to_string(fit.jackknife_runs) +
                       " runs disagree more than the model's sigmas say (sigma_between_runs / sigma: " +
                       wider + "); trust sigma_between_runs");
  }
  // Its sigmas hold when the model leaves nothing but noise. When the
  // remainder is significant (explain's test: F against chi-square with the
  // residuals' autocorrelation), they are optimistic, and the report says so
  // (a real robot: the December OptiOdom Ivanjko set's Eb is 1.027 +- 0.0007
  // where its squares say 1.006).
  const calibration::UnexplainedReport remainder = calibration::FindUnexplained(pooled, fit);
  if (remainder.significant) {
    char text[400];
    std::snprintf(text, sizeof(text),
                  "trajectory_fit: the model leaves a significant remainder (gap %.3f mm against %.3f mm "
                  "expected, residuals correlated in time: lag-1 %.2f); its sigmas assume nothing is missing "
                  "and are optimistic here; `odocal explain` looks for what is",
                  remainder.gap_m * kMToMm, remainder.expected_gap_m * kMToMm, fit.lag1_autocorrelation);
    notes->push_back(text);
  }
  return fit;
}

int CountUsableRuns(const std::vector<SessionMeasurement>& sessions) {
  int usable = 0;
  for (const SessionMeasurement& sm : sessions)
    for (const RunMeasurement& rm : sm.runs) usable += UsableReturnError(rm.measured) ? 1 : 0;
  return usable;
}

}  // namespace odocal::measure
