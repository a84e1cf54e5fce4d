#include "odocal/config/camera_file.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <vector>

#include <opencv2/core.hpp>
#include <yaml-cpp/yaml.h>

#include "file_result.h"
#include "odocal/config/files.h"

namespace odocal::config {
namespace {

// Key spellings accepted on reading; the first is the one written and named
// in messages. The others are those of OpenCV's older calibration sample and
// of its interactive-calibration app.
const std::initializer_list<const char*> kCameraMatrixKeys = {"camera_matrix", "Camera_Matrix",
                                                              "cameraMatrix"};
const std::initializer_list<const char*> kDistortionKeys = {
    "distortion_coefficients", "Distortion_Coefficients", "dist_coeffs", "distCoeffs"};
// Keys only ROS camera_info files have.
// (distortion_model is also in odocal's OpenCV files of fisheye lenses.)
const std::initializer_list<const char*> kRosOnlyKeys = {"camera_name", "rectification_matrix",
                                                         "projection_matrix"};

// The reader's own failure: carries the "<key>: <message>" part; converted to
// a returned string before leaving this file.
struct CameraKeyError {
  std::string text;
};

[[noreturn]] void Throw(const std::string& key, const std::string& message) {
  throw CameraKeyError{key + ": " + message};
}

// nullopt when none of the spellings is present (a default YAML::Node would
// be a defined null, indistinguishable from `key: ~`).
std::optional<YAML::Node> Find(const YAML::Node& root, std::initializer_list<const char*> keys,
                               std::string* used) {
  for (const char* key : keys) {
    if (const YAML::Node node = root[key]) {
      *used = key;
      return node;
    }
  }
  return std::nullopt;
}

bool ParseDouble(const std::string& text, double* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  errno = 0;
  *value = std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0' && errno != ERANGE;
}

bool ParseInt(const std::string& text, int* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (end == text.c_str() || *end != '\0' || errno == ERANGE || v < -(1L << 30) || v > (1L << 30))
    return false;
  *value = static_cast<int>(v);
  return true;
}

int ReadInt(const YAML::Node& node, const std::string& key) {
  int value = 0;
  if (!node.IsScalar() || !ParseInt(node.Scalar(), &value))
    Throw(key, "expected an integer, got '" + (node.IsScalar() ? node.Scalar() : "a collection") + "'");
  return value;
}

// A matrix node: {rows, cols, data} (ROS), the same with `dt` and the
// !!opencv-matrix tag (OpenCV), or a bare list (read as one row).
cv::Mat ReadMatrix(const YAML::Node& node, const std::string& key) {
  YAML::Node data;
  int rows = 1, cols = 0;
  if (node.IsSequence()) {
    data = node;
    cols = static_cast<int>(node.size());
  } else if (node.IsMap()) {
    if (!node["rows"] || !node["cols"] || !node["data"])
      Throw(key, "expected a matrix {rows, cols, data}");
    rows = ReadInt(node["rows"], key + ".rows");
    cols = ReadInt(node["cols"], key + ".cols");
    data = node["data"];
    if (rows <= 0 || cols <= 0) Throw(key, "rows and cols must be positive");
    if (!data.IsSequence()) Throw(key + ".data", "expected a list of numbers");
    if (const YAML::Node dt = node["dt"]) {
      // OpenCV element types with one channel; anything else is not a plain matrix.
      const std::string t = dt.IsScalar() ? dt.Scalar() : "";
      if (t.size() != 1 || std::string("ucwsifd").find(t) == std::string::npos)
        Throw(key + ".dt", "expected a one-channel element type (u c w s i f d), got '" + t + "'");
    }
  } else {
    Throw(key, "expected a matrix {rows, cols, data}");
  }
  if (static_cast<long>(data.size()) != static_cast<long>(rows) * cols)
    Throw(key, "data has " + std::to_string(data.size()) + " values, rows x cols = " +
                   std::to_string(static_cast<long>(rows) * cols));
  cv::Mat m(rows, cols, CV_64F);
  for (int i = 0; i < rows * cols; ++i) {
    const YAML::Node v = data[i];
    double value = 0.0;
    if (!v.IsScalar() || !ParseDouble(v.Scalar(), &value) || !std::isfinite(value))
      Throw(key, "data[" + std::to_string(i) + "]: '" + (v.IsScalar() ? v.Scalar() : "?") +
                     "' is not a finite number");
    m.at<double>(i / cols, i % cols) = value;
  }
  return m;
}

std::vector<double> ReadNumbers(const YAML::Node& node, const std::string& key, size_t count) {
  if (!node.IsSequence() || (count && node.size() != count))
    Throw(key, "expected a list of " + (count ? std::to_string(count) + " " : std::string()) + "numbers");
  std::vector<double> values;
  for (size_t i = 0; i < node.size(); ++i) {
    double v = 0.0;
    if (!node[i].IsScalar() || !ParseDouble(node[i].Scalar(), &v) || !std::isfinite(v))
      Throw(key + "[" + std::to_string(i) + "]", "not a finite number");
    values.push_back(v);
  }
  return values;
}

// A Kalibr camchain (camchain.yaml, or its camera file): cam0 {camera_model:
// pinhole, distortion_model: equidistant | radtan, intrinsics: [fu, fv, pu,
// pv], distortion_coeffs, resolution: [w, h]}. The first camera is read.
// The ASL/EuRoC sensor.yaml (EuRoC, TUM-VI's export, OKVIS, maplab) is the
// same at its top level, with `distortion_coefficients` and
// `radial-tangential`.
CameraFile ParseKalibr(const YAML::Node& cam, const std::string& name) {
  const std::string key = name + ".";
  if (const YAML::Node model = cam["camera_model"]) {
    if (!model.IsScalar() || model.Scalar() != "pinhole")
      Throw(key + "camera_model", "'" + (model.IsScalar() ? model.Scalar() : "?") +
                                      "' is not supported (pinhole, with radtan or equidistant distortion)");
  }
  if (!cam["distortion_model"]) Throw(key + "distortion_model", "missing");
  const std::string model_name = cam["distortion_model"].IsScalar() ? cam["distortion_model"].Scalar() : "";
  const auto lens = vision::ParseLensModel(model_name);
  if (!lens) Throw(key + "distortion_model", "'" + model_name + "' is not supported (radtan, equidistant)");
  if (!cam["intrinsics"]) Throw(key + "intrinsics", "missing");
  std::string d_key = "distortion_coeffs";
  const auto d_node = Find(cam, {"distortion_coeffs", "distortion_coefficients"}, &d_key);
  if (!d_node) Throw(key + "distortion_coeffs", "missing");
  if (!cam["resolution"]) Throw(key + "resolution", "missing");
  const std::vector<double> k = ReadNumbers(cam["intrinsics"], key + "intrinsics", 4);
  const std::vector<double> d = ReadNumbers(*d_node, key + d_key, 4);
  const YAML::Node res = cam["resolution"];
  if (!res.IsSequence() || res.size() != 2) Throw(key + "resolution", "expected [width, height]");
  const int width = ReadInt(res[0], key + "resolution[0]"), height = ReadInt(res[1], key + "resolution[1]");
  if (width <= 0 || height <= 0) Throw(key + "resolution", "must be positive");
  const cv::Mat K = (cv::Mat_<double>(3, 3) << k[0], 0.0, k[2], 0.0, k[1], k[3], 0.0, 0.0, 1.0);
  // Kalibr's radtan is [k1 k2 r1 r2] = OpenCV's k1 k2 p1 p2.
  const cv::Mat D = (cv::Mat_<double>(1, 4) << d[0], d[1], d[2], d[3]);
  const auto intrinsics = vision::Intrinsics::FromCv(K, D, width, height, *lens);
  if (!intrinsics) Throw(key + "intrinsics", intrinsics.message);
  CameraFile file;
  file.format = CameraFileFormat::kRos;
  file.intrinsics = *intrinsics;
  file.camera_name = name;
  return file;
}

// The image size: image_width / image_height, or the interactive-calibration
// app's cameraResolution: [w, h].
cv::Size ReadImageSize(const YAML::Node& root) {
  cv::Size size;
  if (root["image_width"] || root["image_height"] || !root["cameraResolution"]) {
    if (!root["image_width"]) Throw("image_width", "missing");
    if (!root["image_height"]) Throw("image_height", "missing");
    size.width = ReadInt(root["image_width"], "image_width");
    size.height = ReadInt(root["image_height"], "image_height");
    if (size.width <= 0) Throw("image_width", "must be positive");
    if (size.height <= 0) Throw("image_height", "must be positive");
  } else {
    const YAML::Node res = root["cameraResolution"];
    if (!res.IsSequence() || res.size() != 2) Throw("cameraResolution", "expected [width, height]");
    size.width = ReadInt(res[0], "cameraResolution[0]");
    size.height = ReadInt(res[1], "cameraResolution[1]");
    if (size.width <= 0 || size.height <= 0) Throw("cameraResolution", "must be positive");
  }
  return size;
}

// The lens: ROS's distortion_model (also written into OpenCV files by
// odocal), or the OpenCV calibration sample's fisheye_model: 1.
vision::LensModel ReadLensModel(const YAML::Node& root) {
  vision::LensModel lens = vision::LensModel::kPlumbBob;
  if (const YAML::Node model = root["distortion_model"]) {
    const std::string name = model.IsScalar() ? model.Scalar() : "";
    // rational_polynomial is plumb_bob plus k4 k5 k6, accepted when those are zero.
    const auto parsed = name == "rational_polynomial" ? vision::LensModel::kPlumbBob : vision::ParseLensModel(name);
    if (!parsed)
      Throw("distortion_model", "'" + name + "' is not supported (plumb_bob, rational_polynomial, equidistant)");
    lens = *parsed;
  }
  if (const YAML::Node fisheye = root["fisheye_model"]) {
    const int on = ReadInt(fisheye, "fisheye_model");
    if (on != 0 && on != 1) Throw("fisheye_model", "expected 0 or 1");
    if (on == 1) lens = vision::LensModel::kEquidistant;
  }
  return lens;
}

// What the file says beside the intrinsics: the camera's name and the calibration's reprojection errors.
void ReadCalibrationNotes(const YAML::Node& root, CameraFile& file) {
  if (const YAML::Node name = root["camera_name"]) {
    if (!name.IsScalar()) Throw("camera_name", "expected a string");
    file.camera_name = name.Scalar();
  }
  if (const YAML::Node rms = root["avg_reprojection_error"]) {
    double value = 0.0;
    if (!rms.IsScalar() || !ParseDouble(rms.Scalar(), &value) || !(value >= 0.0))
      Throw("avg_reprojection_error", "expected a non-negative number");
    file.rms_reprojection_error_px = value;
  }
  if (const YAML::Node per_view = root["per_view_reprojection_errors"]) {
    const cv::Mat e = ReadMatrix(per_view, "per_view_reprojection_errors");
    for (int i = 0; i < static_cast<int>(e.total()); ++i)
      file.per_view_reprojection_errors_px.push_back(e.at<double>(i / e.cols, i % e.cols));
  }
}

CameraFile ParseRoot(const YAML::Node& root) {
  // Kalibr: the cameras are maps cam0, cam1, ... holding `intrinsics`.
  for (const char* cam : {"cam0"}) {
    if (const YAML::Node node = root[cam]; node && node.IsMap() && node["intrinsics"]) return ParseKalibr(node, cam);
  }
  if (root["intrinsics"] && (root["distortion_coeffs"] || root["distortion_coefficients"]))
    return ParseKalibr(root, "camera");
  CameraFile file;
  bool ros = false;
  for (const char* key : kRosOnlyKeys) ros |= static_cast<bool>(root[key]);
  std::string k_key = "camera_matrix";
  const auto k_found = Find(root, kCameraMatrixKeys, &k_key);
  if (!k_found) Throw("camera_matrix", "missing");
  const YAML::Node k_node = *k_found;
  if (k_node.IsMap() && !k_node["dt"] && k_node.Tag().find("opencv-matrix") == std::string::npos) ros = true;
  file.format = ros ? CameraFileFormat::kRos : CameraFileFormat::kOpenCv;

  const cv::Size size = ReadImageSize(root);
  const int width = size.width, height = size.height;

  const cv::Mat K = ReadMatrix(k_node, k_key);
  if (K.rows != 3 || K.cols != 3)
    Throw(k_key, "expected a 3x3 matrix, got " + std::to_string(K.rows) + "x" + std::to_string(K.cols));
  if (const auto k_only = vision::Intrinsics::FromCv(K, cv::Mat(), width, height); !k_only)
    Throw(k_key, k_only.message);

  std::string d_key = "distortion_coefficients";
  const auto d_node = Find(root, kDistortionKeys, &d_key);
  if (!d_node) Throw("distortion_coefficients", "missing");
  const vision::LensModel lens = ReadLensModel(root);
  const cv::Mat D = ReadMatrix(*d_node, d_key);
  if (D.rows != 1 && D.cols != 1)
    Throw(d_key, "expected a 1xN or Nx1 vector, got " + std::to_string(D.rows) + "x" + std::to_string(D.cols));
  const auto intrinsics = vision::Intrinsics::FromCv(K, D, width, height, lens);
  if (!intrinsics) Throw(d_key, intrinsics.message);
  file.intrinsics = *intrinsics;

  ReadCalibrationNotes(root, file);
  return file;
}

// An empty file parses as a YAML null; say "empty" rather than "not a mapping".
bool IsBlank(const std::string& text) {
  for (char c : text) {
    if (!std::isspace(static_cast<unsigned char>(c))) return false;
  }
  return true;
}

void EmitMatrix(YAML::Emitter& out, const char* key, const cv::Mat& m) {
  out << YAML::Key << key << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "rows" << YAML::Value << m.rows;
  out << YAML::Key << "cols" << YAML::Value << m.cols;
  out << YAML::Key << "data" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (int r = 0; r < m.rows; ++r) {
    for (int c = 0; c < m.cols; ++c) out << m.at<double>(r, c);
  }
  out << YAML::EndSeq << YAML::EndMap;
}

}  // namespace

const char* CameraFileFormatName(CameraFileFormat format) {
  return format == CameraFileFormat::kRos ? "ros" : "opencv";
}

std::optional<CameraFileFormat> ParseCameraFileFormat(const std::string& name) {
  if (name == "opencv") return CameraFileFormat::kOpenCv;
  if (name == "ros") return CameraFileFormat::kRos;
  return std::nullopt;
}

namespace {

// The parser: the value, or nullopt with one error line.
std::optional<CameraFile> ParseCameraText(const std::string& text, const std::string& name, std::string* error) {
  auto fail = [&](const std::string& message) -> std::optional<CameraFile> {
    if (error) *error = name + ": " + message;
    return std::nullopt;
  };
  if (IsBlank(text)) return fail("empty file");
  // yaml-cpp reads cv::FileStorage's own output, "%YAML:1.0" header and
  // !!opencv-matrix tags included, so one parser serves both layouts and
  // every message can name its key.
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return fail("not valid YAML (line " + std::to_string(e.mark.line + 1) + ": " + e.msg + ")");
  }
  if (root.IsNull()) return fail("empty file");  // comments only
  if (!root.IsMap()) return fail("expected a mapping of keys (camera_matrix, ...) at the top level");
  try {
    return ParseRoot(root);
  } catch (const CameraKeyError& e) {
    return fail(e.text);
  } catch (const YAML::Exception& e) {
    // Not expected (every access above is checked), but no exception leaves.
    return fail(e.msg);
  }
}

// The reader; the public function wraps its error line in a Result.
std::optional<CameraFile> ReadCameraFileOrError(const std::string& path, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    if (error) *error = path + ": cannot open file";
    return std::nullopt;
  }
  std::stringstream buffer;
  buffer << in.rdbuf();
  return ParseCameraText(buffer.str(), path, error);
}

}  // namespace

Result<CameraFile> ParseCameraFile(const std::string& text, const std::string& name) {
  std::string error;
  std::optional<CameraFile> file = ParseCameraText(text, name, &error);
  if (!file) return Result<CameraFile>::Error(StatusCode::kBadFile, error);
  return Result<CameraFile>::Ok(std::move(*file));
}

std::string FormatCameraFile(const CameraFile& file, CameraFileFormat format) {
  const vision::Intrinsics& in = file.intrinsics;
  if (format == CameraFileFormat::kOpenCv) {
    // cv::FileStorage itself, so the file is exactly what OpenCV programs expect.
    cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY |
                                    cv::FileStorage::FORMAT_YAML);
    fs << "image_width" << in.width << "image_height" << in.height;
    fs << "camera_matrix" << in.CameraMatrix();
    fs << "distortion_coefficients" << in.DistortionCoeffs();
    // Plain OpenCV files stay as OpenCV writes them; a fisheye lens says so
    // (OpenCV's calibration sample's key, and the model's name).
    if (in.lens == vision::LensModel::kEquidistant)
      fs << "fisheye_model" << 1 << "distortion_model" << vision::LensModelName(in.lens);
    if (file.rms_reprojection_error_px) fs << "avg_reprojection_error" << *file.rms_reprojection_error_px;
    if (!file.per_view_reprojection_errors_px.empty()) {
      fs << "per_view_reprojection_errors"
         << cv::Mat(file.per_view_reprojection_errors_px, /*copyData=*/true);
    }
    return fs.releaseAndGetString();
  }
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << YAML::BeginMap;
  out << YAML::Key << "image_width" << YAML::Value << in.width;
  out << YAML::Key << "image_height" << YAML::Value << in.height;
  out << YAML::Key << "camera_name" << YAML::Value << file.camera_name;
  EmitMatrix(out, "camera_matrix", in.CameraMatrix());
  out << YAML::Key << "distortion_model" << YAML::Value << vision::LensModelName(in.lens);
  EmitMatrix(out, "distortion_coefficients", in.DistortionCoeffs());
  EmitMatrix(out, "rectification_matrix", cv::Mat::eye(3, 3, CV_64F));
  // A monocular camera: P = [K | 0] (no rectification, no stereo baseline).
  cv::Mat P = cv::Mat::zeros(3, 4, CV_64F);
  in.CameraMatrix().copyTo(P(cv::Rect(0, 0, 3, 3)));
  EmitMatrix(out, "projection_matrix", P);
  if (file.rms_reprojection_error_px)
    out << YAML::Key << "avg_reprojection_error" << YAML::Value << *file.rms_reprojection_error_px;
  if (!file.per_view_reprojection_errors_px.empty()) {
    EmitMatrix(out, "per_view_reprojection_errors",
               cv::Mat(file.per_view_reprojection_errors_px, true));
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

Status WriteCameraFile(const std::string& path, const CameraFile& file, CameraFileFormat format) {
  std::string why;
  if (!file.intrinsics.IsValid(&why))
    return Status::Error(StatusCode::kInvalidArgument, path + ": not written: " + why);
  return WriteFileAtomically(path, FormatCameraFile(file, format));
}

Result<CameraFile> ReadCameraFile(const std::string& path) {
  return ReadFileAs<CameraFile>(path, [&](std::string* error) { return ReadCameraFileOrError(path, error); });
}

}  // namespace odocal::config
