// `odocal check`: does a parameter set hold on runs it never saw? Every run
// of a measured session is replayed with each set (calibration/replay.h: the
// start anchored on the start rest, the ticks dead-reckoned through the set's
// model, compared with every later camera frame); the result is written as
// check.json, a self-contained report.html and a table on stdout.
//
// Per run and set: the final position error (predicted − measured end pose,
// mm), the final heading error (deg, signed, predicted − measured), the RMS
// position error over the compared frames (mm) and the final error as a
// percentage of the distance the wheels travelled. Per set: max and mean of
// each over the runs it could replay (|heading|). A run that cannot be
// replayed carries its reason instead of numbers.
//
// Frames: the camera's measurement frame (REP-103). Units at this edge: mm, deg.
#ifndef ODOCAL_REPORT_CHECK_REPORT_H_
#define ODOCAL_REPORT_CHECK_REPORT_H_

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "odocal/calibration/measured_session.h"
#include "odocal/calibration/replay.h"
#include "odocal/config/param_files.h"

namespace odocal::report {

struct CheckResult {
  std::vector<config::ReplaySet> sets;
  // replays[set][run], runs in the session's order.
  std::vector<std::vector<calibration::RunReplay>> replays;

  // How many (set, run) pairs were replayed.
  int Replayed() const;
};

// Replays every run of `session` with every set, in the session's order (each
// wheel's last direction carries over from run to run, as backlash needs).
// A set with a lens error is seen through session.camera; without one its
// runs are not replayed, with the reason.
CheckResult RunCheck(const calibration::MeasuredSession& session, const std::vector<config::ReplaySet>& sets,
                     const calibration::ReplayOptions& options = {});

// check.json (keys in docs/reports.md). Trajectories are thinned to at most
// `max_points` points per curve.
nlohmann::json CheckJson(const std::string& session_path, const calibration::MeasuredSession& session,
                         const CheckResult& result, int max_points = 300);

// The summary and per-run errors as a plain-text table (stdout).
std::string CheckTable(const nlohmann::json& check);

// report.html from check.json: per run the trajectories overlaid (measured
// against each set) with its errors, a bar chart of the final errors per set,
// the summary; no script, no external asset.
std::string CheckHtml(const nlohmann::json& check);

}  // namespace odocal::report

#endif  // ODOCAL_REPORT_CHECK_REPORT_H_
