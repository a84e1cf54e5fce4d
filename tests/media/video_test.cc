// Video files (rig/media/video.h): a clip OpenCV's own writer made, read back by VideoReader
// frame by frame against what was drawn; Mp4Writer's timestamp list through ReadTimestamps; the
// statuses bad files and bad options give.
#include "odocal/media/video.h"

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

#include "media_fixtures.h"
#include "media_test.h"
#include "odocal/test_util/test_util.h"

namespace odocal::media {
namespace {

using ::testing::HasSubstr;
using namespace odocal::testing;  // the clip

class Video : public odocal::testing::MediaTest {};

TEST_F(Video, ReaderGivesEveryFrameOfAnH264ClipAsGreyWithinCodecTolerance) {
  const std::string path = Path("square.mp4");
  ASSERT_TRUE(WriteClipWithOpenCv(path)) << "this OpenCV cannot write H.264 (avc1)";
  VideoReader reader;
  const Status opened = reader.Open(path);
  ASSERT_TRUE(opened.ok()) << opened;
  EXPECT_NEAR(reader.fps(), kClipFps, 1e-6);
  EXPECT_EQ(reader.frame_count(), kClipFrames);
  cv::Mat grey;
  int n = 0;
  while (reader.Read(&grey)) {
    ASSERT_LT(n, kClipFrames) << "more frames than were written";
    ASSERT_EQ(grey.type(), CV_8UC1) << "frame " << n;
    ASSERT_EQ(grey.size(), cv::Size(kClipWidth, kClipHeight)) << "frame " << n;
    cv::Mat drawn;
    cv::cvtColor(ClipFrame(n), drawn, cv::COLOR_BGR2GRAY);
    // libx264 at its default quality: ~2 grey levels on average (the field comes back at 38 of
    // 40: the limited-range YUV round trip), the square exactly where it was drawn.
    EXPECT_LT(cv::norm(grey, drawn, cv::NORM_L1) / grey.total(), 4.0) << "frame " << n;
    const cv::Point2d centre = BrightCentroid(grey);
    EXPECT_NEAR(centre.x, ClipSquareCentre(n).x, 0.5) << "frame " << n;
    EXPECT_NEAR(centre.y, ClipSquareCentre(n).y, 0.5) << "frame " << n;
    EXPECT_NEAR(grey.at<uchar>(cvRound(centre.y), cvRound(centre.x)), 255.0, 8.0) << "frame " << n;
    EXPECT_NEAR(grey.at<uchar>(5, 5), kBackground, 4.0) << "frame " << n;
    ++n;
  }
  EXPECT_EQ(n, kClipFrames);
  EXPECT_FALSE(reader.Read(&grey)) << "the end stays the end";
}

// Mp4Writer keeps each frame's time as given (a camera's clock need not tick evenly) and
// ReadTimestamps gives them back; the video itself is counted by OpenCV's reader.
TEST_F(Video, WriterTimestampsRoundTripThroughReadTimestamps) {
  const std::vector<double> stamps = {0.0, 0.1, 0.2004, 0.2999, 0.41, 0.5, 123.456789012};
  Mp4Writer writer;
  const std::string path = Path("stamped.mp4");
  const Status opened = writer.Open(path, kClipFps, cv::Size(kClipWidth, kClipHeight));
  ASSERT_TRUE(opened.ok()) << opened;
  for (size_t k = 0; k < stamps.size(); ++k) {
    cv::Mat grey;
    cv::cvtColor(ClipFrame(static_cast<int>(k)), grey, cv::COLOR_BGR2GRAY);
    ASSERT_TRUE(writer.Write(grey, stamps[k]).ok()) << "frame " << k;
  }
  const Status wrong = writer.Write(cv::Mat(kClipHeight, kClipWidth, CV_8UC3), 1.0);
  EXPECT_EQ(wrong.status, StatusCode::kInvalidArgument) << "colour is refused";
  ASSERT_TRUE(writer.Close().ok());
  ASSERT_TRUE(writer.WriteTimestamps(Path("stamped.csv")).ok());

  const Result<std::vector<double>> read = ReadTimestamps(Path("stamped.csv"));
  ASSERT_TRUE(read.ok()) << read;
  ASSERT_EQ(read->size(), stamps.size());
  for (size_t k = 0; k < stamps.size(); ++k) EXPECT_NEAR((*read)[k], stamps[k], 1e-9 * (1.0 + stamps[k])) << k;

  cv::VideoCapture capture(path, cv::CAP_FFMPEG);
  ASSERT_TRUE(capture.isOpened());
  int frames = 0;
  for (cv::Mat f; capture.read(f);) ++frames;
  EXPECT_EQ(frames, static_cast<int>(stamps.size()));
}

TEST_F(Video, BadTimestampListsAreNamedWithTheirLine) {
  Result<std::vector<double>> read = ReadTimestamps(Path("missing.csv"));
  EXPECT_EQ(read.status, StatusCode::kNotFound);
  EXPECT_THAT(read.message, HasSubstr(Path("missing.csv")));

  std::ofstream(Path("no_comma.csv")) << "frame,t_s\n0,0.0\n1\n";
  read = ReadTimestamps(Path("no_comma.csv"));
  EXPECT_EQ(read.status, StatusCode::kBadFile);
  EXPECT_THAT(read.message, HasSubstr(Path("no_comma.csv") + ":3"));

  std::ofstream(Path("not_a_number.csv")) << "frame,t_s\n0,0.0\n1,0.1\n2,soon\n";
  read = ReadTimestamps(Path("not_a_number.csv"));
  EXPECT_EQ(read.status, StatusCode::kBadFile);
  EXPECT_THAT(read.message, HasSubstr(Path("not_a_number.csv") + ":4"));
  EXPECT_THAT(read.message, HasSubstr("t_s is not a number"));
}

TEST_F(Video, ReaderNamesAFileItCannotRead) {
  std::ofstream(Path("empty.mp4"));
  std::ofstream(Path("notes.mp4")) << "not a video, whatever the name says\n";
  std::filesystem::create_directory(Path("empty_dir"));
  const std::vector<std::pair<std::string, StatusCode>> cases = {{"missing.mp4", StatusCode::kNotFound},
                                                                 {"empty.mp4", StatusCode::kBadFile},
                                                                 {"notes.mp4", StatusCode::kBadFile},
                                                                 {"empty_dir", StatusCode::kBadFile}};
  for (const auto& [name, code] : cases) {
    VideoReader reader;
    const Status s = reader.Open(Path(name));
    EXPECT_EQ(s.status, code) << name << ": " << s;
    EXPECT_THAT(s.message, HasSubstr("'" + Path(name) + "'"));
    cv::Mat frame;
    EXPECT_FALSE(reader.Read(&frame)) << name;
    if (name == "empty_dir") {
      EXPECT_THAT(s.message, HasSubstr("is a directory, not a video file"));
    }
  }
}

TEST(Mp4WriterOptions, DefaultIsValidAndEachBadFieldIsNamed) {
  std::string why;
  EXPECT_TRUE(Mp4WriterOptions{}.IsValid(&why)) << why;
  const std::vector<std::pair<std::function<void(Mp4WriterOptions*)>, std::string>> edits = {
      {[](Mp4WriterOptions* o) { o->crf = -1; }, "crf"},
      {[](Mp4WriterOptions* o) { o->crf = 52; }, "crf"},
      {[](Mp4WriterOptions* o) { o->preset = "warp"; }, "preset 'warp'"},
      {[](Mp4WriterOptions* o) { o->tune = "cinema"; }, "tune 'cinema'"},
      {[](Mp4WriterOptions* o) { o->keyint = -1; }, "keyint"}};
  const std::string dir = test_util::MakeTempDir("odocal_media_options_");
  for (const auto& [edit, field] : edits) {
    Mp4WriterOptions bad;
    edit(&bad);
    why.clear();
    EXPECT_FALSE(bad.IsValid(&why)) << field;
    EXPECT_THAT(why, HasSubstr(field));
    // Open refuses them with the same words, before touching the file.
    Mp4Writer writer;
    const Status opened = writer.Open(dir + "/out.mp4", 10.0, cv::Size(16, 16), bad);
    EXPECT_EQ(opened.status, StatusCode::kInvalidArgument) << field;
    EXPECT_EQ(opened.message, why);
    EXPECT_FALSE(std::filesystem::exists(dir + "/out.mp4")) << field;
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace odocal::media
