// base/text.h: the one Trim and field splitter the file readers share.
#include "odocal/base/text.h"

#include <gtest/gtest.h>

namespace odocal {
namespace {

TEST(Text, TrimTakesWhiteSpaceOffBothEnds) {
  EXPECT_EQ(Trim("  a b \t\r"), "a b");
  EXPECT_EQ(Trim("\r\n"), "");
  EXPECT_EQ(Trim(""), "");
  EXPECT_EQ(Trim("x"), "x");
}

TEST(Text, SplitFieldsTrimsEachAndKeepsEmptyOnes) {
  EXPECT_EQ(SplitFields("t_s, x_m ,y_m"), (std::vector<std::string>{"t_s", "x_m", "y_m"}));
  EXPECT_EQ(SplitFields("a,,b,"), (std::vector<std::string>{"a", "", "b", ""}));
  EXPECT_EQ(SplitFields("one"), (std::vector<std::string>{"one"}));
  EXPECT_TRUE(SplitFields("").empty()) << "an empty line has no field";
  EXPECT_EQ(SplitFields(" ; ", ';'), (std::vector<std::string>{"", ""}));
  EXPECT_EQ(SplitFields("run=3; x = 4", ';'), (std::vector<std::string>{"run=3", "x = 4"}));
}

}  // namespace
}  // namespace odocal
