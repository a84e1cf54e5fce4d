// End to end: `odocal detect` and `calibrate-camera --board aprilgrid` / a
// Kalibr target.yaml, on rendered tags with exact truth and on the 30 real
// aprilgrid frames (../shared/realdata/aprilgrid-d435i), and their bad input.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "odocal/config/camera_file.h"
#include "odocal/test_util/test_util.h"
#include "odocal/vision/renderer.h"

namespace odocal {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using test_util::CommandResult;
using test_util::RunCommand;

vision::CameraModel SmallCamera() {
  return vision::CameraModel(
      vision::Intrinsics{640, 480, 700.0, 700.0, 320.0, 240.0, {-0.12, 0.05, 0.0, 0.0, 0.0}},
      vision::CameraMount{0.0, 0.0, 1200.0, 0.0, 2.0, 0.0});
}

struct Rendered {
  std::string path;
  vision::RenderedFrame frame;
};

// One rendered frame of tag `family` id 5 (80 mm at 150 mm), as a PNG.
Rendered Render(const std::string& dir, const std::string& family, double x, double y, double heading) {
  vision::TagSpec tag;
  tag.family = family;
  tag.id = 5;
  tag.size_mm = 80.0;
  tag.height_mm = 150.0;
  vision::RenderOptions o;
  o.noise_sigma = 2.0;
  o.blur_sigma_px = 0.8;
  auto r = vision::Renderer::Create(SmallCamera(), tag, o);
  EXPECT_TRUE(r.ok()) << r.message;
  Rendered out{dir + "/" + family + ".png", r.renderer->Render(calibration::Pose2::FromXYHeading(x, y, heading))};
  EXPECT_TRUE(out.frame.tag_visible);
  EXPECT_TRUE(cv::imwrite(out.path, out.frame.image));
  return out;
}

std::string WriteCamera(const std::string& dir) {
  config::CameraFile file;
  file.intrinsics = SmallCamera().intrinsics();
  const std::string path = dir + "/camera.yaml";
  EXPECT_TRUE(config::WriteCameraFile(path, file, config::CameraFileFormat::kOpenCv).ok());
  return path;
}

fs::path AprilgridDir() {
  for (const fs::path& c : {fs::path(test_util::SourceDir()) / ".." / "shared" / "realdata" / "aprilgrid-d435i",
                            fs::path("/work/shared/realdata/aprilgrid-d435i")}) {
    if (fs::exists(c / "calib_mocap-intel_d435i.yaml")) return c;
  }
  return {};
}

std::vector<std::string> AprilgridFrames(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir / "cam0" / "data"))
    if (e.path().extension() == ".jpg") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& p : v) s += " " + p;
  return s;
}

TEST(CliDetect, KalibrTagCornersSigmaAndPoseAgainstRenderedTruth) {
  const std::string dir = test_util::MakeTempDir("odocal_detect_");
  const Rendered r = Render(dir, "tag36h11b2", 0.05, -0.03, 0.4);
  const std::string camera = WriteCamera(dir);
  const CommandResult c = RunCommand(test_util::OdocalBinary() + " detect " + r.path +
                                     " --tag tag36h11b2:5:80:150 --calibration " + camera + " --json " + dir +
                                     "/out.json --annotate " + dir + "/png");
  ASSERT_EQ(c.exit_code, 0) << c.err;
  EXPECT_THAT(c.out, HasSubstr("tag 5 found")) << c.out;
  std::ifstream in(dir + "/out.json");
  const nlohmann::json doc = nlohmann::json::parse(in);
  ASSERT_EQ(doc["images"].size(), 1u);
  const auto& image = doc["images"][0];
  EXPECT_EQ(image["file"], r.path);
  ASSERT_EQ(image["tags"].size(), 1u);
  const auto& tag = image["tags"][0];
  EXPECT_EQ(tag["id"], 5);
  EXPECT_EQ(tag["refined"], true);
  for (int k = 0; k < 4; ++k) {
    // Corner k is the renderer's corner k, OpenCV's convention.
    EXPECT_NEAR(tag["corners_px"][k][0].get<double>(), r.frame.corners_px[k].x, 0.06) << k;
    EXPECT_NEAR(tag["corners_px"][k][1].get<double>(), r.frame.corners_px[k].y, 0.06) << k;
    // The edge fits' sigma at 2 grey levels of noise on a ~46 px tag.
    const double s = tag["corner_sigma_px"][k].get<double>();
    EXPECT_GT(s, 0.002) << k;
    EXPECT_LT(s, 0.05) << k;
  }
  // The renderer draws the print exactly: the edge shift is measured and is
  // about nothing.
  ASSERT_TRUE(tag["edge_shift_px"].is_number()) << tag.dump();
  EXPECT_LT(std::abs(tag["edge_shift_px"].get<double>()), 0.03);
  EXPECT_GT(tag["edge_shift_sigma_px"].get<double>(), 0.0);
  // The pose in the camera frame against the scene's: T_camera_tag =
  // T_camera_world * T_world_tag (the tag face up at 150 mm).
  Eigen::Isometry3d T_world_tag = Eigen::Isometry3d::Identity();
  T_world_tag.translate(Eigen::Vector3d(r.frame.T_world_tag.x(), r.frame.T_world_tag.y(), 0.150));
  T_world_tag.rotate(Eigen::AngleAxisd(r.frame.T_world_tag.heading(), Eigen::Vector3d::UnitZ()));
  const Eigen::Vector3d t_true = (SmallCamera().T_camera_world() * T_world_tag).translation();
  const auto& pose = tag["pose_in_camera"];
  for (int i = 0; i < 3; ++i) {
    const double sigma_m = pose["sigma_translation_mm"][i].get<double>() * 1e-3;
    EXPECT_GT(sigma_m, 0.0);
    // Within 1 mm and within 5 sigma (a 4-corner pose: depth is the weak axis).
    EXPECT_NEAR(pose["translation_m"][i].get<double>(), t_true[i], std::min(1e-3, 5 * sigma_m + 2e-4)) << i;
  }
  EXPECT_LT(pose["rms_residual_px"].get<double>(), 0.1);
  EXPECT_TRUE(fs::exists(dir + "/png/tag36h11b2.png"));

  // A video: each frame, numbered (ffmpeg makes a 3-frame H.264 clip).
  if (RunCommand("ffmpeg -loglevel error -y -loop 1 -i " + r.path + " -frames:v 3 -r 10 -pix_fmt yuv420p " + dir +
                 "/clip.mp4").exit_code != 0)
    GTEST_SKIP() << "no ffmpeg program: the video part is not run";
  const CommandResult v = RunCommand(test_util::OdocalBinary() + " detect " + dir + "/clip.mp4 --tag tag36h11b2:5:80 --json - --annotate " + dir + "/vpng");
  ASSERT_EQ(v.exit_code, 0) << v.err;
  const nlohmann::json video = nlohmann::json::parse(v.out);
  ASSERT_EQ(video["images"].size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(video["images"][i]["frame"], i);
    ASSERT_EQ(video["images"][i]["tags"].size(), 1u);
    // Through H.264 the corners stay within a tenth of a pixel.
    EXPECT_NEAR(video["images"][i]["tags"][0]["corners_px"][0][0].get<double>(), r.frame.corners_px[0].x, 0.1);
  }
  EXPECT_TRUE(fs::exists(dir + "/vpng/clip_000002.png"));
}

// A machine-vision camera's 10- and 12-bit frames, stored as 16-bit PNG:
// read by their sensor's full scale (OpenCV's own 8-bit reading keeps the top
// byte: values 0-15, no tag), the corners where the 8-bit frame puts them.
TEST(CliDetect, TwelveBitFramesInSixteenBitFilesAreReadByTheirFullScale) {
  const std::string dir = test_util::MakeTempDir("odocal_detect_");
  const Rendered r = Render(dir, "tag36h11b2", -0.04, 0.02, -0.7);
  for (const auto& [bits, file] : {std::pair{10, "/deep10.png"}, std::pair{12, "/deep12.png"}}) {
    cv::Mat deep;
    r.frame.image.convertTo(deep, CV_16U, std::ldexp(1.0, bits - 8));
    ASSERT_TRUE(cv::imwrite(dir + file, deep));
  }
  const CommandResult c = RunCommand(test_util::OdocalBinary() + " detect " + dir + "/deep10.png " + dir +
                                     "/deep12.png --tag tag36h11b2:5:80 --json -");
  ASSERT_EQ(c.exit_code, 0) << c.err;
  EXPECT_THAT(c.out, HasSubstr("read as a 12-bit sensor"));
  const nlohmann::json doc = nlohmann::json::parse(c.out.substr(c.out.find('{')));
  ASSERT_EQ(doc["images"].size(), 2u);
  for (int i = 0; i < 2; ++i) {
    const auto& image = doc["images"][i];
    EXPECT_THAT(image["read_as"].get<std::string>(), HasSubstr(i == 0 ? "10-bit sensor" : "12-bit sensor"));
    ASSERT_EQ(image["tags"].size(), 1u) << image.dump();
    for (int k = 0; k < 4; ++k) {
      EXPECT_NEAR(image["tags"][0]["corners_px"][k][0].get<double>(), r.frame.corners_px[k].x, 0.06) << k;
      EXPECT_NEAR(image["tags"][0]["corners_px"][k][1].get<double>(), r.frame.corners_px[k].y, 0.06) << k;
    }
  }
}

TEST(CliDetect, ABorderThatDoesNotMatchIsNotFoundAndShownAsRefused) {
  const std::string dir = test_util::MakeTempDir("odocal_detect_");
  const Rendered one_bit = Render(dir, "tag36h11", -0.05, 0.02, -0.7);
  const CommandResult c = RunCommand(test_util::OdocalBinary() + " detect " + one_bit.path +
                                     " --tag tag36h11b2:5:80 --json - --annotate " + dir + "/png");
  ASSERT_EQ(c.exit_code, 0) << c.err;
  const nlohmann::json doc = nlohmann::json::parse(c.out);
  const auto& image = doc["images"][0];
  EXPECT_TRUE(image["tags"].empty());
  // The quad libapriltag decoded as id 5 with the 2-bit layout, refused for
  // its border, with its corners where the tag is.
  bool shown = false;
  for (const auto& q : image["rejected_quads"]) {
    if (q["decoded_id"] != 5) continue;
    shown = true;
    EXPECT_THAT(q["reason"].get<std::string>(), HasSubstr("1 bit wide, not 2"));
    for (int k = 0; k < 4; ++k) {
      const double x = q["corners_px"][k][0], y = q["corners_px"][k][1];
      double nearest = 1e9;
      for (const auto& p : one_bit.frame.corners_px) nearest = std::min(nearest, std::hypot(x - p.x, y - p.y));
      EXPECT_LT(nearest, 1.0);
    }
  }
  EXPECT_TRUE(shown) << image.dump();
  EXPECT_TRUE(fs::exists(dir + "/png/tag36h11.png"));
  // With the right family it is found.
  const CommandResult ok = RunCommand(test_util::OdocalBinary() + " detect " + one_bit.path + " --tag tag36h11:5:80");
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_THAT(ok.out, HasSubstr("tag 5 found"));
}

TEST(CliDetect, BadInputIsOneLineExitTwoAndNothingWritten) {
  const std::string dir = test_util::MakeTempDir("odocal_detect_");
  const Rendered r = Render(dir, "tag36h11", 0.0, 0.0, 0.3);
  std::ofstream(dir + "/checkerboard.yaml") << "target_type: 'checkerboard'\ntargetCols: 6\ntargetRows: 7\n"
                                               "rowSpacingMeters: 0.06\ncolSpacingMeters: 0.06\n";
  // A lens model odocal does not know (an equidistant fisheye it does).
  std::ofstream(dir + "/unknown_lens.yaml") << "image_width: 640\nimage_height: 480\ncamera_name: c\n"
                                          "camera_matrix: {rows: 3, cols: 3, data: [700, 0, 320, 0, 700, 240, 0, 0, 1]}\n"
                                          "distortion_model: kannala_brandt_omni\n"
                                          "distortion_coefficients: {rows: 1, cols: 4, data: [0, 0, 0, 0]}\n";
  const std::string out = " --json " + dir + "/out.json --annotate " + dir + "/png";
  for (const auto& [args, message] : std::vector<std::pair<std::string, std::string>>{
           {" --board aprilgrid:6x6:88", "--board: expected chessboard:COLSxROWS:SQUARE_MM"},
           {" --board aprilgrid:6x6:88:0", "--board: expected"},
           {" --board " + dir + "/checkerboard.yaml",
            dir + "/checkerboard.yaml:1: target_type: 'checkerboard': only aprilgrid targets"},
           {" --tag tag36h11:5:80 --calibration " + dir + "/unknown_lens.yaml",
            "'kannala_brandt_omni' is not supported"},
           {" --tag tag36h11b3:5:80", "unknown tag family 'tag36h11b3'"},
           // A board named, none of it in view (4 tags needed in some image).
           {" --board aprilgrid:6x6:88:0.3", "no image of 1 shows 4 or more of its tag36h11b2 tags"},
       }) {
    const CommandResult c = RunCommand(test_util::OdocalBinary() + " detect " + r.path + args + out);
    EXPECT_EQ(c.exit_code, 2) << args << ": " << c.err;
    EXPECT_THAT(c.err, HasSubstr(message)) << args;
    EXPECT_EQ(std::count(c.err.begin(), c.err.end(), '\n'), 1) << c.err;
    EXPECT_FALSE(fs::exists(dir + "/out.json")) << args;
    EXPECT_FALSE(fs::exists(dir + "/png")) << args;
  }
}

TEST(CliDetect, RealAprilgridBoardPoseAndResiduals) {
  const fs::path data = AprilgridDir();
  if (data.empty()) GTEST_SKIP() << "../shared/realdata/aprilgrid-d435i not present";
  const std::string dir = test_util::MakeTempDir("odocal_detect_");
  const auto frames = AprilgridFrames(data);
  // The camera odocal calibrated from every other frame (sample_data/README.md
  // says how; calibrate-camera on all 30 is its own test below), then the
  // board's pose in three frames.
  const std::string camera = test_util::SourceDir() + "/sample_data/cameras/d435i_640x480.yaml";
  CommandResult c = RunCommand(test_util::OdocalBinary() + " detect " + frames[0] + " " + frames[10] + " " +
                               frames[20] + " --board aprilgrid:6x6:88:0.3 --calibration " + camera + " --json -");
  ASSERT_EQ(c.exit_code, 0) << c.err;
  const nlohmann::json doc = nlohmann::json::parse(c.out);
  ASSERT_EQ(doc["images"].size(), 3u);
  // The images are searched on one worker each; on one worker in all, the
  // same output in the same order.
  const CommandResult one = RunCommand(test_util::OdocalBinary() + " detect " + frames[0] + " " + frames[10] + " " +
                                       frames[20] + " --board aprilgrid:6x6:88:0.3 --calibration " + camera +
                                       " --json - --threads 1");
  ASSERT_EQ(one.exit_code, 0) << one.err;
  EXPECT_EQ(nlohmann::json::parse(one.out), doc);
  for (const auto& image : doc["images"]) {
    ASSERT_TRUE(image["board"]["usable"].get<bool>()) << image["file"];
    const auto& pose = image["board"]["pose_in_camera"];
    // 1.25-2.2 m away (README of the data).
    const double distance = std::hypot(pose["translation_m"][0].get<double>(), pose["translation_m"][1].get<double>(),
                                       pose["translation_m"][2].get<double>());
    EXPECT_GT(distance, 0.9) << image["file"];
    EXPECT_LT(distance, 2.6) << image["file"];
    // 0.33-0.62 px in these three (the last is one of the two frames that fit worst).
    EXPECT_LT(pose["rms_residual_px"].get<double>(), 1.0) << image["file"];
    // The corners' sigmas hold the image noise only; the board's residual is
    // several times that on real frames, and the covariance says so.
    EXPECT_GT(pose["chi2_per_dof"].get<double>(), 1.0) << image["file"];
    EXPECT_NEAR(pose["covariance_scale"].get<double>(), pose["chi2_per_dof"].get<double>(), 1e-9) << image["file"];
    std::printf("%s: board %d tags, %.3f m, rms %.3f px\n", image["file"].get<std::string>().c_str(),
                image["board"]["tags_used"].get<int>(), distance, pose["rms_residual_px"].get<double>());
    int with_residuals = 0;
    for (const auto& t : image["tags"]) {
      // One tag's 4 corners: too few degrees of freedom to rescale by.
      if (t.contains("pose_in_camera") && t["pose_in_camera"].is_object()) {
        EXPECT_NEAR(t["pose_in_camera"]["covariance_scale"].get<double>(), 1.0, 1e-12);
      }
      if (!t.contains("residuals_px")) continue;
      ++with_residuals;
      for (int k = 0; k < 4; ++k) EXPECT_LT(std::hypot(t["residuals_px"][k][0].get<double>(), t["residuals_px"][k][1].get<double>()), 2.5);
    }
    EXPECT_EQ(with_residuals, image["board"]["tags_used"].get<int>());
  }
}

TEST(CliCalibrateCamera, RealAprilgridFromKalibrTargetFile) {
  const fs::path data = AprilgridDir();
  if (data.empty()) GTEST_SKIP() << "../shared/realdata/aprilgrid-d435i not present";
  const std::string dir = test_util::MakeTempDir("odocal_calcam_april_");
  const auto frames = AprilgridFrames(data);
  const std::string target = (data / "calib_mocap-intel_d435i.yaml").string();
  // The yac/Kalibr file names the same board as the spec: the same tags and corners.
  const CommandResult a = RunCommand(test_util::OdocalBinary() + " detect " + frames[5] + " --board " + target + " --json -");
  const CommandResult b =
      RunCommand(test_util::OdocalBinary() + " detect " + frames[5] + " --board aprilgrid:6x6:88:0.3 --json -");
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  EXPECT_EQ(nlohmann::json::parse(a.out)["images"], nlohmann::json::parse(b.out)["images"]);

  const CommandResult c = RunCommand(test_util::OdocalBinary() + " calibrate-camera" + Join(frames) + " --board " +
                                     target + " --out " + dir + "/d435i.yaml --json --board-shape fit");
  ASSERT_EQ(c.exit_code, 0) << c.err;
  const nlohmann::json doc = nlohmann::json::parse(c.out);
  std::printf("real aprilgrid: %d views, %d corners, RMS %.4f px, fx %.2f fy %.2f cx %.2f cy %.2f k1 %.4f\n",
              doc["views_used"].get<int>(), doc["corners_used"].get<int>(), doc["rms_reprojection_error_px"].get<double>(),
              doc["fx"].get<double>(), doc["fy"].get<double>(), doc["cx"].get<double>(), doc["cy"].get<double>(),
              doc["distortion"][0].get<double>());
  // Frames with fewer than 4 tags exist (README); the rest are views.
  EXPECT_GE(doc["views_used"].get<int>(), 27);
  // Taken as flat 0.20 px (0.29 with the tags' own edges only, 0.42 before
  // the edge shift); yac's own corners give 0.294 (kalibr_tag_test.cc,
  // docs/vision.md). This board is not flat, and calibrated with each tag at
  // its lift (--board-shape fit) 0.162 px.
  const nlohmann::json& shape = doc["board_shape"];
  ASSERT_TRUE(shape.is_object()) << doc.dump();
  EXPECT_FALSE(shape["flat"].get<bool>());
  EXPECT_NEAR(shape["rms_lift_mm"].get<double>(), 0.5, 0.15);
  EXPECT_EQ(shape["tags"].size(), 36u);
  ASSERT_TRUE(shape["fitted"].get<bool>()) << shape.dump();
  const double as_flat = shape["rms_as_flat_px"].get<double>();
  EXPECT_LT(as_flat, 0.25);
  EXPECT_LT(doc["rms_reprojection_error_px"].get<double>(), as_flat - 0.02);
  // The second pass, the tags' edges through the first pass's lens: a D435i
  // bends them little, so the RMS barely moves (and must not grow).
  ASSERT_TRUE(doc["first_pass_rms_px"].is_number()) << doc.dump();
  EXPECT_LT(as_flat, doc["first_pass_rms_px"].get<double>() + 0.005);
  // A D435i colour camera at 640x480: fx ~ fy ~ 610 (yac's corners: 606.6, 610.0).
  EXPECT_NEAR(doc["fx"].get<double>(), 606.6, 0.01 * 606.6);
  EXPECT_NEAR(doc["fy"].get<double>(), 610.0, 0.01 * 610.0);
  EXPECT_NEAR(doc["cx"].get<double>(), 320.0, 25.0);
  EXPECT_NEAR(doc["cy"].get<double>(), 240.0, 25.0);
  // The frames hold the board all over the image: 55 of 64 cells.
  EXPECT_GE(doc["coverage"]["cells_covered"].get<int>(), 50) << doc["coverage"].dump();
  EXPECT_FALSE(doc["coverage"]["extrapolated"].get<bool>());
}

TEST(CliCalibrateCamera, AprilgridNotInViewIsBadInput) {
  const std::string dir = test_util::MakeTempDir("odocal_calcam_april_");
  const Rendered a = Render(dir, "tag36h11", 0.0, 0.0, 0.3);
  const Rendered b = Render(dir, "tag36h11b2", 0.1, 0.0, 0.3);
  const CommandResult c = RunCommand(test_util::OdocalBinary() + " calibrate-camera " + a.path + " " + b.path +
                                     " --board aprilgrid:6x6:88:0.3 --out " + dir + "/x.yaml");
  EXPECT_EQ(c.exit_code, 2) << c.err;
  EXPECT_THAT(c.err, HasSubstr("--board aprilgrid 6x6 (tag36h11b2, ids 0-35): no image of 2 shows 4 or more of its tags"));
  EXPECT_FALSE(fs::exists(dir + "/x.yaml"));
}

}  // namespace
}  // namespace odocal
