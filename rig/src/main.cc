// odocal: calibration station for differential-drive robots.
#include <CLI/CLI.hpp>

#include "odocal/rig/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"odocal: odometry calibration for differential-drive robots"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "odocal 0.1.0");
  odocal::rig::RegisterSimulateCommand(app);
  odocal::rig::RegisterUmbmarkCommand(app);
  odocal::rig::RegisterCvraCommand(app);
  odocal::rig::RegisterDemoCommand(app);
  odocal::rig::RegisterMeasureCommand(app);
  odocal::rig::RegisterBatchCommand(app);
  odocal::rig::RegisterCalibrateCameraCommand(app);
  odocal::rig::RegisterRobotCommand(app);
  odocal::rig::RegisterRobotSimCommand(app);
  odocal::rig::RegisterExplainCommand(app);
  odocal::rig::RegisterValidateCommand(app);
  odocal::rig::RegisterStationCommand(app);
  odocal::rig::RegisterImportCommand(app);
  odocal::rig::RegisterCheckCommand(app);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
