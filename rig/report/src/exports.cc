#include "odocal/config/files.h"
#include "odocal/report/exports.h"

#include "odocal/base/format.h"
#include "odocal/base/units.h"
#include "odocal/calibration/corrections.h"
#include "odocal/report/json.h"

namespace odocal::report {
namespace {

std::string Number(double v) { return Format("%.9g", v); }

}  // namespace

Status CheckExports(const ExportRequests& requests) {
  if (requests.raw.size() % 2 != 0) return Status::Error(StatusCode::kInvalidArgument, "--export takes KIND FILE");
  for (size_t i = 0; i < requests.raw.size(); i += 2) {
    const std::string& kind = requests.raw[i];
    if (kind != "ros2" && kind != "firmware")
      return Status::Error(StatusCode::kInvalidArgument, "--export " + kind + ": unknown kind (ros2 or firmware)");
  }
  return Status::Ok();
}

std::string Ros2ExportYaml(const calibration::WheelParams& nominal,
                           const calibration::WheelParams& corrected) {
  const calibration::Ros2Multipliers m = calibration::Ros2MultipliersFrom(nominal, corrected);
  return "# odocal: ROS 2 diff_drive_controller multipliers (nominal -> corrected)\n"
         "diff_drive_controller:\n"
         "  ros__parameters:\n"
         "    wheel_separation_multiplier: " + Number(m.wheel_separation_multiplier) + "\n" +
         "    left_wheel_radius_multiplier: " + Number(m.left_wheel_radius_multiplier) + "\n" +
         "    right_wheel_radius_multiplier: " + Number(m.right_wheel_radius_multiplier) + "\n";
}

std::string FirmwareExportYaml(const calibration::WheelParams& c) {
  const std::string left = Number(c.left_wheel_diameter_m * kMToMm),
                    right = Number(c.right_wheel_diameter_m * kMToMm), track = Number(c.track_m * kMToMm),
                    ticks = Number(c.ticks_per_rev);
  return "# odocal: corrected parameters in the robot link's names (mm)\n"
         "# push: odocal robot push --port DEVICE left_wheel_diameter_mm=" + left +
         " right_wheel_diameter_mm=" + right + " track_mm=" + track + " ticks_per_rev=" + ticks +
         "\n"
         "left_wheel_diameter_mm: " + left + "\n" +
         "right_wheel_diameter_mm: " + right + "\n" +
         "track_mm: " + track + "\n" +
         "ticks_per_rev: " + ticks + "\n";
}

Status WriteExports(const ExportRequests& requests, const calibration::WheelParams& nominal,
                    const std::optional<calibration::WheelParams>& corrected) {
  if (Status checked = CheckExports(requests); !checked) return checked;
  for (size_t i = 0; i < requests.raw.size(); i += 2) {
    const std::string& kind = requests.raw[i];
    const std::string& file = requests.raw[i + 1];
    if (!corrected)
      return Status::Error(StatusCode::kFailed,
                           "--export " + kind + " " + file + ": no corrected parameters to export");
    const std::string text =
        kind == "ros2" ? Ros2ExportYaml(nominal, *corrected) : FirmwareExportYaml(*corrected);
    if (Status written = config::WriteFileAtomically(file, text); !written) return written;
  }
  return Status::Ok();
}

}  // namespace odocal::report
