// End to end: rendered chessboard photographs -> the real `odocal
// calibrate-camera` -> camera file and report, against the known camera.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "odocal/config/camera_file.h"
#include "odocal/test_util/test_util.h"
#include "odocal/vision/board_render.h"

namespace odocal {
namespace {

using test_util::CommandResult;
using test_util::RunCommand;
using vision::Intrinsics;

// 640x480, barrel distortion, slightly off-centre, non-square pixels.
Intrinsics Truth() {
  return Intrinsics{640, 480, 610.0, 606.0, 322.5, 237.25, {-0.21, 0.09, 6e-4, -4e-4, 0.0}};
}

// Writes `count` seeded views of a 9x6 (25 mm) chessboard as PNGs; returns their paths.
std::vector<std::string> WriteViews(const std::string& dir, int count, uint64_t seed) {
  const auto corners = vision::ChessboardCorners(9, 6, 0.025);
  vision::BoardPoseSampling sampling;
  sampling.count = count;
  sampling.seed = seed;
  const auto poses = vision::SampleBoardPoses(Truth(), corners, sampling);
  EXPECT_TRUE(poses);
  std::vector<std::string> paths;
  for (int i = 0; poses && i < count; ++i) {
    vision::BoardRenderOptions o;  // 2 grey levels of noise, 0.7 px blur
    o.seed = seed * 100 + i;
    const auto r = vision::RenderBoard(Truth(), vision::BoardPattern::Chessboard(9, 6, 0.025),
                                       (*poses)[i], corners, o);
    EXPECT_TRUE(r.ok()) << r.message;
    paths.push_back(dir + "/view" + std::to_string(i) + ".png");
    EXPECT_TRUE(cv::imwrite(paths.back(), r.frame.image));
  }
  return paths;
}

std::string WriteBlank(const std::string& dir) {
  cv::Mat blank(480, 640, CV_8U, cv::Scalar(110));
  cv::randn(blank, 110, 2);
  const std::string path = dir + "/no_board.png";
  EXPECT_TRUE(cv::imwrite(path, blank));
  return path;
}

std::string Join(const std::vector<std::string>& paths) {
  std::string out;
  for (const auto& p : paths) out += " " + p;
  return out;
}

// Kalibr's 6 x 6 aprilgrid (88 mm tags, spacing 0.3): its pattern and its
// corners in the pattern's frame, tag by tag.
struct KalibrGrid {
  vision::CalibrationBoard board;
  std::optional<vision::BoardPattern> pattern;
  std::vector<Eigen::Vector3d> points;
  KalibrGrid() {
    board.type = vision::CalibrationBoard::Type::kAprilgrid;
    board.cols = board.rows = 6;
    board.square_m = 0.088;
    board.spacing = 0.3;
    pattern = vision::AprilgridPattern(board).value;
    for (int id = 0; id < 36; ++id)
      for (int k = 0; k < 4; ++k)
        points.push_back(vision::AprilgridPointInPattern(board, *board.AprilgridCorner(id, k)));
  }
};

TEST(CliCalibrateCamera, RecoversTheRenderedCameraAndSkipsAnImageWithoutBoard) {
  const std::string dir = test_util::MakeTempDir("odocal_calcam_");
  std::vector<std::string> images = WriteViews(dir, 12, 1);
  images.insert(images.begin() + 5, WriteBlank(dir));
  const std::string out = dir + "/camera.yaml";
  const CommandResult r = RunCommand(test_util::OdocalBinary() + " calibrate-camera" + Join(images) +
                                     " --board chessboard:9x6:25 --out " + out + " --json --board-shape fit");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // The image without a board is named, on stderr and in the report.
  EXPECT_THAT(r.err, ::testing::HasSubstr("skipping " + dir + "/no_board.png: chessboard 9x6 not found"))
      << r.err;
  // A chessboard's shape is not measured: asked to fit it, it says so.
  EXPECT_THAT(r.err, ::testing::HasSubstr("--board-shape fit: a board's shape is measured on aprilgrids only"))
      << r.err;
  const nlohmann::json doc = nlohmann::json::parse(r.out);
  EXPECT_EQ(doc["views_used"], 12);
  ASSERT_EQ(doc["images"].size(), 13u);
  EXPECT_EQ(doc["images"][5]["path"], dir + "/no_board.png");
  EXPECT_EQ(doc["images"][5]["used"], false);
  EXPECT_EQ(doc["images"][0]["corners"], 54);

  // Measured (seed 1, this set-up): fx +0.005 px, fy +0.058, cx +0.12,
  // cy +0.06, k1 +0.0004, RMS 0.039 px; over 8 seeds the worst were 0.12,
  // 0.12, 0.17, 0.28 px and 0.0025 (camera_calibration_test). Bounds ~3x
  // that: 0.1 % on the focal lengths (the issue asks 0.5 %), 1 px on the
  // principal point, 0.006 on k1.
  const auto file = config::ReadCameraFile(out);
  ASSERT_TRUE(file) << file.message;
  EXPECT_EQ(file->format, config::CameraFileFormat::kOpenCv);
  const Intrinsics t = Truth();
  const Intrinsics& e = file->intrinsics;
  EXPECT_EQ(e.width, 640);
  EXPECT_EQ(e.height, 480);
  EXPECT_NEAR(e.fx, t.fx, 1e-3 * t.fx);
  EXPECT_NEAR(e.fy, t.fy, 1e-3 * t.fy);
  EXPECT_NEAR(e.cx, t.cx, 1.0);
  EXPECT_NEAR(e.cy, t.cy, 1.0);
  EXPECT_NEAR(e.distortion[0], t.distortion[0], 0.006);
  // The default --model auto keeps plumb_bob for a lens that is one.
  EXPECT_EQ(e.lens, vision::LensModel::kPlumbBob);
  ASSERT_TRUE(doc["model_choice"].is_object()) << r.out;
  EXPECT_EQ(doc["model_choice"]["chosen"], "plumb_bob");
  std::printf("figures: --model auto on a plumb_bob lens: %.4f px as plumb_bob, %.4f px as a fisheye\n",
              doc["model_choice"]["plumb_bob_rms_px"].get<double>(), doc["model_choice"]["fisheye_rms_px"].get<double>());
  // The report and the file agree, and carry the reprojection errors.
  EXPECT_NEAR(doc["fx"].get<double>(), e.fx, 1e-9 * e.fx);
  ASSERT_TRUE(file->rms_reprojection_error_px);
  EXPECT_LT(*file->rms_reprojection_error_px, 0.1);
  EXPECT_NEAR(doc["rms_reprojection_error_px"].get<double>(), *file->rms_reprojection_error_px, 1e-12);
  ASSERT_EQ(file->per_view_reprojection_errors_px.size(), 12u);
  EXPECT_NEAR(doc["images"][6]["rms_px"].get<double>(), file->per_view_reprojection_errors_px[5], 1e-12);
  // Views spread over the image: the lens is measured, not extrapolated.
  EXPECT_GT(doc["coverage"]["fraction"].get<double>(), 0.5) << doc["coverage"].dump();
  EXPECT_FALSE(doc["coverage"]["extrapolated"].get<bool>());
}

// The same camera with a sensor twice as wide and high, the views in its top
// left quarter (each pixel where it was: the same intrinsics). The corners
// then reach a quarter of the image at most, and calibrate-camera says that
// the lens is extrapolated over the rest, in the text and in the JSON.
TEST(CliCalibrateCamera, ViewsInOneQuarterOfTheImageAreNamedAsExtrapolated) {
  const std::string dir = test_util::MakeTempDir("odocal_calcam_quarter_");
  std::vector<std::string> images;
  for (const std::string& small : WriteViews(dir, 8, 3)) {
    cv::Mat big(960, 1280, CV_8U, cv::Scalar(110));
    cv::imread(small, cv::IMREAD_GRAYSCALE).copyTo(big(cv::Rect(0, 0, 640, 480)));
    images.push_back(small.substr(0, small.size() - 4) + "_big.png");
    ASSERT_TRUE(cv::imwrite(images.back(), big));
  }
  const std::string common = " calibrate-camera" + Join(images) + " --board chessboard:9x6:25 --model plumb_bob --out ";
  const CommandResult json = RunCommand(test_util::OdocalBinary() + common + dir + "/a.yaml --json");
  ASSERT_EQ(json.exit_code, 0) << json.err;
  const nlohmann::json c = nlohmann::json::parse(json.out)["coverage"];
  EXPECT_EQ(c["grid"], 8);
  EXPECT_LE(c["cells_covered"].get<int>(), 16) << c.dump();
  EXPECT_GE(c["cells_covered"].get<int>(), 8) << c.dump();
  EXPECT_LE(c["x_span"][1].get<double>(), 0.5);
  EXPECT_LE(c["y_span"][1].get<double>(), 0.5);
  EXPECT_TRUE(c["extrapolated"].get<bool>());
  const CommandResult text = RunCommand(test_util::OdocalBinary() + common + dir + "/b.yaml");
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, ::testing::HasSubstr("coverage: the corners reach " +
                                             std::to_string(c["cells_covered"].get<int>()) + " of 64 cells"));
  EXPECT_THAT(text.out, ::testing::HasSubstr("and extrapolated elsewhere"));
}

TEST(CliCalibrateCamera, FewerThanThreeUsableImagesFailWithoutWritingAFile) {
  const std::string dir = test_util::MakeTempDir("odocal_calcam_");
  std::vector<std::string> images = WriteViews(dir, 2, 2);
  images.push_back(WriteBlank(dir));
  images.push_back(dir + "/missing.png");
  const std::string out = dir + "/camera.yaml";
  const CommandResult r = RunCommand(test_util::OdocalBinary() + " calibrate-camera" + Join(images) +
                                     " --board chessboard:9x6:25 --out " + out + " --format ros");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, ::testing::HasSubstr("skipping " + dir + "/missing.png: no such file")) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("odocal calibrate-camera: only 2 of 4 images show the board; "
                                          "need at least 3 (no camera file written)"))
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(CliCalibrateCamera, WritesRosFilesAndRejectsBadArguments) {
  const std::string dir = test_util::MakeTempDir("odocal_calcam_");
  const std::vector<std::string> images = WriteViews(dir, 4, 3);
  const std::string out = dir + "/ost.yaml";
  CommandResult r = RunCommand(test_util::OdocalBinary() + " calibrate-camera" + Join(images) +
                               " --board chessboard:9x6:25 --out " + out +
                               " --format ros --camera-name overhead");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("RMS reprojection error")) << r.out;
  const auto file = config::ReadCameraFile(out);
  ASSERT_TRUE(file) << file.message;
  EXPECT_EQ(file->format, config::CameraFileFormat::kRos);
  EXPECT_EQ(file->camera_name, "overhead");

  for (const auto& [args, message] : std::vector<std::pair<std::string, std::string>>{
           {"--board chessboard:9x6", "--board: expected chessboard:COLSxROWS:SQUARE_MM"},
           {"--board chessboard:9by6:25", "--board: expected chessboard:COLSxROWS:SQUARE_MM"},
           {"--board chessboard:9x6:-25", "--board: expected chessboard:COLSxROWS:SQUARE_MM"},
           {"--board chessboard:9x6:25 --format xml", "--format: expected opencv or ros, got 'xml'"},
           // Refused by the command-line parser: exit 2 too, the bound readable.
           {"--board chessboard:9x6:25 --max-views -1", "--max-views: Value -1 not in range 0 to 1000000"},
           {"--board chessboard:9x6:25 --no-such-option", "--no-such-option"},
       }) {
    r = RunCommand(test_util::OdocalBinary() + " calibrate-camera" + Join(images) + " " + args +
                   " --out " + dir + "/x.yaml");
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_THAT(r.err, ::testing::HasSubstr(message)) << args << ": " << r.err;
  }

  // ChArUco: parsed, and chessboard photographs are skipped for want of
  // markers; or, in a build without OpenCV's aruco module, refused up front.
  r = RunCommand(test_util::OdocalBinary() + " calibrate-camera" + Join(images) +
                 " --board charuco:8x6:36:28:DICT_5X5_100 --out " + dir + "/x.yaml");
  if (r.exit_code == 2) {
    EXPECT_THAT(r.err, ::testing::HasSubstr("ChArUco boards are not available in this build")) << r.err;
  } else {
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_THAT(r.err, ::testing::HasSubstr("skipping " + images[0] + ": no DICT_5X5_100 markers found"))
        << r.err;
    r = RunCommand(test_util::OdocalBinary() + " calibrate-camera" + Join(images) +
                   " --board charuco:8x6:36:28:DICT_NOPE --out " + dir + "/x.yaml");
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_THAT(r.err, ::testing::HasSubstr("--board: unknown ArUco dictionary 'DICT_NOPE'")) << r.err;
  }
}

// A Kalibr/ROS data set keeps its frames in a folder (cam0/data): the folder
// stands for its images, other files ignored; the camera file's directory is
// made before the work; an empty folder or a folder named as the output is
// bad input, said before any detection.
TEST(CliCalibrateCamera, ADirectoryStandsForItsImagesAndTheOutDirectoryIsMade) {
  const std::string dir = test_util::MakeTempDir("odocal_calcam_dir_");
  std::filesystem::create_directories(dir + "/cam0/data");
  WriteViews(dir + "/cam0/data", 5, 4);
  { std::ofstream(dir + "/cam0/data/notes.txt") << "not an image\n"; }
  const std::string out = dir + "/results/today/camera.yaml";
  CommandResult r = RunCommand(test_util::OdocalBinary() + " calibrate-camera " + dir +
                               "/cam0/data --board chessboard:9x6:25 --out " + out + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json doc = nlohmann::json::parse(r.out);
  EXPECT_EQ(doc["views_used"], 5);
  EXPECT_TRUE(doc["view_choice"].is_null()) << "5 images, not more than --max-views: every view";
  ASSERT_EQ(doc["images"].size(), 5u);
  EXPECT_EQ(doc["images"][0]["path"], dir + "/cam0/data/view0.png");  // sorted by name
  EXPECT_TRUE(std::filesystem::exists(out));
  // The data set's top folder stands for the one folder below it with images;
  // with two such folders, both are named and the user picks one.
  r = RunCommand(test_util::OdocalBinary() + " calibrate-camera " + dir + " --board chessboard:9x6:25 --out " + dir +
                 "/top.yaml --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr(dir + ": reading the files in " + dir + "/cam0/data")) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["views_used"], 5);
  std::filesystem::create_directories(dir + "/mav0/cam1/data");
  WriteViews(dir + "/mav0/cam1/data", 1, 9);
  r = RunCommand(test_util::OdocalBinary() + " calibrate-camera " + dir + " --board chessboard:9x6:25 --out " + dir +
                 "/two.yaml");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr("in 2 folders below it (" + dir + "/cam0/data, " + dir +
                                          "/mav0/cam1/data): name one")) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/two.yaml"));

  std::filesystem::create_directories(dir + "/empty");
  r = RunCommand(test_util::OdocalBinary() + " calibrate-camera " + dir + "/empty --board chessboard:9x6:25 --out " +
                 dir + "/x.yaml");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr(dir + "/empty: a directory with no .png")) << r.err;
  r = RunCommand(test_util::OdocalBinary() + " calibrate-camera " + dir + "/cam0/data --board chessboard:9x6:25 --out " +
                 dir + "/results");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr("--out " + dir + "/results: is a directory")) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/x.yaml"));
}

// A fisheye: the default (--model auto) fits both models and takes the
// fisheye; named --model plumb_bob, the fit leaves pixels of error and the
// command says what the same views give as a fisheye. Rendered: Kalibr's
// aprilgrid through a 190-degree (TUM-VI-like) lens, 5 views.
// Five views of a Kalibr grid through a TUM-VI-like 190-degree fisheye,
// rendered once for the tests below (with each corner's true pixel).
class FisheyeViews : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = test_util::MakeTempDir("odocal_calcam_fisheye_");
    lens_ = Intrinsics{512, 512, 190.98, 190.97, 254.93, 256.90, {0.00348, 0.000715, -0.00205, 0.000203, 0.0}};
    lens_.lens = vision::LensModel::kEquidistant;
    const KalibrGrid grid;
    ASSERT_TRUE(grid.pattern);
    vision::FieldPoseSampling sampling;
    sampling.count = 5;
    sampling.seed = 5;
    sampling.max_off_axis_deg = 50.0;
    sampling.near_m = 0.4;
    sampling.far_m = 0.7;
    sampling.min_points_in_view = 144;
    const auto poses = vision::SampleFieldBoardPoses(lens_, grid.points, sampling);
    ASSERT_TRUE(poses);
    truth_.clear();
    for (size_t i = 0; i < poses->size(); ++i) {
      vision::BoardRenderOptions o;
      o.seed = 70 + i;
      o.supersample = 8;
      const auto r = vision::RenderBoard(lens_, *grid.pattern, (*poses)[i], grid.points, o);
      ASSERT_TRUE(r.ok()) << r.message;
      const std::string path = dir_ + "/view" + std::to_string(i) + ".png";
      ASSERT_TRUE(cv::imwrite(path, r.frame.image));
      truth_[path] = r.frame.points_px;
    }
  }
  static std::string dir_;
  static Intrinsics lens_;
  static std::map<std::string, std::vector<cv::Point2d>> truth_;  // image -> corner 4 id + k
};
std::string FisheyeViews::dir_;
Intrinsics FisheyeViews::lens_;
std::map<std::string, std::vector<cv::Point2d>> FisheyeViews::truth_;

TEST_F(FisheyeViews, AFisheyeIsChosenByDefaultAndNamedWhenFittedAsPlumbBob) {
  const std::string& dir = dir_;
  const Intrinsics& lens = lens_;
  const CommandResult chosen = RunCommand(test_util::OdocalBinary() + " calibrate-camera " + dir +
                                          " --board aprilgrid:6x6:88:0.3 --json --out " + dir + "/auto.yaml");
  ASSERT_EQ(chosen.exit_code, 0) << chosen.err;
  const nlohmann::json automatic = nlohmann::json::parse(chosen.out);
  EXPECT_EQ(automatic["distortion_model"], "equidistant");
  ASSERT_TRUE(automatic["model_choice"].is_object()) << chosen.out;
  EXPECT_EQ(automatic["model_choice"]["chosen"], "equidistant");
  EXPECT_EQ(automatic["model_choice"]["views_compared"], 5);
  EXPECT_GT(automatic["model_choice"]["plumb_bob_rms_px"].get<double>(), 1.0);
  EXPECT_LT(automatic["rms_reprojection_error_px"].get<double>(), 0.1);
  EXPECT_NEAR(automatic["fx"].get<double>(), lens.fx, 0.5);
  EXPECT_NEAR(automatic["cx"].get<double>(), lens.cx, 0.5);
  const auto camera = config::ReadCameraFile(dir + "/auto.yaml");
  ASSERT_TRUE(camera.ok()) << camera.message;
  EXPECT_EQ(camera.value->intrinsics.lens, vision::LensModel::kEquidistant);

  const CommandResult r = RunCommand(test_util::OdocalBinary() + " calibrate-camera " + dir +
                                     " --board aprilgrid:6x6:88:0.3 --model plumb_bob --json --out " + dir +
                                     "/camera.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json doc = nlohmann::json::parse(r.out);
  EXPECT_TRUE(doc["model_choice"].is_null());
  EXPECT_EQ(doc["distortion_model"], "plumb_bob");
  EXPECT_GT(doc["rms_reprojection_error_px"].get<double>(), 1.0);
  // Measured: plumb_bob 1.70 px, the same views as a fisheye 0.045 px.
  ASSERT_TRUE(doc["fisheye_rms_px"].is_number()) << r.out;
  EXPECT_LT(doc["fisheye_rms_px"].get<double>(), 0.1);
  const CommandResult text = RunCommand(test_util::OdocalBinary() + " calibrate-camera " + dir +
                                        " --board aprilgrid:6x6:88:0.3 --model plumb_bob --out " + dir + "/camera.yaml");
  EXPECT_THAT(text.out, ::testing::HasSubstr("this looks like a fisheye lens; calibrate again with --model fisheye"))
      << text.out;
}

// --max-views' quick look (libapriltag's corners alone) misses a board the
// full search finds: a far view of the grid at the fisheye's rim, where the
// quick look reads 3 tags and the full search 18. With fewer views seen than
// asked for, the images it saw nothing in are probed with the full search,
// and searched fully when a probe finds the board.
TEST_F(FisheyeViews, AViewTheQuickLookMissesIsFoundByTheFullSearch) {
  const KalibrGrid grid;
  vision::FieldPoseSampling sampling;  // rendered_lenses_bench's TUM-VI-like views
  sampling.count = 12;
  sampling.seed = 7;
  sampling.max_off_axis_deg = 60.0;
  sampling.near_m = 0.35;
  sampling.far_m = 0.9;
  const auto poses = vision::SampleFieldBoardPoses(lens_, grid.points, sampling);
  ASSERT_TRUE(poses);
  vision::BoardRenderOptions o;
  o.seed = 7000;
  o.supersample = 8;
  const auto r = vision::RenderBoard(lens_, *grid.pattern, (*poses)[2], grid.points, o);
  ASSERT_TRUE(r.ok()) << r.message;
  const std::string dir = test_util::MakeTempDir("odocal_calcam_quick_");
  std::string images;
  for (int i = 0; i < 5; ++i) images += " " + dir_ + "/view" + std::to_string(i) + ".png";
  for (const std::string name : {"/rim_a.png", "/rim_b.png"}) {
    ASSERT_TRUE(cv::imwrite(dir + name, r.frame.image));
    images += " " + dir + name;
  }
  // The quick look alone would not see it (checked here, so that the test
  // keeps testing the fallback).
  vision::BoardDetectionOptions quick;
  quick.aprilgrid_corners_only = true;
  ASSERT_FALSE(vision::DetectBoard(r.frame.image, grid.board, quick).found);
  ASSERT_TRUE(vision::DetectBoard(r.frame.image, grid.board).found);

  const CommandResult c = RunCommand(test_util::OdocalBinary() + " calibrate-camera" + images +
                                     " --board aprilgrid:6x6:88:0.3 --max-views 6 --json --out " + dir + "/cam.yaml");
  ASSERT_EQ(c.exit_code, 0) << c.err;
  EXPECT_THAT(c.err, ::testing::HasSubstr("the quick look (--max-views) missed the board")) << c.err;
  const nlohmann::json doc = nlohmann::json::parse(c.out);
  EXPECT_EQ(doc["view_choice"]["images_with_the_board"], 7) << doc["view_choice"].dump();
  EXPECT_EQ(doc["views_used"], 6);
  for (const auto& image : doc["images"])
    EXPECT_THAT(image.value("reason", ""), ::testing::Not(::testing::HasSubstr("quick look"))) << image.dump();
}

// detect --board without --calibration: a fisheye bends a tag's edges, so
// they are refined through a lens calibrated from the images themselves (as
// calibrate-camera's two passes do); --straight-edges refines them as lines.
TEST_F(FisheyeViews, DetectWithoutACalibrationRefinesTheBoardThroughALensFromTheImages) {
  const auto detect = [&](const std::string& extra) {
    const CommandResult r = RunCommand(test_util::OdocalBinary() + " detect " + dir_ +
                                       " --board aprilgrid:6x6:88:0.3 --json -" + extra);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return nlohmann::json::parse(r.out);
  };
  struct Score {
    int tags = 0;
    double rms_px = 0.0;
  };
  const auto score = [&](const nlohmann::json& doc) {
    Score s;
    double sum = 0.0;
    int n = 0;
    for (const auto& image : doc["images"]) {
      const auto& truth = truth_.at(image["file"].get<std::string>());
      for (const auto& t : image["tags"]) {
        if (!t["on_board"].get<bool>()) continue;
        ++s.tags;
        for (int k = 0; k < 4; ++k) {
          const cv::Point2d& p = truth[4 * t["id"].get<int>() + k];
          sum += std::pow(t["corners_px"][k][0].get<double>() - p.x, 2) + std::pow(t["corners_px"][k][1].get<double>() - p.y, 2);
          n += 2;
        }
      }
    }
    s.rms_px = std::sqrt(sum / std::max(n, 1));
    return s;
  };
  const nlohmann::json through = detect("");
  const nlohmann::json straight = detect(" --straight-edges");
  ASSERT_EQ(through["lens"]["source"], "images") << through["lens"].dump();
  EXPECT_EQ(through["lens"]["distortion_model"], "equidistant");
  EXPECT_NEAR(through["lens"]["fx"].get<double>(), lens_.fx, 1.0);
  EXPECT_EQ(straight["lens"]["source"], "none");
  EXPECT_EQ(straight["lens"]["why"], "--straight-edges");
  // No poses from a lens the user did not give.
  for (const auto& image : through["images"]) EXPECT_FALSE(image["board"].contains("pose_in_camera"));
  const Score a = score(through), b = score(straight);
  std::printf("[figure] fisheye detect without a calibration: through the images' lens %d tags, %.4f px rms; "
              "straight edges %d tags, %.4f px rms\n", a.tags, a.rms_px, b.tags, b.rms_px);
  EXPECT_GE(a.tags, b.tags);
  EXPECT_LT(a.rms_px, 0.06);
  EXPECT_LT(a.rms_px, b.rms_px);
  // One image cannot calibrate a lens: its edges are straight, and it says why.
  const CommandResult one = RunCommand(test_util::OdocalBinary() + " detect " + dir_ +
                                       "/view0.png --board aprilgrid:6x6:88:0.3 --json -");
  ASSERT_EQ(one.exit_code, 0) << one.err;
  const nlohmann::json lone = nlohmann::json::parse(one.out);
  EXPECT_EQ(lone["lens"]["source"], "none");
  EXPECT_THAT(lone["lens"]["why"].get<std::string>(), ::testing::HasSubstr("a lens needs 3"));
}

// A calibration video: mostly one pose again. With more images than
// --max-views, the aprilgrid is first only looked for, the views that differ
// are chosen and only those refined and calibrated. Rendered: 7 frames of
// one pose (fresh noise each), 4 other poses, one frame without the board.
TEST(CliCalibrateCamera, FromMoreImagesThanMaxViewsTheViewsThatDifferAreChosen) {
  const std::string dir = test_util::MakeTempDir("odocal_calcam_views_");
  const KalibrGrid grid;
  const auto& pattern = grid.pattern;
  ASSERT_TRUE(pattern);
  const std::vector<Eigen::Vector3d>& points = grid.points;
  vision::FieldPoseSampling sampling;
  sampling.count = 5;
  sampling.seed = 9;
  sampling.max_off_axis_deg = 20.0;
  sampling.near_m = 0.7;
  sampling.far_m = 1.0;
  sampling.min_points_in_view = 144;
  const auto poses = vision::SampleFieldBoardPoses(Truth(), points, sampling);
  ASSERT_TRUE(poses);
  // Frames 00-06: pose 0; frames 07-10: poses 1-4; frame 11: no board.
  std::vector<int> pose_of = {0, 0, 0, 0, 0, 0, 0, 1, 2, 3, 4};
  for (size_t i = 0; i < pose_of.size(); ++i) {
    vision::BoardRenderOptions o;
    o.seed = 300 + i;
    o.supersample = 4;
    const auto r = vision::RenderBoard(Truth(), *pattern, (*poses)[pose_of[i]], points, o);
    ASSERT_TRUE(r.ok()) << r.message;
    ASSERT_TRUE(cv::imwrite(dir + "/frame" + (i < 10 ? "0" : "") + std::to_string(i) + ".png", r.frame.image));
  }
  std::filesystem::copy_file(WriteBlank(dir), dir + "/frame11.png");
  std::filesystem::remove(dir + "/no_board.png");

  const CommandResult r = RunCommand(test_util::OdocalBinary() + " calibrate-camera " + dir +
                                     " --board aprilgrid:6x6:88:0.3 --model plumb_bob --max-views 5 --json --out " +
                                     dir + "/camera.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json doc = nlohmann::json::parse(r.out);
  ASSERT_TRUE(doc["view_choice"].is_object()) << r.out;
  EXPECT_EQ(doc["view_choice"]["images_with_the_board"], 11);
  EXPECT_EQ(doc["view_choice"]["chosen"], 5);
  EXPECT_EQ(doc["views_used"], 5);
  ASSERT_EQ(doc["images"].size(), 12u);
  int same_pose_used = 0;
  for (size_t i = 0; i < 12; ++i) {
    const nlohmann::json& image = doc["images"][i];
    if (i >= 7 && i <= 10) {
      EXPECT_TRUE(image["used"].get<bool>()) << "a pose seen once: " << image.dump();
    } else if (i < 7 && image["used"].get<bool>()) {
      ++same_pose_used;
    } else if (i < 7) {
      EXPECT_THAT(image["reason"].get<std::string>(), ::testing::HasSubstr("--max-views")) << image.dump();
    }
  }
  EXPECT_EQ(same_pose_used, 1);
  EXPECT_FALSE(doc["images"][11]["used"].get<bool>());
  // Five views that differ: the focal length within a pixel.
  EXPECT_NEAR(doc["fx"].get<double>(), Truth().fx, 1.0);  // 609.97
  EXPECT_LT(doc["rms_reprojection_error_px"].get<double>(), 0.1);
}

}  // namespace
}  // namespace odocal
