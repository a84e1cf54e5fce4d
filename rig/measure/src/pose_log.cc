#include "odocal/measure/pose_log.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "odocal/base/format.h"
#include "odocal/base/text.h"
#include "odocal/base/units.h"
#include "odocal/calibration/arc.h"
#include "odocal/calibration/statistics.h"

namespace odocal::measure {

using calibration::RunFlag;
using calibration::RunFlagKind;

namespace {

using calibration::Pose2;

std::string JoinNames(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : ",") + n;
  return s;
}

// A whole field as a number (NaN and infinities included: the caller
// decides); false when it is not one.
bool ParseNumber(const std::string& field, double* value) {
  if (field.empty()) return false;
  char* end = nullptr;
  *value = std::strtod(field.c_str(), &end);
  return end == field.c_str() + field.size();
}

std::string Where(const std::string& path, int line, int column = 0) {
  return path + ":" + std::to_string(line) + (column > 0 ? ":" + std::to_string(column) : "");
}

// Checks a header against the expected leading columns and the optional ones
// after them; `columns` receives what was found.
bool CheckHeader(const std::string& path, const std::string& line,
                 const std::vector<std::string>& required, const std::vector<std::string>& optional,
                 bool extra_allowed, std::vector<std::string>* columns, std::string* error) {
  *columns = SplitFields(line);
  std::vector<std::string> all = required;
  all.insert(all.end(), optional.begin(), optional.end());
  const std::string expected = JoinNames(required) +
                               (optional.empty() ? "" : "[," + JoinNames(optional) + "]");
  for (size_t i = 0; i < required.size(); ++i) {
    if (i >= columns->size()) {
      *error = Where(path, 1) + ": missing column " + required[i] + " (header must be " + expected +
               ")";
      return false;
    }
    if ((*columns)[i] != required[i]) {
      *error = Where(path, 1, static_cast<int>(i) + 1) + ": column " + std::to_string(i + 1) +
               " is '" + (*columns)[i] + "', expected " + required[i] + " (header must be " +
               expected + ")";
      return false;
    }
  }
  for (size_t i = required.size(); i < columns->size(); ++i) {
    const size_t k = i - required.size();
    if (k < optional.size() && (*columns)[i] == optional[k]) continue;
    if (extra_allowed) break;
    *error = Where(path, 1, static_cast<int>(i) + 1) + ": unexpected column '" + (*columns)[i] +
             "' (header must be " + expected + ")";
    return false;
  }
  return true;
}

// A CSV file read past its header line, the header checked (CheckHeader). `what` names the
// file in the errors ("pose log"); `header` is the header the empty file's error asks for.
struct CsvHead {
  std::ifstream in;
  std::vector<std::string> columns;
};
Result<CsvHead> OpenCsv(const std::string& path, const std::string& what, const std::string& header,
                        const std::vector<std::string>& required, const std::vector<std::string>& optional,
                        bool extra_allowed) {
  CsvHead head{std::ifstream(path), {}};
  if (!head.in) return Result<CsvHead>::Error(StatusCode::kNotFound, path + ": cannot read the " + what);
  std::string line;
  if (!std::getline(head.in, line))
    return Result<CsvHead>::Error(StatusCode::kBadFile,
                                  path + ": empty " + what + " (expected a header " + header + ")");
  std::string error;
  if (!CheckHeader(path, line, required, optional, extra_allowed, &head.columns, &error))
    return Result<CsvHead>::Error(StatusCode::kBadFile, error);
  return Result<CsvHead>::Ok(std::move(head));
}

struct Series {
  std::vector<double> t;
  std::vector<double> v;
};

// Linear interpolation of a series at t (clamped at its ends).
double Interpolate(const Series& s, double t) {
  if (t <= s.t.front()) return s.v.front();
  if (t >= s.t.back()) return s.v.back();
  const size_t k = static_cast<size_t>(std::upper_bound(s.t.begin(), s.t.end(), t) - s.t.begin());
  const double u = (t - s.t[k - 1]) / (s.t[k] - s.t[k - 1]);
  return s.v[k - 1] + u * (s.v[k] - s.v[k - 1]);
}

// The heading by the ticks (nominal parameters), unwrapped, at each record.
Series TicksHeading(const std::vector<calibration::TelemetryRecord>& telemetry,
                    const calibration::WheelParams& nominal) {
  Series s;
  for (const auto& r : telemetry) {
    const double left = (r.left_ticks - telemetry.front().left_ticks) * nominal.LeftMetresPerTick();
    const double right =
        (r.right_ticks - telemetry.front().right_ticks) * nominal.RightMetresPerTick();
    s.t.push_back(r.t_s);
    s.v.push_back((right - left) / nominal.track_m);
  }
  return s;
}

// The clock offset (pose clock - telemetry clock) maximizing the correlation
// of the heading rates, on a grid of the pose period; nullopt when either
// series does not turn.
std::optional<double> EstimateClockOffset(const Series& pose_heading, const Series& ticks_heading,
                                          double step_s, double max_offset_s) {
  if (pose_heading.t.size() < 3 || ticks_heading.t.size() < 3 || !(step_s > 0.0))
    return std::nullopt;
  const double t0 = std::max(pose_heading.t.front(), ticks_heading.t.front());
  const double t1 = std::min(pose_heading.t.back(), ticks_heading.t.back());
  if (!(t1 - t0 > 4.0 * step_s)) return std::nullopt;
  // Rates on a common grid (the telemetry's span, padded by the search).
  const int n = static_cast<int>((t1 - t0) / step_s);
  std::vector<double> ticks_rate(n);
  for (int i = 0; i < n; ++i) {
    const double t = t0 + i * step_s;
    ticks_rate[i] = Interpolate(ticks_heading, t + step_s) - Interpolate(ticks_heading, t);
  }
  double best = -1e300;
  std::optional<double> best_offset;
  const int max_lag = static_cast<int>(max_offset_s / step_s);
  for (int lag = -max_lag; lag <= max_lag; ++lag) {
    const double offset = lag * step_s;
    double sum = 0.0, norm_p = 0.0, norm_t = 0.0;
    for (int i = 0; i < n; ++i) {
      const double t = t0 + i * step_s + offset;
      const double p = Interpolate(pose_heading, t + step_s) - Interpolate(pose_heading, t);
      sum += p * ticks_rate[i];
      norm_p += p * p;
      norm_t += ticks_rate[i] * ticks_rate[i];
    }
    if (!(norm_p > 0.0 && norm_t > 0.0)) continue;
    const double r = sum / std::sqrt(norm_p * norm_t);
    if (r > best) {
      best = r;
      best_offset = offset;
    }
  }
  return best_offset;
}

// Total variation of a series, counted in steps beyond `step` (hysteresis):
// noise and a controller's wiggle below the step add nothing.
double Variation(const std::vector<double>& values, double step) {
  if (values.empty()) return 0.0;
  double total = 0.0, anchor = values.front();
  for (double v : values) {
    if (std::abs(v - anchor) > step) {
      total += std::abs(v - anchor);
      anchor = v;
    }
  }
  return total;
}

}  // namespace

Result<std::vector<PoseLogRow>> ReadPoseLog(const std::string& path) {
  using Rows = Result<std::vector<PoseLogRow>>;
  const auto fail = [](std::string message) { return Rows::Error(StatusCode::kBadFile, std::move(message)); };
  Result<CsvHead> head = OpenCsv(path, "pose log", "t_s,x_mm,y_mm,heading_deg[,valid]",
                                 {"t_s", "x_mm", "y_mm", "heading_deg"}, {"valid"}, false);
  if (!head) return Rows::From(head);
  std::ifstream& in = head->in;
  const std::vector<std::string>& columns = head->columns;
  std::string line;
  const size_t n_columns = columns.size();
  std::vector<PoseLogRow> rows;
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (Trim(line).empty()) continue;
    const std::vector<std::string> fields = SplitFields(line);
    if (fields.size() != n_columns) {
      return fail(Where(path, line_no) + ": expected " + std::to_string(n_columns) + " fields (" + JoinNames(columns) +
                  "), got " + std::to_string(fields.size()));
    }
    double v[5] = {0.0, 0.0, 0.0, 0.0, 1.0};
    for (size_t i = 0; i < n_columns; ++i) {
      if (!ParseNumber(fields[i], &v[i])) {
        return fail(Where(path, line_no, static_cast<int>(i) + 1) + ": column " + columns[i] + ": not a number: '" +
                    fields[i] + "'");
      }
    }
    PoseLogRow row;
    row.line = line_no;
    row.t_s = v[0];
    if (!std::isfinite(row.t_s)) {
      return fail(Where(path, line_no, 1) + ": column t_s: not a finite time: '" + fields[0] + "'");
    }
    if (n_columns == 5 && v[4] != 0.0 && v[4] != 1.0) {
      return fail(Where(path, line_no, 5) + ": column valid: expected 0 or 1, got '" + fields[4] + "'");
    }
    row.nan = !std::isfinite(v[1]) || !std::isfinite(v[2]) || !std::isfinite(v[3]);
    row.valid = v[4] != 0.0 && !row.nan;
    if (!row.nan)
      row.T_world_body = Pose2::FromXYHeading(v[1] * kMmToM, v[2] * kMmToM, v[3] * kDegToRad);
    if (!rows.empty() && !(row.t_s > rows.back().t_s)) {
      return fail(Where(path, line_no, 1) + ": t_s " + fields[0] +
                  (row.t_s == rows.back().t_s ? " duplicates" : " is before") + " line " +
                  std::to_string(rows.back().line) + "'s (timestamps must increase strictly)");
    }
    rows.push_back(row);
  }
  if (rows.empty()) {
    return fail(path + ": no rows after the header");
  }
  return Rows::Ok(std::move(rows));
}

Result<std::vector<calibration::TelemetryRecord>> ReadTelemetryCsv(const std::string& path,
                                                                   const calibration::WheelParams& nominal) {
  using Records = Result<std::vector<calibration::TelemetryRecord>>;
  const auto fail = [](std::string message) { return Records::Error(StatusCode::kBadFile, std::move(message)); };
  Result<CsvHead> head = OpenCsv(path, "telemetry", "t_s,left_ticks,right_ticks,...",
                                 {"t_s", "left_ticks", "right_ticks"}, {"x_mm", "y_mm", "heading_deg"}, true);
  if (!head) return Records::From(head);
  std::ifstream& in = head->in;
  const std::vector<std::string>& columns = head->columns;
  std::string line;
  const bool has_odometry = columns.size() >= 6 && columns[3] == "x_mm" && columns[4] == "y_mm" &&
                            columns[5] == "heading_deg";
  const size_t used = has_odometry ? 6 : 3;
  std::vector<calibration::TelemetryRecord> records;
  double x = 0.0, y = 0.0, heading = 0.0;  // dead reckoning without odometry columns
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (Trim(line).empty()) continue;
    const std::vector<std::string> fields = SplitFields(line);
    if (fields.size() != columns.size()) {
      return fail(Where(path, line_no) + ": expected " + std::to_string(columns.size()) + " fields (" +
                  JoinNames(columns) + "), got " + std::to_string(fields.size()));
    }
    double v[6] = {};
    for (size_t i = 0; i < used; ++i) {
      if (!ParseNumber(fields[i], &v[i]) || !std::isfinite(v[i])) {
        return fail(Where(path, line_no, static_cast<int>(i) + 1) + ": column " + columns[i] + ": not a number: '" +
                    fields[i] + "'");
      }
    }
    calibration::TelemetryRecord r;
    r.t_s = v[0];
    r.left_ticks = std::llround(v[1]);
    r.right_ticks = std::llround(v[2]);
    if (!records.empty() && !(r.t_s > records.back().t_s)) {
      return fail(Where(path, line_no, 1) + ": t_s " + fields[0] +
                  " is not after the previous row's (timestamps must increase strictly)");
    }
    if (has_odometry) {
      r.odometry = Pose2::FromXYHeading(v[3] * kMmToM, v[4] * kMmToM, v[5] * kDegToRad);
    } else {
      if (!records.empty()) {
        calibration::AdvanceArc(
            (r.left_ticks - records.back().left_ticks) * nominal.LeftMetresPerTick(),
            (r.right_ticks - records.back().right_ticks) * nominal.RightMetresPerTick(),
            nominal.track_m, &x, &y, &heading);
      }
      r.odometry = Pose2::FromXYHeading(x, y, heading);
    }
    records.push_back(r);
  }
  if (records.size() < 2) {
    return fail(path + ": fewer than two telemetry rows");
  }
  return Records::Ok(std::move(records));
}

bool PoseLogOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!rest.IsValid(why)) return false;
  if (!(rest_search_fraction > 0.0 && rest_search_fraction <= 1.0))
    return fail("rest_search_fraction must be in (0, 1]");
  if (!(default_sigma_position_m > 0.0) || !(default_sigma_heading_rad > 0.0))
    return fail("default frame sigmas must be positive");
  if (!(min_unit_ratio > 0.0 && max_unit_ratio > min_unit_ratio))
    return fail("unit ratio bounds must satisfy 0 < min < max");
  if (!(jump_speed_factor > 1.0) || !(jump_speed_floor_m_s > 0.0))
    return fail("jump speed factor must exceed 1 and its floor be positive");
  if (!(max_clock_offset_s >= 0.0)) return fail("max_clock_offset_s must not be negative");
  return true;
}

namespace {

// MeasurePoseLogRun's steps, in order.

// The run's telemetry and its span of the pose log (the tracker's clock),
// which must overlap; the log's rows and period in `stats`.
Result<std::vector<PoseLogRow>> ReadRunSpan(const config::SessionRun& run, const calibration::WheelParams& nominal,
                                            calibration::MeasuredRun* m, PoseLogStats* stats) {
  using Rows = Result<std::vector<PoseLogRow>>;
  const auto rows = ReadPoseLog(run.poses);
  if (!rows) return rows;
  const auto telemetry = ReadTelemetryCsv(run.telemetry, nominal);
  if (!telemetry) return Rows::Error(telemetry.status, telemetry.message);
  m->telemetry = *telemetry;
  // A telemetry file shared by several runs: the run's span of it (the two
  // clocks share an origin, as below; 0.1 s either side for a small offset).
  if (run.start_s != 0.0 || std::isfinite(run.end_s)) {
    std::vector<calibration::TelemetryRecord> span;
    for (const calibration::TelemetryRecord& r : m->telemetry)
      if (r.t_s >= run.start_s - 0.1 && r.t_s <= run.end_s + 0.1) span.push_back(r);
    if (span.size() >= 2) m->telemetry = std::move(span);
  }

  // The run's span of the log (tracker clock).
  std::vector<PoseLogRow> frames;
  for (const PoseLogRow& r : *rows)
    if (r.t_s >= run.start_s - 1e-9 && r.t_s <= run.end_s + 1e-9) frames.push_back(r);
  if (frames.empty()) {
    return Rows::Error(StatusCode::kBadFile, run.poses + ": no rows within the run's start_s..end_s");
  }
  const double tel0 = m->telemetry.front().t_s, tel1 = m->telemetry.back().t_s;
  if (frames.back().t_s < tel0 || frames.front().t_s > tel1) {
    char span[160];
    std::snprintf(span, sizeof(span), " (poses %.3f..%.3f s, telemetry %.3f..%.3f s)", frames.front().t_s,
                  frames.back().t_s, tel0, tel1);
    return Rows::Error(StatusCode::kBadFile, run.poses + " and " + run.telemetry + ": never overlap in time" + span +
                                                 "; the two clocks must share an origin");
  }
  stats->rows = static_cast<int>(frames.size());
  std::vector<double> periods;
  for (size_t i = 1; i < frames.size(); ++i) periods.push_back(frames[i].t_s - frames[i - 1].t_s);
  stats->pose_period_s = calibration::Median(periods);
  return Rows::Ok(std::move(frames));
}

// Which frames are the robot: those the file says are valid, less the
// tracker's jumps. Which side of a jump is the tracker's error? The longest
// stretch of mutually consistent frames is taken as the robot; from it,
// forwards and backwards, each frame must be reachable from the last good
// one, at up to the ticks' top speed and turn rate (nominal) times
// jump_speed_factor. A swapped marker at the very first frame is then
// rejected, not the run.
std::vector<bool> FramesWithoutJumps(const std::vector<PoseLogRow>& frames,
                                     const std::vector<calibration::TelemetryRecord>& telemetry,
                                     const calibration::WheelParams& nominal, const PoseLogOptions& options) {
  // Top speeds by the ticks (nominal), for the jump test.
  double top_speed = 0.0, top_turn = 0.0;
  for (size_t i = 1; i < telemetry.size(); ++i) {
    const auto& a = telemetry[i - 1];
    const auto& b = telemetry[i];
    const double dt = b.t_s - a.t_s;
    const double l = (b.left_ticks - a.left_ticks) * nominal.LeftMetresPerTick();
    const double r = (b.right_ticks - a.right_ticks) * nominal.RightMetresPerTick();
    top_speed = std::max({top_speed, std::abs(l) / dt, std::abs(r) / dt});
    top_turn = std::max(top_turn, std::abs(r - l) / nominal.track_m / dt);
  }
  const double max_speed = std::max(options.jump_speed_factor * top_speed, options.jump_speed_floor_m_s);
  // A heading step likewise: the turn rate of wheels at max_speed, or 3x the top one.
  const double max_turn =
      std::max(options.jump_speed_factor * top_turn, 2.0 * options.jump_speed_floor_m_s / nominal.track_m);
  const auto reachable = [&](const PoseLogRow& a, const PoseLogRow& b) {
    const double dt = std::abs(b.t_s - a.t_s);
    const double step = (b.T_world_body.translation() - a.T_world_body.translation()).norm();
    const double turn = std::abs(calibration::WrapAngle(b.T_world_body.heading() - a.T_world_body.heading()));
    return step <= max_speed * dt && turn <= max_turn * dt;
  };
  std::vector<size_t> candidates;  // frames the file says are valid
  for (size_t i = 0; i < frames.size(); ++i)
    if (frames[i].valid) candidates.push_back(i);
  std::vector<bool> good(frames.size(), false);
  if (!candidates.empty()) {
    size_t best_begin = 0, best_length = 0;
    for (size_t k = 0; k < candidates.size();) {
      size_t e = k + 1;
      while (e < candidates.size() && reachable(frames[candidates[e - 1]], frames[candidates[e]])) ++e;
      if (e - k > best_length) {
        best_begin = k;
        best_length = e - k;
      }
      k = e;
    }
    for (size_t k = best_begin; k < best_begin + best_length; ++k) good[candidates[k]] = true;
    size_t last = candidates[best_begin + best_length - 1];
    for (size_t k = best_begin + best_length; k < candidates.size(); ++k)
      if (reachable(frames[last], frames[candidates[k]])) good[last = candidates[k]] = true;
    last = candidates[best_begin];
    for (size_t k = best_begin; k-- > 0;)
      if (reachable(frames[last], frames[candidates[k]])) good[last = candidates[k]] = true;
  }
  return good;
}

// The frames as the run's camera records (robot poses), counted in `stats`
// and flagged.
void AddFrames(const std::vector<PoseLogRow>& frames, const std::vector<bool>& good, const Pose2& T_body_robot,
               calibration::MeasuredRun* m, PoseLogStats* stats) {
  for (size_t i = 0; i < frames.size(); ++i) {
    const PoseLogRow& f = frames[i];
    calibration::CameraRecord c;
    c.t_s = f.t_s;
    c.valid = good[i];
    if (f.nan) ++stats->nan_rows;
    if (f.valid && !good[i]) ++stats->jump_frames;
    if (c.valid) {
      c.T_world_robot = f.T_world_body * T_body_robot;
      ++stats->valid;
    }
    m->camera.push_back(c);
  }
  if (stats->nan_rows > 0) m->flags.push_back(RunFlag::Of(RunFlagKind::kNanFrames, std::to_string(stats->nan_rows)));
  if (stats->jump_frames > 0)
    m->flags.push_back(RunFlag::Of(RunFlagKind::kTrackerJump, std::to_string(stats->jump_frames)));
}

// The path and heading change of the tracked body as logged, within the
// telemetry's span; `pose_heading` gets the valid frames' unwrapped heading.
std::pair<double, double> LoggedPathAndTurn(const calibration::MeasuredRun& run, const Pose2& T_robot_body,
                                            double heading_step_rad, Series* pose_heading) {
  const double tel0 = run.telemetry.front().t_s, tel1 = run.telemetry.back().t_s;
  // The path of the tracked body as logged, before any lever arm is undone:
  // it checks the file's unit (a body off the axle adds its lever arm's
  // sweep in the turns, well inside the bounds). It accumulates in steps of
  // 10 mm so that frame noise does not add up to a path of its own.
  const auto Body = [&](const calibration::CameraRecord& c) { return c.T_world_robot * T_robot_body; };
  double pose_path = 0.0, pose_turn = 0.0;
  {
    const calibration::CameraRecord* anchor = nullptr;
    const calibration::CameraRecord* prev = nullptr;
    double unwrapped = 0.0;
    std::vector<double> overlap_heading;
    for (const calibration::CameraRecord& c : run.camera) {
      if (!c.valid) continue;
      if (prev) unwrapped += calibration::WrapAngle(c.T_world_robot.heading() - prev->T_world_robot.heading());
      prev = &c;
      pose_heading->t.push_back(c.t_s);
      pose_heading->v.push_back(unwrapped);
      if (c.t_s < tel0 || c.t_s > tel1) continue;
      overlap_heading.push_back(unwrapped);
      if (!anchor) anchor = &c;
      const double d = (Body(c).translation() - Body(*anchor).translation()).norm();
      if (d > 0.010) {
        pose_path += d;
        anchor = &c;
      }
    }
    pose_turn = Variation(overlap_heading, heading_step_rad);
  }
  return {pose_path, pose_turn};
}

// The log's units against the ticks' (path length and heading change), then
// the clock offset from the heading rates (reported, not applied). kBadFile
// naming the column when a unit is off.
Status CheckUnitsAndClock(const config::SessionRun& run, const calibration::WheelParams& nominal,
                          const PoseLogOptions& options, const Pose2& T_robot_body, calibration::MeasuredRun* m,
                          PoseLogStats* stats) {
  double tick_path = 0.0;
  for (size_t i = 1; i < m->telemetry.size(); ++i) {
    const auto& a = m->telemetry[i - 1];
    const auto& b = m->telemetry[i];
    const double l = (b.left_ticks - a.left_ticks) * nominal.LeftMetresPerTick();
    const double r = (b.right_ticks - a.right_ticks) * nominal.RightMetresPerTick();
    tick_path += std::abs(l + r) / 2.0;
  }
  // Headings compared as total variations in steps of 2 degrees on both
  // sides: summing every control cycle's |dtheta| of the ticks would count a
  // straight run's wiggle as turning.
  constexpr double kHeadingStep = 2.0 * kDegToRad;
  const Series ticks_heading = TicksHeading(m->telemetry, nominal);
  const double tick_turn = Variation(ticks_heading.v, kHeadingStep);
  Series pose_heading;  // unwrapped, valid frames
  const auto [pose_path, pose_turn] = LoggedPathAndTurn(*m, T_robot_body, kHeadingStep, &pose_heading);
  if (tick_path >= options.min_path_for_unit_check_m) {
    stats->path_ratio = pose_path / tick_path;
    if (stats->path_ratio < options.min_unit_ratio || stats->path_ratio > options.max_unit_ratio) {
      return Status::Error(StatusCode::kBadFile,
                           run.poses + ": columns x_mm,y_mm: the logged path is " + Format("%.4g", stats->path_ratio) +
                               " times the ticks' (" + Format("%.0f", tick_path * kMToMm) + " mm by " + run.telemetry +
                               ", nominal parameters)" +
                               (stats->path_ratio < 0.01 ? ": metres where millimetres are expected?"
                                                         : ": wrong unit or wrong telemetry?"));
    }
  }
  if (tick_turn >= options.min_turn_for_unit_check_rad) {
    stats->heading_ratio = pose_turn / tick_turn;
    if (stats->heading_ratio < options.min_unit_ratio || stats->heading_ratio > options.max_unit_ratio) {
      return Status::Error(StatusCode::kBadFile,
                           run.poses + ": column heading_deg: the logged heading change is " +
                               Format("%.4g", stats->heading_ratio) + " times the ticks' (" +
                               Format("%.0f", tick_turn * kRadToDeg) + " deg by " + run.telemetry + ")" +
                               (stats->heading_ratio < 0.05 ? ": radians where degrees are expected?"
                                                            : ": wrong unit or wrong telemetry?"));
    }
  }

  // The clock offset, from the heading rates (reported, not applied).
  {
    if (tick_turn >= options.min_turn_for_unit_check_rad) {
      stats->clock_offset_s =
          EstimateClockOffset(pose_heading, ticks_heading, stats->pose_period_s, options.max_clock_offset_s);
    }
    if (stats->clock_offset_s && std::abs(*stats->clock_offset_s) > 2.0 * stats->pose_period_s) {
      m->flags.push_back(RunFlag::Of(RunFlagKind::kClockOffset, Format("%+.3fs", *stats->clock_offset_s)));
    }
  }
  return Status::Ok();
}

// The start and end rests FindRests finds in the frames, as for video: the
// first and last rests within rest_search_fraction of the run's ends.
void RestsByThePoses(const PoseLogOptions& options, const std::vector<calibration::PoseSample>& samples,
                     calibration::MeasuredRun* m) {
  const calibration::RestSummary rests = calibration::FindRests(samples, options.rest);
  const double t0 = samples.front().t_s, t1 = samples.back().t_s;
  const double span = t1 - t0;
  if (!rests.rests.empty() && rests.rests.front().t_begin_s <= t0 + options.rest_search_fraction * span)
    m->start_rest = rests.rests.front();
  if (!rests.rests.empty() && rests.rests.back().t_end_s >= t1 - options.rest_search_fraction * span &&
      (!m->start_rest || rests.rests.size() >= 2))
    m->end_rest = rests.rests.back();
}

// The start and end rests: as for video (FindRests on the frames of the
// run's span), each clipped to where the wheels were still; failing that,
// the still wheels' frames, or the first / last valid frame, flagged.
void FindPoseLogRests(const PoseLogOptions& options, const PoseLogStats& stats, calibration::MeasuredRun* m) {
  // Rests: as for video (FindRests on the frames of the run's span)...
  std::vector<calibration::PoseSample> samples;
  for (const calibration::CameraRecord& c : m->camera) samples.push_back({c.t_s, c.T_world_robot, c.valid});
  RestsByThePoses(options, samples, m);
  // ...and when a log has only a short still window at an end, the frames
  // while the wheels are still by the telemetry (ticks unchanged) before the
  // first / after the last wheel motion; failing that, the first / last
  // valid frame.
  const auto& tel = m->telemetry;
  size_t first_move = tel.size(), last_move = 0;
  for (size_t i = 1; i < tel.size(); ++i) {
    if (tel[i].left_ticks != tel[i - 1].left_ticks || tel[i].right_ticks != tel[i - 1].right_ticks) {
      if (first_move == tel.size()) first_move = i;
      last_move = i;
    }
  }
  auto window = [&](double a, double b) {
    std::vector<calibration::PoseSample> still;
    for (const auto& s : samples)
      if (s.t_s >= a - 1e-9 && s.t_s <= b + 1e-9) still.push_back(s);
    return calibration::SummarizeRest(still);
  };
  // A rest is where the wheels were still, too. A turn in place barely moves
  // a tracked body near the axle, and a pose-only rest finder took the last
  // second of the OptiOdom squares' final turn for their end rest (return
  // errors 20 mm off). The ticks say exactly when the wheels moved: clip each
  // rest to the still-wheel span, with two pose periods of margin for the
  // clocks' offset.
  const double margin = 2.0 * stats.pose_period_s + (stats.clock_offset_s ? std::abs(*stats.clock_offset_s) : 0.0);
  if (first_move < tel.size()) {
    const double still_until = tel[first_move - 1].t_s - margin;
    const double still_from = tel[last_move].t_s + margin;
    if (m->start_rest && m->start_rest->t_end_s > still_until) {
      m->start_rest =
          m->start_rest->t_begin_s < still_until ? window(m->start_rest->t_begin_s, still_until) : std::nullopt;
    }
    if (m->end_rest && m->end_rest->t_begin_s < still_from) {
      m->end_rest = m->end_rest->t_end_s > still_from ? window(still_from, m->end_rest->t_end_s) : std::nullopt;
    }
  }
  if (!m->start_rest) {
    std::optional<calibration::RestWindow> w;
    if (first_move < tel.size()) w = window(-1e300, tel[first_move - 1].t_s - margin);
    if (w) {
      m->start_rest = w;
      m->flags.push_back(RunFlag::Of(RunFlagKind::kStartRestFromStillWheels));
    } else {
      for (const auto& s : samples)
        if (s.valid) {
          m->start_rest = calibration::SummarizeRest({s});
          break;
        }
      m->flags.push_back(RunFlag::Of(RunFlagKind::kStartRestFromFirstPose));
    }
  }
  if (!m->end_rest) {
    std::optional<calibration::RestWindow> w;
    if (last_move > 0) w = window(tel[last_move].t_s + margin, 1e300);
    if (w) {
      m->end_rest = w;
      m->flags.push_back(RunFlag::Of(RunFlagKind::kEndRestFromStillWheels));
    } else {
      for (auto s = samples.rbegin(); s != samples.rend(); ++s)
        if (s->valid) {
          m->end_rest = calibration::SummarizeRest({*s});
          break;
        }
      m->flags.push_back(RunFlag::Of(RunFlagKind::kEndRestFromLastPose));
    }
  }
  if (m->start_rest && m->start_rest->n < 10) m->flags.push_back(RunFlag::Of(RunFlagKind::kShortStartRest));
  if (m->end_rest && m->end_rest->n < 10) m->flags.push_back(RunFlag::Of(RunFlagKind::kShortEndRest));
}

}  // namespace

Status MeasurePoseLogRun(const config::SessionRun& run, const config::TrackerMount& tracker,
                         const calibration::WheelParams& nominal, const PoseLogOptions& options,
                         calibration::MeasuredRun* m, PoseLogStats* stats) {
  m->name = run.name;
  m->spec = run.spec;
  const Result<std::vector<PoseLogRow>> frames = ReadRunSpan(run, nominal, m, stats);
  if (!frames) return Status::Error(frames.status, frames.message);
  // The robot's pose from the body's: T_world_robot = T_world_body * T_robot_body^-1.
  const Pose2 T_robot_body =
      Pose2::FromXYHeading(tracker.offset_x_mm * kMmToM, tracker.offset_y_mm * kMmToM, tracker.yaw_deg * kDegToRad);
  AddFrames(*frames, FramesWithoutJumps(*frames, m->telemetry, nominal, options), T_robot_body.inverse(), m, stats);
  if (stats->valid < 2) {
    m->flags.push_back(RunFlag::Of(RunFlagKind::kTrackerNeverValid));
    return Status::Ok();
  }
  if (const Status units = CheckUnitsAndClock(run, nominal, options, T_robot_body, m, stats); !units) return units;
  FindPoseLogRests(options, *stats, m);
  return Status::Ok();
}

void FinishPoseLogRuns(const PoseLogOptions& options, std::vector<calibration::MeasuredRun*> runs) {
  // One frame's noise, from the frames at rest about their window's mean,
  // pooled over every rest of the pose-log runs (the video path's rule).
  const calibration::RestScatter scatter = calibration::PooledRestScatter(
      std::vector<const calibration::MeasuredRun*>(runs.begin(), runs.end()));
  const bool measured = scatter.dof >= 2;
  // A tracker that reports identical poses at rest has a resolution, not zero noise.
  const double sigma_p = measured ? std::max(scatter.sigma_position_m, 1e-6)
                                  : options.default_sigma_position_m;
  const double sigma_h = measured ? std::max(scatter.sigma_heading_rad, 1e-6 * kDegToRad)
                                  : options.default_sigma_heading_rad;
  for (calibration::MeasuredRun* run : runs) {
    if (!measured) run->flags.push_back(RunFlag::Of(RunFlagKind::kDefaultFrameSigma));
    for (calibration::CameraRecord& c : run->camera) {
      if (!c.valid) continue;
      c.sigma_position_m = sigma_p;
      c.sigma_heading_rad = sigma_h;
    }
    if (!run->start_rest || !run->end_rest) continue;
    // A rest of few frames says little about its own spread: floor its
    // covariance by the pooled frame noise.
    for (calibration::RestWindow* rest : {&*run->start_rest, &*run->end_rest}) {
      const double n = std::max(rest->n, 1);
      rest->covariance(0, 0) = std::max(rest->covariance(0, 0), sigma_p * sigma_p / n);
      rest->covariance(1, 1) = std::max(rest->covariance(1, 1), sigma_p * sigma_p / n);
      rest->covariance(2, 2) = std::max(rest->covariance(2, 2), sigma_h * sigma_h / n);
    }
    calibration::RelativePose r = calibration::Between(*run->start_rest, *run->end_rest);
    // true - odometry: remove the odometry's own relative pose between the
    // same instants (zero for a plan that closes; anything for a recorded run).
    const auto odometry_at = [&](double t) {
      const auto& tel = run->telemetry;
      auto it = std::upper_bound(tel.begin(), tel.end(), t,
                                 [](double v, const calibration::TelemetryRecord& rec) { return v < rec.t_s; });
      if (it != tel.begin()) --it;
      return it->odometry;
    };
    const Pose2 odo = odometry_at(run->start_rest->t_end_s).inverse() *
                      odometry_at(run->end_rest->t_begin_s);
    run->return_error = calibration::TrueMinusOdometry(r, odo);
  }
}

}  // namespace odocal::measure
