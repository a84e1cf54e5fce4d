// Camera files: round trips in both layouts, files written by OpenCV itself,
// and one-line errors that name the key.
#include <cmath>
#include <fstream>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "odocal/config/camera_file.h"
#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

using vision::Intrinsics;

// Relative closeness; the files carry 17 significant digits, so a round trip
// is exact up to the last bit and 1e-12 leaves a wide margin.
void ExpectSameIntrinsics(const Intrinsics& a, const Intrinsics& b, double rel = 1e-12) {
  auto near = [&](double x, double y, const char* what) {
    EXPECT_LE(std::abs(x - y), rel * std::max(1.0, std::abs(y))) << what << ": " << x << " vs " << y;
  };
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  near(a.fx, b.fx, "fx");
  near(a.fy, b.fy, "fy");
  near(a.cx, b.cx, "cx");
  near(a.cy, b.cy, "cy");
  for (int i = 0; i < 5; ++i) near(a.distortion[i], b.distortion[i], "distortion");
}

Intrinsics RandomIntrinsics(std::mt19937& rng) {
  std::uniform_real_distribution<double> f(300.0, 3000.0), c(0.3, 0.7), d(-0.3, 0.3), t(-1e-3, 1e-3);
  Intrinsics in;
  in.width = 640 + static_cast<int>(rng() % 1400);
  in.height = 480 + static_cast<int>(rng() % 700);
  in.fx = f(rng);
  in.fy = in.fx * (1.0 + t(rng));
  in.cx = in.width * c(rng);
  in.cy = in.height * c(rng);
  in.distortion = {d(rng), d(rng) * 0.3, t(rng), t(rng), d(rng) * 0.1};
  return in;
}

std::string WriteText(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

TEST(CameraIo, RoundTripsBothFormats) {
  std::mt19937 rng(11);
  const std::string dir = test_util::MakeTempDir("odocal_camio_");
  for (int trial = 0; trial < 20; ++trial) {
    config::CameraFile file;
    file.intrinsics = RandomIntrinsics(rng);
    file.camera_name = "overhead";
    file.rms_reprojection_error_px = 0.123456789;
    file.per_view_reprojection_errors_px = {0.1, 0.2, 0.15};
    for (config::CameraFileFormat format : {config::CameraFileFormat::kOpenCv, config::CameraFileFormat::kRos}) {
      SCOPED_TRACE(config::CameraFileFormatName(format));
      const std::string path = dir + "/camera.yaml";
      ASSERT_TRUE(config::WriteCameraFile(path, file, format).ok());
      const auto back = config::ReadCameraFile(path);
      ASSERT_TRUE(back) << back.message;
      EXPECT_EQ(back->format, format);  // auto-detected
      ExpectSameIntrinsics(back->intrinsics, file.intrinsics);
      ASSERT_TRUE(back->rms_reprojection_error_px);
      EXPECT_NEAR(*back->rms_reprojection_error_px, 0.123456789, 1e-15);
      ASSERT_EQ(back->per_view_reprojection_errors_px.size(), 3u);
      EXPECT_NEAR(back->per_view_reprojection_errors_px[1], 0.2, 1e-15);
      if (format == config::CameraFileFormat::kRos) {
        EXPECT_EQ(back->camera_name, "overhead");
      }
    }
  }
}

TEST(CameraIo, WritesTheRosCameraInfoLayout) {
  config::CameraFile file;
  file.intrinsics = Intrinsics{640, 480, 700.0, 701.0, 320.5, 239.5, {-0.12, 0.05, 0, 0, 0}};
  const std::string text = config::FormatCameraFile(file, config::CameraFileFormat::kRos);
  for (const char* key : {"image_width: 640", "image_height: 480", "camera_name: camera",
                          "camera_matrix:", "distortion_model: plumb_bob",
                          "distortion_coefficients:", "rectification_matrix:",
                          "projection_matrix:", "rows: 3", "cols: 4"}) {
    EXPECT_THAT(text, ::testing::HasSubstr(key)) << key << "\n" << text;
  }
}

// What an OpenCV program writes with cv::FileStorage, file and all.
TEST(CameraIo, ReadsFilesWrittenByCvFileStorage) {
  const std::string dir = test_util::MakeTempDir("odocal_camio_");
  const cv::Mat K = (cv::Mat_<double>(3, 3) << 812.3456789012345, 0, 633.25, 0, 811.5, 358.75, 0, 0, 1);
  // The calibration sample writes D as a 5x1 column, plus keys we ignore.
  const cv::Mat D = (cv::Mat_<double>(5, 1) << -0.2345678901234567, 0.0812, 1.5e-4, -2.5e-4, -0.012);
  const std::string path = dir + "/out_camera_data.yml";
  {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    fs << "calibration_time" << "Sat Nov 21 06:00:00 2026";
    fs << "nr_of_frames" << 14 << "image_width" << 1280 << "image_height" << 720;
    fs << "board_width" << 9 << "board_height" << 6 << "square_size" << 25.0;
    fs << "flags" << 0 << "fisheye_model" << 0;
    fs << "camera_matrix" << K << "distortion_coefficients" << D;
    fs << "avg_reprojection_error" << 0.25;
    const cv::Mat per_view = (cv::Mat_<float>(3, 1) << 0.2f, 0.3f, 0.25f);
    fs << "per_view_reprojection_errors" << per_view;
    fs << "extrinsic_parameters" << cv::Mat::zeros(3, 6, CV_64F);
    fs << "image_points" << cv::Mat::zeros(3, 54, CV_32FC2);  // written as an nd-matrix of 2-channel points
  }
  const auto file = config::ReadCameraFile(path);
  ASSERT_TRUE(file) << file.message;
  EXPECT_EQ(file->format, config::CameraFileFormat::kOpenCv);
  const auto expected = Intrinsics::FromCv(K, D, 1280, 720);
  ASSERT_TRUE(expected) << expected.message;
  ExpectSameIntrinsics(file->intrinsics, *expected);
  EXPECT_NEAR(*file->rms_reprojection_error_px, 0.25, 1e-12);

  // Older samples: capitalised keys, float matrices, 8 coefficients.
  const std::string old_path = dir + "/old.yml";
  {
    cv::FileStorage fs(old_path, cv::FileStorage::WRITE);
    cv::Mat Kf, D8 = cv::Mat::zeros(8, 1, CV_64F);
    K.convertTo(Kf, CV_32F);
    D.copyTo(D8(cv::Rect(0, 0, 1, 5)));
    fs << "image_width" << 1280 << "image_height" << 720 << "Camera_Matrix" << Kf
       << "Distortion_Coefficients" << D8;
  }
  const auto old_file = config::ReadCameraFile(old_path);
  ASSERT_TRUE(old_file) << old_file.message;
  ExpectSameIntrinsics(old_file->intrinsics, *expected, 1e-6);  // float precision

  // And the other way: OpenCV reads what we write.
  config::CameraFile ours;
  ours.intrinsics = *expected;
  const std::string ours_path = dir + "/ours.yaml";
  ASSERT_TRUE(config::WriteCameraFile(ours_path, ours, config::CameraFileFormat::kOpenCv).ok());
  cv::FileStorage fs(ours_path, cv::FileStorage::READ);
  cv::Mat K2, D2;
  fs["camera_matrix"] >> K2;
  fs["distortion_coefficients"] >> D2;
  EXPECT_LE(cv::norm(K2, K, cv::NORM_INF), 1e-12 * 812);
  EXPECT_LE(cv::norm(D2.reshape(1, 5), D, cv::NORM_INF), 1e-15);
  EXPECT_EQ(static_cast<int>(fs["image_width"]), 1280);
}

TEST(CameraIo, ReadsAHandWrittenRosFile) {
  const std::string dir = test_util::MakeTempDir("odocal_camio_");
  const std::string path = WriteText(dir, "ost.yaml", R"(image_width: 640
image_height: 480
camera_name: narrow_stereo
camera_matrix:
  rows: 3
  cols: 3
  data: [700.5, 0, 319.5, 0, 699.25, 239.5, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.1, 0.02, 0.001, -0.0005, 0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [700.5, 0, 319.5, 0, 0, 699.25, 239.5, 0, 0, 0, 1, 0]
)");
  const auto file = config::ReadCameraFile(path);
  ASSERT_TRUE(file) << file.message;
  EXPECT_EQ(file->format, config::CameraFileFormat::kRos);
  EXPECT_EQ(file->camera_name, "narrow_stereo");
  ExpectSameIntrinsics(file->intrinsics,
                       Intrinsics{640, 480, 700.5, 699.25, 319.5, 239.5, {-0.1, 0.02, 0.001, -0.0005, 0}});
  EXPECT_FALSE(file->rms_reprojection_error_px);
}

const char* kGood = R"(image_width: 640
image_height: 480
camera_matrix: {rows: 3, cols: 3, data: [700, 0, 320, 0, 700, 240, 0, 0, 1]}
distortion_model: plumb_bob
distortion_coefficients: {rows: 1, cols: 5, data: [-0.1, 0.02, 0, 0, 0]}
)";

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

TEST(CameraIo, MalformedFilesGiveOneLineNamingTheKey) {
  const std::string dir = test_util::MakeTempDir("odocal_camio_");
  std::string error;
  ASSERT_TRUE(config::ParseCameraFile(kGood, "camera.yaml"));
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "camera.yaml: empty file"},
      {"  \n# nothing\n", "camera.yaml: empty file"},
      {"camera_matrix: [1, 2\nimage_width: 3\n", "camera.yaml: not valid YAML"},
      {"just a string\n", "camera.yaml: expected a mapping"},
      {Replace(kGood, "image_width: 640\n", ""), "camera.yaml: image_width: missing"},
      {Replace(kGood, "image_height: 480", "image_height: tall"), "camera.yaml: image_height: expected an integer"},
      {Replace(kGood, "camera_matrix", "camera_matrx"), "camera.yaml: camera_matrix: missing"},
      {Replace(kGood, "rows: 3, cols: 3, data: [700, 0, 320, 0, 700, 240, 0, 0, 1]",
               "rows: 2, cols: 3, data: [700, 0, 320, 0, 700, 240]"),
       "camera.yaml: camera_matrix: expected a 3x3 matrix, got 2x3"},
      {Replace(kGood, "0, 0, 1]}", "0, 1]}"), "camera.yaml: camera_matrix: data has 8 values, rows x cols = 9"},
      {Replace(kGood, "700, 240", "700, abc"), "camera.yaml: camera_matrix: data[5]: 'abc' is not a finite number"},
      {Replace(kGood, "[700, 0, 320", "[-700, 0, 320"), "camera.yaml: camera_matrix: focal lengths"},
      {Replace(kGood, "{rows: 3, cols: 3, data:", "{rows: 3, data:"), "camera.yaml: camera_matrix: expected a matrix {rows, cols, data}"},
      {Replace(kGood, "distortion_coefficients", "distortion"), "camera.yaml: distortion_coefficients: missing"},
      {Replace(kGood, "rows: 1, cols: 5, data: [-0.1, 0.02, 0, 0, 0]", "rows: 1, cols: 3, data: [-0.1, 0.02, 0]"),
       "camera.yaml: distortion_coefficients: distortion must have 4, 5 or more coefficients"},
      {Replace(kGood, "plumb_bob", "kannala"), "camera.yaml: distortion_model: 'kannala' is not supported"},
      {Replace(kGood, "plumb_bob", "equidistant"),
       "camera.yaml: distortion_coefficients: an equidistant (fisheye) lens has exactly 4 coefficients"},
  };
  for (const auto& [text, expected] : cases) {
    const std::string path = WriteText(dir, "camera.yaml", text);
    error = test_util::ErrorOf(config::ParseCameraFile(text, "camera.yaml"));
    EXPECT_EQ(error.rfind(expected, 0), 0u) << "got: " << error << "\nfor:\n" << text;
    EXPECT_THAT(error, ::testing::Not(::testing::HasSubstr("\n"))) << error;
    // The same through the file reader, which names the path it was given.
    error = test_util::ErrorOf(config::ReadCameraFile(path));
    EXPECT_EQ(error.rfind(path + ": ", 0), 0u) << error;
  }
  error = test_util::ErrorOf(config::ReadCameraFile(dir + "/missing.yaml"));
  EXPECT_EQ(error, dir + "/missing.yaml: cannot open file");
}

// Fisheye lenses (issue 24 §2): ROS camera_info `equidistant`, OpenCV's
// calibration sample's `fisheye_model: 1` with cv::fisheye's four
// coefficients, Kalibr's camchain `pinhole-equi` and `pinhole-radtan`; both
// written layouts read back as the same lens.
TEST(CameraIo, ReadsAndWritesFisheyeLensesInEveryLayout) {
  Intrinsics fisheye{1280, 800, 420.5, 421.25, 641.5, 398.25, {-0.02, 0.004, -0.0015, 0.0002, 0.0}};
  fisheye.lens = vision::LensModel::kEquidistant;
  for (const auto format : {config::CameraFileFormat::kOpenCv, config::CameraFileFormat::kRos}) {
    config::CameraFile file;
    file.intrinsics = fisheye;
    const std::string text = config::FormatCameraFile(file, format);
    std::string error;
    const auto back = config::ParseCameraFile(text, "fisheye.yaml");
    ASSERT_TRUE(back) << error << "\n" << text;
    EXPECT_EQ(back->intrinsics.lens, vision::LensModel::kEquidistant) << text;
    ExpectSameIntrinsics(back->intrinsics, fisheye);
  }
  // What OpenCV's own FileStorage writes for cv::fisheye, with the sample's flag.
  cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  fs << "image_width" << 1280 << "image_height" << 800 << "camera_matrix" << fisheye.CameraMatrix()
     << "distortion_coefficients" << fisheye.DistortionCoeffs() << "fisheye_model" << 1;
  std::string error;
  auto opencv = config::ParseCameraFile(fs.releaseAndGetString(), "opencv.yaml");
  ASSERT_TRUE(opencv) << opencv.message;
  EXPECT_EQ(opencv->intrinsics.lens, vision::LensModel::kEquidistant);
  ExpectSameIntrinsics(opencv->intrinsics, fisheye);
  // Kalibr's camchain.yaml, as kalibr_calibrate_cameras writes it.
  const std::string camchain = R"(cam0:
  cam_overlaps: []
  camera_model: pinhole
  distortion_coeffs: [-0.02, 0.004, -0.0015, 0.0002]
  distortion_model: equidistant
  intrinsics: [420.5, 421.25, 641.5, 398.25]
  resolution: [1280, 800]
  rostopic: /cam0/image_raw
)";
  auto kalibr = config::ParseCameraFile(camchain, "camchain.yaml");
  ASSERT_TRUE(kalibr) << kalibr.message;
  EXPECT_EQ(kalibr->intrinsics.lens, vision::LensModel::kEquidistant);
  ExpectSameIntrinsics(kalibr->intrinsics, fisheye);
  auto radtan = config::ParseCameraFile(Replace(camchain, "equidistant", "radtan"), "camchain.yaml");
  ASSERT_TRUE(radtan) << radtan.message;
  EXPECT_EQ(radtan->intrinsics.lens, vision::LensModel::kPlumbBob);
  EXPECT_DOUBLE_EQ(radtan->intrinsics.distortion[2], -0.0015);  // Kalibr's r1 is OpenCV's p1
  // Bad input names the key.
  error = test_util::ErrorOf(config::ParseCameraFile(Replace(camchain, "pinhole", "omni"), "camchain.yaml"));
  EXPECT_EQ(error.rfind("camchain.yaml: cam0.camera_model: 'omni' is not supported", 0), 0u) << error;
  error = test_util::ErrorOf(config::ParseCameraFile(Replace(camchain, "equidistant", "fov"), "camchain.yaml"));
  EXPECT_EQ(error.rfind("camchain.yaml: cam0.distortion_model: 'fov' is not supported", 0), 0u) << error;
  error = test_util::ErrorOf(config::ParseCameraFile(Replace(camchain, ", 0.0002]", "]"), "camchain.yaml"));
  EXPECT_EQ(error.rfind("camchain.yaml: cam0.distortion_coeffs: expected a list of 4 numbers", 0), 0u) << error;
}

// The ASL/EuRoC sensor.yaml, as EuRoC's mav0/cam0/sensor.yaml holds it.
TEST(CameraIo, ReadsTheEurocSensorYaml) {
  const std::string sensor = R"(# General sensor definitions.
sensor_type: camera
comment: VI-Sensor cam0 (MT9M034)
T_BS:
  cols: 4
  rows: 4
  data: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]
rate_hz: 20
resolution: [752, 480]
camera_model: pinhole
intrinsics: [458.654, 457.296, 367.215, 248.375] #fu, fv, cu, cv
distortion_model: radial-tangential
distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
)";
  std::string error;
  const auto file = config::ParseCameraFile(sensor, "sensor.yaml");
  ASSERT_TRUE(file) << file.message;
  const Intrinsics& in = file->intrinsics;
  EXPECT_EQ(in.lens, vision::LensModel::kPlumbBob);
  EXPECT_EQ(in.width, 752);
  EXPECT_EQ(in.height, 480);
  EXPECT_NEAR(in.fx, 458.654, 1e-12);
  EXPECT_NEAR(in.fy, 457.296, 1e-12);
  EXPECT_NEAR(in.cx, 367.215, 1e-12);
  EXPECT_NEAR(in.cy, 248.375, 1e-12);
  EXPECT_NEAR(in.distortion[0], -0.28340811, 1e-15);
  EXPECT_NEAR(in.distortion[3], 1.76187114e-05, 1e-18);  // radtan's r2 is OpenCV's p2
  EXPECT_NEAR(in.distortion[4], 0.0, 1e-18);
  const auto equi = config::ParseCameraFile(Replace(sensor, "radial-tangential", "equidistant"), "sensor.yaml");
  ASSERT_TRUE(equi) << equi.message;
  EXPECT_EQ(equi->intrinsics.lens, vision::LensModel::kEquidistant);
  // Bad input names the key.
  error = test_util::ErrorOf(config::ParseCameraFile(Replace(sensor, "[752, 480]", "[752]"), "sensor.yaml"));
  EXPECT_EQ(error, "sensor.yaml: camera.resolution: expected [width, height]");
  error = test_util::ErrorOf(config::ParseCameraFile(Replace(sensor, ", 1.76187114e-05]", "]"), "sensor.yaml"));
  EXPECT_EQ(error.rfind("sensor.yaml: camera.distortion_coefficients: expected a list of 4 numbers", 0), 0u) << error;
  error = test_util::ErrorOf(config::ParseCameraFile(Replace(sensor, "radial-tangential", "omni"), "sensor.yaml"));
  EXPECT_EQ(error.rfind("sensor.yaml: camera.distortion_model: 'omni' is not supported", 0), 0u) << error;
}

TEST(CameraIo, RefusesToWriteInvalidIntrinsicsAndLeavesNoPartialFile) {
  const std::string dir = test_util::MakeTempDir("odocal_camio_");
  config::CameraFile file;  // all zero: invalid
  const Status written = config::WriteCameraFile(dir + "/camera.yaml", file, config::CameraFileFormat::kOpenCv);
  ASSERT_FALSE(written.ok());
  EXPECT_EQ(written.status, StatusCode::kInvalidArgument);
  EXPECT_THAT(written.message, ::testing::HasSubstr("camera.yaml: not written")) << written.message;
  EXPECT_FALSE(std::ifstream(dir + "/camera.yaml").good());
}

}  // namespace
}  // namespace odocal
