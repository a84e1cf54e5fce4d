// The media tests' fixture: a test with a temporary directory of its own, removed after it.
#ifndef ODOCAL_TESTS_MEDIA_MEDIA_TEST_H_
#define ODOCAL_TESTS_MEDIA_MEDIA_TEST_H_

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "odocal/test_util/test_util.h"

namespace odocal::testing {

class MediaTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test_util::MakeTempDir("odocal_media_"); }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string Path(const std::string& name) const { return dir_ + "/" + name; }

  std::string dir_;
};

}  // namespace odocal::testing

#endif  // ODOCAL_TESTS_MEDIA_MEDIA_TEST_H_
