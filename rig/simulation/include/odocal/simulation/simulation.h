// Running a scenario on the virtual robot and writing what it did: the truth
// (for tests and benchmarks, never for estimators) and the telemetry.
#ifndef ODOCAL_SIMULATION_SIMULATION_H_
#define ODOCAL_SIMULATION_SIMULATION_H_

#include <optional>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/config/scenario.h"
#include "odocal/sim/virtual_robot.h"

namespace odocal::simulation {

struct SimulationResult {
  calibration::ErrorFactors truth;
  std::vector<std::string> run_names;
  std::vector<sim::RunRecord> runs;
};

// Runs the scenario's runs in order on one robot (each starts where the
// previous ended), with `believed` as the firmware's parameters when given.
SimulationResult Simulate(const config::Scenario& scenario,
                          const std::optional<calibration::WheelParams>& believed = std::nullopt);

struct RecordedRun;

// Writes DIR/truth.json and DIR/<run>.telemetry.csv, DIR/<run>.trajectory.csv;
// with `recorded` videos also DIR/session.yaml and DIR/camera.yaml (what an
// operator would have) and the videos' entries in truth.json.
// The first file's error (config::WriteFileAtomically's, WriteSession's).
Status WriteSimulation(const config::Scenario& scenario, const SimulationResult& result, const std::string& dir,
                       const std::vector<RecordedRun>* recorded = nullptr);

}  // namespace odocal::simulation

#endif  // ODOCAL_SIMULATION_SIMULATION_H_
