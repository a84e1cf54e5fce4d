// Camera files: the intrinsics of a camera (pinhole + a lens model,
// vision::LensModel: plumb_bob k1 k2 p1 p2 k3, or equidistant k1..k4 for a
// fisheye) as the YAML layouts operators already have.
//
//   OpenCV FileStorage YAML   what cv::FileStorage writes: a `%YAML:1.0`
//     header, `camera_matrix` and `distortion_coefficients` as
//     `!!opencv-matrix {rows, cols, dt, data}`, `image_width`, `image_height`.
//     Also read: OpenCV's calibration sample layout (extra keys such as
//     `avg_reprojection_error`, `extrinsic_parameters`, `image_points` are
//     ignored; the distortion may be a 5x1 column, or have 4, 8, 12 or 14
//     coefficients whose extra terms are zero), and the capitalised
//     `Camera_Matrix` / `Distortion_Coefficients` of older samples.
//   ROS camera_info YAML      what camera_calibration_parsers reads and writes:
//     `image_width`, `image_height`, `camera_name`, `camera_matrix`,
//     `distortion_model: plumb_bob | equidistant`, `distortion_coefficients`,
//     `rectification_matrix`, `projection_matrix`, each matrix as
//     `{rows, cols, data}`.
//     OpenCV files of a fisheye lens carry `fisheye_model: 1` (OpenCV's
//     calibration sample) or `distortion_model: equidistant` (odocal writes
//     both); D then holds cv::fisheye's k1..k4.
//   Kalibr camchain YAML      `cam0: {camera_model: pinhole, distortion_model:
//     radtan | equidistant, intrinsics: [fu, fv, pu, pv], distortion_coeffs,
//     resolution: [w, h]}` (read only; the first camera).
// Reading auto-detects the layout (the ROS-only keys, or matrices without
// OpenCV's `dt`, mean ROS). Pixel coordinates are OpenCV's in both (ROS
// uses the same convention), so nothing is converted.
//
// Errors are one line, "<path>: <key>: <what is wrong>", returned as a value:
// no exception leaves this module.
#ifndef ODOCAL_CONFIG_CAMERA_FILE_H_
#define ODOCAL_CONFIG_CAMERA_FILE_H_

#include <optional>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/vision/camera_model.h"

namespace odocal::config {

enum class CameraFileFormat { kOpenCv, kRos };

// "opencv" / "ros".
const char* CameraFileFormatName(CameraFileFormat format);
std::optional<CameraFileFormat> ParseCameraFileFormat(const std::string& name);

// What a camera file holds. The quality figures are optional: a file written
// by `odocal calibrate-camera` has them, a hand-made one need not.
struct CameraFile {
  vision::Intrinsics intrinsics;
  // The layout the file was read in (writing takes the format explicitly).
  CameraFileFormat format = CameraFileFormat::kOpenCv;
  // ROS `camera_name`; written to ROS files only.
  std::string camera_name = "camera";
  // RMS reprojection error of the calibration over all corners [px], and per
  // image [px] (OpenCV sample keys `avg_reprojection_error`,
  // `per_view_reprojection_errors`; the same keys are added to ROS files,
  // whose readers ignore keys they do not know).
  std::optional<double> rms_reprojection_error_px;
  std::vector<double> per_view_reprojection_errors_px;
};

// Parses the text of a camera file; `name` is the path used in messages.
// kBadFile with one line naming the file and key when it does not parse.
Result<CameraFile> ParseCameraFile(const std::string& text, const std::string& name);
// Reads and parses `path`.
Result<CameraFile> ReadCameraFile(const std::string& path);

// The file's text in `format` (OpenCV: written by cv::FileStorage itself;
// numbers with 17 significant digits, so a round trip is exact).
std::string FormatCameraFile(const CameraFile& file, CameraFileFormat format);
// Writes atomically (temporary file + rename). Refuses intrinsics that fail
// Intrinsics::IsValid (kInvalidArgument); kIoError when the file cannot be written.
Status WriteCameraFile(const std::string& path, const CameraFile& file, CameraFileFormat format);

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_CAMERA_FILE_H_
