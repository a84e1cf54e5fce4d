// CaptureSource (rig/media/frame_source.h): the camera the station reads, here given a video file
// (OpenCV opens files and streams through the same call): every frame grey, where it was drawn,
// stamped by the host's clock, then the end of the stream as a named error; what cannot be opened.
#include "odocal/media/frame_source.h"

#include <filesystem>
#include <memory>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "media_fixtures.h"
#include "media_test.h"
#include "odocal/test_util/test_util.h"

namespace odocal::media {
namespace {

using ::testing::HasSubstr;
using namespace odocal::testing;  // the clip

class CaptureSourceTest : public odocal::testing::MediaTest {};

TEST_F(CaptureSourceTest, AVideoFileIsACameraOfGreyFramesOnTheHostClock) {
  const std::string path = Path("square.mp4");
  ASSERT_TRUE(WriteClipWithOpenCv(path)) << "this OpenCV cannot write H.264 (avc1)";
  Result<std::unique_ptr<CaptureSource>> opened = CaptureSource::Open(path);
  ASSERT_TRUE(opened) << opened.message;
  CaptureSource* source = opened->get();
  EXPECT_EQ(source->Describe(), "camera " + path);
  ASSERT_TRUE(source->NominalFps());
  EXPECT_NEAR(*source->NominalFps(), kClipFps, 1e-6);
  double last_t_s = 0.0;
  for (int k = 0; k < kClipFrames; ++k) {
    const Result<CameraFrame> frame = source->Grab();
    ASSERT_TRUE(frame) << "frame " << k << ": " << frame.message;
    ASSERT_EQ(frame->grey.type(), CV_8UC1) << "the colour file is delivered grey";
    ASSERT_EQ(frame->grey.size(), cv::Size(kClipWidth, kClipHeight));
    const cv::Point2d centre = BrightCentroid(frame->grey);
    EXPECT_NEAR(centre.x, ClipSquareCentre(k).x, 0.5) << "frame " << k;
    EXPECT_NEAR(centre.y, ClipSquareCentre(k).y, 0.5) << "frame " << k;
    // Stamped when grabbed (seconds since Open), not by the file's 0.1 s spacing.
    EXPECT_GE(frame->t_s, last_t_s) << "frame " << k;
    EXPECT_LT(frame->t_s, 5.0) << "frame " << k;
    last_t_s = frame->t_s;
  }
  const Result<CameraFrame> after = source->Grab();
  EXPECT_FALSE(after) << "ten frames written, ten delivered";
  EXPECT_EQ(after.status, StatusCode::kIoError);
  EXPECT_THAT(after.message, HasSubstr("camera '" + path + "' delivered no frame"));
}

// Each refusal costs every backend's try (GStreamer's ~0.5 s): two cases here, the rest of the bad
// files in video_test.cc (VideoReader).
TEST_F(CaptureSourceTest, WhatCannotBeOpenedIsNamed) {
  std::filesystem::create_directory(Path("empty_dir"));
  for (const std::string& device : {Path("missing.mp4"), Path("empty_dir")}) {
    const auto opened = CaptureSource::Open(device);
    EXPECT_FALSE(opened) << device;
    EXPECT_EQ(opened.status, StatusCode::kOpenFailed) << device;
    EXPECT_THAT(opened.message, HasSubstr("cannot open camera '" + device + "'"));
    EXPECT_THAT(opened.message, HasSubstr("no such stream or file"));
  }
}

}  // namespace
}  // namespace odocal::media
