#include "odocal/measure/segment_runs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>

#include "odocal/measure/pose_log.h"

namespace odocal::measure {

namespace {

// Each segment's span for its run. A rest between two runs is both the end
// rest of one and the start rest of the next: split at its middle, so that
// each run's span holds no motion of its neighbour's (its telemetry's first
// and last wheel motion are its own) and each keeps half the rest's frames.
std::vector<std::pair<double, double>> RunSpans(const std::vector<calibration::MotionSegment>& segments) {
  auto shared = [&](const calibration::RestWindow& r) {
    int uses = 0;
    for (const calibration::MotionSegment& s : segments)
      uses += (std::abs(s.start_rest.t_begin_s - r.t_begin_s) < 1e-9) +
              (std::abs(s.end_rest.t_begin_s - r.t_begin_s) < 1e-9);
    return uses > 1;
  };
  auto middle = [](const calibration::RestWindow& r) { return 0.5 * (r.t_begin_s + r.t_end_s); };
  std::vector<std::pair<double, double>> spans;
  for (const calibration::MotionSegment& s : segments)
    spans.emplace_back(shared(s.start_rest) ? middle(s.start_rest) : s.begin_s(),
                       shared(s.end_rest) ? middle(s.end_rest) : s.end_s());
  return spans;
}

}  // namespace

bool HasOwnSpan(const config::SessionRun& run) { return run.start_s != 0.0 || std::isfinite(run.end_s); }

Status AssignSpansFromRecording(const std::string& source, const std::vector<calibration::PoseSample>& samples,
                                const std::vector<config::SessionRun*>& runs,
                                const calibration::RestOptions& rest_options,
                                std::vector<SegmentAssignment>* assignments) {
  if (runs.size() < 2) return Status::Ok();
  std::vector<config::SessionRun*> open;
  std::vector<std::pair<double, double>> fixed;  // the overrides' spans
  for (config::SessionRun* run : runs) {
    if (HasOwnSpan(*run))
      fixed.emplace_back(run->start_s, run->end_s);
    else
      open.push_back(run);
  }
  if (open.empty()) return Status::Ok();
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
  if (!match.ok()) {
    std::string text = source + ": the runs found in it do not match the session's plan:";
    for (const std::string& p : match.problems) text += "\n  " + p;
    // Readings as good: the recording cannot tell which is right.
    for (const std::vector<std::string>& other : match.other_readings) {
      text += "\n  or, as well (the recording cannot tell which):";
      for (const std::string& p : other) text.append("\n    ").append(p);
    }
    if (match.more_readings) text += "\n  (and more readings as good)";
    text += "\n  found " + std::to_string(segments.size()) + " motion segment" + (segments.size() == 1 ? "" : "s") +
            " between rests:";
    for (const calibration::MotionSegment& s : segments) {
      char line[192];
      std::snprintf(line, sizeof(line), "\n    %.1f-%.1f s: %s", s.start_rest.t_end_s, s.end_rest.t_begin_s,
                    calibration::DescribeSeen(s).c_str());
      text += line;
    }
    text += "\n  (give a run start_s/end_s to place it by hand)";
    return Status::Error(StatusCode::kFailed, text);
  }
  const std::vector<std::pair<double, double>> spans = RunSpans(segments);
  for (size_t k = 0; k < open.size(); ++k) {
    const int i = match.segment_of_run[k];
    const calibration::MotionSegment& s = segments[i];
    open[k]->start_s = spans[i].first;
    open[k]->end_s = spans[i].second;
    if (open[k]->infer_procedure && s.inferred.procedure != calibration::Procedure::kRecorded)
      open[k]->spec = s.inferred;  // `procedure: auto`: what the poses show
    if (assignments) {
      SegmentAssignment a{open[k]->name, source, open[k]->start_s, open[k]->end_s,
                          calibration::Describe(s.inferred)};
      if (!s.readable) {
        // The plan's order and the rests decided; what was seen agrees.
        char why[160];
        std::snprintf(why, sizeof(why), " (taken from the plan, not seen: out of view %.1f s of %.1f s)",
                      s.seen.unseen_s, s.end_rest.t_begin_s - s.start_rest.t_end_s);
        a.found = calibration::Describe(open[k]->spec) + why;
        a.procedure_seen = false;
      }
      assignments->push_back(a);
    }
  }
  return Status::Ok();
}

bool IsLoneAutoRun(const std::vector<config::SessionRun*>& group) {
  return group.size() == 1 && group.front()->infer_procedure && !HasOwnSpan(*group.front());
}

Status ExpandAutoRun(const config::SessionRun& run, const std::string& source,
                     const std::vector<calibration::PoseSample>& samples, const calibration::RestOptions& rest_options,
                     std::vector<config::SessionRun>* runs, std::vector<SegmentAssignment>* assignments) {
  const std::vector<calibration::MotionSegment> segments = calibration::SegmentMotion(samples, rest_options);
  if (segments.empty()) {
    return Status::Error(StatusCode::kFailed, source + ": run '" + run.name +
                                                  "' (procedure auto): no motion between two rests found in it" +
                                                  " (a run needs a still second before and after)");
  }
  const std::vector<std::pair<double, double>> spans = RunSpans(segments);
  // The squares of one recording were planned alike: read from the poses
  // their sides differ by a few % (a tracked point off the axle lengthens
  // one direction's excursion and shortens the other's), and UMBMark pools
  // only squares of one side. Within 30 % of each other they get their
  // median.
  std::vector<double> sides;
  for (const calibration::MotionSegment& s : segments)
    if (s.inferred.procedure == calibration::Procedure::kUmbmark) sides.push_back(s.inferred.side_m);
  std::optional<double> pooled_side;
  if (!sides.empty()) {
    std::sort(sides.begin(), sides.end());
    const size_t n = sides.size();
    if (sides.back() < 1.3 * sides.front())
      pooled_side = n % 2 ? sides[n / 2] : 0.5 * (sides[n / 2 - 1] + sides[n / 2]);
  }
  for (size_t i = 0; i < segments.size(); ++i) {
    config::SessionRun r = run;
    char suffix[24];
    std::snprintf(suffix, sizeof(suffix), "_%02zu", i + 1);
    r.name = run.name + suffix;
    r.spec = segments[i].inferred;
    if (r.spec.procedure == calibration::Procedure::kUmbmark && pooled_side) r.spec.side_m = *pooled_side;
    r.start_s = spans[i].first;
    r.end_s = spans[i].second;
    runs->push_back(r);
    if (assignments)
      assignments->push_back({r.name, source, r.start_s, r.end_s, calibration::Describe(r.spec)});
  }
  return Status::Ok();
}

Status AssignPoseLogSpans(config::Session* session, const calibration::RestOptions& rest_options,
                          std::vector<SegmentAssignment>* assignments) {
  std::map<std::string, std::vector<config::SessionRun*>> groups;
  std::vector<std::string> order;
  for (config::SessionRun& run : session->runs) {
    if (run.poses.empty()) continue;
    if (!groups.count(run.poses)) order.push_back(run.poses);
    groups[run.poses].push_back(&run);
  }
  std::map<std::string, std::vector<config::SessionRun>> expanded;  // a lone auto run's runs
  for (const std::string& path : order) {
    const std::vector<config::SessionRun*>& runs = groups[path];
    const bool lone_auto = IsLoneAutoRun(runs);
    if (runs.size() < 2 && !lone_auto) continue;
    const auto rows = ReadPoseLog(path);
    if (!rows) {
      return Status::Error(StatusCode::kFailed, rows.message);
    }
    std::vector<calibration::PoseSample> samples;
    samples.reserve(rows->size());
    for (const PoseLogRow& r : *rows) samples.push_back({r.t_s, r.T_world_body, r.valid});
    const Status assigned =
        lone_auto ? ExpandAutoRun(*runs.front(), path, samples, rest_options, &expanded[path], assignments)
                  : AssignSpansFromRecording(path, samples, runs, rest_options, assignments);
    if (!assigned) return assigned;
  }
  if (!expanded.empty()) {
    std::vector<config::SessionRun> all;
    for (const config::SessionRun& run : session->runs) {
      const auto it = run.poses.empty() ? expanded.end() : expanded.find(run.poses);
      if (it == expanded.end()) {
        all.push_back(run);
      } else {
        all.insert(all.end(), it->second.begin(), it->second.end());
      }
    }
    session->runs = std::move(all);
  }
  return Status::Ok();
}

}  // namespace odocal::measure
