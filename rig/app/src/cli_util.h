// Small helpers shared by the commands: failing with one clear line, and
// parsing number lists from the command line.
#ifndef ODOCAL_APP_CLI_UTIL_H_
#define ODOCAL_APP_CLI_UTIL_H_

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "odocal/report/exports.h"
#include "odocal/vision/camera_calibration.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/tag.h"

namespace CLI {
class App;
}

namespace odocal::app {

// Exit codes: 1 = the work failed (no valid result), 2 = bad input.
inline constexpr int kExitFailure = 1;
inline constexpr int kExitBadInput = 2;

// A count option (threads, views) is checked with CLI::Range(0, kMaxCount):
// a refusal then names a bound one can read (CLI11's NonNegativeNumber names
// the largest double).
inline constexpr int kMaxCount = 1000000;

// Prints "odocal <command>: <message>" on stderr and ends the command with
// `exit_code` (through CLI11, so main returns it).
[[noreturn]] void Fail(const std::string& command, int exit_code, const std::string& message);

// The inputs with every directory replaced by the files in it whose
// extension is one of `extensions` (lower case, with the dot; matched
// case-insensitively), sorted by name, as Kalibr/ROS data sets keep frames
// (cam0/data/*.png). A directory with none of them fails the command
// (bad input), naming it. Files are passed through unchecked.
std::vector<std::string> ExpandDirectories(const std::string& command, const std::vector<std::string>& inputs,
                                           const std::vector<std::string>& extensions);
// Still images OpenCV reads: .png .jpg .jpeg .bmp .tif .tiff .pgm .ppm .webp.
const std::vector<std::string>& ImageExtensions();

// "1.5,-2,0.25" -> {1.5, -2, 0.25}; nullopt unless every field is a finite number.
std::optional<std::vector<double>> ParseNumberList(const std::string& text);

// `--OPTION FAMILY:ID:SIZE_MM[:HEIGHT_MM]` (e.g. tag36h11:5:80:150): the robot's tag;
// fails `command` with exit 2 naming the option and the field otherwise.
vision::TagSpec ParseTagOption(const std::string& command, const std::string& option, const std::string& text);

// `--OPTION SPEC` naming a calibration board (sides in mm):
//   chessboard:COLSxROWS:SQUARE_MM                (inner corners)
//   charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICT    (squares)
//   aprilgrid:COLSxROWS:TAG_MM:SPACING[:FIRST_ID]  (Kalibr's target: tags, tag36h11b2,
//                                                   TAG_MM the outer black edge, gap = SPACING x tag)
//   FILE                                          (Kalibr's target.yaml, aprilgrid; config/calib_target.h)
// fails `command` with exit 2 naming the option, the field or the file's line otherwise.
vision::CalibrationBoard ParseBoardOption(const std::string& command, const std::string& option,
                                          const std::string& text);

// `--OPTION x,y,height,roll,pitch,yaw` (mm, deg; as session.yaml's camera_mount_guess):
// where the camera hangs; fails `command` with exit 2 otherwise.
vision::CameraMount ParseMountOption(const std::string& command, const std::string& option,
                                     const std::string& text);

// What a command that watches the robot's tag through one camera is told
// (setup-check, watch): the camera (a device, a stream URL or a video file),
// its calibration, the tag (`--tag`, ParseTagOption) and, when given, where
// the camera hangs (`--mount-guess`, ParseMountOption; empty: not given).
struct CameraTagArgs {
  std::string camera;
  std::string calibration;
  std::string tag;
  std::string mount;
};
// Adds them to `cmd`: the camera as `camera_option` ("--camera", or a
// positional name such as "camera"), --calibration, --tag and --mount-guess;
// all but the last required.
void AddCameraTagOptions(CLI::App* cmd, const std::string& camera_option, CameraTagArgs* args);

// A progress bar on stderr when it is a terminal, nothing otherwise.
std::function<void(long, long)> TerminalProgressBar(const std::string& label);

// Adds `--export KIND FILE` (repeatable) to `cmd`; kinds are checked at parse time.
void AddExportOption(CLI::App* cmd, report::ExportRequests* requests);

}  // namespace odocal::app

#endif  // ODOCAL_APP_CLI_UTIL_H_
