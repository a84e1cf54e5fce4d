// odocal: calibration station for differential-drive robots.
#include <CLI/CLI.hpp>

#include "commands.h"

int main(int argc, char** argv) {
  CLI::App app{"odocal: odometry calibration for differential-drive robots"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "odocal 0.1.0");
  odocal::app::RegisterSimulateCommand(app);
  odocal::app::RegisterUmbmarkCommand(app);
  odocal::app::RegisterCvraCommand(app);
  odocal::app::RegisterDemoCommand(app);
  odocal::app::RegisterMeasureCommand(app);
  odocal::app::RegisterBatchCommand(app);
  odocal::app::RegisterCalibrateCameraCommand(app);
  odocal::app::RegisterRobotCommand(app);
  odocal::app::RegisterRobotSimCommand(app);
  odocal::app::RegisterExplainCommand(app);
  odocal::app::RegisterValidateCommand(app);
  odocal::app::RegisterStationCommand(app);
  odocal::app::RegisterImportCommand(app);
  odocal::app::RegisterCheckCommand(app);
  odocal::app::RegisterSetupCheckCommand(app);
  odocal::app::RegisterWatchCommand(app);
  odocal::app::RegisterDetectCommand(app);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
