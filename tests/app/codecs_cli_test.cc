// OpenCV's image and video codecs as a plugin (rig/media/src/codecs.h): the
// binary does not link them, so a command that reads no image starts without
// their 240 libraries; the first image or video read loads them from beside
// the binary; and when they cannot be loaded, the error says so and where it
// looked instead of blaming the image.
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

namespace fs = std::filesystem;
using test_util::CommandResult;
using test_util::Odocal;
using test_util::RunCommand;
using ::testing::HasSubstr;
using ::testing::Not;

// A real photograph with a tag36h11 tag (shared/realdata/apriltag-test), if present.
std::string Photograph() {
  for (const fs::path dir : {fs::path(test_util::SourceDir()) / ".." / "shared" / "realdata" / "apriltag-test",
                             fs::path("/work/shared/realdata/apriltag-test")}) {
    const fs::path jpg = dir / "34085369442_304b6bafd9_c.jpg";
    if (fs::exists(jpg)) return jpg.string();
  }
  return "";
}

TEST(Codecs, TheBinaryDoesNotLinkOpenCvsCodecsAndItsPluginIsBesideIt) {
  const CommandResult ldd = RunCommand("ldd " + test_util::OdocalBinary());
  ASSERT_EQ(ldd.exit_code, 0) << ldd.err;
  EXPECT_THAT(ldd.out, HasSubstr("libopencv_core"));
  EXPECT_THAT(ldd.out, Not(HasSubstr("libopencv_imgcodecs")));
  EXPECT_THAT(ldd.out, Not(HasSubstr("libopencv_videoio")));
  EXPECT_TRUE(fs::exists(fs::path(test_util::OdocalBinary()).parent_path() / "libodocal_media_codecs.so"));
}

TEST(Codecs, AnImageIsReadThroughThePluginAndWithoutItTheErrorSaysWhy) {
  const std::string jpg = Photograph();
  if (jpg.empty()) GTEST_SKIP() << "shared/realdata/apriltag-test not present";
  const std::string detect = "detect " + jpg + " --tag tag36h11:0:100";
  const CommandResult read = RunCommand(Odocal(detect));
  EXPECT_EQ(read.exit_code, 0) << read.err;
  EXPECT_THAT(read.out, HasSubstr("ids"));

  const CommandResult missing =
      RunCommand("ODOCAL_CODECS_PLUGIN=/nonexistent/libodocal_media_codecs.so " + Odocal(detect));
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_THAT(missing.err, HasSubstr("the image and video codecs cannot be loaded"));
  EXPECT_THAT(missing.err, HasSubstr("/nonexistent/libodocal_media_codecs.so: no such file"));

  // A file that is not the plugin: dlopen's own reason.
  const CommandResult wrong = RunCommand("ODOCAL_CODECS_PLUGIN=" + jpg + " " + Odocal(detect));
  EXPECT_NE(wrong.exit_code, 0);
  EXPECT_THAT(wrong.err, HasSubstr("the image and video codecs cannot be loaded (" + jpg));
}

}  // namespace
}  // namespace odocal
