// Format and Fixed (base/format.h): text of any length, printf's rounding.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "odocal/base/format.h"

namespace odocal {
namespace {

TEST(Format, WritesWhatPrintfWritesAtAnyLength) {
  EXPECT_EQ(Format("tag %d lost for %.1f s", 5, 2.25), "tag 5 lost for 2.2 s");  // printf rounds half to even here
  EXPECT_EQ(Format("%s", ""), "");
  // Longer than every fixed buffer the helpers it replaced had (640 bytes).
  const std::string long_name(1500, 'x');
  const std::string text = Format("file %s: bad value %g", long_name.c_str(), 0.5);
  EXPECT_EQ(text.size(), 5u + 1500u + 12u + 3u);  // "file ", the name, ": bad value ", "0.5"
  EXPECT_EQ(text.substr(text.size() - 16), "x: bad value 0.5");
}

TEST(Fixed, DecimalsAsAsked) {
  EXPECT_EQ(Fixed(1.5, 2), "1.50");
  EXPECT_EQ(Fixed(-0.0034, 3), "-0.003");
  EXPECT_EQ(Fixed(302.97398184, 6), "302.973982");
  EXPECT_EQ(Fixed(2.0, 0), "2");
  EXPECT_EQ(Fixed(NAN, 2), "nan");
}

}  // namespace
}  // namespace odocal
