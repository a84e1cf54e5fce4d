// Renderer: ground truth, area-correct anti-aliasing, noise, motion blur,
// frames without the robot, and the H.264 video round trip.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "odocal/media/video.h"
#include "odocal/test_util/test_util.h"
#include "odocal/vision/renderer.h"
#include "vision_fixtures.h"

namespace odocal::media {

// GoogleTest prints a writer backend by its name (found by argument-dependent
// lookup in the enum's namespace).
const char* BackendName(Mp4WriterOptions::Backend backend) {
  return backend == Mp4WriterOptions::Backend::kOpenCv ? "OpenCv" : "FfmpegCli";
}
void PrintTo(Mp4WriterOptions::Backend backend, std::ostream* os) { *os << BackendName(backend); }

}  // namespace odocal::media

namespace odocal::vision {
namespace {

using calibration::Pose2;

std::unique_ptr<Renderer> MakeRenderer(const CameraModel& cam, const TagSpec& tag,
                                       const RenderOptions& options) {
  auto r = Renderer::Create(cam, tag, options);
  EXPECT_TRUE(r.ok()) << r.message;
  return std::move(r.renderer);
}

TEST(Renderer, TruthCornersAreTheProjectedTagCorners) {
  const CameraModel cam = testing::SmallCamera();
  auto renderer = MakeRenderer(cam, testing::StandardTag(), testing::StandardRender());
  const Pose2 pose = Pose2::FromXYHeading(0.05, -0.03, 0.7);
  const RenderedFrame f = renderer->Render(pose);
  EXPECT_TRUE(f.tag_visible);
  const auto model = TagCornersInTag(0.08);
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d p = pose * model[k];
    const auto px = cam.ProjectWorld(Eigen::Vector3d(p.x(), p.y(), 0.15));
    EXPECT_NEAR(f.corners_px[k].x, px->x(), 1e-9);
    EXPECT_NEAR(f.corners_px[k].y, px->y(), 1e-9);
  }
  // Pixel convention: the tag centre (mean of the corners, exact here up to
  // perspective) is dark-or-light tag, and far outside it is floor/body.
  EXPECT_EQ(f.image.type(), CV_8UC1);
  EXPECT_EQ(f.image.size(), cv::Size(640, 480));
}

// The tag's black cells in a frame of the straight-down camera below: the 28
// of the border ring plus the data bits that are black, read at the cell
// centres (8 px cells: no ambiguity there).
int BlackCells(const RenderedFrame& f) {
  const auto c = f.corners_px;
  int black_cells = 28;  // the border ring: 8*8 - 6*6
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) {
      // Bilinear in the (undistorted, similarity) image: cell centre.
      const double s = (i + 1.5) / 8.0, t = (j + 1.5) / 8.0;
      const cv::Point2d bottom = c[0] + (c[1] - c[0]) * s, top = c[3] + (c[2] - c[3]) * s;
      const cv::Point2d p = bottom + (top - bottom) * t;
      black_cells += f.image.at<uint8_t>(cvRound(p.y), cvRound(p.x)) < 125 ? 1 : 0;
    }
  }
  return black_cells;
}

// The integral of "blackness" over the image equals the black area of the
// tag in pixels: anti-aliasing is area-correct, not just pretty.
TEST(Renderer, EdgeAntiAliasingIsAreaCorrect) {
  // No distortion, straight down: the plane maps to the image by a similarity.
  const CameraModel cam(Intrinsics{400, 400, 800.0, 800.0, 200.0, 200.0, {0, 0, 0, 0, 0}},
                        CameraMount{0, 0, 1150.0, 0, 0, 0});
  RenderOptions o;
  o.noise_sigma = 0.0;
  o.blur_sigma_px = 0.0;
  o.body_radius_mm = 0.0;     // white plate on the floor...
  o.plate_margin_mm = 400.0;  // ...that fills the whole view
  TagSpec tag = testing::StandardTag();
  auto renderer = MakeRenderer(cam, tag, o);
  const double scale_px_per_m = 800.0 / 1.0;  // 1150 - 150 mm above the tag plane
  for (double heading : {0.0, 0.3, 1.1}) {
    // The pixels the cells' edges cross inside the plate are integrated in
    // closed form (each pixel's quadrilateral clipped by the cell lines), so
    // one frame must be area-correct to the 8-bit rounding of its ~1000 edge
    // pixels (~1.5e-5 of the black area). The stratified samples these
    // pixels had before missed by 1-2e-4 a frame, unbiased over frames.
    const RenderedFrame f = renderer->Render(Pose2::FromXYHeading(0.0031, -0.0017, heading));
    cv::Mat fl;
    f.image.convertTo(fl, CV_64F);
    // Blackness in [0, 1] per pixel.
    const double blackness = cv::sum((o.tag_white - fl) / (o.tag_white - o.tag_black))[0];
    const double cell_px = 0.010 * scale_px_per_m;
    const double expected = BlackCells(f) * cell_px * cell_px;
    // Measured: one sample per pixel misses by 2e-3, 2x2 by 3e-4; 16x16 edge
    // pixels with a fixed grid agree to < 1e-4 in total area but are biased
    // edge by edge; the shifted grid is unbiased, 1-2e-4 per frame; the
    // closed form 2e-15, 1.5e-5 and 1.9e-6 at these three headings.
    EXPECT_NEAR(blackness / expected, 1.0, 5e-5) << "heading " << heading;
  }
}

TEST(Renderer, NoiseHasTheRequestedSigmaAndIsSeeded) {
  const CameraModel cam = testing::SmallCamera();
  RenderOptions o = testing::StandardRender();
  o.noise_sigma = 3.0;
  auto a = MakeRenderer(cam, testing::StandardTag(), o);
  auto b = MakeRenderer(cam, testing::StandardTag(), o);
  const Pose2 far = Pose2::FromXYHeading(50.0, 50.0, 0.0);  // robot out of view
  const RenderedFrame fa = a->Render(far), fb = b->Render(far);
  EXPECT_FALSE(fa.tag_visible);
  EXPECT_EQ(cv::norm(fa.image, fb.image, cv::NORM_INF), 0.0);  // same seed, same frame
  cv::Mat diff;
  fa.image.convertTo(diff, CV_64F);
  diff -= a->background();
  cv::Scalar mean, stddev;
  cv::meanStdDev(diff, mean, stddev);
  EXPECT_NEAR(stddev[0], std::sqrt(3.0 * 3.0 + 1.0 / 12.0), 0.1);  // noise + rounding
  EXPECT_NEAR(mean[0], 0.0, 0.05);
  // Successive frames get different noise.
  const RenderedFrame fa2 = a->Render(far);
  EXPECT_GT(cv::norm(fa.image, fa2.image, cv::NORM_L1) / fa.image.total(), 1.0);
  o.seed = 2;
  auto c = MakeRenderer(cam, testing::StandardTag(), o);
  EXPECT_GT(cv::norm(fa.image, c->Render(far).image, cv::NORM_L1) / fa.image.total(), 1.0);
}

TEST(Renderer, RobotOutsideTheViewGivesAFloorOnlyFrame) {
  const CameraModel cam = testing::SmallCamera();
  RenderOptions o = testing::StandardRender();
  o.noise_sigma = 0.0;
  auto renderer = MakeRenderer(cam, testing::StandardTag(), o);
  // Half out: corners outside the image, no crash, not "visible".
  const RenderedFrame edge = renderer->Render(Pose2::FromXYHeading(0.0, 0.55, 0.0));
  EXPECT_FALSE(edge.tag_visible);
  const RenderedFrame gone = renderer->Render(Pose2::FromXYHeading(-5.0, 3.0, 1.0));
  EXPECT_FALSE(gone.tag_visible);
  cv::Mat bg8;
  renderer->background().convertTo(bg8, CV_8U);
  EXPECT_EQ(cv::norm(gone.image, bg8, cv::NORM_INF), 0.0);
}

TEST(Renderer, MotionBlurAveragesSubFramePoses) {
  const CameraModel cam = testing::SmallCamera();
  RenderOptions o = testing::StandardRender();
  o.noise_sigma = 0.0;
  o.exposure_s = 0.004;
  auto renderer = MakeRenderer(cam, testing::StandardTag(), o);
  // 0.5 m/s along x: 2 mm in 4 ms, ~1.3 px in this camera.
  auto moving = [](double t) { return Pose2::FromXYHeading(-0.05 + 0.5 * t, 0.01, 0.2 + 0.3 * t); };
  const RenderedFrame blurred = renderer->RenderExposure(moving, 0.1);
  EXPECT_GT(blurred.motion_substeps, 3);
  EXPECT_NEAR(blurred.T_world_robot.x(), 0.0, 1e-12);  // truth at mid-exposure
  const RenderedFrame sharp = renderer->Render(moving(0.1));
  EXPECT_EQ(sharp.motion_substeps, 1);
  const double diff = cv::norm(blurred.image, sharp.image, cv::NORM_L1);
  EXPECT_GT(diff, 1000.0);  // the edges are smeared...
  // ...but only near the robot: far pixels are identical.
  EXPECT_EQ(cv::norm(blurred.image(cv::Rect(0, 0, 60, 60)), sharp.image(cv::Rect(0, 0, 60, 60)),
                     cv::NORM_INF),
            0.0);
  // A standing robot gets one pose even with an exposure.
  const RenderedFrame still = renderer->RenderExposure([](double) { return Pose2(); }, 0.0);
  EXPECT_EQ(still.motion_substeps, 1);
}

TEST(Renderer, RejectsInvalidInput) {
  TagSpec bad_tag = testing::StandardTag();
  bad_tag.family = "tag99h99";
  auto r = Renderer::Create(testing::SmallCamera(), bad_tag, RenderOptions{});
  EXPECT_FALSE(r.ok());
  EXPECT_THAT(r.message, ::testing::HasSubstr("family"));
  TagSpec big_id = testing::StandardTag();
  big_id.id = 100000;
  EXPECT_FALSE(Renderer::Create(testing::SmallCamera(), big_id, RenderOptions{}).ok());
  RenderOptions o;
  o.noise_sigma = -1;
  EXPECT_FALSE(Renderer::Create(testing::SmallCamera(), testing::StandardTag(), o).ok());
}

class Video : public ::testing::TestWithParam<media::Mp4WriterOptions::Backend> {};

TEST_P(Video, H264RoundTripWithTimestamps) {
  const std::string dir = test_util::MakeTempDir("odocal_vision_video");
  media::Mp4WriterOptions wo;
  wo.backend = GetParam();
  const std::string path = dir + "/clip.mp4";
  const CameraModel cam(Intrinsics{320, 240, 350.0, 350.0, 160.0, 120.0, {0, 0, 0, 0, 0}},
                        CameraMount{0, 0, 1000.0, 0, 0, 0});
  auto renderer = MakeRenderer(cam, testing::StandardTag(), testing::StandardRender());
  media::Mp4Writer writer;
  const Status opened = writer.Open(path, 30.0, cv::Size(320, 240), wo);
  if (!opened.ok() && GetParam() == media::Mp4WriterOptions::Backend::kFfmpegCli &&
      opened.message.find("cannot run the ffmpeg program") != std::string::npos) {
    GTEST_SKIP() << opened.message;  // the ffmpeg program is optional
  }
  ASSERT_TRUE(opened.ok()) << opened.message;
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 10; ++i) {
    frames.push_back(renderer->Render(Pose2::FromXYHeading(0.01 * i, 0.0, 0.1 * i)).image);
    ASSERT_TRUE(writer.Write(frames.back(), i / 30.0).ok());
  }
  EXPECT_FALSE(writer.Write(cv::Mat(10, 10, CV_8U), 1.0).ok());  // wrong size
  const Status closed = writer.Close();
  ASSERT_TRUE(closed.ok()) << closed.message;
  ASSERT_TRUE(writer.WriteTimestamps(dir + "/clip.timestamps.csv").ok());
  std::ifstream ts(dir + "/clip.timestamps.csv");
  int lines = 0;
  for (std::string line; std::getline(ts, line);) ++lines;
  EXPECT_EQ(lines, 11);

  media::VideoReader reader;
  const Status read_open = reader.Open(path);
  ASSERT_TRUE(read_open.ok()) << read_open.message;
  EXPECT_NEAR(reader.fps(), 30.0, 0.01);
  int n = 0;
  cv::Mat grey;
  while (reader.Read(&grey)) {
    ASSERT_LT(n, 10);
    EXPECT_EQ(grey.type(), CV_8UC1);
    // Lossy, but close: the mean absolute difference stays within a few levels.
    EXPECT_LT(cv::norm(grey, frames[n], cv::NORM_L1) / grey.total(), 4.0) << "frame " << n;
    ++n;
  }
  EXPECT_EQ(n, 10);
  std::filesystem::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Backends, Video,
                         ::testing::Values(media::Mp4WriterOptions::Backend::kOpenCv,
                                           media::Mp4WriterOptions::Backend::kFfmpegCli),
                         [](const ::testing::TestParamInfo<media::Mp4WriterOptions::Backend>& info) {
                           return std::string(media::BackendName(info.param));
                         });

// Two ffmpeg writers open at once, closed one after the other: the second
// child must not hold the first one's socket (before close-on-exec it did,
// and the first Close waited for ever: a deadlock of parallel recording).
TEST(VideoFiles, ConcurrentFfmpegWritersEachFinish) {
  const std::string dir = test_util::MakeTempDir("odocal_vision_two_writers");
  media::Mp4WriterOptions wo;
  wo.backend = media::Mp4WriterOptions::Backend::kFfmpegCli;
  media::Mp4Writer a, b;
  const Status opened_a = a.Open(dir + "/a.mp4", 30.0, cv::Size(64, 48), wo);
  if (!opened_a.ok() && opened_a.message.find("cannot run the ffmpeg program") != std::string::npos)
    GTEST_SKIP() << opened_a.message;
  ASSERT_TRUE(opened_a.ok()) << opened_a.message;
  ASSERT_TRUE(b.Open(dir + "/b.mp4", 30.0, cv::Size(64, 48), wo).ok());
  const cv::Mat grey(48, 64, CV_8U, cv::Scalar(128));
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(a.Write(grey, i / 30.0).ok());
    ASSERT_TRUE(b.Write(grey, i / 30.0).ok());
  }
  ASSERT_TRUE(a.Close().ok());
  ASSERT_TRUE(b.Close().ok());
  for (const char* name : {"/a.mp4", "/b.mp4"}) {
    media::VideoReader reader;
    ASSERT_TRUE(reader.Open(dir + name).ok()) << name;
    cv::Mat frame;
    int frames = 0;
    while (reader.Read(&frame)) ++frames;
    EXPECT_EQ(frames, 5) << name;
  }
}

TEST(VideoFiles, BadFilesGiveAClearStatus) {
  const std::string dir = test_util::MakeTempDir("odocal_vision_badvideo");
  media::VideoReader missing;
  Status s = missing.Open(dir + "/nope.mp4");
  EXPECT_FALSE(s.ok());
  EXPECT_THAT(s.message, ::testing::HasSubstr("does not exist"));
  cv::Mat frame;
  EXPECT_FALSE(missing.Read(&frame));

  { std::ofstream(dir + "/empty.mp4"); }
  media::VideoReader empty;
  s = empty.Open(dir + "/empty.mp4");
  EXPECT_FALSE(s.ok());
  EXPECT_THAT(s.message, ::testing::HasSubstr("empty"));

  {
    std::ofstream junk(dir + "/junk.mp4", std::ios::binary);
    std::mt19937 rng(5);
    for (int i = 0; i < 20000; ++i) junk.put(static_cast<char>(rng() & 0xFF));
  }
  media::VideoReader corrupt;
  s = corrupt.Open(dir + "/junk.mp4");
  EXPECT_FALSE(s.ok());
  EXPECT_FALSE(s.message.empty());
  EXPECT_FALSE(corrupt.Read(&frame));

  media::Mp4Writer writer;
  EXPECT_FALSE(writer.Open(dir + "/no/such/dir/out.mp4", 30.0, cv::Size(64, 64)).ok());
  EXPECT_FALSE(writer.Write(cv::Mat(64, 64, CV_8U), 0.0).ok());
  media::Mp4WriterOptions cli;
  cli.backend = media::Mp4WriterOptions::Backend::kFfmpegCli;
  EXPECT_FALSE(writer.Open(dir + "/no/such/dir/out.mp4", 30.0, cv::Size(64, 64), cli).ok());
  EXPECT_FALSE(writer.Open(dir + "/odd.mp4", 30.0, cv::Size(63, 64), cli).ok());
  cli.crf = 99;
  EXPECT_FALSE(writer.Open(dir + "/out.mp4", 30.0, cv::Size(64, 64), cli).ok());

  // A truncated file: the first half of a good one.
  {
    media::Mp4Writer good;
    ASSERT_TRUE(good.Open(dir + "/good.mp4", 30.0, cv::Size(64, 64)).ok());
    for (int i = 0; i < 30; ++i) good.Write(cv::Mat(64, 64, CV_8U, cv::Scalar(4 * i)), i / 30.0);
    good.Close();
    std::ifstream in(dir + "/good.mp4", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir + "/cut.mp4", std::ios::binary).write(bytes.data(), bytes.size() / 2);
  }
  media::VideoReader truncated;
  const Status t = truncated.Open(dir + "/cut.mp4");
  int frames = 0;
  if (t.ok()) {
    while (truncated.Read(&frame)) ++frames;
  } else {
    EXPECT_FALSE(t.message.empty());
  }
  EXPECT_LT(frames, 30);  // never more than what survived, never a crash
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace odocal::vision
