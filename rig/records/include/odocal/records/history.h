// What a robot's records say over time (`odocal history`), and what a fleet's say together
// (`odocal fleet`): wear, repairs, the date a robot leaves its limits, the production line's
// control charts. Pure functions of the records (no store, no files).
#ifndef ODOCAL_RECORDS_HISTORY_H_
#define ODOCAL_RECORDS_HISTORY_H_

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "odocal/records/limits.h"
#include "odocal/records/record.h"

namespace odocal::records {

struct HistoryOptions {
  Limits limits;
  double now_s = 0.0;       // seconds since the epoch: what "due" is measured from
  double step_z = 4.0;      // a calibrated value this many sigmas off the trend is a step (a repair)
  double disagree_z = 3.0;  // the newest calibration this far off the trend: a warning
};

// A change between two calibrations that the trend does not explain: a repair, a wheel change.
struct Step {
  int index = 0;            // the record after the step
  std::string time_utc;
  std::string parameter;    // "track_mm", "mean_wheel_diameter_mm", "Ed"
  double change = 0.0;      // its size, in the parameter's unit
  double z = 0.0;           // in sigmas of the prediction from the records before it
};

struct HistoryAnalysis {
  std::string robot;
  std::vector<Record> records;  // oldest first (calibrations: records with a calibrated set)
  int segment_start = 0;        // the first record after the wheels' last step: wear is fitted from here
  int track_segment_start = 0;  // the same for the track
  // The mean wheel diameter's trend (negative: shrinking), per week and per 1000 km (the latter
  // when the records carry the odometer).
  std::optional<Estimate> wear_mm_per_week;
  std::optional<Estimate> wear_mm_per_1000km;
  std::optional<Estimate> track_mm_per_week;
  std::vector<Step> steps;
  // E_max,syst's growth while the robot runs between calibrations (mm per week), and the date
  // it is predicted to reach limits.emax_syst_after_mm after the last calibration.
  std::optional<Estimate> emax_growth_mm_per_week;
  std::optional<std::string> limit_crossing_utc;
  std::optional<std::string> due_utc;  // the last calibration + limits.recalibrate_days, or the crossing if sooner
  bool due = false;                    // due_utc is not after now
  // The newest calibration against the trend of the ones before it, when it disagrees beyond
  // disagree_z sigmas (and is not explained as a step).
  std::vector<std::string> warnings;
};

HistoryAnalysis AnalyseHistory(const std::string& robot, std::vector<Record> records, const HistoryOptions& options);
// {"robot", "records": [record.json ...], "analysis": {...}} (docs/formats.md, "Records").
nlohmann::json HistoryJson(const HistoryAnalysis& analysis);
std::string HistoryTable(const HistoryAnalysis& analysis);
std::string HistoryHtml(const HistoryAnalysis& analysis);

// One robot's line in the fleet view.
struct FleetRobot {
  std::string robot;
  Record last;
  int calibrations = 0;
  std::optional<Estimate> wear_mm_per_week;
  std::optional<std::string> due_utc;
  bool due = false;
  std::optional<std::string> limit_crossing_utc;  // when E_max,syst is predicted to reach its limit
  int steps = 0;                                  // steps (repairs) in its history
  std::vector<std::string> warnings;
};

// A control chart: values in build order (a robot's first record), mean ± 3 sigma from the
// values (sigma from the moving range, as an individuals chart), and the points flagged by the
// Western Electric rules (1: beyond 3 sigma; 2: 2 of 3 beyond 2 sigma on one side; 3: 4 of 5
// beyond 1 sigma on one side; 4: 8 in a row on one side).
struct ControlChart {
  std::string quantity;  // "Ed", "Eb", "emax_syst_before_mm", "emax_syst_after_mm"
  std::vector<std::string> robots;
  std::vector<double> values;
  double mean = 0.0, sigma = 0.0;
  struct Flag {
    int index = 0;
    int rule = 0;
    std::string why;
  };
  std::vector<Flag> flags;
};
std::vector<ControlChart::Flag> WesternElectricFlags(const std::vector<double>& values, double mean, double sigma);

struct FleetSummary {
  std::vector<FleetRobot> robots;  // sorted by name
  int records = 0;
  int judged = 0, passed = 0;                       // robots whose last record has a verdict
  std::vector<std::pair<std::string, int>> causes;  // failed limits by kind, most common first
  std::vector<ControlChart> charts;
  // The robot predicted to reach its E_max,syst limit first, and when (none without a limit).
  std::optional<std::pair<std::string, std::string>> first_to_cross;
};

// `all` grouped by robot, each oldest first (RecordStore::All's order).
FleetSummary SummariseFleet(const std::vector<Record>& all, const HistoryOptions& options);
nlohmann::json FleetJson(const FleetSummary& fleet);
std::string FleetTable(const FleetSummary& fleet);
std::string FleetHtml(const FleetSummary& fleet);

}  // namespace odocal::records

#endif  // ODOCAL_RECORDS_HISTORY_H_
