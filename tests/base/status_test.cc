#include "odocal/base/status.h"

#include <set>
#include <sstream>
#include <string>
#include <string_view>

#include <gtest/gtest.h>

namespace odocal {
namespace {

// Every code, first to last; a new code must be added here (and to ToString).
constexpr StatusCode kAllCodes[] = {
    StatusCode::kOk,
    StatusCode::kInvalidArgument,
    StatusCode::kNotFound,
    StatusCode::kBadFile,
    StatusCode::kNoConvergence,
    StatusCode::kFailed,
    StatusCode::kIoError,
    StatusCode::kOpenFailed,
    StatusCode::kLineCut,
    StatusCode::kTimeout,
    StatusCode::kCrcErrors,
    StatusCode::kVersionMismatch,
    StatusCode::kTableMismatch,
    StatusCode::kNack,
    StatusCode::kVerifyFailed,
    StatusCode::kProtocolError,
};

TEST(Status, EveryCodeHasItsOwnWords) {
  std::set<std::string_view> words;
  for (StatusCode code : kAllCodes) {
    const std::string_view w = ToString(code);
    EXPECT_FALSE(w.empty()) << static_cast<int>(code);
    EXPECT_NE(w, "?") << static_cast<int>(code);
    EXPECT_TRUE(words.insert(w).second) << "'" << w << "' names two codes";
  }
  EXPECT_EQ(words.size(), std::size(kAllCodes));
}

// The robot link's words, which operators and scripts already read.
TEST(Status, RobotLinkWordsAreKept) {
  EXPECT_EQ(ToString(StatusCode::kOk), "ok");
  EXPECT_EQ(ToString(StatusCode::kTimeout), "robot not answering");
  EXPECT_EQ(ToString(StatusCode::kOpenFailed), "cannot open device");
  EXPECT_EQ(ToString(StatusCode::kNack), "robot refused");
}

TEST(Status, OkIsOk) {
  const Status s = Status::Ok();
  EXPECT_TRUE(s.ok());
  EXPECT_TRUE(static_cast<bool>(s));
  EXPECT_EQ(s.status, StatusCode::kOk);
  EXPECT_TRUE(s.message.empty());
  const Result<int> r = Result<int>::Ok(7);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(*r.value, 7);
}

TEST(Status, ErrorCarriesCodeAndMessageAndNoValue) {
  const Result<int> r = Result<int>::Error(StatusCode::kBadFile, "line 3: x_mm is not a number");
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(static_cast<bool>(r));
  EXPECT_EQ(r.status, StatusCode::kBadFile);
  EXPECT_EQ(r.message, "line 3: x_mm is not a number");
  EXPECT_FALSE(r.value.has_value());
}

TEST(Status, FromKeepsCodeAndMessage) {
  const Result<std::string> inner =
      Result<std::string>::Error(StatusCode::kTimeout, "no HELLO reply");
  const Result<int> outer = Result<int>::From(inner);
  EXPECT_EQ(outer.status, StatusCode::kTimeout);
  EXPECT_EQ(outer.message, "no HELLO reply");
  EXPECT_FALSE(outer.value.has_value());
  const Status as_status = Status::From(outer);
  EXPECT_EQ(as_status.status, StatusCode::kTimeout);
  EXPECT_EQ(as_status.message, "no HELLO reply");
}

TEST(Status, PrintsWordsThenMessage) {
  std::ostringstream with_message, without;
  with_message << Status::Error(StatusCode::kLineCut, "cable pulled");
  without << Status::Ok();
  EXPECT_EQ(with_message.str(), "line cut: cable pulled");
  EXPECT_EQ(without.str(), "ok");
}

}  // namespace
}  // namespace odocal
