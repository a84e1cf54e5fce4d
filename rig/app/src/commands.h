// The odocal command line: each command group registers its subcommands on
// the CLI11 app. Commands return the process exit code through the callback
// by throwing CLI::RuntimeError(code) after printing one clear line on stderr.
#ifndef ODOCAL_APP_COMMANDS_H_
#define ODOCAL_APP_COMMANDS_H_

#include <CLI/CLI.hpp>

namespace odocal::app {

void RegisterSimulateCommand(CLI::App& app);
void RegisterUmbmarkCommand(CLI::App& app);
void RegisterCvraCommand(CLI::App& app);
void RegisterDemoCommand(CLI::App& app);
void RegisterBatchCommand(CLI::App& app);
void RegisterMeasureCommand(CLI::App& app);
void RegisterCalibrateCameraCommand(CLI::App& app);
void RegisterRobotCommand(CLI::App& app);
void RegisterRobotSimCommand(CLI::App& app);
void RegisterExplainCommand(CLI::App& app);
void RegisterValidateCommand(CLI::App& app);
void RegisterStationCommand(CLI::App& app);
void RegisterImportCommand(CLI::App& app);
void RegisterCheckCommand(CLI::App& app);
void RegisterSetupCheckCommand(CLI::App& app);
void RegisterWatchCommand(CLI::App& app);
void RegisterDetectCommand(CLI::App& app);
void RegisterHistoryCommand(CLI::App& app);
void RegisterFleetCommand(CLI::App& app);

}  // namespace odocal::app

#endif  // ODOCAL_APP_COMMANDS_H_
