// odocal: calibration station for differential-drive robots.
#include <CLI/CLI.hpp>

#include "cli_util.h"
#include "commands.h"
#include "odocal/records/record.h"

int main(int argc, char** argv) {
  CLI::App app{"odocal: odometry calibration for differential-drive robots"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "odocal " + std::string(odocal::records::OdocalVersion()));
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
  odocal::app::RegisterHistoryCommand(app);
  odocal::app::RegisterFleetCommand(app);
  // A command line CLI11 refuses (an unknown option, a value out of range)
  // is bad input: exit 2, as every command's own checks (cli_util.h); --help
  // and --version exit 0.
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    // A command's own exit (cli_util.h's Fail throws CLI::RuntimeError with
    // its code) passes through as it is.
    if (dynamic_cast<const CLI::RuntimeError*>(&e) != nullptr || code == 0) return code;
    return odocal::app::kExitBadInput;
  }
  return 0;
}
