#include "odocal/measure/segment_runs.h"

#include <cmath>
#include <cstdio>
#include <map>

#include "odocal/measure/pose_log.h"

namespace odocal::measure {

bool HasOwnSpan(const config::SessionRun& run) { return run.start_s != 0.0 || std::isfinite(run.end_s); }

bool AssignSpansFromRecording(const std::string& source, const std::vector<calibration::PoseSample>& samples,
                              const std::vector<config::SessionRun*>& runs,
                              const calibration::RestOptions& rest_options,
                              std::vector<SegmentAssignment>* assignments, std::string* error) {
  if (runs.size() < 2) return true;
  std::vector<config::SessionRun*> open;
  std::vector<std::pair<double, double>> fixed;  // the overrides' spans
  for (config::SessionRun* run : runs) {
    if (HasOwnSpan(*run))
      fixed.emplace_back(run->start_s, run->end_s);
    else
      open.push_back(run);
  }
  if (open.empty()) return true;
  std::vector<calibration::MotionSegment> segments;
  for (const calibration::MotionSegment& s : calibration::SegmentMotion(samples, rest_options)) {
    // The motion (between the rests) inside an override's span is that run's.
    const double a = s.start_rest.t_end_s, b = s.end_rest.t_begin_s;
    bool overridden = false;
    for (const auto& [t0, t1] : fixed) overridden |= a >= t0 - 1e-6 && b <= t1 + 1e-6;
    if (!overridden) segments.push_back(s);
  }
  std::vector<calibration::RunSpec> plan;
  std::vector<std::string> names;
  for (const config::SessionRun* run : open) {
    plan.push_back(run->spec);
    names.push_back(run->name);
  }
  const calibration::PlanMatch match = calibration::MatchSegmentsToPlan(segments, plan, names);
  if (!match.ok) {
    std::string text = source + ": the runs found in it do not match the session's plan:";
    for (const std::string& p : match.problems) text += "\n  " + p;
    text += "\n  found " + std::to_string(segments.size()) + " motion segment" + (segments.size() == 1 ? "" : "s") +
            " between rests:";
    for (const calibration::MotionSegment& s : segments) {
      char line[192];
      std::snprintf(line, sizeof(line), "\n    %.1f-%.1f s: %s", s.start_rest.t_end_s, s.end_rest.t_begin_s,
                    calibration::Describe(s.inferred).c_str());
      text += line;
    }
    text += "\n  (give a run start_s/end_s to place it by hand)";
    *error = text;
    return false;
  }
  // A rest between two runs is both the end rest of one and the start rest
  // of the next: split at its middle, so that each run's span holds no
  // motion of its neighbour's (its telemetry's first and last wheel motion
  // are its own) and each keeps half the rest's frames.
  auto shared = [&](const calibration::RestWindow& r) {
    int uses = 0;
    for (const calibration::MotionSegment& s : segments)
      uses += (std::abs(s.start_rest.t_begin_s - r.t_begin_s) < 1e-9) + (std::abs(s.end_rest.t_begin_s - r.t_begin_s) < 1e-9);
    return uses > 1;
  };
  auto middle = [](const calibration::RestWindow& r) { return 0.5 * (r.t_begin_s + r.t_end_s); };
  for (size_t k = 0; k < open.size(); ++k) {
    const calibration::MotionSegment& s = segments[match.segment_of_run[k]];
    open[k]->start_s = shared(s.start_rest) ? middle(s.start_rest) : s.begin_s();
    open[k]->end_s = shared(s.end_rest) ? middle(s.end_rest) : s.end_s();
    if (assignments)
      assignments->push_back({open[k]->name, source, open[k]->start_s, open[k]->end_s,
                              calibration::Describe(s.inferred)});
  }
  return true;
}

bool AssignPoseLogSpans(config::Session* session, const calibration::RestOptions& rest_options,
                        std::vector<SegmentAssignment>* assignments, std::string* error) {
  std::map<std::string, std::vector<config::SessionRun*>> groups;
  std::vector<std::string> order;
  for (config::SessionRun& run : session->runs) {
    if (run.poses.empty()) continue;
    if (!groups.count(run.poses)) order.push_back(run.poses);
    groups[run.poses].push_back(&run);
  }
  for (const std::string& path : order) {
    const std::vector<config::SessionRun*>& runs = groups[path];
    if (runs.size() < 2) continue;
    const auto rows = ReadPoseLog(path, error);
    if (!rows) return false;
    std::vector<calibration::PoseSample> samples;
    samples.reserve(rows->size());
    for (const PoseLogRow& r : *rows) samples.push_back({r.t_s, r.T_world_body, r.valid});
    if (!AssignSpansFromRecording(path, samples, runs, rest_options, assignments, error)) return false;
  }
  return true;
}

}  // namespace odocal::measure
